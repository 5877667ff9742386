#include "conn_guard.h"

#include "clock.h"
#include "ratelimit.h"

#include <arpa/inet.h>
#include <linux/tcp.h> /* struct tcp_info with tcpi_bytes_received (glibc's lacks it) */
#include <netinet/in.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <zmq.h>

#define GUARD_EVENTS (ZMQ_EVENT_ACCEPTED | ZMQ_EVENT_DISCONNECTED)
#define BURST 20
#define WINDOW_S 10.0

/* A host: its address as 16 bytes (IPv4 mapped into IPv6) and its open connections. */
typedef struct host {
    uint8_t addr[16];
    int open; /* 0: an empty slot */
} host_t;

struct conn_guard {
    void *router, *pair;
    char what[32];
    conn_guard_config_t cfg;
    conn_guard_log_fn log;
    void *user;
    /* By descriptor: the host slot's address of each open connection the guard let in, and
     * the list of them in the order they were accepted (prev/next: descriptors, -1 none). */
    uint8_t (*addr_of)[16];
    bool *is_open;
    int *prev, *next;
    int head, tail;
    size_t nfd;
    host_t *hosts; /* open addressing, linear probing, power-of-two capacity */
    size_t cap, nhosts, open;
    uint64_t refused, evicted;
    ratelimit_t rl;
};

/* The refusals a window held back, said once. */
static void log_held(conn_guard_t *self, uint64_t held)
{
    if (held == 0 || !self->log)
        return;
    char line[256];
    snprintf(line, sizeof line,
             "%s endpoint: %llu more refused connections not logged (at most %d per %.0f s)",
             self->what, (unsigned long long)held, BURST, WINDOW_S);
    self->log(self->user, line);
}

__attribute__((format(printf, 2, 3))) static void glog(conn_guard_t *self, const char *fmt, ...)
{
    uint64_t held;
    bool allow = ratelimit_allow(&self->rl, clock_now_s(), &held);
    log_held(self, held);
    if (!allow || !self->log)
        return;
    char line[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    self->log(self->user, line);
}

static size_t hash16(const uint8_t a[16])
{
    uint64_t h = 1469598103934665603ull; /* FNV-1a */
    for (int i = 0; i < 16; i++)
        h = (h ^ a[i]) * 1099511628211ull;
    return (size_t)h;
}

static host_t *host_find(conn_guard_t *self, const uint8_t a[16], bool add)
{
    if (add && 2 * (self->nhosts + 1) > self->cap) {
        size_t cap = self->cap ? 2 * self->cap : 64;
        host_t *h = calloc(cap, sizeof *h);
        if (!h)
            return NULL;
        for (size_t i = 0; i < self->cap; i++)
            if (self->hosts[i].open > 0) {
                size_t k = hash16(self->hosts[i].addr) & (cap - 1);
                while (h[k].open > 0)
                    k = (k + 1) & (cap - 1);
                h[k] = self->hosts[i];
            }
        free(self->hosts);
        self->hosts = h;
        self->cap = cap;
    }
    if (!self->cap)
        return NULL;
    size_t k = hash16(a) & (self->cap - 1);
    while (self->hosts[k].open > 0) {
        if (!memcmp(self->hosts[k].addr, a, 16))
            return &self->hosts[k];
        k = (k + 1) & (self->cap - 1);
    }
    if (!add)
        return NULL;
    memcpy(self->hosts[k].addr, a, 16);
    self->nhosts++;
    return &self->hosts[k]; /* open 0: the caller counts the connection */
}

/* Empties a slot without breaking the probe chains after it (backward-shift deletion). */
static void host_remove(conn_guard_t *self, host_t *h)
{
    size_t i = (size_t)(h - self->hosts), mask = self->cap - 1;
    self->hosts[i].open = 0;
    self->nhosts--;
    for (size_t j = (i + 1) & mask; self->hosts[j].open > 0; j = (j + 1) & mask) {
        size_t home = hash16(self->hosts[j].addr) & mask;
        /* Moves j into the hole at i when its home is not in (i, j]. */
        bool stays = i <= j ? (home > i && home <= j) : (home > i || home <= j);
        if (!stays) {
            self->hosts[i] = self->hosts[j];
            self->hosts[j].open = 0;
            i = j;
        }
    }
}

static bool peer_addr(int fd, uint8_t out[16], char *text, size_t size)
{
    struct sockaddr_storage ss;
    socklen_t len = sizeof ss;
    memset(out, 0, 16);
    if (getpeername(fd, (struct sockaddr *)&ss, &len) != 0)
        return false;
    if (ss.ss_family == AF_INET) {
        const struct sockaddr_in *s4 = (const struct sockaddr_in *)&ss;
        out[10] = out[11] = 0xff;
        memcpy(out + 12, &s4->sin_addr, 4);
        inet_ntop(AF_INET, &s4->sin_addr, text, (socklen_t)size);
    } else if (ss.ss_family == AF_INET6) {
        const struct sockaddr_in6 *s6 = (const struct sockaddr_in6 *)&ss;
        memcpy(out, &s6->sin6_addr, 16);
        inet_ntop(AF_INET6, &s6->sin6_addr, text, (socklen_t)size);
    } else {
        return false; /* ipc:// and the like: one host */
    }
    return true;
}

static bool grow_fds(conn_guard_t *self, size_t fd)
{
    if (fd < self->nfd)
        return true;
    size_t n = self->nfd ? self->nfd : 256;
    while (n <= fd)
        n *= 2;
    uint8_t(*a)[16] = realloc(self->addr_of, n * sizeof *a);
    if (!a)
        return false;
    self->addr_of = a;
    bool *o = realloc(self->is_open, n * sizeof *o);
    if (!o)
        return false;
    self->is_open = o;
    int *p = realloc(self->prev, n * sizeof *p);
    if (!p)
        return false;
    self->prev = p;
    int *q = realloc(self->next, n * sizeof *q);
    if (!q)
        return false;
    self->next = q;
    memset(self->is_open + self->nfd, 0, (n - self->nfd) * sizeof *o);
    self->nfd = n;
    return true;
}

static void order_append(conn_guard_t *self, int fd)
{
    self->prev[fd] = self->tail;
    self->next[fd] = -1;
    if (self->tail >= 0)
        self->next[self->tail] = fd;
    else
        self->head = fd;
    self->tail = fd;
}

static void order_remove(conn_guard_t *self, int fd)
{
    if (self->prev[fd] >= 0)
        self->next[self->prev[fd]] = self->next[fd];
    else
        self->head = self->next[fd];
    if (self->next[fd] >= 0)
        self->prev[self->next[fd]] = self->prev[fd];
    else
        self->tail = self->prev[fd];
}

/* The bytes the peer has sent on fd; -1 when the kernel does not say (not TCP, or older than
 * Linux 4.1's tcpi_bytes_received). */
static int64_t bytes_received(int fd)
{
    struct tcp_info ti;
    socklen_t len = sizeof ti;
    memset(&ti, 0, sizeof ti);
    if (getsockopt(fd, IPPROTO_TCP, TCP_INFO, &ti, &len) != 0 ||
        len < offsetof(struct tcp_info, tcpi_bytes_received) + sizeof ti.tcpi_bytes_received)
        return -1;
    return (int64_t)ti.tcpi_bytes_received;
}

/* The oldest open connection (of host a when a is not NULL) whose handshake is unfinished;
 * -1 when none. Under a flood the oldest are the flood's idle ones, so the walk is short. */
static int find_unfinished(conn_guard_t *self, const uint8_t *a)
{
    if (self->cfg.handshake_bytes == 0)
        return -1;
    for (int fd = self->head; fd >= 0; fd = self->next[fd]) {
        if (a && memcmp(self->addr_of[fd], a, 16) != 0)
            continue;
        int64_t got = bytes_received(fd);
        if (got >= 0 && (uint64_t)got < self->cfg.handshake_bytes)
            return fd;
    }
    return -1;
}

/* Forgets fd (open, let in by the guard) as disconnected. */
static void forget(conn_guard_t *self, int fd)
{
    self->is_open[fd] = false;
    order_remove(self, fd);
    self->open--;
    host_t *h = host_find(self, self->addr_of[fd], false);
    if (h && --h->open == 0)
        host_remove(self, h);
}

static void on_accepted(conn_guard_t *self, int fd)
{
    uint8_t a[16];
    char text[INET6_ADDRSTRLEN] = "a local peer";
    (void)peer_addr(fd, a, text, sizeof text);
    if (fd < 0 || !grow_fds(self, (size_t)fd))
        return;
    /* The host is looked up (and added) after any eviction, which may move the slots. */
    const host_t *known = host_find(self, a, false);
    const char *why = NULL;
    bool total = self->cfg.max_total > 0 && self->open >= (size_t)self->cfg.max_total;
    bool per_host = known && self->cfg.max_per_host > 0 && known->open >= self->cfg.max_per_host;
    if (total || per_host) {
        /* Room made by the oldest unfinished handshake, if any: the host's own for its
         * bound, anyone's for the endpoint's. */
        int victim = find_unfinished(self, per_host ? a : NULL);
        if (victim >= 0) {
            char vtext[INET6_ADDRSTRLEN] = "a local peer";
            uint8_t va[16];
            (void)peer_addr(victim, va, vtext, sizeof vtext);
            (void)shutdown(victim, SHUT_RDWR);
            forget(self, victim); /* its DISCONNECTED finds it gone */
            self->evicted++;
            glog(self,
                 "closed an unfinished handshake to the %s endpoint from %s to make room for a "
                 "new connection from %s (%s holds its limit of open connections, %d)",
                 self->what, vtext, text, per_host ? "that host" : "the endpoint",
                 per_host ? self->cfg.max_per_host : self->cfg.max_total);
            total = per_host = false;
        }
    }
    host_t *h = host_find(self, a, true);
    if (total)
        why = "the endpoint holds its limit of open connections";
    else if (per_host)
        why = "that host holds its limit of open connections";
    if (why || !h) {
        if (h && h->open == 0)
            host_remove(self, h);
        (void)shutdown(fd, SHUT_RDWR);
        self->refused++;
        int limit = why && strstr(why, "host") ? self->cfg.max_per_host : self->cfg.max_total;
        glog(self, "refused a connection to the %s endpoint from %s: %s (%d)", self->what, text,
             why ? why : "out of memory", limit);
        return;
    }
    h->open++;
    memcpy(self->addr_of[fd], a, 16);
    self->is_open[fd] = true;
    order_append(self, fd);
    self->open++;
}

static void on_disconnected(conn_guard_t *self, int fd)
{
    if (fd < 0 || (size_t)fd >= self->nfd || !self->is_open[fd])
        return; /* one the guard refused or evicted, or accepted before it watched */
    forget(self, fd);
}

conn_guard_t *conn_guard_new(void *zmq_ctx, void *router, const char *what,
                             const conn_guard_config_t *config, conn_guard_log_fn log, void *user,
                             err_t *err)
{
    conn_guard_t *self = calloc(1, sizeof *self);
    if (!self) {
        err_set(err, "connection guard: out of memory");
        return NULL;
    }
    self->router = router;
    snprintf(self->what, sizeof self->what, "%s", what);
    self->cfg = *config;
    self->log = log;
    self->user = user;
    self->rl = ratelimit_make(BURST, WINDOW_S);
    self->head = self->tail = -1;
    char addr[96];
    snprintf(addr, sizeof addr, "inproc://prismfarm-guard-%p", (void *)self);
    int linger = 0;
    if (zmq_socket_monitor(router, addr, GUARD_EVENTS) != 0) {
        err_set(err, "connection guard: zmq_socket_monitor: %s", zmq_strerror(zmq_errno()));
        free(self);
        return NULL;
    }
    if (!(self->pair = zmq_socket(zmq_ctx, ZMQ_PAIR)) ||
        zmq_setsockopt(self->pair, ZMQ_LINGER, &linger, sizeof linger) != 0 ||
        zmq_connect(self->pair, addr) != 0) {
        err_set(err, "connection guard: monitor %s: %s", addr, zmq_strerror(zmq_errno()));
        conn_guard_destroy(&self);
        return NULL;
    }
    return self;
}

void conn_guard_pump(conn_guard_t *self)
{
    /* The refusals held back in a window that is over, even if no more come. */
    if (self->rl.held > 0 && clock_now_s() - self->rl.start >= WINDOW_S) {
        log_held(self, self->rl.held);
        self->rl.held = 0;
    }
    for (;;) {
        zmq_msg_t ev, where;
        zmq_msg_init(&ev);
        if (zmq_msg_recv(&ev, self->pair, ZMQ_DONTWAIT) < 0) {
            zmq_msg_close(&ev);
            return;
        }
        bool ok = zmq_msg_more(&ev) && zmq_msg_size(&ev) == 6;
        uint16_t event = 0;
        uint32_t value = 0;
        if (ok) {
            memcpy(&event, zmq_msg_data(&ev), 2);
            memcpy(&value, (const uint8_t *)zmq_msg_data(&ev) + 2, 4);
        }
        int more = zmq_msg_more(&ev);
        zmq_msg_close(&ev);
        while (more) { /* the endpoint frame */
            zmq_msg_init(&where);
            if (zmq_msg_recv(&where, self->pair, 0) < 0) {
                zmq_msg_close(&where);
                return;
            }
            more = zmq_msg_more(&where);
            zmq_msg_close(&where);
        }
        if (!ok)
            continue;
        if (event == ZMQ_EVENT_ACCEPTED)
            on_accepted(self, (int)value);
        else if (event == ZMQ_EVENT_DISCONNECTED)
            on_disconnected(self, (int)value);
    }
}

conn_guard_stats_t conn_guard_stats(const conn_guard_t *self)
{
    return (conn_guard_stats_t){
        .open = self->open, .refused = self->refused, .evicted = self->evicted};
}

void conn_guard_destroy(conn_guard_t **self_p)
{
    conn_guard_t *self = self_p ? *self_p : NULL;
    if (!self)
        return;
    (void)zmq_socket_monitor(self->router, NULL, 0);
    if (self->pair)
        (void)zmq_close(self->pair);
    free(self->addr_of);
    free(self->is_open);
    free(self->prev);
    free(self->next);
    free(self->hosts);
    free(self);
    *self_p = NULL;
}
