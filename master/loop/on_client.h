/* on_client: the master's answers to its clients' requests (docs/protocol.md): SUBMIT (handed
 * to the submission pipeline, submit.h), STATUS
 * (at once, or held as a long poll until the job is over or the wait runs out), JOBS, WORKERS,
 * FETCH, REFINE and CANCEL. Every request is answered, with an ERROR that says why when it
 * cannot be done; a submission is journaled before it is acknowledged, and a client sees
 * paths as they are in its bundle, never the master's spool folder. */
#ifndef PRISMFARM_ON_CLIENT_H
#define PRISMFARM_ON_CLIENT_H

#include "master_state.h"

void on_client_message(master_t *m, const proto_peer_t *from, const proto_msg_t *msg, double now);

/* Answers the STATUS long polls whose job is over or whose wait ran out; returns the time
 * until the next deadline in ms (at most POLL_MS), for the poll. */
int on_client_answer_waiters(master_t *m, double now);

#endif
