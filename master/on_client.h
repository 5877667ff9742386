/* on_client: the master's answers to its clients' requests (docs/protocol.md): SUBMIT, STATUS
 * (at once, or held as a long poll until the job is over or the wait runs out), JOBS, WORKERS,
 * FETCH, REFINE and CANCEL. Every request is answered, with an ERROR that says why when it
 * cannot be done; a submission is journaled before it is acknowledged, and a client sees
 * paths as they are in its bundle, never the master's spool folder. */
#ifndef PRISMFARM_ON_CLIENT_H
#define PRISMFARM_ON_CLIENT_H

#include "master_state.h"

void on_client_message(master_t *m, const proto_peer_t *from, const proto_msg_t *msg, double now);

/* How often a client whose scene is loading hears PROGRESS (well inside any client's wait),
 * after the first, sent as soon as the submission is queued to load. */
#define PROGRESS_S 2.0

/* Finishes the submissions whose scene the loader has loaded (or refused): each is scheduled,
 * journaled and answered SUBMITTED, or answered with the load's error; and sends a PROGRESS
 * to each client whose scene is still loading, every PROGRESS_S. Call it every turn. */
void on_client_loads(master_t *m, double now);

/* Frees a submission the loader hands back without it being finished (loader_destroy's
 * release): its staged folder is removed. */
void on_client_submission_drop(void *arg);

/* Answers the STATUS long polls whose job is over or whose wait ran out; returns the time
 * until the next deadline in ms (at most POLL_MS), for the poll. */
int on_client_answer_waiters(master_t *m, double now);

#endif
