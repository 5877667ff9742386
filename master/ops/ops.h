/* ops: what an operator does to a running farm (docs/farm.md, "Operating a farm"): a job's
 * priority, pause and resume, a stuck task requeued by hand, a blocked worker unblocked. One
 * implementation for the client requests (ACT, on_ops.c) and the dashboard's HTTP actions:
 * each function checks that who may act -- the job's owner or an admin; a worker is every
 * job's, so only an admin unblocks one -- does it, journals it (a paused job is still paused
 * after a restart; a blocked worker still blocked), and writes it to the master's log and the
 * job's task log with the key's name. It returns 0, or -1 with err saying why not (the text a
 * client or the dashboard shows). Also here: the master's side of the scheduler's blocklist
 * (by worker name, so that a worker that reconnects stays blocked) and the scheduler's events
 * turned into task-log lines. */
#ifndef PRISMFARM_OPS_H
#define PRISMFARM_OPS_H

#include "master_state.h"

#include <stdbool.h>

/* Who asks: a key's name ("" without keys) and whether it is an admin's. */
typedef struct master_actor {
    const char *name;
    bool admin;
} master_actor_t;

/* The actor of a client connection: its ZAP user id; an admin when its key is an admin's
 * (access.h), or when the master has no keys at all (every client is then the same anonymous
 * user, who holds every right: docs/security.md). */
master_actor_t ops_actor_of_peer(const master_t *m, const proto_peer_t *peer);
/* Whether who may act on the job (access.h's rule: its owner or an admin); err says why
 * not. */
bool ops_may_act(const master_t *m, const job_t *j, const master_actor_t *who, err_t *err);

/* On a frame sequence, these three act on each of its frames that is not over. */
int master_job_set_priority(master_t *m, uint64_t job, int priority, const master_actor_t *who,
                            err_t *err);
/* Workers finish the tasks of the job they hold; no more are handed out until resumed. */
int master_job_pause(master_t *m, uint64_t job, const master_actor_t *who, err_t *err);
int master_job_resume(master_t *m, uint64_t job, const master_actor_t *who, err_t *err);
/* A running task (stuck on its worker) back to the queue: sched_requeue_task. */
int master_task_requeue(master_t *m, uint64_t job, uint32_t task, const master_actor_t *who,
                        err_t *err);
/* worker: a worker's name or its id as `prismfarm workers` shows it. */
int master_worker_unblock(master_t *m, const char *worker, const master_actor_t *who, err_t *err);
/* Blocks a worker from every job by hand (the dashboard's blocklist action): as if it had
 * failed too often, until unblocked. An admin's action. */
int master_worker_block(master_t *m, const char *worker, const master_actor_t *who, err_t *err);

/* A job about to be scheduled, submitted with priority (not paused). */
void ops_job_init(job_t *j, int priority);
/* A worker said HELLO: blocked again if its name is on the blocklist. */
void ops_worker_joined(master_t *m, mworker_t *w);
/* Whether the worker is on the blocklist (for WORKERS): by its name, or by its key. */
bool ops_worker_blocked(const master_t *m, const mworker_t *w);
/* A blocklist entry of a worker's key: "key:NAME" (`prismfarm unblock key:NAME` lifts it). */
#define OPS_KEY_PREFIX "key:"
/* The entry a worker's strikes block (SCHED_EV_WORKER_BLOCKED): its key's when it has one,
 * else its name. */
void ops_block_entry(const mworker_t *w, char *buf, size_t size);
/* The blocklist from the journal (at start). */
int ops_load_blocked(master_t *m, err_t *err);
void ops_free(master_t *m);
/* The scheduler's events since the last call, as task-log lines (and new blocks onto the
 * blocklist); then the task logs are flushed. Once per loop turn. */
void ops_turn(master_t *m);

#endif
