#include "local_render.h"

#include "adaptive.h"
#include "clock.h"
#include "error_estimate.h"
#include "passes.h"
#include "photon_pass.h"
#include "pool.h"
#include "tilegrid.h"

#include <pthread.h>
#include <stdlib.h>
#include <string.h>

typedef struct shared {
    const scene_t *scene;
    const local_render_opts_t *opts;
    tilegrid_t grid;
    uint32_t bounds[PASSES_MAX_BOUNDS];
    int npasses;
    tilebuf_t *target;   /* where finished tiles are merged: the image, or the pass's buffer */
    int pass;            /* under a stopping rule: the pass being rendered */
    bool *active;        /* adaptive sampling: per tile, whether it still runs; NULL without */
    bool *decided;       /* adapt's copy of active (allocated with it) */
    double deadline;     /* under a stopping rule: clock after which the pass is dropped; 0 never */
    render_stats_t stats;       /* of the tiles merged into target */
    render_stats_t image_stats; /* under a stopping rule: of the passes merged into the image */
    uint64_t samples_before, samples_done, samples_total;
    int *tile_spp;       /* adaptive sampling: the samples per pixel each tile stopped at */
    double t0;
    pthread_mutex_t lock;
} shared_t;

static void stats_add(render_stats_t *sum, const render_stats_t *s)
{
    sum->samples += s->samples;
    sum->rays += s->rays;
    sum->nonfinite += s->nonfinite;
    sum->dispersive += s->dispersive;
}

/* Samples [sb, se) of one tile into acc, pass by pass as the farm renders and merges them
 * (docs/farm.md, "Same pixels"): each pass of the cut rendered on its own into a scratch
 * buffer, its sums rounded by the rule the workers apply before sending (tilebuf_round_sums),
 * and added into acc in pass order -- the arithmetic of the master's scheduler, which merges a
 * tile's passes into its zeroed image in that order. Adding acc into the zeroed image
 * afterwards changes no bit. */
static int render_passes(const shared_t *sh, int x0, int y0, int w, int h, int p0, int p1,
                         tilebuf_t *acc, render_stats_t *st, err_t *err)
{
    tilebuf_t *pass = tilebuf_new(x0, y0, w, h, render_settings_buckets(&sh->scene->settings), err);
    if (!pass)
        return -1;
    int r = 0;
    for (int p = p0; p < p1 && r == 0; p++) {
        tilebuf_clear(pass);
        r = render_tile(sh->scene, sh->opts->photons, x0, y0, w, h, sh->bounds[p],
                        sh->bounds[p + 1], pass, st, err);
        if (r == 0) {
            tilebuf_round_sums(pass);
            r = tilebuf_merge(acc, pass, err);
        }
    }
    tilebuf_destroy(&pass);
    return r;
}

/* One tile of the grid: every pass (no stopping rule), or the current pass. */
static int render_one(void *user, int t, err_t *err)
{
    shared_t *sh = user;
    const bool by_pass = stopping_active(&sh->opts->stop);
    /* Past the time limit a pass with tiles left is dropped: a tile already rendering finishes,
     * no other starts (the farm's workers are told to cancel, as for a cancel). */
    if (by_pass && sh->deadline > 0 && clock_now_s() >= sh->deadline)
        return 1;
    if (by_pass && sh->active && !sh->active[t])
        return 0; /* stopped by adaptive sampling: its pass buffer stays zero */
    int x0, y0, w, h;
    tilegrid_rect(&sh->grid, t, &x0, &y0, &w, &h);
    render_stats_t st = {0};
    tilebuf_t *buf = tilebuf_new(x0, y0, w, h, render_settings_buckets(&sh->scene->settings), err);
    int p0 = by_pass ? sh->pass : 0, p1 = by_pass ? sh->pass + 1 : sh->npasses;
    int r = buf ? render_passes(sh, x0, y0, w, h, p0, p1, buf, &st, err) : -1;
    pthread_mutex_lock(&sh->lock);
    if (r == 0)
        r = tilebuf_merge(sh->target, buf, err);
    if (r == 0) {
        stats_add(&sh->stats, &st);
        sh->samples_done += (uint64_t)w * (uint64_t)h * (sh->bounds[p1] - sh->bounds[p0]);
        if (sh->opts->progress)
            sh->opts->progress(sh->opts->user, sh->samples_before + sh->samples_done,
                               sh->samples_total, clock_now_s() - sh->t0);
    }
    pthread_mutex_unlock(&sh->lock);
    tilebuf_destroy(&buf);
    return r;
}

/* Adaptive sampling at the boundary after passes passes (film/adaptive.h, the master's rule):
 * the tiles that stop leave the samples still to come. */
static void adapt(shared_t *sh, const tilebuf_t *image, int passes, const error_estimate_t *e)
{
    int n = tilegrid_count(&sh->grid);
    bool *was = sh->decided;
    memcpy(was, sh->active, (size_t)n * sizeof *was);
    if (adaptive_decide(image, &sh->grid, sh->opts->stop.target_error, (int)sh->bounds[passes], e,
                        sh->active) > 0)
        for (int t = 0; t < n; t++)
            if (was[t] && !sh->active[t]) {
                int x0, y0, w, h;
                tilegrid_rect(&sh->grid, t, &x0, &y0, &w, &h);
                sh->samples_total -=
                    (uint64_t)w * (uint64_t)h * (sh->bounds[sh->npasses] - sh->bounds[passes]);
                sh->tile_spp[t] = (int)sh->bounds[passes];
            }
}

/* Under a stopping rule: pass after pass over the whole image, each rendered into a buffer of
 * its own and merged into the image only when whole, in pass order (the per-pixel sums the
 * farm's master makes, bit for bit); after each the rule decides, as on the master. */
static int render_by_pass(shared_t *sh, tilebuf_t *image, local_render_result_t *res, err_t *err)
{
    const render_settings_t *rs = &sh->scene->settings;
    const local_render_opts_t *o = sh->opts;
    int n = tilegrid_count(&sh->grid);
    for (int pass = 0; pass < sh->npasses; pass++) {
        tilebuf_t *buf = tilebuf_new(0, 0, rs->xres, rs->yres, render_settings_buckets(rs), err);
        if (!buf)
            return -1;
        sh->target = buf;
        sh->pass = pass;
        sh->samples_done = 0;
        sh->stats = (render_stats_t){0};
        /* The first pass always completes. */
        sh->deadline = pass > 0 && o->stop.time_limit > 0 ? sh->t0 + o->stop.time_limit : 0;
        int r = pool_for(o->threads, n, render_one, sh, err);
        if (r == 0) {
            /* The pass's sums rounded as the farm's workers round theirs (tilebuf.h): the rule
             * is per value, so rounding the whole pass equals rounding each tile. */
            tilebuf_round_sums(buf);
            r = tilebuf_merge(image, buf, err);
        }
        tilebuf_destroy(&buf);
        if (r < 0)
            return -1;
        if (r > 0) {
            res->why = STOPPING_TIME;
            return 0;
        }
        /* The counters describe the image: a dropped pass's work is not in them. */
        stats_add(&sh->image_stats, &sh->stats);
        sh->samples_before += sh->samples_done;
        error_estimate_t e = error_estimate_image(image);
        double elapsed = clock_now_s() - sh->t0;
        pass_record_t *rec = &res->history[res->nhistory++];
        *rec = stopping_record(pass + 1, (int)sh->bounds[pass + 1], elapsed, &e);
        if (o->pass_done)
            o->pass_done(o->user, rec, sh->samples_before, sh->samples_total);
        if (pass + 1 < sh->npasses && (res->why = stopping_decide(&o->stop, &e, elapsed)) != STOPPING_NONE)
            return 0;
        if (sh->active && pass + 1 < sh->npasses)
            adapt(sh, image, pass + 1, &e);
    }
    return 0;
}

int local_render(const scene_t *scene, const local_render_opts_t *opts, tilebuf_t *image,
                 render_stats_t *stats, local_render_result_t *result, err_t *err)
{
    const render_settings_t *rs = &scene->settings;
    if (tilebuf_x0(image) != 0 || tilebuf_y0(image) != 0 || tilebuf_width(image) != rs->xres ||
        tilebuf_height(image) != rs->yres || tilebuf_nbuckets(image) != render_settings_buckets(rs))
        return err_set(err, "the image buffer does not match the %dx%d film with %d buckets",
                       rs->xres, rs->yres, rs->grid.n);
    local_render_result_t local;
    local_render_result_t *res = result ? result : &local;
    memset(res, 0, sizeof *res);
    shared_t sh = {.scene = scene, .opts = opts, .target = image};
    sh.grid = tilegrid_make(rs->xres, rs->yres, opts->tile_size > 0 ? opts->tile_size : 32);
    sh.npasses = passes_bounds(rs->spp, sh.bounds);
    sh.samples_total = (uint64_t)rs->xres * (uint64_t)rs->yres * (uint64_t)rs->spp;
    sh.t0 = opts->t0 > 0 ? opts->t0 : clock_now_s();
    photon_store_t *traced = NULL;
    local_render_opts_t with_store;
    if (rs->photon.enabled && !opts->photons) {
        if (!(traced = photon_pass_run(scene, opts->threads, NULL, NULL, err)))
            return err_prefix(err, "photon pass: ");
        with_store = *opts;
        with_store.photons = traced;
        sh.opts = opts = &with_store;
    }
    if (pthread_mutex_init(&sh.lock, NULL)) {
        photon_store_destroy(&traced);
        return err_set(err, "cannot create a mutex");
    }
    int r;
    int ntiles = tilegrid_count(&sh.grid);
    if (opts->adaptive && opts->stop.target_error > 0) {
        sh.active = malloc((size_t)ntiles * sizeof *sh.active);
        sh.tile_spp = malloc((size_t)ntiles * sizeof *sh.tile_spp);
        sh.decided = malloc((size_t)ntiles * sizeof *sh.decided);
        if (!sh.active || !sh.tile_spp || !sh.decided) {
            free(sh.active);
            free(sh.tile_spp);
            free(sh.decided);
            pthread_mutex_destroy(&sh.lock);
            photon_store_destroy(&traced);
            return err_set(err, "out of memory for %d tiles", ntiles);
        }
        for (int t = 0; t < ntiles; t++) {
            sh.active[t] = true;
            sh.tile_spp[t] = -1;
        }
    }
    if (stopping_active(&opts->stop)) {
        r = render_by_pass(&sh, image, res, err);
        sh.stats = sh.image_stats;
        if (r == 0 && sh.tile_spp) {
            /* The tiles still running hold what the last pass merged. */
            int spp_done = res->nhistory > 0 ? res->history[res->nhistory - 1].spp : 0;
            for (int t = 0; t < ntiles; t++)
                if (sh.active[t])
                    sh.tile_spp[t] = spp_done;
            res->grid = sh.grid;
            res->tile_spp = sh.tile_spp;
            sh.tile_spp = NULL;
        }
    } else {
        r = pool_for(opts->threads, tilegrid_count(&sh.grid), render_one, &sh, err) ? -1 : 0;
        if (r == 0) {
            /* One record: every pass at once. */
            error_estimate_t e = error_estimate_image(image);
            res->history[res->nhistory++] =
                stopping_record(sh.npasses, rs->spp, clock_now_s() - sh.t0, &e);
        }
    }
    pthread_mutex_destroy(&sh.lock);
    photon_store_destroy(&traced);
    free(sh.active);
    free(sh.decided);
    free(sh.tile_spp);
    if (r == 0 && stats)
        stats_add(stats, &sh.stats);
    return r;
}

void local_render_result_free(local_render_result_t *result)
{
    if (!result)
        return;
    free(result->tile_spp);
    result->tile_spp = NULL;
}
