/* client_rpc: one request to the master's client endpoint and its reply, for the `prismfarm`
 * commands that talk to a master (submit, status, jobs, workers, fetch, cancel). */
#ifndef PRISMFARM_CLIENT_RPC_H
#define PRISMFARM_CLIENT_RPC_H

#include "err.h"
#include "proto.h"

/* The endpoint used when --master is not given: $PRISMFARM_MASTER, else tcp://127.0.0.1:5556. */
const char *client_default_master(void);

typedef struct client_rpc client_rpc_t;

/* A connection to the master at endpoint; ctx NULL makes one. */
client_rpc_t *client_rpc_new(const char *endpoint, void *zmq_ctx, err_t *err);
void client_rpc_destroy(client_rpc_t **self_p);

/* Sends req and waits up to timeout_ms for the reply (free it with proto_msg_free). An ERROR or
 * REFUSE reply becomes -1 with its text in err; so does silence ("no answer from the master at
 * ENDPOINT within 10 s: is it running?"). */
int client_rpc_call(client_rpc_t *self, const proto_msg_t *req, proto_msg_t *reply, int timeout_ms,
                    err_t *err);

#endif
