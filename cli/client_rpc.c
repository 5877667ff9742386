#include "client_rpc.h"

#include "clock.h"
#include "net.h"

#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <zmq.h>

#define SLICE_MS 100 /* how often a waiting call looks at the connection's handshake */

struct client_rpc {
    void *ctx;
    int own_ctx;
    net_t *net;
    char endpoint[256];
    client_security_t sec; /* to connect again (client_rpc_reconnect) */
    client_rpc_progress_fn progress;
    void *progress_user;
};

void client_rpc_on_progress(client_rpc_t *self, client_rpc_progress_fn fn, void *user)
{
    self->progress = fn;
    self->progress_user = user;
}

const char *client_default_master(void)
{
    const char *e = getenv("PRISMFARM_MASTER");
    return e && *e ? e : "tcp://127.0.0.1:5556";
}

client_security_t client_security_default(void)
{
    const char *k = getenv("PRISMFARM_KEY"), *m = getenv("PRISMFARM_MASTER_KEY");
    return (client_security_t){.key_file = k && *k ? k : NULL,
                               .master_key_file = m && *m ? m : NULL};
}

int client_security_load(const client_security_t *sec, const char *endpoint,
                         curve_pair_t *pair, char master_public[CURVE_Z85 + 1],
                         int *use_curve, err_t *err)
{
    *use_curve = 0;
    if (sec->insecure && sec->keys_from_flags)
        return err_set(err, "--insecure and --key/--master-key exclude each other: choose one");
    /* --insecure overrides keys that only the environment gave. */
    int key = sec->key_file && !sec->insecure, master = sec->master_key_file && !sec->insecure;
    if (key != master)
        return err_set(err, "%s",
                       key ? "--key needs --master-key FILE.pub (or "
                             "$PRISMFARM_MASTER_KEY), the master's public key"
                           : "--master-key needs --key FILE (or $PRISMFARM_KEY), "
                             "our own key pair");
    if (curve_require(endpoint, key, sec->insecure, "--key FILE and --master-key FILE.pub",
                            err) < 0)
        return -1;
    if (!key)
        return 0;
    if (curve_load_pair(sec->key_file, pair, err) < 0 ||
        curve_load_public(sec->master_key_file, master_public, err) < 0)
        return -1;
    *use_curve = 1;
    return 0;
}

/* A DEALER connected to the endpoint with self->sec's keys, as self->net. */
static int open_net(client_rpc_t *self, err_t *err)
{
    curve_pair_t pair;
    char master_public[CURVE_Z85 + 1];
    int curve = 0;
    if (client_security_load(&self->sec, self->endpoint, &pair, master_public, &curve, err) < 0)
        return -1;
    net_options_t o = net_options_default();
    o.linger_ms = 0;
    o.send_timeout_ms = 5000;
    if (curve)
        o.curve = (net_curve_t){.server_public = master_public,
                                      .public_key = pair.public_key,
                                      .secret_key = pair.secret_key};
    self->net = net_new(self->ctx, NET_DEALER, &o, err);
    memset(&pair, 0, sizeof pair); /* libzmq keeps its own copy */
    if (!self->net || net_connect(self->net, self->endpoint, err)) {
        net_destroy(&self->net);
        return -1;
    }
    return 0;
}

/* What can be known at once about a tcp:// endpoint before ZeroMQ retries it quietly for as
 * long as a call waits: a port that is not a number in 1..65535, a host name that does not
 * resolve (-1), and (probe_ms > 0) a host that refuses the connection, nothing listening there
 * (CHECK_REFUSED, which a later try may not meet). A probe that gets no answer within probe_ms
 * says nothing: the call's own wait decides. */
enum { CHECK_REFUSED = -2 };
static int check_tcp_endpoint(const char *endpoint, int probe_ms, err_t *err)
{
    if (strncmp(endpoint, "tcp://", 6) != 0)
        return 0;
    char host[256];
    const char *hp = endpoint + 6, *colon = strrchr(hp, ':');
    if (!colon)
        return err_set(err, "the master's endpoint %s has no port (tcp://HOST:PORT)", endpoint);
    const char *port = colon + 1;
    char *end;
    errno = 0;
    long pn = strtol(port, &end, 10);
    if (end == port || *end || errno || pn < 1 || pn > 65535)
        return err_set(err, "the master's endpoint %s has port '%s': expected a number in 1..65535",
                       endpoint, port);
    size_t n = (size_t)(colon - hp);
    if (n >= sizeof host)
        return err_set(err, "the host name of %s is too long", endpoint);
    memcpy(host, hp, n);
    host[n] = 0;
    if (n >= 2 && host[0] == '[' && host[n - 1] == ']') { /* [::1] */
        memmove(host, host + 1, n - 2);
        host[n - 2] = 0;
    }
    struct addrinfo hints = {.ai_family = AF_UNSPEC, .ai_socktype = SOCK_STREAM}, *ai = NULL;
    int g = getaddrinfo(host, port, &hints, &ai);
    if (g != 0)
        return err_set(err, "cannot resolve the host '%s' of the master's endpoint %s: %s", host,
                       endpoint, gai_strerror(g));
    int refused = 0;
    int fd = probe_ms > 0 ? socket(ai->ai_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0) : -1;
    if (fd >= 0) {
        int rc = connect(fd, ai->ai_addr, ai->ai_addrlen);
        if (rc < 0 && errno == EINPROGRESS) {
            struct pollfd p = {.fd = fd, .events = POLLOUT};
            if (poll(&p, 1, probe_ms) == 1) {
                int e = 0;
                socklen_t len = sizeof e;
                if (getsockopt(fd, SOL_SOCKET, SO_ERROR, &e, &len) == 0 && e == ECONNREFUSED)
                    refused = 1;
            }
        } else if (rc < 0 && errno == ECONNREFUSED) {
            refused = 1;
        }
        (void)close(fd);
    }
    freeaddrinfo(ai);
    if (refused) {
        err_set(err, "the master at %s refused the connection: nothing listens on port %ld of %s "
                     "(is it running, on this port?)",
                endpoint, pn, host);
        return CHECK_REFUSED;
    }
    return 0;
}

int client_rpc_probe(const char *endpoint, double wait_s, const char *cmd, err_t *err)
{
    if (wait_s > CLIENT_RPC_LISTEN_WAIT_S)
        wait_s = CLIENT_RPC_LISTEN_WAIT_S;
    const double deadline = clock_now_s() + wait_s;
    for (int tries = 0;; tries++) {
        err_t e;
        const int rc = check_tcp_endpoint(endpoint, 2000, &e);
        if (rc == 0)
            return 0;
        /* Only a refusal is worth waiting out (a master starting or restarting); a bad port or
         * a host that does not resolve will not change. */
        if (rc != CHECK_REFUSED || clock_now_s() >= deadline) {
            *err = e;
            if (tries > 0)
                return err_set(err, "%s; waited %g s", e.msg, wait_s);
            return -1;
        }
        if (tries == 0 && cmd)
            fprintf(stderr,
                    "prismfarm %s: nothing listens at %s yet: waiting up to %g s for the master "
                    "to start\n",
                    cmd, endpoint, wait_s);
        struct timespec ts = {0, 200 * 1000 * 1000};
        nanosleep(&ts, NULL);
    }
}

client_rpc_t *client_rpc_new(const char *endpoint, void *zmq_ctx, const client_security_t *sec,
                             err_t *err)
{
    client_rpc_t *self = calloc(1, sizeof *self);
    if (!self) {
        err_set(err, "out of memory");
        return NULL;
    }
    snprintf(self->endpoint, sizeof self->endpoint, "%s", endpoint);
    if (check_tcp_endpoint(endpoint, 0, err) < 0) {
        free(self);
        return NULL;
    }
    if (sec)
        self->sec = *sec;
    self->ctx = zmq_ctx ? zmq_ctx : zmq_ctx_new();
    self->own_ctx = !zmq_ctx;
    if (!self->ctx) {
        err_set(err, "zmq_ctx_new: %s", zmq_strerror(errno));
        free(self);
        return NULL;
    }
    if (open_net(self, err) < 0) {
        client_rpc_destroy(&self);
        return NULL;
    }
    return self;
}

int client_rpc_reconnect(client_rpc_t *self, err_t *err)
{
    net_destroy(&self->net);
    return open_net(self, err);
}

void client_rpc_destroy(client_rpc_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    client_rpc_t *self = *self_p;
    net_destroy(&self->net);
    if (self->own_ctx && self->ctx)
        zmq_ctx_term(self->ctx);
    free(self);
    *self_p = NULL;
}

int client_rpc_call(client_rpc_t *self, const proto_msg_t *req, proto_msg_t *reply, int timeout_ms,
                    err_t *err)
{
    int r = net_send(self->net, NULL, req, err);
    char why[256];
    net_link_t link = NET_LINK_NONE;
    if (r == PROTO_EAGAIN) {
        /* The send found no connection: a refused handshake (its monitor event may be in by
         * now) says why, as it does while waiting for an answer below. */
        if (net_link(self->net, why, sizeof why) == NET_LINK_REFUSED)
            return err_set(err, "the master at %s %s", self->endpoint, why);
        return err_set(err, "cannot reach the master at %s: is it running?", self->endpoint),
               CLIENT_RPC_UNREACHABLE;
    }
    if (r)
        return -1;
    /* Waits in slices: a refused handshake or a dropped connection ends the wait at once, since
     * no answer can come through it. */
    for (int waited = 0;;) {
        int slice = timeout_ms < 0                   ? SLICE_MS
                    : timeout_ms - waited < SLICE_MS ? timeout_ms - waited
                                                     : SLICE_MS;
        r = net_recv(self->net, NULL, reply, slice, err);
        if (r == 0 && reply->type == PROTO_PROGRESS) {
            /* The master is at work on the request (a large scene loading): the answer
             * follows, so the wait starts again, however long the work takes. */
            if (self->progress)
                self->progress(self->progress_user, reply->progress.message,
                               reply->progress.elapsed);
            proto_msg_free(reply);
            waited = 0;
            continue;
        }
        if (r != PROTO_EAGAIN)
            break;
        waited += slice;
        link = net_link(self->net, why, sizeof why);
        if (link == NET_LINK_REFUSED)
            return err_set(err, "the master at %s %s", self->endpoint, why);
        if (link == NET_LINK_DROPPED)
            return err_set(err, "the master at %s %s", self->endpoint, why),
                   CLIENT_RPC_UNREACHABLE;
        if (timeout_ms >= 0 && waited >= timeout_ms)
            break;
    }
    if (r == PROTO_EAGAIN)
        return err_set(err, "no answer from the master at %s within %.1f s: %s", self->endpoint,
                       timeout_ms / 1000.0,
                       link == NET_LINK_UP
                           ? "it accepted the connection, but is busy or stuck"
                           : "is it running?"),
               CLIENT_RPC_UNREACHABLE;
    if (r == PROTO_EVERSION)
        return err_set(err, "the master at %s speaks protocol version %d, this client %d",
                       self->endpoint, reply->version, PROTO_VERSION);
    if (r)
        return -1;
    if (reply->type == PROTO_ERROR || reply->type == PROTO_REFUSE) {
        err_set(err, "%s",
                reply->type == PROTO_ERROR ? reply->error.message : reply->refuse.reason);
        proto_msg_free(reply);
        return -1;
    }
    return 0;
}
