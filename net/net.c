#include "net.h"

#include "curve.h"
#include "zap.h"

#include <zmq.h>

#include <errno.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* The monitor events a DEALER watches to tell its user why a master does not answer. */
#define LINK_EVENTS                                                                                \
    (ZMQ_EVENT_CONNECTED | ZMQ_EVENT_DISCONNECTED | ZMQ_EVENT_HANDSHAKE_SUCCEEDED |                \
     ZMQ_EVENT_HANDSHAKE_FAILED_NO_DETAIL | ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL |                  \
     ZMQ_EVENT_HANDSHAKE_FAILED_AUTH)

static int drain(void *sock);

struct net {
    void *sock;
    net_kind_t kind;
    net_options_t opt;
    void *monitor;     /* DEALER: PAIR receiving the socket's monitor events */
    net_link_t link;   /* what those events said last */
    bool transport_up; /* a connection is made and its handshake is under way */
    char why[256];
    net_stats_t stats;
    size_t last_sent; /* bytes of the last message sent, to say what a drop may mean */
    char last_type[24];
};

net_stats_t net_stats(const net_t *self)
{
    return self->stats;
}

net_options_t net_options_default(void)
{
    return (net_options_t){
        .limits = proto_limits_default(),
        .sndhwm = 100,
        .rcvhwm = 100,
        .linger_ms = 1000,
        .send_timeout_ms = 0,
        /* zguide "Paranoid Pirate": interval 1 s, liveness 3. */
        .heartbeat_ivl_ms = 1000,
        .heartbeat_timeout_ms = 0,
        .heartbeat_ttl_ms = 0,
        .tcp_maxrt_ms = 10000,
        .handshake_ms = 10000,
        .reconnect_ivl_ms = 100,
        .reconnect_ivl_max_ms = 5000,
    };
}

const char *proto_peer_str(const proto_peer_t *peer, char buf[PROTO_PEER_STR])
{
    size_t n = peer->len < sizeof peer->id ? peer->len : sizeof peer->id;
    int printable = n > 0;
    for (size_t i = 0; i < n && printable; i++)
        printable = peer->id[i] >= 0x21 && peer->id[i] <= 0x7e;
    size_t end;
    if (printable) {
        memcpy(buf, peer->id, n);
        end = n;
    } else {
        static const char digits[] = "0123456789abcdef";
        buf[0] = '0';
        buf[1] = 'x';
        for (size_t i = 0; i < n; i++) {
            buf[2 + 2 * i] = digits[peer->id[i] >> 4];
            buf[3 + 2 * i] = digits[peer->id[i] & 15];
        }
        end = 2 + 2 * n;
    }
    buf[end] = 0;
    if (peer->user[0])
        snprintf(buf + end, PROTO_PEER_STR - end, " (key '%.*s')", (int)sizeof peer->user - 1,
                 peer->user);
    return buf;
}

/* How long a link may go without a whole message (net.h, heartbeat_timeout_ms): the base,
 * plus the largest message at the slowest link; within ZMQ_HEARTBEAT_TTL's 16-bit deciseconds. */
static int silence_ms(const net_options_t *o)
{
    double ms = NET_HEARTBEAT_BASE_MS +
                1000.0 * (double)o->limits.max_message_bytes / NET_MIN_LINK_BYTES_PER_S;
    return ms > 6553000.0 ? 6553000 : (int)ms;
}

/* The return code for a failed zmq call, from errno. */
static int zmq_code(int e)
{
    switch (e) {
    case EHOSTUNREACH:
        return PROTO_EUNREACHABLE;
    case EAGAIN:
    case EINTR:
        return PROTO_EAGAIN;
    default:
        return PROTO_ESOCKET;
    }
}

static int set_int(void *sock, int option, const char *name, int value, err_t *err)
{
    if (zmq_setsockopt(sock, option, &value, sizeof value) != 0)
        return err_set(err, "zmq_setsockopt(%s, %d): %s", name, value, zmq_strerror(zmq_errno()));
    return 0;
}

static int set_key(void *sock, int option, const char *name, const char *z85, err_t *err)
{
    size_t n = strlen(z85);
    if (n != 40)
        return err_set(err, "%s: a key is 40 Z85 characters, got %zu", name, n);
    /* 41 bytes: the Z85 text with its NUL (zmq_setsockopt's way of telling it from binary). */
    if (zmq_setsockopt(sock, option, z85, n + 1) != 0)
        return err_set(err, "zmq_setsockopt(%s): %s", name, zmq_strerror(zmq_errno()));
    return 0;
}

static int configure_curve(net_t *self, err_t *err)
{
    const net_curve_t *c = &self->opt.curve;
    void *s = self->sock;
    if (!c->server_public && !c->public_key && !c->secret_key)
        return c->zap_domain ? err_set(err, "a ZAP domain without CURVE keys") : 0;
    if (curve_available(err) < 0)
        return -1;
    if (self->kind == NET_ROUTER) {
        if (!c->secret_key || c->server_public || c->public_key)
            return err_set(err, "a ROUTER is a CURVE server: it takes its secret key only");
        if (set_int(s, ZMQ_CURVE_SERVER, "ZMQ_CURVE_SERVER", 1, err) ||
            set_key(s, ZMQ_CURVE_SECRETKEY, "ZMQ_CURVE_SECRETKEY", c->secret_key, err))
            return -1;
        if (c->zap_domain &&
            zmq_setsockopt(s, ZMQ_ZAP_DOMAIN, c->zap_domain, strlen(c->zap_domain)) != 0)
            return err_set(err, "zmq_setsockopt(ZMQ_ZAP_DOMAIN): %s", zmq_strerror(zmq_errno()));
        return 0;
    }
    if (!c->server_public || !c->public_key || !c->secret_key || c->zap_domain)
        return err_set(err, "a CURVE client needs the server's public key and its own key "
                            "pair (and no ZAP domain)");
    return set_key(s, ZMQ_CURVE_SERVERKEY, "ZMQ_CURVE_SERVERKEY", c->server_public, err) ||
                   set_key(s, ZMQ_CURVE_PUBLICKEY, "ZMQ_CURVE_PUBLICKEY", c->public_key, err) ||
                   set_key(s, ZMQ_CURVE_SECRETKEY, "ZMQ_CURVE_SECRETKEY", c->secret_key, err)
               ? -1
               : 0;
}

/* A DEALER's monitor: libzmq publishes the socket's events on an inproc endpoint named after
 * this object, and a PAIR of ours reads them (net_link). */
static int start_monitor(net_t *self, void *ctx, err_t *err)
{
    /* The name of a closed monitor stays taken until libzmq reaps its socket, and a new object
     * may get the old one's address: the clock and a retry make each name fresh. */
    char addr[96];
    int rc = -1;
    for (int attempt = 0; attempt < 16 && rc != 0; attempt++) {
        struct timespec ts;
        clock_gettime(CLOCK_MONOTONIC, &ts);
        snprintf(addr, sizeof addr, "inproc://prismfarm-net-monitor-%p-%llx-%d", (void *)self,
                 (unsigned long long)ts.tv_sec * 1000000000ULL + (unsigned long long)ts.tv_nsec,
                 attempt);
        rc = zmq_socket_monitor(self->sock, addr, LINK_EVENTS);
        if (rc != 0 && zmq_errno() != EADDRINUSE)
            break;
    }
    if (rc != 0)
        return err_set(err, "zmq_socket_monitor: %s", zmq_strerror(zmq_errno()));
    int linger = 0;
    if (!(self->monitor = zmq_socket(ctx, ZMQ_PAIR)))
        return err_set(err, "zmq_socket(PAIR) for the monitor: %s", zmq_strerror(zmq_errno()));
    if (zmq_setsockopt(self->monitor, ZMQ_LINGER, &linger, sizeof linger) != 0 ||
        zmq_connect(self->monitor, addr) != 0)
        return err_set(err, "monitor %s: %s", addr, zmq_strerror(zmq_errno()));
    return 0;
}

static int configure(net_t *self, err_t *err)
{
    const net_options_t *o = &self->opt;
    void *s = self->sock;
    if (configure_curve(self, err) < 0)
        return -1;
    int64_t maxmsg = o->limits.max_message_bytes > (size_t)INT64_MAX
                         ? INT64_MAX
                         : (int64_t)o->limits.max_message_bytes;
    if (zmq_setsockopt(s, ZMQ_MAXMSGSIZE, &maxmsg, sizeof maxmsg) != 0)
        return err_set(err, "zmq_setsockopt(ZMQ_MAXMSGSIZE, %lld): %s", (long long)maxmsg,
                       zmq_strerror(zmq_errno()));
    if (set_int(s, ZMQ_SNDHWM, "ZMQ_SNDHWM", o->sndhwm, err) ||
        set_int(s, ZMQ_RCVHWM, "ZMQ_RCVHWM", o->rcvhwm, err) ||
        set_int(s, ZMQ_LINGER, "ZMQ_LINGER", o->linger_ms, err) ||
        set_int(s, ZMQ_SNDTIMEO, "ZMQ_SNDTIMEO", o->send_timeout_ms, err) ||
        set_int(s, ZMQ_HEARTBEAT_IVL, "ZMQ_HEARTBEAT_IVL", o->heartbeat_ivl_ms, err) ||
        set_int(s, ZMQ_HEARTBEAT_TIMEOUT, "ZMQ_HEARTBEAT_TIMEOUT",
                o->heartbeat_timeout_ms > 0 ? o->heartbeat_timeout_ms : silence_ms(o), err) ||
        set_int(s, ZMQ_HEARTBEAT_TTL, "ZMQ_HEARTBEAT_TTL",
                o->heartbeat_ttl_ms > 0 ? o->heartbeat_ttl_ms : silence_ms(o), err) ||
        set_int(s, ZMQ_TCP_KEEPALIVE, "ZMQ_TCP_KEEPALIVE", 1, err) ||
        set_int(s, ZMQ_TCP_KEEPALIVE_IDLE, "ZMQ_TCP_KEEPALIVE_IDLE", 2, err) ||
        set_int(s, ZMQ_TCP_KEEPALIVE_INTVL, "ZMQ_TCP_KEEPALIVE_INTVL", 1, err) ||
        set_int(s, ZMQ_TCP_KEEPALIVE_CNT, "ZMQ_TCP_KEEPALIVE_CNT", 3, err) ||
        set_int(s, ZMQ_TCP_MAXRT, "ZMQ_TCP_MAXRT", o->tcp_maxrt_ms, err) ||
        set_int(s, ZMQ_HANDSHAKE_IVL, "ZMQ_HANDSHAKE_IVL", o->handshake_ms, err))
        return -1;
    if (self->kind == NET_ROUTER) {
        /* Without MANDATORY a ROUTER silently drops messages to unknown peers; with HANDOVER a
         * reconnecting worker that reuses its routing id takes over its old connection. */
        return set_int(s, ZMQ_ROUTER_MANDATORY, "ZMQ_ROUTER_MANDATORY", 1, err) ||
                       set_int(s, ZMQ_ROUTER_HANDOVER, "ZMQ_ROUTER_HANDOVER", 1, err)
                   ? -1
                   : 0;
    }
    if (set_int(s, ZMQ_RECONNECT_IVL, "ZMQ_RECONNECT_IVL", o->reconnect_ivl_ms, err) ||
        set_int(s, ZMQ_RECONNECT_IVL_MAX, "ZMQ_RECONNECT_IVL_MAX", o->reconnect_ivl_max_ms, err))
        return -1;
    if (o->routing_id) {
        size_t n = strlen(o->routing_id);
        if (n == 0 || n > 255)
            return err_set(err, "routing id has %zu bytes, expected 1..255", n);
        if (zmq_setsockopt(s, ZMQ_ROUTING_ID, o->routing_id, n) != 0)
            return err_set(err, "zmq_setsockopt(ZMQ_ROUTING_ID, '%s'): %s", o->routing_id,
                           zmq_strerror(zmq_errno()));
    }
    return 0;
}

net_t *net_new(void *zmq_ctx, net_kind_t kind, const net_options_t *options, err_t *err)
{
    if (kind != NET_ROUTER && kind != NET_DEALER) {
        err_set(err, "socket kind %d is neither ROUTER nor DEALER", (int)kind);
        return NULL;
    }
    net_t *self = calloc(1, sizeof *self);
    if (!self) {
        err_set(err, "out of memory for a socket");
        return NULL;
    }
    self->kind = kind;
    self->opt = options ? *options : net_options_default();
    self->sock = zmq_socket(zmq_ctx, kind == NET_ROUTER ? ZMQ_ROUTER : ZMQ_DEALER);
    if (!self->sock) {
        err_set(err, "zmq_socket(%s): %s", kind == NET_ROUTER ? "ROUTER" : "DEALER",
                zmq_strerror(zmq_errno()));
        free(self);
        return NULL;
    }
    if (configure(self, err) < 0 || (kind == NET_DEALER && start_monitor(self, zmq_ctx, err) < 0)) {
        net_destroy(&self);
        return NULL;
    }
    return self;
}

void net_destroy(net_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    net_t *self = *self_p;
    if (self->monitor) {
        (void)zmq_socket_monitor(self->sock, NULL, 0);
        (void)zmq_close(self->monitor);
    }
    /* zmq_close fails only on something that is not a socket (ENOTSOCK), which self->sock
     * always is; there is nobody to report to from a destructor. */
    (void)zmq_close(self->sock);
    free(self);
    *self_p = NULL;
}

int net_bind(net_t *self, const char *endpoint, err_t *err)
{
    if (zmq_bind(self->sock, endpoint) != 0)
        return err_set(err, "cannot bind %s: %s", endpoint, zmq_strerror(zmq_errno()));
    return 0;
}

int net_connect(net_t *self, const char *endpoint, err_t *err)
{
    if (zmq_connect(self->sock, endpoint) != 0)
        return err_set(err, "cannot connect to %s: %s", endpoint, zmq_strerror(zmq_errno()));
    return 0;
}

int net_endpoint(net_t *self, char *buf, size_t size, err_t *err)
{
    size_t n = size;
    if (zmq_getsockopt(self->sock, ZMQ_LAST_ENDPOINT, buf, &n) != 0)
        return err_set(err, "zmq_getsockopt(ZMQ_LAST_ENDPOINT): %s", zmq_strerror(zmq_errno()));
    return 0;
}

/* What one monitor event says about the link. */
static void link_event(net_t *self, unsigned event, uint32_t value)
{
    bool keys = self->opt.curve.secret_key != NULL;
    switch (event) {
    case ZMQ_EVENT_CONNECTED:
        self->transport_up = true;
        break;
    case ZMQ_EVENT_HANDSHAKE_SUCCEEDED:
        self->link = NET_LINK_UP;
        self->why[0] = 0;
        break;
    case ZMQ_EVENT_HANDSHAKE_FAILED_AUTH:
        self->link = NET_LINK_REFUSED;
        snprintf(self->why, sizeof self->why,
                 "refused our key (ZAP status %u): our .pub must be in its --authorized folder",
                 (unsigned)value);
        break;
    case ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL:
        self->link = NET_LINK_REFUSED;
        if (value == ZMQ_PROTOCOL_ERROR_ZMTP_MECHANISM_MISMATCH)
            snprintf(self->why, sizeof self->why, "%s",
                     keys ? "does not use CURVE, and we do: it runs with --insecure?"
                          : "requires CURVE: give our --key and its public key as --master-key");
        else if (value == ZMQ_PROTOCOL_ERROR_ZMTP_CRYPTOGRAPHIC)
            snprintf(self->why, sizeof self->why,
                     "failed the CURVE handshake (a cryptographic error): is --master-key its "
                     "public key?");
        else
            snprintf(self->why, sizeof self->why, "broke off the handshake (ZMTP error 0x%x)",
                     (unsigned)value);
        break;
    case ZMQ_EVENT_HANDSHAKE_FAILED_NO_DETAIL:
        self->link = NET_LINK_REFUSED;
        /* The other side closed during the handshake (EPIPE here): a CURVE server that cannot
         * read our HELLO, or a mechanism mismatch seen from our side before its ERROR. */
        snprintf(self->why, sizeof self->why, "broke off the %shandshake (%s): %s",
                 keys ? "CURVE " : "", zmq_strerror((int)value),
                 keys ? "is --master-key its public key, and does it use CURVE (not --insecure)?"
                      : "it may require CURVE keys (--key and --master-key)");
        break;
    case ZMQ_EVENT_DISCONNECTED:
        if (self->link == NET_LINK_UP) {
            self->link = NET_LINK_DROPPED;
            /* Which of the causes it can be: a large message may have passed the peer's
             * --max-message-mb (its ZMQ_MAXMSGSIZE closes the link without a word); any
             * message, a restart or a failed link. */
            if (self->last_sent > ((size_t)1 << 20))
                snprintf(self->why, sizeof self->why,
                         "closed the connection after we sent a %s of %.1f MiB: above its "
                         "--max-message-mb, or it restarted, or the link failed",
                         self->last_type, (double)self->last_sent / 1048576.0);
            else
                snprintf(self->why, sizeof self->why,
                         "closed the connection (it restarted, or the link failed)");
        } else if (self->transport_up && self->link != NET_LINK_REFUSED) {
            /* A CURVE server that cannot read our HELLO closes without a word. */
            self->link = NET_LINK_REFUSED;
            snprintf(self->why, sizeof self->why, "%s",
                     keys ? "closed the connection during the CURVE handshake: is --master-key "
                            "its public key?"
                          : "closed the connection during the handshake");
        }
        self->transport_up = false;
        break;
    default:
        break;
    }
}

net_link_t net_link(net_t *self, char *why, size_t size)
{
    while (self->monitor) {
        zmq_msg_t ev;
        if (zmq_msg_init(&ev) != 0)
            break;
        if (zmq_msg_recv(&ev, self->monitor, ZMQ_DONTWAIT) < 0) {
            (void)zmq_msg_close(&ev);
            break;
        }
        /* libzmq 4.3 event: [u16 event, u32 value] in host order, then the endpoint. */
        uint16_t event = 0;
        uint32_t value = 0;
        if (zmq_msg_size(&ev) >= 6) {
            memcpy(&event, zmq_msg_data(&ev), 2);
            memcpy(&value, (const char *)zmq_msg_data(&ev) + 2, 4);
        }
        int more = zmq_msg_more(&ev);
        (void)zmq_msg_close(&ev);
        if (more)
            (void)drain(self->monitor);
        link_event(self, event, value);
    }
    if (why && size > 0)
        snprintf(why, size, "%s", self->why);
    return self->link;
}

void *net_socket(net_t *self)
{
    return self->sock;
}

static void free_body(void *data, void *hint)
{
    (void)hint;
    free(data);
}

int net_send(net_t *self, const proto_peer_t *to, const proto_msg_t *msg, err_t *err)
{
    char who[PROTO_PEER_STR] = "master";
    if (self->kind == NET_ROUTER) {
        if (!to || to->len == 0 || to->len > sizeof to->id)
            return err_set(err, "%s: a ROUTER needs a peer to send to", proto_type_name(msg->type)),
                   PROTO_ESOCKET;
        proto_peer_str(to, who);
    } else if (to) {
        return err_set(err, "%s: a DEALER sends to its connection, not to a peer",
                       proto_type_name(msg->type)),
               PROTO_ESOCKET;
    }
    msgpack_sbuffer sb;
    msgpack_sbuffer_init(&sb);
    if (proto_encode(msg, &self->opt.limits, &sb, err) < 0) {
        msgpack_sbuffer_destroy(&sb);
        return PROTO_EMALFORMED;
    }
    /* The encoded buffer becomes the frame without a copy; libzmq frees it once sent. */
    size_t size = sb.size;
    char *data = msgpack_sbuffer_release(&sb);
    zmq_msg_t body;
    if (zmq_msg_init_data(&body, data, size, free_body, NULL) != 0) {
        int e = zmq_errno();
        free(data);
        return err_set(err, "%s to %s: zmq_msg_init_data: %s", proto_type_name(msg->type), who,
                       zmq_strerror(e)),
               PROTO_ESOCKET;
    }
    if (self->kind == NET_ROUTER && zmq_send(self->sock, to->id, to->len, ZMQ_SNDMORE) < 0) {
        int e = zmq_errno();
        (void)zmq_msg_close(&body); /* frees data through free_body */
        return err_set(err, "%s to %s: %s", proto_type_name(msg->type), who, zmq_strerror(e)),
               zmq_code(e);
    }
    if (zmq_msg_send(&body, self->sock, 0) < 0) {
        int e = zmq_errno();
        (void)zmq_msg_close(&body); /* after a failed send the message is still ours */
        return err_set(err, "%s to %s: %s", proto_type_name(msg->type), who, zmq_strerror(e)),
               zmq_code(e);
    }
    self->last_sent = size;
    snprintf(self->last_type, sizeof self->last_type, "%s", proto_type_name(msg->type));
    return 0;
}

/* Reads and drops what is left of a multipart message; returns the frames dropped. */
static int drain(void *sock)
{
    int more = 1, n = 0;
    size_t len = sizeof more;
    while (zmq_getsockopt(sock, ZMQ_RCVMORE, &more, &len) == 0 && more) {
        zmq_msg_t f;
        if (zmq_msg_init(&f) != 0)
            break;
        int rc = zmq_msg_recv(&f, sock, 0);
        (void)zmq_msg_close(&f);
        if (rc < 0)
            break;
        n++;
    }
    return n;
}

/* A received frame lent to its decoded message (proto_decode_lent): closed when the message is
 * freed. zmq_msg_close fails only on an invalid message, which this never is. */
static void body_release(void *arg)
{
    zmq_msg_t *body = arg;
    (void)zmq_msg_close(body);
    free(body);
}

int net_recv(net_t *self, proto_peer_t *from, proto_msg_t *out, int timeout_ms, err_t *err)
{
    memset(out, 0, sizeof *out);
    if (from)
        from->len = 0;
    if (self->kind == NET_ROUTER && !from)
        return err_set(err, "a ROUTER must say where the sender goes"), PROTO_ESOCKET;
    int flags = 0;
    if (timeout_ms >= 0) {
        zmq_pollitem_t item = {.socket = self->sock, .events = ZMQ_POLLIN};
        int n = zmq_poll(&item, 1, timeout_ms);
        if (n < 0) {
            int e = zmq_errno();
            return err_set(err, "zmq_poll: %s", zmq_strerror(e)), zmq_code(e);
        }
        if (n == 0)
            return err_set(err, "no message within %d ms", timeout_ms), PROTO_EAGAIN;
        flags = ZMQ_DONTWAIT;
    }
    char who[PROTO_PEER_STR] = "master";
    int more = 0;
    size_t len = sizeof more;
    if (self->kind == NET_ROUTER) {
        int n = zmq_recv(self->sock, from->id, sizeof from->id, flags);
        if (n < 0) {
            int e = zmq_errno();
            return err_set(err, "receiving: %s", zmq_strerror(e)), zmq_code(e);
        }
        /* libzmq routing ids are at most 255 bytes, the size of id: never truncated. */
        from->len = (size_t)n < sizeof from->id ? (size_t)n : sizeof from->id;
        proto_peer_str(from, who);
        if (zmq_getsockopt(self->sock, ZMQ_RCVMORE, &more, &len) != 0)
            return err_set(err, "from %s: ZMQ_RCVMORE: %s", who, zmq_strerror(zmq_errno())),
                   PROTO_ESOCKET;
        if (!more)
            return err_set(err, "from %s: a routing id without a message", who), PROTO_EMALFORMED;
        flags = 0; /* the rest of a multipart message has already arrived */
    }
    /* On the heap: a decoded message's bundle points into it (proto_decode_lent) until the
     * message is freed, so a large scene is held once, not twice. */
    zmq_msg_t *body = malloc(sizeof *body);
    if (!body)
        return err_set(err, "from %s: out of memory", who), PROTO_ESOCKET;
    if (zmq_msg_init(body) != 0) {
        free(body);
        return err_set(err, "zmq_msg_init: %s", zmq_strerror(zmq_errno())), PROTO_ESOCKET;
    }
    if (zmq_msg_recv(body, self->sock, flags) < 0) {
        int e = zmq_errno();
        body_release(body);
        return err_set(err, "from %s: %s", who, zmq_strerror(e)), zmq_code(e);
    }
    if (from) {
        /* The user id the ZAP handler gave this connection (RFC 27): the key's name. */
        const char *user = zmq_msg_gets(body, "User-Id");
        snprintf(from->user, sizeof from->user, "%s", user ? user : "");
        const char *role = user && *user ? zmq_msg_gets(body, ZAP_ROLE_PROPERTY) : NULL;
        snprintf(from->role, sizeof from->role, "%s", role ? role : "");
    }
    self->stats.messages_received++;
    self->stats.bytes_received += zmq_msg_size(body);
    int extra = drain(self->sock);
    int rc;
    if (extra > 0) {
        err_set(err, "from %s: %d frames after the message, expected none", who, extra);
        rc = PROTO_EMALFORMED;
    } else
        rc = proto_decode_lent(zmq_msg_data(body), zmq_msg_size(body), &self->opt.limits, out,
                               body_release, body, err);
    if (rc < 0)
        body_release(body); /* not lent: the message did not decode */
    if (rc < 0 && extra == 0)
        err_prefix(err, "from %s: ", who);
    return rc;
}
