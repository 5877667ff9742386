#include "dash_server.h"

#include <arpa/inet.h>
#include <microhttpd.h>
#include <netinet/in.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>

#define MAX_ARGS 16 /* query arguments of one request */

/* An open connection, in the order of its last activity (the head idle longest). */
typedef struct conn {
    struct conn *prev, *next;
    int fd;
    bool busy;    /* a request is being answered */
    bool evicted; /* shut down by us, waiting for libmicrohttpd to notice */
} conn_t;

struct dash_server {
    struct MHD_Daemon *d;
    dash_router_t *router;
    int fd, port;
    conn_t *head, *tail;
    size_t nconns;
    uint64_t evictions;
};

/* What one request gathers between libmicrohttpd's calls: its body, cut at DASH_MAX_BODY. */
typedef struct request_ctx {
    char body[DASH_MAX_BODY];
    size_t len;
    bool too_big;
    dash_arg_t args[MAX_ARGS];
    size_t nargs;
    bool too_many_args;
} request_ctx_t;

int dash_server_parse_address(const char *spec, dash_server_config_t *out, err_t *err)
{
    memset(out, 0, sizeof *out);
    const char *colon = spec ? strrchr(spec, ':') : NULL;
    const char *port = colon ? colon + 1 : spec;
    size_t alen = colon ? (size_t)(colon - spec) : 0;
    if (!spec || !*port || strlen(port) > 5 || strspn(port, "0123456789") != strlen(port))
        return err_set(err,
                       "--http '%.100s': expected PORT or ADDR:PORT (PORT 0..65535, ADDR "
                       "an IPv4 address; 127.0.0.1 when only a port is given)",
                       spec ? spec : "");
    long p = strtol(port, NULL, 10);
    if (p > 65535)
        return err_set(err, "--http '%.100s': port %ld is outside 0..65535", spec, p);
    out->port = (int)p;
    if (alen == 0 || (alen == 9 && !strncmp(spec, "localhost", 9)))
        snprintf(out->address, sizeof out->address, "127.0.0.1");
    else if (alen >= sizeof out->address)
        return err_set(err, "--http '%.100s': the address is too long", spec);
    else {
        snprintf(out->address, sizeof out->address, "%.*s", (int)alen, spec);
        struct in_addr a;
        if (inet_pton(AF_INET, out->address, &a) != 1)
            return err_set(err,
                           "--http '%.100s': '%s' is not an IPv4 address (like 127.0.0.1 "
                           "or 0.0.0.0)",
                           spec, out->address);
    }
    return 0;
}

bool dash_server_loopback(const dash_server_config_t *cfg)
{
    struct in_addr a;
    return inet_pton(AF_INET, cfg->address, &a) == 1 && (ntohl(a.s_addr) >> 24) == 127;
}

static enum MHD_Result take_arg(void *cls, enum MHD_ValueKind kind, const char *key,
                                const char *value)
{
    (void)kind;
    request_ctx_t *c = cls;
    if (c->nargs == MAX_ARGS) {
        c->too_many_args = true;
        return MHD_NO;
    }
    c->args[c->nargs++] = (dash_arg_t){.key = key, .value = value};
    return MHD_YES;
}

static enum MHD_Result add_headers(struct MHD_Response *r, const dash_response_t *out)
{
    /* The pages load only their own scripts and styles and talk only to this origin; no other
     * site may frame them (docs/dashboard.md, "Security"). */
    enum MHD_Result ok =
        MHD_add_response_header(r, "Content-Type", out->content_type) &
        MHD_add_response_header(r, "Cache-Control", out->cacheable ? "no-cache" : "no-store") &
        MHD_add_response_header(r, "X-Content-Type-Options", "nosniff") &
        MHD_add_response_header(r, "X-Frame-Options", "DENY") &
        MHD_add_response_header(r, "Referrer-Policy", "no-referrer") &
        MHD_add_response_header(r, "Content-Security-Policy",
                                "default-src 'self'; img-src 'self' data: blob:; style-src 'self'; "
                                "script-src 'self'; connect-src 'self'; frame-ancestors 'none'; "
                                "form-action 'none'; base-uri 'none'");
    if (out->www_authenticate)
        ok &= MHD_add_response_header(r, "WWW-Authenticate", "Bearer realm=\"prismfarm\"");
    if (out->allow)
        ok &= MHD_add_response_header(r, "Allow", out->allow);
    return ok;
}

/* ---------------------------------------------------------------- eviction */

static void list_unlink(dash_server_t *self, conn_t *c)
{
    if (c->prev)
        c->prev->next = c->next;
    else
        self->head = c->next;
    if (c->next)
        c->next->prev = c->prev;
    else
        self->tail = c->prev;
    c->prev = c->next = NULL;
}

static void list_append(dash_server_t *self, conn_t *c)
{
    c->prev = self->tail;
    c->next = NULL;
    if (self->tail)
        self->tail->next = c;
    else
        self->head = c;
    self->tail = c;
}

/* Closes the connection idle longest: shutdown(2), never close, so the descriptor stays
 * libmicrohttpd's, which reads the end of the stream and closes it on its next run. */
static void evict_idlest(dash_server_t *self)
{
    for (conn_t *c = self->head; c; c = c->next)
        if (!c->busy && !c->evicted && c->fd >= 0) {
            c->evicted = true;
            (void)shutdown(c->fd, SHUT_RDWR);
            self->evictions++;
            return;
        }
}

static void on_connection(void *cls, struct MHD_Connection *conn, void **socket_ctx,
                          enum MHD_ConnectionNotificationCode code)
{
    dash_server_t *self = cls;
    conn_t *c = *socket_ctx;
    if (code == MHD_CONNECTION_NOTIFY_CLOSED) {
        if (c) {
            list_unlink(self, c);
            self->nconns--;
            free(c);
            *socket_ctx = NULL;
        }
        return;
    }
    if (code != MHD_CONNECTION_NOTIFY_STARTED || !(c = calloc(1, sizeof *c)))
        return; /* out of memory: the connection is served, only never evicted */
    const union MHD_ConnectionInfo *fd =
        MHD_get_connection_info(conn, MHD_CONNECTION_INFO_CONNECTION_FD);
    c->fd = fd ? fd->connect_fd : -1;
    *socket_ctx = c;
    list_append(self, c);
    if (++self->nconns > DASH_EVICT_AT)
        evict_idlest(self);
}

/* The connection's record: busy while a request is answered, and last in the order after. */
static void conn_mark(dash_server_t *self, struct MHD_Connection *conn, bool busy)
{
    const union MHD_ConnectionInfo *info =
        MHD_get_connection_info(conn, MHD_CONNECTION_INFO_SOCKET_CONTEXT);
    conn_t *c = info ? info->socket_context : NULL;
    if (!c)
        return;
    c->busy = busy;
    list_unlink(self, c);
    list_append(self, c);
}

/* ---------------------------------------------------------------- requests */

static enum MHD_Result on_request(void *cls, struct MHD_Connection *conn, const char *url,
                                  const char *method, const char *version, const char *upload_data,
                                  size_t *upload_data_size, void **ctx)
{
    (void)version;
    dash_server_t *self = cls;
    request_ctx_t *c = *ctx;
    if (!c) {
        /* The first call brings the headers only; the body (if any) follows. */
        if (!(c = calloc(1, sizeof *c)))
            return MHD_NO;
        *ctx = c;
        conn_mark(self, conn, true);
        return MHD_YES;
    }
    if (*upload_data_size > 0) {
        if (c->len + *upload_data_size > sizeof c->body)
            c->too_big = true; /* read and dropped: the answer is a 413 */
        else {
            memcpy(c->body + c->len, upload_data, *upload_data_size);
            c->len += *upload_data_size;
        }
        *upload_data_size = 0;
        return MHD_YES;
    }
    (void)MHD_get_connection_values(conn, MHD_GET_ARGUMENT_KIND, take_arg, c);
    dash_request_t req = {
        .method = method,
        .path = url,
        .args = c->args,
        .nargs = c->nargs,
        .host = MHD_lookup_connection_value(conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_HOST),
        .authorization =
            MHD_lookup_connection_value(conn, MHD_HEADER_KIND, MHD_HTTP_HEADER_AUTHORIZATION),
        .body = c->body,
        .body_len = c->too_big ? DASH_MAX_BODY + 1 : c->len,
    };
    dash_response_t out;
    if (c->too_many_args) {
        static const char msg[] = "{\"error\":\"more than 16 query arguments\"}";
        out = (dash_response_t){.status = 400,
                                .content_type = "application/json",
                                .body = (uint8_t *)msg,
                                .size = sizeof msg - 1,
                                .is_static = true};
    } else
        dash_route(self->router, &req, &out);
    struct MHD_Response *r =
        out.is_static ? MHD_create_response_from_buffer(out.size, out.body, MHD_RESPMEM_PERSISTENT)
                      : MHD_create_response_from_buffer(out.size, out.body, MHD_RESPMEM_MUST_FREE);
    if (!r) {
        dash_response_free(&out);
        return MHD_NO;
    }
    enum MHD_Result ok = add_headers(r, &out);
    if (ok == MHD_YES)
        ok = MHD_queue_response(conn, (unsigned)out.status, r);
    MHD_destroy_response(r); /* the body now belongs to the response */
    return ok;
}

static void on_completed(void *cls, struct MHD_Connection *conn, void **ctx,
                         enum MHD_RequestTerminationCode toe)
{
    (void)toe;
    if (*ctx)
        conn_mark(cls, conn, false);
    free(*ctx);
    *ctx = NULL;
}

dash_server_t *dash_server_new(const dash_server_config_t *cfg, dash_router_t *router, err_t *err)
{
    dash_server_t *self = calloc(1, sizeof *self);
    if (!self) {
        err_set(err, "dashboard: out of memory");
        return NULL;
    }
    self->router = router;
    struct sockaddr_in sa = {.sin_family = AF_INET, .sin_port = htons((uint16_t)cfg->port)};
    if (inet_pton(AF_INET, cfg->address, &sa.sin_addr) != 1) {
        err_set(err, "dashboard: '%s' is not an IPv4 address", cfg->address);
        free(self);
        return NULL;
    }
    /* No thread of its own (no MHD_USE_INTERNAL_POLLING_THREAD): the daemon's loop polls the
     * epoll descriptor and calls dash_server_run, so the pages read the master's state without
     * a lock. Answers are quick (the state is in memory, a preview one file), so one thread
     * serves a flood's real requests; the idle connections are what must not lock users out,
     * and on_connection evicts them. No per-address limit: it refused every user of a
     * loopback dashboard once one of them (or a flood) held 16 connections. */
    self->d =
        MHD_start_daemon(MHD_USE_EPOLL, 0, NULL, NULL, on_request, self, MHD_OPTION_SOCK_ADDR,
                         (struct sockaddr *)&sa, MHD_OPTION_CONNECTION_LIMIT,
                         (unsigned)DASH_MAX_CONNECTIONS, MHD_OPTION_CONNECTION_TIMEOUT,
                         (unsigned)DASH_IDLE_TIMEOUT_S, MHD_OPTION_CONNECTION_MEMORY_LIMIT,
                         (size_t)DASH_CONNECTION_MEMORY, MHD_OPTION_NOTIFY_COMPLETED, on_completed,
                         self, MHD_OPTION_NOTIFY_CONNECTION, on_connection, self, MHD_OPTION_END);
    if (!self->d) {
        err_set(err, "dashboard: cannot listen on %s:%d (in use, or not an address of this host)",
                cfg->address, cfg->port);
        free(self);
        return NULL;
    }
    const union MHD_DaemonInfo *fd = MHD_get_daemon_info(self->d, MHD_DAEMON_INFO_EPOLL_FD);
    const union MHD_DaemonInfo *port = MHD_get_daemon_info(self->d, MHD_DAEMON_INFO_BIND_PORT);
    if (!fd || fd->epoll_fd < 0 || !port) {
        err_set(err, "dashboard: libmicrohttpd gives no epoll descriptor (built without epoll?)");
        dash_server_destroy(&self);
        return NULL;
    }
    self->fd = fd->epoll_fd;
    self->port = port->port;
    return self;
}

void dash_server_destroy(dash_server_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    dash_server_t *self = *self_p;
    if (self->d)
        MHD_stop_daemon(self->d);
    free(self);
    *self_p = NULL;
}

int dash_server_fd(const dash_server_t *self)
{
    return self->fd;
}

int dash_server_port(const dash_server_t *self)
{
    return self->port;
}

dash_server_stats_t dash_server_stats(const dash_server_t *self)
{
    return (dash_server_stats_t){.open = self->nconns, .evicted = self->evictions};
}

int dash_server_timeout_ms(dash_server_t *self, int cap_ms)
{
    MHD_UNSIGNED_LONG_LONG ms;
    if (MHD_get_timeout(self->d, &ms) != MHD_YES || ms >= (MHD_UNSIGNED_LONG_LONG)cap_ms)
        return cap_ms;
    return (int)ms;
}

int dash_server_run(dash_server_t *self, err_t *err)
{
    if (MHD_run(self->d) != MHD_YES)
        return err_set(err, "dashboard: libmicrohttpd's run failed");
    return 0;
}
