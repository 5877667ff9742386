/* photon_pass: running the photon tracer (photon.h) on this machine -- a job's whole photon pass
 * on a thread pool, or one farm worker's batch encoded for the master. The store a run gives
 * depends only on the photons traced, never on the thread count: ranges are merged in index
 * order. */
#ifndef PRISMFARM_PHOTON_PASS_H
#define PRISMFARM_PHOTON_PASS_H

#include "photon.h"

#include <stddef.h>
#include <stdint.h>

/* The whole photon pass of the scene's photon integrator on this machine: photons
 * [0, settings.photon.photons) traced by nthreads threads (0: every core) in contiguous
 * ranges merged in index order, then finished. The store is the same whatever nthreads, and
 * the same as a farm's that merged batches covering the same photons in index order. */
photon_store_t *photon_pass_run(const scene_t *scene, int nthreads, photon_stats_t *stats,
                                double *seconds, err_t *err);

/* photon_pass_run, telling fn (when not NULL) how many photons of total are traced so far,
 * every PHOTON_PASS_REPORT photons or so, from the tracing threads one at a time (fn need not
 * be thread-safe, and must be quick: the threads wait for it). The store is photon_pass_run's
 * to the bit: a thread traces its range in pieces, each appended in index order. */
#define PHOTON_PASS_REPORT 32768
typedef void (*photon_pass_progress_fn)(void *user, uint64_t done, uint64_t total);
photon_store_t *photon_pass_run_reporting(const scene_t *scene, int nthreads,
                                          photon_stats_t *stats, double *seconds,
                                          photon_pass_progress_fn fn, void *user, err_t *err);

/* A farm worker's photon batch: photons [first, end) of the scene's photon pass traced into a
 * fresh store (the scene's kind) and encoded in its wire form (*out malloc'ed), raw and
 * unnormalised, for the master to merge. Adds to *stats (may be NULL). */
int photon_batch_run(const scene_t *scene, uint64_t first, uint64_t end, uint8_t **out,
                     size_t *out_len, photon_stats_t *stats, err_t *err);

#endif
