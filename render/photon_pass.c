#include "photon_pass.h"

#include "clock.h"
#include "pool.h"

#include <stdlib.h>

typedef struct pass_part {
    const scene_t *scene;
    photon_job_t job;
    uint64_t i0, i1;
    photon_store_t *store;
    photon_stats_t stats;
} pass_part_t;

static int pass_trace(void *user, int k, err_t *err)
{
    pass_part_t *pt = &((pass_part_t *)user)[k];
    return photon_trace(pt->scene, &pt->job, pt->i0, pt->i1, pt->store, &pt->stats, err) ? -1 : 0;
}

photon_store_t *photon_pass_run(const scene_t *scene, int nthreads, photon_stats_t *stats,
                                double *seconds, err_t *err)
{
    const double t0 = clock_now_s();
    const render_settings_t *rs = &scene->settings;
    const uint64_t total = rs->photon.photons;
    if (nthreads <= 0)
        nthreads = pool_cores();
    if ((uint64_t)nthreads > total)
        nthreads = total > 0 ? (int)total : 1;
    pass_part_t *parts = calloc((size_t)nthreads, sizeof *parts);
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
