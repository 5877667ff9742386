#define _XOPEN_SOURCE 700 /* strdup */

#include "pbrt_meshes.h"

#include "loopsubdiv.h"
#include "mesh_import.h"
#include "pool.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

static int mesh_job_run(void *user, int index, err_t *err);
static int mesh_job_adopt(parser_t *P, mesh_job_t *j);

/* budget.h: one more shape or object instance. */
int pbrt_meshes_budget_shape(parser_t *P, const char *what, pbrt_loc_t loc)
{
    err_t late;
    if (scene_budget_check_time(P->budget, &late) != 0)
        return pbrt_error(P->err, loc, "%s", late.msg);
    if (!P->budget || !P->budget->shapes || ++P->nshapes <= P->budget->shapes)
        return 0;
    return pbrt_error(P->err, loc,
                      "%s: the scene has more than %llu shapes and object instances, the "
                      "master's budget (prismfarm master --max-shapes)",
                      what, (unsigned long long)P->budget->shapes);
}

/* budget.h: n more triangles (or patches). */
int pbrt_meshes_budget_refuse(parser_t *P, uint64_t n, pbrt_loc_t loc)
{
    return pbrt_error(P->err, loc,
                      "this shape's %llu triangles take the scene over %llu triangles, the "
                      "master's budget (prismfarm master --max-triangles)",
                      (unsigned long long)n, (unsigned long long)P->budget->triangles);
}

/* Notes a triangle count to check in order after the jobs (tri_count_t). */
int pbrt_meshes_note_count(parser_t *P, long job, uint64_t n, pbrt_loc_t loc)
{
    if (P->ncounts == P->cap_counts) {
        size_t cap = P->cap_counts ? 2 * P->cap_counts : 64;
        tri_count_t *c = realloc(P->counts, cap * sizeof *c);
        if (!c)
            return pbrt_error(P->err, loc, "out of memory");
        P->counts = c;
        P->cap_counts = cap;
    }
    P->counts[P->ncounts++] = (tri_count_t){job, n, loc};
    if (job < 0)
        P->ntriangles_ahead =
            n > UINT64_MAX - P->ntriangles_ahead ? UINT64_MAX : P->ntriangles_ahead + n;
    return 0;
}

int pbrt_meshes_budget_triangles(parser_t *P, uint64_t n, pbrt_loc_t loc)
{
    if (!P->budget || !P->budget->triangles)
        return 0;
    if (P->njobs > 0 && !P->resolving)
        return pbrt_meshes_note_count(P, -1, n, loc);
    if (n <= P->budget->triangles - P->ntriangles && P->ntriangles <= P->budget->triangles) {
        P->ntriangles += n;
        return 0;
    }
    return pbrt_meshes_budget_refuse(P, n, loc);
}

int pbrt_meshes_adopt(parser_t *P, scene_shape_t *s, mesh_data_t *md)
{
    scene_mesh_t *m = &s->mesh;
    m->nvertices = md->nvertices;
    m->ntriangles = md->ntriangles;
    m->P = md->P;
    m->N = md->N;
    m->uv = md->uv;
    m->indices = md->indices;
    /* adopt frees on failure, so hand over every block before checking */
    int rc = scene_desc_adopt(P->scene, md->P, P->err);
    rc |= scene_desc_adopt(P->scene, md->N, P->err);
    rc |= scene_desc_adopt(P->scene, md->uv, P->err);
    rc |= scene_desc_adopt(P->scene, md->indices, P->err);
    memset(md, 0, sizeof *md);
    return rc ? -1 : pbrt_meshes_budget_triangles(P, m->ntriangles, s->loc);
}

/* The job's inputs (the file's bytes, a loopsubdiv's control mesh), once it has run. */
static void mesh_job_free_inputs(mesh_job_t *j)
{
    free(j->buf);
    free(j->P);
    free(j->idx);
    j->buf = NULL;
    j->P = NULL;
    j->idx = NULL;
}

void pbrt_meshes_job_free(mesh_job_t *j)
{
    mesh_job_free_inputs(j);
    mesh_data_free(&j->md);
}

static size_t path_hash(const char *path)
{
    uint64_t h = 1469598103934665603ull; /* FNV-1a */
    for (const unsigned char *c = (const unsigned char *)path; *c; c++)
        h = (h ^ *c) * 1099511628211ull;
    return (size_t)h;
}

/* The slot of path in P->ply_slots: the queued job that decodes it, or the empty slot where it
 * goes. */
static size_t *ply_slot(parser_t *P, const char *path)
{
    size_t mask = P->ply_cap - 1, i = path_hash(path) & mask;
    while (P->ply_slots[i] && strcmp(P->jobs[P->ply_slots[i] - 1].path, path) != 0)
        i = (i + 1) & mask;
    return &P->ply_slots[i];
}

/* A queued PLY job that decodes path (its index into *k), or false (and path is noted for the
 * job about to be queued at index P->njobs; false too when there is no memory to note it). */
static bool ply_queued(parser_t *P, const char *path, size_t *k)
{
    if (2 * (P->nply + 1) > P->ply_cap) {
        size_t cap = P->ply_cap ? 2 * P->ply_cap : 256;
        size_t *slots = calloc(cap, sizeof *slots), *old = P->ply_slots;
        if (!slots)
            return false;
        size_t oldcap = P->ply_cap;
        P->ply_slots = slots;
        P->ply_cap = cap;
        for (size_t i = 0; i < oldcap; i++)
            if (old[i])
                *ply_slot(P, P->jobs[old[i] - 1].path) = old[i];
        free(old);
    }
    size_t *slot = ply_slot(P, path);
    if (*slot) {
        *k = *slot - 1;
        return true;
    }
    *slot = P->njobs + 1;
    P->nply++;
    return false;
}

/* Queues a job for shape s (an element of the scene's shapes or object_shapes), or, in
 * check mode (whose refusals are recorded as the parse meets them), runs it now. The job's
 * buffers are the job's from here on, whatever the outcome. */
int pbrt_meshes_queue(parser_t *P, const scene_shape_t *s, mesh_job_t *j)
{
    bool in_object = P->object >= 0;
    j->in_object = in_object;
    j->shape = (size_t)(s - (in_object ? P->scene->object_shapes : P->scene->shapes));
    if (P->errors) {
        (void)mesh_job_run(j, 0, NULL);
        int rc = mesh_job_adopt(P, j);
        pbrt_meshes_job_free(j);
        return rc;
    }
    if (P->njobs == P->cap_jobs) {
        size_t cap = P->cap_jobs ? 2 * P->cap_jobs : 64;
        mesh_job_t *a = realloc(P->jobs, cap * sizeof *a);
        if (!a) {
            pbrt_meshes_job_free(j);
            return pbrt_error(P->err, j->loc, "out of memory");
        }
        P->jobs = a;
        P->cap_jobs = cap;
    }
    /* A file the queue decodes already: this shape shares that mesh (a confined parse has
     * read and charged the file again all the same, as pbrt_parser.h says). */
    size_t k;
    if ((j->kind == MESH_JOB_PLY_FILE || j->kind == MESH_JOB_PLY_MEMORY) &&
        ply_queued(P, j->path, &k)) {
        free(j->buf);
        j->buf = NULL;
        j->len = 0;
        j->kind = MESH_JOB_PLY_SAME;
        j->same = k;
    }
    P->jobs[P->njobs++] = *j;
    P->queued_bytes += j->len;
    if (P->budget && P->budget->triangles &&
        pbrt_meshes_note_count(P, (long)P->njobs - 1, 0, s->loc) != 0)
        return -1;
    /* The files' bytes wait in memory until their jobs run: past MESH_QUEUE_BYTES_MAX the
     * queue is made now (everything in it is before this point, so the order of failures is
     * kept). */
    return P->queued_bytes > MESH_QUEUE_BYTES_MAX ? pbrt_meshes_finish(P) : 0;
}

/* One job, on a pool thread: its mesh into j->md (state 1), or its message into j->err
 * (state -1, and -1 so that the pool starts no later job: the first failure in file order
 * is then among those run). */
static int mesh_job_run(void *user, int index, err_t *err)
{
    mesh_job_t *j = &((mesh_job_t *)user)[index];
    int rc;
    switch (j->kind) {
    case MESH_JOB_PLY_FILE:
        rc = mesh_import_ply(j->path, &j->md, &j->err);
        break;
    case MESH_JOB_PLY_MEMORY:
        rc = mesh_import_ply_memory(j->buf, j->len, j->path, &j->md, &j->err);
        break;
    case MESH_JOB_PLY_SAME:
        rc = 0; /* made by job j->same */
        break;
    default:
        rc = loopsubdiv_mesh(j->P, j->nv, j->idx, j->nt, j->levels, &j->md, &j->err);
        if (rc != 0)
            err_prefix(&j->err, "Shape \"loopsubdiv\": ");
        break;
    }
    mesh_job_free_inputs(j);
    j->state = rc == 0 ? 1 : -1;
    if (rc != 0 && err)
        *err = j->err;
    return rc;
}

/* A job that has run, in file order: its failure reported at its location, or its mesh
 * given to its shape (and counted against the budget). */
static int mesh_job_adopt(parser_t *P, mesh_job_t *j)
{
    if (j->state != 1)
        return pbrt_error(P->err, j->loc, "%s",
                          j->state < 0 ? j->err.msg : "mesh not made (internal error)");
    scene_shape_t *s =
        j->in_object ? &P->scene->object_shapes[j->shape] : &P->scene->shapes[j->shape];
    j->state = 0;
    if (j->kind == MESH_JOB_PLY_SAME) {
        /* Job j->same is earlier in file order, so its shape holds the mesh by now (had it
         * failed, the walk would have stopped there). The scene owns the arrays once. */
        const mesh_job_t *from = &P->jobs[j->same];
        const scene_shape_t *f = from->in_object ? &P->scene->object_shapes[from->shape]
                                                 : &P->scene->shapes[from->shape];
        s->mesh.nvertices = f->mesh.nvertices;
        s->mesh.ntriangles = f->mesh.ntriangles;
        s->mesh.P = f->mesh.P;
        s->mesh.N = f->mesh.N;
        s->mesh.uv = f->mesh.uv;
        s->mesh.indices = f->mesh.indices;
        return pbrt_meshes_budget_triangles(P, s->mesh.ntriangles, s->loc);
    }
    return pbrt_meshes_adopt(P, s, &j->md);
}

/* Runs the queued jobs on the pool, then takes their results in file order, checking the
 * budget's triangle counts in that order too: the failure reported is the first in the
 * file, whatever the number of threads or the order in which the jobs ran. Called at the end
 * of a parse, when the queue holds too many bytes (pbrt_meshes_queue), and when a parse fails
 * (whose own error stands only if nothing queued before it failed: every job and count is from
 * before the point where the parse stopped). Leaves the queue empty. */
int pbrt_meshes_finish(parser_t *P)
{
    int rc = 0;
    if (P->njobs > 0) {
        err_t ignored;
        (void)pool_for(P->threads, (int)P->njobs, mesh_job_run, P->jobs, &ignored);
        P->resolving = true;
        if (P->ncounts > 0) {
            for (size_t i = 0; i < P->ncounts && rc == 0; i++) {
                const tri_count_t *c = &P->counts[i];
                rc = c->job >= 0 ? mesh_job_adopt(P, &P->jobs[c->job])
                                 : pbrt_meshes_budget_triangles(P, c->n, c->loc);
            }
        } else {
            for (size_t i = 0; i < P->njobs && rc == 0; i++)
                rc = mesh_job_adopt(P, &P->jobs[i]);
        }
    }
    for (size_t i = 0; i < P->njobs; i++)
        pbrt_meshes_job_free(&P->jobs[i]);
    free(P->jobs);
    free(P->counts);
    P->jobs = NULL;
    P->counts = NULL;
    P->njobs = P->ncounts = P->cap_jobs = P->cap_counts = 0;
    P->queued_bytes = 0;
    P->ntriangles_ahead = 0;
    free(P->ply_slots);
    P->ply_slots = NULL;
    P->ply_cap = P->nply = 0;
    P->resolving = false;
    return rc;
}
