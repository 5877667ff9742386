#include "client_rpc.h"

#include "net.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <zmq.h>

struct client_rpc {
    void *ctx;
    int own_ctx;
    proto_net_t *net;
    char endpoint[256];
};

const char *client_default_master(void)
{
    const char *e = getenv("PRISMFARM_MASTER");
    return e && *e ? e : "tcp://127.0.0.1:5556";
}

client_rpc_t *client_rpc_new(const char *endpoint, void *zmq_ctx, err_t *err)
{
    client_rpc_t *self = calloc(1, sizeof *self);
    if (!self) {
        err_set(err, "out of memory");
        return NULL;
    }
    snprintf(self->endpoint, sizeof self->endpoint, "%s", endpoint);
    self->ctx = zmq_ctx ? zmq_ctx : zmq_ctx_new();
    self->own_ctx = !zmq_ctx;
    if (!self->ctx) {
        err_set(err, "zmq_ctx_new: %s", zmq_strerror(errno));
        free(self);
        return NULL;
    }
    proto_net_options_t o = proto_net_options_default();
    o.linger_ms = 0;
    o.send_timeout_ms = 5000;
    self->net = proto_net_new(self->ctx, PROTO_NET_DEALER, &o, err);
    if (!self->net || proto_net_connect(self->net, endpoint, err)) {
        client_rpc_destroy(&self);
        return NULL;
    }
    return self;
}

void client_rpc_destroy(client_rpc_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    client_rpc_t *self = *self_p;
    proto_net_destroy(&self->net);
    if (self->own_ctx && self->ctx)
        zmq_ctx_term(self->ctx);
    free(self);
    *self_p = NULL;
}

int client_rpc_call(client_rpc_t *self, const proto_msg_t *req, proto_msg_t *reply, int timeout_ms,
                    err_t *err)
{
    int r = proto_net_send(self->net, NULL, req, err);
    if (r == PROTO_EAGAIN)
        return err_set(err, "cannot reach the master at %s: is it running?", self->endpoint);
    if (r)
        return -1;
    r = proto_net_recv(self->net, NULL, reply, timeout_ms, err);
    if (r == PROTO_EAGAIN)
        return err_set(err, "no answer from the master at %s within %.1f s: is it running?",
                       self->endpoint, timeout_ms / 1000.0);
    if (r == PROTO_EVERSION)
        return err_set(err, "the master at %s speaks protocol version %d, this client %d",
                       self->endpoint, reply->version, PROTO_VERSION);
    if (r)
        return -1;
    if (reply->type == PROTO_ERROR || reply->type == PROTO_REFUSE) {
        err_set(err, "%s", reply->type == PROTO_ERROR ? reply->error.message : reply->refuse.reason);
        proto_msg_free(reply);
        return -1;
    }
    return 0;
}
