#include "photon_pass.h"

#include "clock.h"
#include "pool.h"

#include <pthread.h>
#include <stdlib.h>

/* What the tracing threads share for progress reports (photon_pass_run_reporting). */
typedef struct pass_report {
    pthread_mutex_t lock;
    uint64_t done, total;
    photon_pass_progress_fn fn;
    void *user;
} pass_report_t;

typedef struct pass_part {
    const scene_t *scene;
    photon_job_t job;
    uint64_t i0, i1;
    photon_store_t *store;
    photon_stats_t stats;
    pass_report_t *report; /* NULL: no reports, the range in one piece */
} pass_part_t;

static int pass_trace(void *user, int k, err_t *err)
{
    pass_part_t *pt = &((pass_part_t *)user)[k];
    if (!pt->report)
        return photon_trace(pt->scene, &pt->job, pt->i0, pt->i1, pt->store, &pt->stats, err) ? -1
                                                                                             : 0;
    /* In pieces, each appended in index order: the same store as one call (a photon depends
     * only on its index). */
    for (uint64_t a = pt->i0; a < pt->i1;) {
        uint64_t b = pt->i1 - a > PHOTON_PASS_REPORT ? a + PHOTON_PASS_REPORT : pt->i1;
        if (photon_trace(pt->scene, &pt->job, a, b, pt->store, &pt->stats, err))
            return -1;
        pass_report_t *r = pt->report;
        pthread_mutex_lock(&r->lock);
        r->done += b - a;
        r->fn(r->user, r->done, r->total);
        pthread_mutex_unlock(&r->lock);
        a = b;
    }
    return 0;
}

photon_store_t *photon_pass_run(const scene_t *scene, int nthreads, photon_stats_t *stats,
                                double *seconds, err_t *err)
{
    return photon_pass_run_reporting(scene, nthreads, stats, seconds, NULL, NULL, err);
}

photon_store_t *photon_pass_run_reporting(const scene_t *scene, int nthreads, photon_stats_t *stats,
                                          double *seconds, photon_pass_progress_fn fn, void *user,
                                          err_t *err)
{
    const double t0 = clock_now_s();
    const render_settings_t *rs = &scene->settings;
    const uint64_t total = rs->photon.photons;
    if (nthreads <= 0)
        nthreads = pool_cores();
    if ((uint64_t)nthreads > total)
        nthreads = total > 0 ? (int)total : 1;
    pass_part_t *parts = calloc((size_t)nthreads, sizeof *parts);
    pass_report_t report = {.total = total, .fn = fn, .user = user};
    pthread_mutex_init(&report.lock, NULL);
    photon_store_t *store = photon_store_new(scene, err);
    int r = parts && store ? 0 : -1;
    if (r && store)
        err_set(err, "out of memory");
    for (int k = 0; !r && k < nthreads; k++) {
        pass_part_t *pt = &parts[k];
        pt->scene = scene;
        pt->job = photon_job_from_settings(rs);
        pt->i0 = total * (uint64_t)k / (uint64_t)nthreads;
        pt->i1 = total * (uint64_t)(k + 1) / (uint64_t)nthreads;
        pt->report = fn ? &report : NULL;
        if (!(pt->store = photon_store_new(scene, err)))
            r = -1;
    }
    if (!r && pool_for(nthreads, nthreads, pass_trace, parts, err) != 0)
        r = -1;
    /* The merge in index order makes the store independent of the thread count, and equal to
     * the farm's, which merges its batches in index order too. */
    for (int k = 0; !r && k < nthreads; k++) {
        r = photon_store_merge(store, parts[k].store, err);
        if (stats && !r)
            photon_stats_add(stats, &parts[k].stats);
    }
    for (int k = 0; parts && k < nthreads; k++)
        photon_store_destroy(&parts[k].store);
    free(parts);
    pthread_mutex_destroy(&report.lock);
    if (!r)
        r = photon_store_finish(store, err);
    if (r) {
        photon_store_destroy(&store);
        return NULL;
    }
    if (seconds)
        *seconds = clock_now_s() - t0;
    return store;
}

int photon_batch_run(const scene_t *scene, uint64_t first, uint64_t end, uint8_t **out,
                     size_t *out_len, photon_stats_t *stats, err_t *err)
{
    *out = NULL;
    *out_len = 0;
    photon_store_t *store = photon_store_new(scene, err);
    if (!store)
        return -1;
    photon_job_t job = photon_job_from_settings(&scene->settings);
    int r = photon_trace(scene, &job, first, end, store, stats, err);
    if (!r)
        r = photon_store_encode(store, out, out_len, err);
    photon_store_destroy(&store);
    return r;
}
