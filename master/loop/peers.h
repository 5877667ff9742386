/* peers: the master's table of workers (master_state.h's m->workers) and what it says to them
 * beyond tasks (dispatch.h). A worker joins by HELLO (on_worker.c) and stays in the table,
 * alive or lost; a lost worker's tasks are back in the scheduler's queue the moment it is
 * marked lost, and a peer that can no longer be reached is lost at the first send. The master
 * and the scheduler always agree on who is alive. */
#ifndef PRISMFARM_PEERS_H
#define PRISMFARM_PEERS_H

#include "master_state.h"

/* The worker with this routing id, alive or lost; NULL if none. */
mworker_t *peers_find(const master_t *m, const proto_peer_t *p);
/* A new worker in the table with the next worker id; NULL (logged) when out of memory. */
mworker_t *peers_add(master_t *m, const proto_peer_t *from);
void peers_free(mworker_t *w);

/* The worker of this id, alive or lost (O(log n): m->workers is in id order); NULL if none. */
mworker_t *peers_by_id(const master_t *m, uint64_t id);
/* The worker w was before its latest HELLO on a new connection: another entry with the same
 * key and name, the live one if any, else the one seen last; NULL when there is none. A worker's
 * standing follows its key and name, not its connection (sched_worker_take_over). */
mworker_t *peers_find_same(const master_t *m, const mworker_t *w);

/* The scheduler's view of every worker, in m->winfo sorted by id; returns the count. */
size_t peers_sched_table(master_t *m);
/* The entry for worker id among the n of m->winfo (a binary search, so that a listing of every
 * worker is n log n); NULL if none. */
const sched_worker_info_t *peers_sched_info(master_t *m, size_t n, uint64_t id);

/* The worker is gone (why, for the log): its tasks go back to the queue. Nothing for a worker
 * lost already. */
/* why PEERS_DISCONNECTED: its connection dropped, and the tasks it held count as expired
 * (sched_worker_dropped); any other why (silence): they only go back to the queue. */
#define PEERS_DISCONNECTED "disconnected"
void peers_lost(master_t *m, mworker_t *w, const char *why);
/* Forgets the lost worker seen longest ago once more than MAX_LOST_WORKERS are listed. */
void peers_prune_lost(master_t *m);

/* Sends to a worker; a peer that is no longer connected is lost. Returns net_send's
 * code. */
int peers_send(master_t *m, mworker_t *w, const proto_msg_t *msg);
/* CANCEL {job} to every live worker, and the job's unsent task dropped. */
void peers_cancel_job(master_t *m, uint64_t job);

/* The workers' silence: a turn of the loop that took busy seconds, more than half the worker
 * timeout, counts as a sign of life for every worker; a worker silent longer than the timeout
 * is lost. */
void peers_check_silence(master_t *m, double now, double busy);
/* Every worker the scheduler timed out is lost for the master too. */
void peers_agree_with_sched(master_t *m);
/* HEARTBEAT to every live worker, once every heartbeat interval. */
void peers_heartbeat(master_t *m, double now);

/* The worker's state as clients see it (si: its scheduler entry, may be NULL). */
proto_worker_state_t peers_wire_state(const mworker_t *w, const sched_worker_info_t *si);

/* The samples of a result the worker returned at now, counted in its rate. */
void peers_count_samples(mworker_t *w, uint64_t samples, double now);
/* Its samples per second over its last PEERS_RATE_WINDOW_S seconds or more; before its first
 * full window, over the current one (at least a second); 0 when it has returned nothing for two
 * windows. */
double peers_samples_per_s(const mworker_t *w, double now);
#define PEERS_RATE_WINDOW_S 5.0

#endif
