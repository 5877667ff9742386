/* worker_handlers: what the worker does with each message from the master -- on_welcome,
 * on_task, on_scene (a bundle), on_store (a photon store), on_cancel, on_refuse; a HEARTBEAT
 * only shows that the master is alive -- and with the tasks its render threads finished. Each
 * takes the lock for as long as it touches the task queue and the caches. Called on the loop's
 * thread only. */
#ifndef PRISMFARM_WORKER_HANDLERS_H
#define PRISMFARM_WORKER_HANDLERS_H

#include "err.h"
#include "proto.h"
#include "worker_state.h"

/* Handles one message from the master. Returns 0, or -1 with err when the worker must end (the
 * master refused its protocol version). */
int worker_on_message(worker_t *w, const proto_msg_t *m, err_t *err);

/* Sends a RESULT or TASK_FAILED for each finished task of the current connection whose job
 * was not cancelled, and frees them all. A message sent makes now (the loop's time at this
 * turn) the connection's last_sent. */
void worker_send_results(worker_t *w, double now);

/* Says HELLO (name, threads, software). */
int worker_send_hello(worker_t *w);

#endif
