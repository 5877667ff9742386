/* conn_guard: a bound on the TCP connections a listening ROUTER holds (issue 16, item 12:
 * 1100 idle connections against a 1024 file limit locked every client out). libzmq has no
 * connection limit of its own, so the guard watches the socket's monitor events (ACCEPTED and
 * DISCONNECTED carry the connection's descriptor) and, when a new connection would take its
 * host over max_per_host open connections or the socket over max_total, makes room by shutting
 * down (shutdown(2), never close: the descriptor stays libzmq's, which then closes it as a peer
 * that went away) the oldest connection of that host (of any host, for max_total) that has not
 * finished its handshake -- one whose peer has sent fewer than handshake_bytes (TCP_INFO's
 * tcpi_bytes_received), which no finished handshake has -- and refuses the new connection
 * only when there is none (issue 26, finding 4: 2000 idle connections from one address
 * refused that address's own clients, and everyone behind one NAT or login node is one
 * address). A flooding host thus holds at most max_per_host descriptors however fast it
 * connects, its idle connections make room for its real clients, every other host still gets
 * in, and connected workers and clients are never evicted. Connections that never finish
 * their handshake are dropped by libzmq after ZMQ_HANDSHAKE_IVL (net_options_t.handshake_ms),
 * so an idle one costs a descriptor for that long at most. Refusals are logged within a rate
 * limit (ratelimit.h) and counted. */
#ifndef PRISMFARM_CONN_GUARD_H
#define PRISMFARM_CONN_GUARD_H

#include "err.h"

#include <stddef.h>
#include <stdint.h>

typedef struct conn_guard conn_guard_t;

typedef struct conn_guard_config {
    int max_per_host; /* open connections from one IP address; <= 0: no per-host bound */
    int max_total;    /* open connections in all; <= 0: no bound */
    /* The bytes every peer has sent once its handshake is finished (CurveZMQ: the 64-byte
     * greeting, HELLO and INITIATE, at least 521; the NULL mechanism: more than the
     * greeting, 65): fewer marks a connection that may be evicted to make room. 0: refuse the
     * new connection instead, as before. */
    uint64_t handshake_bytes;
} conn_guard_config_t;

#define CONN_GUARD_CURVE_HANDSHAKE 521
#define CONN_GUARD_NULL_HANDSHAKE 65

typedef void (*conn_guard_log_fn)(void *user, const char *line);

/* Watches router (a ZeroMQ ROUTER socket of zmq_ctx) from now on: create it before binding,
 * so that no accepted connection goes unseen. what names the endpoint in logs. */
conn_guard_t *conn_guard_new(void *zmq_ctx, void *router, const char *what,
                             const conn_guard_config_t *config, conn_guard_log_fn log, void *user,
                             err_t *err);

/* Handles the events that have arrived, without waiting. Call it every turn of the loop that
 * owns the socket (the refusal follows the accept by at most one turn). */
void conn_guard_pump(conn_guard_t *self);

typedef struct conn_guard_stats {
    size_t open;      /* connections open now */
    uint64_t refused; /* new connections shut down by the guard since conn_guard_new */
    uint64_t evicted; /* unfinished handshakes shut down to make room for a new one */
} conn_guard_stats_t;

conn_guard_stats_t conn_guard_stats(const conn_guard_t *self);

/* Stops watching (before the ROUTER is closed). */
void conn_guard_destroy(conn_guard_t **self_p);

#endif
