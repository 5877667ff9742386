#define _GNU_SOURCE /* sched_getaffinity, CPU_COUNT */
#include "local_render.h"

#include "passes.h"

#include <pthread.h>
#include <sched.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#if defined(__SSE__)
#include <pmmintrin.h>
#include <xmmintrin.h>
#endif

typedef struct shared {
    const scene_t *scene;
    const local_render_opts_t *opts;
    tilebuf_t *image;
    int tile, tiles_x, tiles_y, ntiles;
    int next;   /* next tile to hand out */
    int failed; /* first error stops the others */
    err_t err;
    render_stats_t stats;
    uint64_t samples_done, samples_total;
    struct timespec start;
    pthread_mutex_t lock;
} shared_t;

static double seconds_since(const struct timespec *t0)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)(t.tv_sec - t0->tv_sec) + 1e-9 * (double)(t.tv_nsec - t0->tv_nsec);
}

int local_render_cores(void)
{
    cpu_set_t set;
    if (sched_getaffinity(0, sizeof set, &set) == 0 && CPU_COUNT(&set) > 0)
        return CPU_COUNT(&set);
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n > 0 ? (int)n : 1;
}

/* One tile as the farm renders and merges it (docs/farm.md, "Same pixels"): each pass of the
 * cut (passes_bounds) rendered on its own into a scratch buffer, its sums rounded by the rule
 * the workers apply before sending (tilebuf_round_sums), and added into acc in pass order --
 * the arithmetic of the master's scheduler, which merges a tile's passes into its zeroed image
 * in that order. Adding acc into the zeroed image afterwards changes no bit. */
static int render_passes(const shared_t *sh, int x0, int y0, int w, int h, tilebuf_t *acc,
                         render_stats_t *st, err_t *err)
{
    const render_settings_t *rs = &sh->scene->settings;
    uint32_t bounds[PASSES_MAX_BOUNDS];
    int npasses = passes_bounds(rs->spp, bounds);
    tilebuf_t *pass = tilebuf_new(x0, y0, w, h, rs->grid.n, err);
    if (!pass)
        return -1;
    int r = 0;
    for (int p = 0; p < npasses && r == 0; p++) {
        tilebuf_clear(pass);
        r = render_tile(sh->scene, x0, y0, w, h, bounds[p], bounds[p + 1], pass, st, err);
        if (r == 0) {
            tilebuf_round_sums(pass);
            r = tilebuf_merge(acc, pass, err);
        }
    }
    tilebuf_destroy(&pass);
    return r;
}

static void *worker_main(void *arg)
{
    shared_t *sh = arg;
#if defined(__SSE__)
    /* Embree's advice: denormals slow its traversal and never matter for images. */
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
#endif
    const render_settings_t *rs = &sh->scene->settings;
    for (;;) {
        pthread_mutex_lock(&sh->lock);
        int t = sh->failed ? sh->ntiles : sh->next++;
        pthread_mutex_unlock(&sh->lock);
        if (t >= sh->ntiles)
            break;
        int x0 = (t % sh->tiles_x) * sh->tile, y0 = (t / sh->tiles_x) * sh->tile;
        int w = rs->xres - x0 < sh->tile ? rs->xres - x0 : sh->tile;
        int h = rs->yres - y0 < sh->tile ? rs->yres - y0 : sh->tile;
        err_t err;
        render_stats_t st = {0};
        tilebuf_t *buf = tilebuf_new(x0, y0, w, h, rs->grid.n, &err);
        int r = buf ? render_passes(sh, x0, y0, w, h, buf, &st, &err) : -1;
        pthread_mutex_lock(&sh->lock);
        if (r == 0)
            r = tilebuf_merge(sh->image, buf, &err);
        if (r != 0 && !sh->failed) {
            sh->failed = 1;
            sh->err = err;
        }
        sh->stats.samples += st.samples;
        sh->stats.rays += st.rays;
        sh->stats.nonfinite += st.nonfinite;
        sh->stats.dispersive += st.dispersive;
        sh->samples_done += (uint64_t)w * (uint64_t)h * (uint64_t)rs->spp;
        if (sh->opts->progress && !sh->failed)
            sh->opts->progress(sh->opts->user, sh->samples_done, sh->samples_total,
                               seconds_since(&sh->start));
        pthread_mutex_unlock(&sh->lock);
        tilebuf_destroy(&buf);
    }
    return NULL;
}

int local_render(const scene_t *scene, const local_render_opts_t *opts, tilebuf_t *image,
                 render_stats_t *stats, err_t *err)
{
    const render_settings_t *rs = &scene->settings;
    if (tilebuf_x0(image) != 0 || tilebuf_y0(image) != 0 || tilebuf_width(image) != rs->xres ||
        tilebuf_height(image) != rs->yres || tilebuf_nbuckets(image) != rs->grid.n)
        return err_set(err, "the image buffer does not match the %dx%d film with %d buckets",
                       rs->xres, rs->yres, rs->grid.n);
    shared_t sh = {.scene = scene, .opts = opts, .image = image};
    sh.tile = opts->tile_size > 0 ? opts->tile_size : 32;
    sh.tiles_x = (rs->xres + sh.tile - 1) / sh.tile;
    sh.tiles_y = (rs->yres + sh.tile - 1) / sh.tile;
    sh.ntiles = sh.tiles_x * sh.tiles_y;
    sh.samples_total = (uint64_t)rs->xres * (uint64_t)rs->yres * (uint64_t)rs->spp;
    clock_gettime(CLOCK_MONOTONIC, &sh.start);
    if (pthread_mutex_init(&sh.lock, NULL))
        return err_set(err, "cannot create a mutex");
    int n = opts->threads > 0 ? opts->threads : local_render_cores();
    if (n > sh.ntiles)
        n = sh.ntiles;
    pthread_t *th = calloc((size_t)n, sizeof *th);
    if (!th) {
        pthread_mutex_destroy(&sh.lock);
        return err_set(err, "out of memory");
    }
    int started = 0;
    for (; started < n; started++)
        if (pthread_create(&th[started], NULL, worker_main, &sh))
            break;
    if (started == 0)
        worker_main(&sh); /* no thread could start: render on this one */
    for (int i = 0; i < started; i++)
        pthread_join(th[i], NULL);
    free(th);
    pthread_mutex_destroy(&sh.lock);
    if (stats) {
        stats->samples += sh.stats.samples;
        stats->rays += sh.stats.rays;
        stats->nonfinite += sh.stats.nonfinite;
        stats->dispersive += sh.stats.dispersive;
    }
    if (sh.failed) {
        if (err)
            *err = sh.err;
        return -1;
    }
    return 0;
}
