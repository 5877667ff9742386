#include "polar_pilot.h"

#include "clock.h"
#include "material_uniaxial.h"
#include "pool.h"
#include "render.h"
#include "tilebuf.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

int polar_pilot_needed(const scene_t *scene)
{
    if (scene->settings.polarised)
        return 0;
    for (size_t i = 0; i < scene->nmaterials; i++) {
        const material_t *m = &scene->materials[i];
        if ((m->kind == MATERIAL_DIELECTRIC || m->kind == MATERIAL_CONDUCTOR) &&
            !material_uniaxial_of(m))
            return 1;
    }
    return 0;
}

/* The pilot's tiles: a grid x grid of tile x tile pixels at the centres of the image's cells
 * (the whole image when it is smaller). */
typedef struct pilot_tile {
    int x0, y0, w, h;
} pilot_tile_t;

static int pilot_tiles(const render_settings_t *rs, int g, int s, pilot_tile_t *t)
{
    if (rs->xres < g * s || rs->yres < g * s) {
        t[0] = (pilot_tile_t){0, 0, rs->xres, rs->yres};
        return 1;
    }
    int n = 0;
    for (int gy = 0; gy < g; gy++)
        for (int gx = 0; gx < g; gx++)
            t[n++] = (pilot_tile_t){(int)((gx + 0.5) * rs->xres / g) - s / 2,
                                    (int)((gy + 0.5) * rs->yres / g) - s / 2, s, s};
    return n;
}

/* Mean luminance per pixel of the tiles, in order, for samples [begin, end); the wall time
 * spent is added to *seconds (reported only: no decision reads it). */
static int pilot_render(const scene_t *scene, const pilot_tile_t *tiles, int ntiles, uint32_t begin,
                        uint32_t end, double *lum, double *seconds, err_t *err)
{
    const double t0 = clock_now_s();
    const int planes = render_settings_buckets(&scene->settings);
    int k = 0;
    for (int i = 0; i < ntiles; i++) {
        const pilot_tile_t *t = &tiles[i];
        tilebuf_t *buf = tilebuf_new(t->x0, t->y0, t->w, t->h, planes, err);
        if (!buf)
            return -1;
        render_stats_t st = {0};
        if (render_tile(scene, NULL, t->x0, t->y0, t->w, t->h, begin, end, buf, &st, err)) {
            tilebuf_destroy(&buf);
            return -1;
        }
        for (int y = t->y0; y < t->y0 + t->h; y++)
            for (int x = t->x0; x < t->x0 + t->w; x++) {
                const double n = (double)tilebuf_count(buf, x, y);
                lum[k++] = n > 0.0 ? tilebuf_luminance_sum(buf, x, y) / n : 0.0;
            }
        tilebuf_destroy(&buf);
    }
    *seconds += clock_now_s() - t0;
    return 0;
}

/* The pilot's four runs: 0, 1 plain and polarised over samples A, 2, 3 over B. */
typedef struct pilot_runs {
    scene_t *view;
    const pilot_tile_t *tiles;
    int ntiles, npix, spp;
    double *lum;
    double seconds[2]; /* plain, polarised */
} pilot_runs_t;

static int pilot_run(void *user, int run, err_t *err)
{
    pilot_runs_t *r = user;
    r->view->settings.polarised = run & 1;
    const uint32_t begin = (uint32_t)(run >> 1) * (uint32_t)r->spp;
    return pilot_render(r->view, r->tiles, r->ntiles, begin, begin + (uint32_t)r->spp,
                        r->lum + (size_t)run * (size_t)r->npix, &r->seconds[run & 1], err);
}

int polar_pilot_measure(const scene_t *scene, int grid, int tile, int spp,
                        polar_pilot_result_t *out, err_t *err)
{
    /* A view of the scene with settings of its own: everything else is shared and read only,
     * so the scene itself (perhaps on a shelf, rendered by other threads) never changes. */
    scene_t *view = malloc(sizeof *view);
    if (!view)
        return err_set(err, "out of memory");
    memcpy(view, scene, sizeof *view);
    render_settings_t *rs = &view->settings;
    if (grid < 1 || grid > POLAR_PILOT_GRID || tile < 1 || spp < 1) {
        free(view);
        return err_set(err, "polarisation pilot: grid %d, tile %d, spp %d out of range", grid, tile,
                       spp);
    }
    pilot_tile_t tiles[POLAR_PILOT_GRID * POLAR_PILOT_GRID];
    const int ntiles = pilot_tiles(rs, grid, tile, tiles);
    int npix = 0;
    for (int i = 0; i < ntiles; i++)
        npix += tiles[i].w * tiles[i].h;
    double *lum = malloc(4 * (size_t)npix * sizeof *lum);
    if (!lum) {
        free(view);
        return err_set(err, "out of memory");
    }
    /* The camera pass alone (no photon store: the caustics are path traced, the same way both
     * times), with directly seen light on the hero lanes both ways (render.c's direct_lanes is
     * not taken with polarisation), intensities only. */
    rs->photon.enabled = 0;
    rs->stokes = 0;
    rs->direct_hero_only = 1;
    /* The four runs on one compute thread of the pool, in order: the floating-point mode of
     * every render thread (base/pool.h), so that the master's loader thread, `render`'s main
     * thread and a test measure the same figure. */
    pilot_runs_t runs = {
        .view = view, .tiles = tiles, .ntiles = ntiles, .npix = npix, .spp = spp, .lum = lum};
    const int rc = pool_for(1, 4, pilot_run, &runs, err) < 0 ? -1 : 0;
    const double t_plain = runs.seconds[0], t_pol = runs.seconds[1];
    free(view);
    if (rc) {
        free(lum);
        return -1;
    }
    /* Runs 0, 1: plain and polarised over samples A; 2, 3 over B. */
    double cross = 0.0, cross2 = 0.0, mean = 0.0;
    for (int i = 0; i < npix; i++) {
        const double da = lum[npix + i] - lum[i], db = lum[3 * npix + i] - lum[2 * npix + i];
        cross += da * db;
        cross2 += da * db * da * db;
        mean += 0.5 * (lum[i] + lum[2 * npix + i]);
    }
    free(lum);
    cross /= npix;
    mean /= npix;
    /* The standard error of the mean product, from the pixels' spread. */
    const double se = npix > 1 ? sqrt(fmax(0.0, cross2 / npix - cross * cross) / (npix - 1)) : 0.0;
    const double change = mean > 0.0 ? sqrt(fmax(0.0, cross)) / mean : 0.0;
    const double hi = mean > 0.0 ? sqrt(fmax(0.0, cross + 2.0 * se)) / mean : 0.0;
    *out = (polar_pilot_result_t){.change = isfinite(change) ? change : 0.0,
                                  .change_hi = isfinite(hi) ? hi : INFINITY,
                                  .pixels = npix,
                                  .spp = spp,
                                  .seconds_plain = t_plain,
                                  .seconds_polarised = t_pol};
    return 0;
}

int polar_pilot_decide(const scene_t *scene, double target_error, polar_decision_t *out, err_t *err)
{
    *out = (polar_decision_t){.setting = SCENE_POLARIZED_OFF,
                              .target = target_error > 0.0 ? fmin(target_error, POLAR_PILOT_TARGET)
                                                           : POLAR_PILOT_TARGET};
    if (scene->settings.polarised) {
        out->setting = SCENE_POLARIZED_ON;
        out->cause_file = 1;
        return 0;
    }
    if (!polar_pilot_needed(scene))
        return 0;
    if (polar_pilot_measure(scene, POLAR_PILOT_GRID, POLAR_PILOT_TILE, POLAR_PILOT_SPP, &out->pilot,
                            err))
        return -1;
    out->measured = 1;
    if (out->pilot.change_hi > out->target)
        out->setting = SCENE_POLARIZED_ON;
    return 0;
}

void polar_pilot_record(scene_t *scene, const polar_decision_t *d)
{
    render_settings_t *rs = &scene->settings;
    if (d->setting == SCENE_POLARIZED_ON)
        rs->polarised = 1;
    if (!d->measured)
        return;
    rs->polar_pilot.run = 1;
    rs->polar_pilot.on = d->setting == SCENE_POLARIZED_ON;
    rs->polar_pilot.change = d->pilot.change;
    rs->polar_pilot.change_hi = d->pilot.change_hi;
    rs->polar_pilot.target = d->target;
    rs->polar_pilot.seconds_plain = d->pilot.seconds_plain;
    rs->polar_pilot.seconds_polarised = d->pilot.seconds_polarised;
}
