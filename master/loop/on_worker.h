/* on_worker: the master's answers to its workers' messages (docs/protocol.md): HELLO (join or
 * join again), HEARTBEAT, RESULT, TASK_FAILED, SCENE_REQUEST and STORE_REQUEST. Any message of
 * a known live worker is a sign of life; one from a worker the master does not know or gave up
 * on is refused with "send HELLO" (its result is still merged first: the work is good), and a
 * message that is not for this endpoint is refused with its name. */
#ifndef PRISMFARM_ON_WORKER_H
#define PRISMFARM_ON_WORKER_H

#include "master_state.h"

void on_worker_message(master_t *m, const proto_peer_t *from, const proto_msg_t *msg, double now);

#endif
