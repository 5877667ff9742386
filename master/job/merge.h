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
    /* The RESULT message's bytes as received (proto_msg_t.wire), journaled as they are once
     * the result is merged (no second encoding); unused for a replay. */
    const void *wire;
    size_t wire_size;
} merge_source_t;

/* A RESULT message (decoded, from a worker or from the journal) for the job's task (the low
 * 32 bits of its task id) and attempt: a photon batch or a camera tile, checked against the
 * task; a bad one counts as the task's failure. */
void merge_result(master_t *m, job_t *j, const merge_source_t *src, uint32_t task, uint32_t attempt,
                  const proto_msg_t *msg, double now);

/* A result journaled by a master of journal version 8 (journal_blobs.c's tile and photon
 * blobs, kind 0 and 1), merged as a replay: a spool written before results were journaled as
 * received still resumes. -1 with err when the blob does not read. */
int merge_replay_v8(master_t *m, job_t *j, uint32_t task, int kind, const void *data, size_t size,
                    double now, err_t *err);

/* The photon phase is merged: its store's hash names it in every camera task, and with a
 * journal it goes to disk at once, so that a restart does not trace it again. */
void merge_photon_phase_done(master_t *m, job_t *j);

#endif
