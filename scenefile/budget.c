#include "budget.h"

#include "clock.h"

scene_budget_t scene_budget_default(void)
{
    return (scene_budget_t){.shapes = 1000000,
                            .triangles = 100000000,
                            .texels = (uint64_t)1 << 28,
                            .image_bytes = (uint64_t)4 << 30,
                            .vertices = (uint64_t)1 << 25,
                            .text_bytes = (uint64_t)256 << 20,
                            .ply_bytes = (uint64_t)1 << 30,
                            .load_seconds = 60.0};
}

uint64_t scene_budget_image_bytes(uint64_t xres, uint64_t yres, uint64_t buckets)
{
    uint64_t per = (buckets + 4) * 8; /* the bucket sums, the XYZ sums and the weight, doubles */
    if (xres && yres > UINT64_MAX / xres)
        return UINT64_MAX;
    uint64_t px = xres * yres;
    return px && per > UINT64_MAX / px ? UINT64_MAX : px * per;
}

void scene_budget_start(scene_budget_t *b, double now)
{
    b->deadline = b->load_seconds > 0 ? now + b->load_seconds : 0;
}

int scene_budget_check_time(const scene_budget_t *b, err_t *err)
{
    if (!b || b->deadline <= 0 || clock_now_s() <= b->deadline)
        return 0;
    return err_set(err,
                   "the scene took longer than %.0f s to load, the master's budget (prismfarm "
                   "master --max-load-seconds)",
                   b->load_seconds);
}

int scene_budget_charge_text(const scene_budget_t *b, scene_budget_use_t *u, uint64_t bytes,
                             const char *name, err_t *err)
{
    if (!b)
        return 0;
    if (b->text_bytes && (u->text_bytes > b->text_bytes || bytes > b->text_bytes - u->text_bytes))
        return err_set(err,
                       "reading \"%s\" (%llu bytes) takes the scene over %llu bytes of text, the "
                       "master's budget (prismfarm master --max-text-mb)",
                       name, (unsigned long long)bytes, (unsigned long long)b->text_bytes);
    u->text_bytes += bytes;
    return scene_budget_check_time(b, err);
}

uint64_t scene_budget_text_left(const scene_budget_t *b, const scene_budget_use_t *u,
                                uint64_t limit)
{
    if (!b || !b->text_bytes)
        return limit;
    uint64_t left = u->text_bytes < b->text_bytes ? b->text_bytes - u->text_bytes : 0;
    return left < limit ? left : limit;
}

int scene_budget_charge_ply(const scene_budget_t *b, scene_budget_use_t *u,
                            const mesh_ply_counts_t *c, const char *name, err_t *err)
{
    if (!b)
        return 0;
    uint64_t vertices = c->vertices, faces = c->faces;
    if (b->vertices && (u->vertices > b->vertices || vertices > b->vertices - u->vertices))
        return err_set(err,
                       "\"%s\" declares %llu vertices, which takes the scene over %llu PLY "
                       "vertices, the master's budget (prismfarm master --max-vertices)",
                       name, (unsigned long long)vertices, (unsigned long long)b->vertices);
    if (b->triangles && faces > b->triangles)
        return err_set(err,
                       "\"%s\" declares %llu faces, more than the %llu triangles of the master's "
                       "budget (prismfarm master --max-triangles)",
                       name, (unsigned long long)faces, (unsigned long long)b->triangles);
    if (b->ply_bytes &&
        (u->ply_bytes > b->ply_bytes || c->body_bytes > b->ply_bytes - u->ply_bytes))
        return err_set(err,
                       "\"%s\" declares at least %llu bytes of vertices and faces, which takes the "
                       "scene over %llu bytes of PLY data, the master's budget (prismfarm master "
                       "--max-ply-mb)",
                       name, (unsigned long long)c->body_bytes, (unsigned long long)b->ply_bytes);
    u->vertices += vertices;
    u->ply_bytes += c->body_bytes;
    return scene_budget_check_time(b, err);
}

int scene_budget_charge_ply_file(const scene_budget_t *b, scene_budget_use_t *u, const void *data,
                                 size_t len, const char *name, err_t *err)
{
    mesh_ply_counts_t c;
    if (!b)
        return 0;
    if (mesh_import_ply_counts(data, len, name, &c, err) != 0)
        return -1;
    return scene_budget_charge_ply(b, u, &c, name, err);
}
