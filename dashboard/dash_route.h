/* dash_route: one HTTP request of the dashboard into its answer, without sockets (the server,
 * dash_server.h, feeds it; the unit tests and the fuzzer call it directly). Every input is
 * bounded and checked -- the path's length and form, the ids, the query values, the body's size
 * and JSON, the Host header -- and anything else is a 4xx answer with a JSON message, never a
 * crash. Reads follow the client protocol's owner rule (docs/security.md, "The dashboard's HTTP
 * port"): without a token only the pages and the count of jobs by state; with a key's token
 * the jobs' figures and the workers, as `jobs`, `status` and `workers` show them; a job's
 * preview, log and tasks with its owner's token or an administrator's; the whole log with an
 * administrator's; /metrics with any token (the scrapers' too). public_reads opens every read
 * (--dashboard-public, a trusted network). Actions need a token (dash_auth.h) and the right to
 * act: a job's owner or an administrator for a job, an administrator for a worker. */
#ifndef PRISMFARM_DASH_ROUTE_H
#define PRISMFARM_DASH_ROUTE_H

#include "dash_auth.h"
#include "dash_provider.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define DASH_MAX_PATH 256      /* bytes of a request path */
#define DASH_MAX_BODY 4096     /* bytes of a request body (actions take a small JSON) */
#define DASH_MAX_ARG 64        /* bytes of a query value */
#define DASH_PRIORITY_MAX 1000 /* priorities are -DASH_PRIORITY_MAX..DASH_PRIORITY_MAX */

typedef struct dash_arg {
    const char *key, *value; /* value may be NULL ("?flag") */
} dash_arg_t;

typedef struct dash_request {
    const char *method;     /* "GET", "HEAD", "POST", ... */
    const char *path;       /* without the query */
    const dash_arg_t *args; /* the query's arguments, decoded */
    size_t nargs;
    const char *host;          /* the Host header; NULL when absent */
    const char *authorization; /* the Authorization header; NULL when absent */
    const char *body;          /* may hold NUL bytes: body_len counts */
    size_t body_len;
} dash_request_t;

typedef struct dash_response {
    int status;
    const char *content_type;
    uint8_t *body; /* malloc'ed, or points into static data when is_static */
    size_t size;
    bool is_static;
    bool cacheable;        /* a static asset: the browser may keep it (revalidating) */
    bool www_authenticate; /* a 401 that names the Bearer scheme */
    const char *allow;     /* a 405's Allow header; NULL otherwise */
} dash_response_t;

typedef struct dash_router_config {
    /* Loopback only: the Host header must name this host (127.0.0.1, localhost, [::1], with
     * the port or without), which keeps a web page of another origin that rebinds its DNS
     * name to 127.0.0.1 from reading the dashboard. false: any Host (a --http-public bind). */
    bool check_host;
    /* Every read open to whoever reaches the port (--dashboard-public: a trusted network);
     * actions still need a token. */
    bool public_reads;
} dash_router_config_t;

typedef struct dash_router dash_router_t;

/* The router keeps provider and auth (not owned); auth may be NULL (no token is accepted). */
dash_router_t *dash_router_new(const dash_provider_t *provider, dash_auth_t *auth,
                               const dash_router_config_t *cfg, err_t *err);
void dash_router_destroy(dash_router_t **self_p);

/* Answers req into *out (always filled; free it with dash_response_free). */
void dash_route(dash_router_t *self, const dash_request_t *req, dash_response_t *out);
void dash_response_free(dash_response_t *r);

#endif
