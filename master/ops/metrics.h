/* metrics: the master's figures in Prometheus' text exposition format (version 0.0.4:
 * prometheus.io/docs/instrumenting/exposition_formats), for `/metrics` on the dashboard's
 * HTTP port and `prismfarm metrics` over the client protocol -- the same text from the same
 * function. Every family has its # HELP and # TYPE lines before its samples; label values
 * are escaped (backslash, double quote, newline); every value is finite. The figures:
 *   prismfarm_jobs{state}                       gauge   jobs the master holds, by state
 *   prismfarm_tasks_in_flight                   gauge   tasks handed to workers, not back yet
 *   prismfarm_queue_depth                       gauge   tasks waiting to be handed out
 *   prismfarm_workers{state}                    gauge   workers by state (idle, busy, ...)
 *   prismfarm_worker_samples_per_second{worker,id}  gauge  each live worker's recent rate
 *   prismfarm_worker_tasks_done_total{worker,id}    counter
 *   prismfarm_worker_tasks_failed_total{worker,id}  counter
 *   prismfarm_received_messages_total{endpoint} counter messages taken off each endpoint
 *   prismfarm_received_bytes_total{endpoint}    counter their bytes
 *   prismfarm_journal_writes_total              counter journal transactions and results
 *   prismfarm_journal_write_seconds_total       counter the time they took
 * A snapshot (metrics_snapshot_t) is what the text is rendered from, so that the format is
 * tested without a master. */
#ifndef PRISMFARM_METRICS_H
#define PRISMFARM_METRICS_H

#include "err.h"
#include "proto.h"

#include <stddef.h>
#include <stdint.h>

typedef struct metrics_worker {
    const char *name;
    uint64_t id;
    proto_worker_state_t state;
    double samples_per_s;
    uint64_t tasks_done, tasks_failed;
} metrics_worker_t;

typedef struct metrics_snapshot {
    uint64_t jobs[JOB_STATE_COUNT]; /* by job_state_t */
    uint64_t tasks_in_flight, queue_depth;
    const metrics_worker_t *workers;
    size_t nworkers;
    uint64_t messages_workers, messages_clients; /* received on each endpoint */
    uint64_t bytes_workers, bytes_clients;
    uint64_t journal_writes;
    double journal_write_seconds;
} metrics_snapshot_t;

/* The text of a snapshot, malloc'ed and NUL-terminated, its length in *len. */
int metrics_render(const metrics_snapshot_t *s, char **text, size_t *len, err_t *err);

typedef struct master master_t;
/* The master's metrics now (monotonic seconds), as metrics_render writes them. For the
 * master's own thread only (it reads the master's state unlocked). */
int master_metrics_text(master_t *m, double now, char **text, size_t *len, err_t *err);

#endif
