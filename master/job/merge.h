/* merge: a result into its job, from a worker or replayed from the journal. Each result is
 * checked against its task (nothing a worker sends is trusted: a bad one fails the task, never
 * the master), handed to the scheduler or the photon phase, and journaled once merged. At each
 * pass boundary: the error estimate, the pass's record and log line, the stopping rules and a
 * preview; when the photon phase is merged, its store's hash for the camera tasks. Replayed
 * results are merged in the same order as first, so a restarted master's pixels are those of
 * an uninterrupted run. */
#ifndef PRISMFARM_MERGE_H
#define PRISMFARM_MERGE_H

#include "master_state.h"

/* Who a result came from: a worker, or the journal (id 0) when a restarted master merges
 * what it had received before again. */
typedef struct merge_source {
    uint64_t id;
    const char *name;
    const char *key; /* the worker's key name (NULL or "" without CURVE) */
    bool replay;
    double elapsed;   /* the worker's time on the task, seconds (for the task log) */
    uint64_t samples; /* samples (or photons) it says it traced */
} merge_source_t;

/* A photon batch's result for task (SCHED_PHOTON_TASK | batch). */
void merge_photon_batch(master_t *m, job_t *j, const merge_source_t *src, uint32_t task,
                        uint32_t attempt, const proto_photon_result_t *r, double now);

/* A camera tile's result: tb (taken) covers samples [sb, se). wire is the result as received,
 * journaled once merged; NULL for one replayed from the journal. */
void merge_camera_tile(master_t *m, job_t *j, const merge_source_t *src, uint32_t task,
                       uint32_t attempt, tilebuf_t *tb, uint32_t sb, uint32_t se,
                       const proto_tile_result_t *wire, double now);

/* The photon phase is merged: its store's hash names it in every camera task, and with a
 * journal it goes to disk at once, so that a restart does not trace it again. */
void merge_photon_phase_done(master_t *m, job_t *j);

#endif
