/* net: ZeroMQ sockets set up the way the farm needs them, and one proto message sent or received
 * per call. libzmq's defaults do not suit a farm (a ROUTER silently drops messages to unknown
 * peers and above its high-water mark, which counts messages, not bytes; any frame size is
 * accepted; a dead peer goes unnoticed), so here a ROUTER reports unroutable peers instead of
 * dropping messages (ZMQ_ROUTER_MANDATORY), every socket has bounded queues, a frame-size cap
 * (ZMQ_MAXMSGSIZE) and libzmq heartbeats, CURVE when given keys, and every failure names the
 * endpoint or peer and zmq_strerror. A DEALER watches its handshake, so that a refused key is
 * reported instead of waited for.
 *
 * Framing (docs/protocol.md): a DEALER sends and receives exactly one frame, the encoded message;
 * the ROUTER sees [peer routing id][message]. No empty delimiter frame (no REQ/REP peers); any
 * other frame count is malformed. */
#ifndef PRISMFARM_NET_H
#define PRISMFARM_NET_H

#include "err.h"
#include "proto.h"

#include <stddef.h>
#include <stdint.h>

/* Return codes beyond proto.h's PROTO_EMALFORMED and PROTO_EVERSION. */
#define PROTO_ESOCKET (-3)      /* the socket is unusable (context terminated, ...): stop */
#define PROTO_EUNREACHABLE (-4) /* ROUTER send: no connected peer with that routing id */
#define PROTO_EAGAIN (-5)       /* nothing within the timeout, a full peer queue, or a signal */

typedef enum net_kind { NET_ROUTER, NET_DEALER } net_kind_t;

/* CURVE encryption and authentication (docs/security.md; keys from curve.h). All NULL: plain
 * text. A ROUTER with secret_key is a CURVE server: its clients' keys are checked by the ZAP
 * handler of its context (zap.h), which must run before the ROUTER binds. A DEALER with the three
 * keys is a CURVE client of the server whose public key it holds. */
typedef struct net_curve {
    const char *server_public; /* DEALER: the master's public key (Z85, 40 chars) */
    const char *public_key;    /* DEALER: this socket's key pair (Z85) */
    const char *secret_key;    /* DEALER: its secret; ROUTER: the server's secret key */
    const char *zap_domain;    /* ROUTER: the ZAP domain, which tells the handler the endpoint */
} net_curve_t;

typedef struct net_options {
    proto_limits_t limits;    /* ZMQ_MAXMSGSIZE is limits.max_message_bytes; recv decodes with it */
    int sndhwm, rcvhwm;       /* messages (not bytes) queued per peer each way */
    int linger_ms;            /* how long closing waits for unsent messages */
    int send_timeout_ms;      /* how long a send waits for room in the peer's queue; -1 forever */
    int heartbeat_ivl_ms;     /* ZMQ_HEARTBEAT_IVL: libzmq pings this often */
    /* ZMQ_HEARTBEAT_TIMEOUT: no whole message that long closes the link; ZMQ_HEARTBEAT_TTL
     * asks the remote side to do the same. libzmq counts only whole messages, so a link busy
     * with one large message (a 450 MB scene: issue 16, item 9) looks silent for as long as it
     * takes: 0, the default, is NET_HEARTBEAT_BASE_MS plus the time limits.max_message_bytes
     * takes at NET_MIN_LINK_BYTES_PER_S. A dead host is found by TCP instead (tcp_maxrt_ms
     * and keepalives), within seconds whatever the messages. */
    int heartbeat_timeout_ms;
    int heartbeat_ttl_ms;
    int tcp_maxrt_ms; /* ZMQ_TCP_MAXRT (TCP_USER_TIMEOUT): data unacknowledged that long drops
                       * the link; keepalive probes after 2 s idle, 1 s apart, 3 of them */
    int handshake_ms;         /* ZMQ_HANDSHAKE_IVL: a connection that has not finished its
                               * (CURVE) handshake by then is dropped, so an idle stranger holds
                               * a descriptor that long at most (issue 16, item 12) */
    int reconnect_ivl_ms, reconnect_ivl_max_ms; /* DEALER: reconnection back-off */
    const char *routing_id; /* DEALER: 1..255 bytes, first byte not 0; NULL lets the ROUTER pick
                             * one. With ROUTER_HANDOVER a reconnecting peer keeps its id. */
    net_curve_t curve;
} net_options_t;

#define NET_HEARTBEAT_BASE_MS 3000
#define NET_MIN_LINK_BYTES_PER_S (10.0 * 1024 * 1024) /* 80 Mbit/s: the slowest link planned for */

/* The defaults: no CURVE, proto_limits_default(), HWM 100 each way, linger 1000 ms, send timeout 0
 * (a send never blocks: a full queue is PROTO_EAGAIN), heartbeats every 1000 ms with the
 * timeouts from the message limit (above), TCP's user timeout 10 s (a dead host is noticed
 * within about 10 s), handshakes within 10 s, reconnect 100 ms doubling to 5000 ms. */
net_options_t net_options_default(void);

/* A peer as a ROUTER knows it: its routing id. */
typedef struct proto_peer {
    uint8_t id[255];
    size_t len;
    /* The ZAP handler's user id for the connection (zap.h: the authorised key's file name),
     * filled by net_recv on a CURVE ROUTER; empty without CURVE. */
    char user[72];
    /* Its role (zap.h's ZAP_ROLE_*: the folder the key is in), filled with user; empty
     * without CURVE. */
    char role[8];
} proto_peer_t;

#define PROTO_PEER_STR 640
/* The routing id for logs: as text when printable, else "0x" and hex, followed by
 * " (key 'NAME')" when the connection has a key (issue 16: logs name the key, not only the
 * connection). Returns buf. */
const char *proto_peer_str(const proto_peer_t *peer, char buf[PROTO_PEER_STR]);

typedef struct net net_t;

/* A configured socket on the caller's ZeroMQ context. options NULL: the defaults. */
net_t *net_new(void *zmq_ctx, net_kind_t kind, const net_options_t *options,
                           err_t *err);
/* Closes the socket (waiting at most linger_ms for unsent messages) and frees it. */
void net_destroy(net_t **self_p);

int net_bind(net_t *self, const char *endpoint, err_t *err);
int net_connect(net_t *self, const char *endpoint, err_t *err);
/* The endpoint last bound, with the port the system chose for "tcp://host:*". */
int net_endpoint(net_t *self, char *buf, size_t size, err_t *err);

/* What a DEALER knows of its connection, from libzmq's monitor events. */
typedef enum net_link {
    NET_LINK_NONE,    /* no connection yet: nothing listens there, or still trying */
    NET_LINK_UP,      /* connected, and the handshake (CURVE or plain) succeeded */
    NET_LINK_REFUSED, /* the handshake failed: refused key, wrong server key, CURVE on
                             * one side only */
    NET_LINK_DROPPED  /* was up, then the other side closed it (a message above its
                             * ZMQ_MAXMSGSIZE, a restart) */
} net_link_t;

/* Reads the DEALER's pending monitor events and returns the state they leave; for REFUSED and
 * DROPPED, why (size bytes, may be NULL) says what happened in words for the user. A ROUTER
 * always returns NET_LINK_NONE. The state persists until an event changes it. */
net_link_t net_link(net_t *self, char *why, size_t size);

/* The libzmq socket, for zmq_poll; do not send or receive on it directly. */
void *net_socket(net_t *self);

/* Encodes and sends msg; to is the destination on a ROUTER and must be NULL on a DEALER.
 * Returns 0, PROTO_EMALFORMED (msg does not encode), PROTO_EUNREACHABLE, PROTO_EAGAIN or
 * PROTO_ESOCKET. */
int net_send(net_t *self, const proto_peer_t *to, const proto_msg_t *msg, err_t *err);

/* Receives and decodes one message into out (free it with proto_msg_free, which also releases
 * the received frame its byte fields point into: proto_decode_lent), waiting at most
 * timeout_ms (0: do not wait, -1: forever). On a ROUTER *from is the sender (from may be NULL on a
 * DEALER). Returns 0; PROTO_EAGAIN when nothing came in time; PROTO_EMALFORMED or PROTO_EVERSION
 * when a peer sent something undecodable (*from says who, so it can be refused: proto.h's
 * proto_refuse_version); PROTO_ESOCKET. */
int net_recv(net_t *self, proto_peer_t *from, proto_msg_t *out, int timeout_ms,
                   err_t *err);

/* What net_recv has taken off the socket since net_new: messages and their bytes (the body,
 * before decoding; malformed ones included). */
typedef struct net_stats {
    uint64_t messages_received, bytes_received;
} net_stats_t;
net_stats_t net_stats(const net_t *self);

#endif
