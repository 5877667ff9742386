/* dash_server: the dashboard's HTTP port, libmicrohttpd run without threads of its own. Its
 * sockets sit behind one epoll descriptor that the daemon's own poll waits on (dash_server_fd,
 * at most dash_server_timeout_ms); dash_server_run then serves what is ready and returns
 * without blocking, so every request is answered on the daemon's thread between two turns of
 * its loop (dash_route.h). Bounded: connections at once, the memory of one connection (request
 * line and headers), the body (DASH_MAX_BODY), an idle connection's life; beyond them the
 * server answers 4xx or closes. Idle connections never lock users out (issue 26, finding 4):
 * once DASH_EVICT_AT connections are open, each new one closes the connection that has been
 * idle longest (no request being answered), so a flood of idle or half-sent connections --
 * from one address, as everyone behind an SSH tunnel or a NAT is, or from many -- only ever
 * evicts itself, and a user's request, sent at once on connecting, is answered. There is no
 * per-address bound: on a loopback dashboard every user is 127.0.0.1. */
#ifndef PRISMFARM_DASH_SERVER_H
#define PRISMFARM_DASH_SERVER_H

#include "dash_route.h"
#include "err.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define DASH_MAX_CONNECTIONS 256 /* at once (libmicrohttpd stops accepting beyond) */
#define DASH_EVICT_AT 224        /* from this many on, a new connection evicts the idlest */
#define DASH_IDLE_TIMEOUT_S 30   /* a connection that sends nothing for this long is closed */
#define DASH_CONNECTION_MEMORY (32 << 10) /* request line and headers of one connection */

typedef struct dash_server_config {
    char address[64]; /* IPv4, dotted */
    int port;         /* 0: the system chooses (dash_server_port) */
} dash_server_config_t;

/* "PORT", ":PORT" or "ADDR:PORT" (ADDR: an IPv4 address or "localhost"; 127.0.0.1 when only a
 * port is given) into *out; -1 with err naming what was expected. */
int dash_server_parse_address(const char *spec, dash_server_config_t *out, err_t *err);
/* Whether the address is 127.x.x.x: only this host can connect. */
bool dash_server_loopback(const dash_server_config_t *cfg);

typedef struct dash_server dash_server_t;

/* Binds and listens; answers with router (not owned). NULL with err. */
dash_server_t *dash_server_new(const dash_server_config_t *cfg, dash_router_t *router, err_t *err);
void dash_server_destroy(dash_server_t **self_p);

/* The descriptor to poll for input; the bound port. */
int dash_server_fd(const dash_server_t *self);
int dash_server_port(const dash_server_t *self);
typedef struct dash_server_stats {
    size_t open;      /* connections open now */
    uint64_t evicted; /* idle connections closed to make room since dash_server_new */
} dash_server_stats_t;
dash_server_stats_t dash_server_stats(const dash_server_t *self);

/* Milliseconds until the server has work without input (an idle connection to close), capped
 * at cap_ms; cap_ms when none. */
int dash_server_timeout_ms(dash_server_t *self, int cap_ms);
/* Serves whatever is ready, without blocking; -1 with err when the server is broken. */
int dash_server_run(dash_server_t *self, err_t *err);

#endif
