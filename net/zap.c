#include "zap.h"

#include "clock.h"
#include "curve.h"
#include "ratelimit.h"

#include <zmq.h>

#include <errno.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define ZAP_ENDPOINT "inproc://zeromq.zap.01" /* fixed by RFC 27 */
#define ZAP_FRAMES 8                          /* a CURVE request has 7; more is malformed */
#define ZAP_POLL_MS 100                       /* how long destroy may wait for the thread */

enum { RING_ANY, RING_WORKERS, RING_CLIENTS, RING_ADMINS, NRINGS };
static const char *const ROLE[NRINGS] = {"authorised", "worker", "client", "admin"};
/* The X-Role values, by ring (zap.h). */
static const char *const ZAP_ROLE[NRINGS] = {ZAP_ROLE_ANY, ZAP_ROLE_WORKER, ZAP_ROLE_CLIENT,
                                             ZAP_ROLE_ADMIN};

struct zap {
    void *sock; /* REP, used by the thread only once it runs */
    curve_ring_t *rings[NRINGS]; /* zap_folders_t's, NULL where none */
    zap_log_fn log;
    void *user;
    pthread_t thread;
    atomic_bool stop;
    atomic_uint_least64_t accepted, refused;
    atomic_size_t keys;
    ratelimit_t refusals; /* the thread's: how many refusals it logs (issue 16, item 12) */
};

/* A flood of strangers must not become a flood of log lines: at most REFUSALS_BURST refusals
 * are logged per REFUSALS_WINDOW_S, and the number held back is logged once the window ends. */
#define REFUSALS_BURST 20
#define REFUSALS_WINDOW_S 10.0

__attribute__((format(printf, 2, 3))) static void zlog(zap_t *self, const char *fmt, ...)
{
    if (!self->log)
        return;
    char line[768];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    self->log(self->user, line);
}

static void log_held(zap_t *self, uint64_t held)
{
    if (held > 0)
        zlog(self,
             "ZAP: %llu more refused connections not logged (at most %d are logged per %.0f s)",
             (unsigned long long)held, REFUSALS_BURST, REFUSALS_WINDOW_S);
}

/* zlog for a refusal, within the rate limit. */
__attribute__((format(printf, 2, 3))) static void zlog_refusal(zap_t *self, const char *fmt, ...)
{
    uint64_t held;
    bool allow = ratelimit_allow(&self->refusals, clock_now_s(), &held);
    log_held(self, held);
    if (!allow || !self->log)
        return;
    char line[768];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    self->log(self->user, line);
}

/* A frame's bytes as text for a log: printable ASCII only, at most size - 1 bytes. */
static const char *frame_text(zmq_msg_t *f, char *buf, size_t size)
{
    const unsigned char *d = zmq_msg_data(f);
    size_t n = zmq_msg_size(f), k = 0;
    for (size_t i = 0; i < n && k + 1 < size; i++)
        buf[k++] = d[i] >= 0x20 && d[i] < 0x7f ? (char)d[i] : '?';
    buf[k] = 0;
    return k ? buf : "(unknown)";
}

static bool frame_is(zmq_msg_t *f, const char *s)
{
    size_t n = strlen(s);
    return zmq_msg_size(f) == n && memcmp(zmq_msg_data(f), s, n) == 0;
}

/* Sends the reply frames; the request id is echoed (RFC 27). role, when not NULL, goes in the
 * metadata frame as the property X-Role (ZMTP 3's property encoding: a name of one length
 * byte, a value of four big-endian length bytes), which libzmq hands to every message of the
 * connection (zmq_msg_gets), so the master knows an admin from a client without a lookup. */
static void send_reply(zap_t *self, zmq_msg_t *request_id, const char *status,
                       const char *text, const char *user_id, const char *role)
{
    uint8_t meta[64];
    size_t nmeta = 0;
    if (role) {
        static const char NAME[] = ZAP_ROLE_PROPERTY;
        size_t nn = sizeof NAME - 1, nv = strlen(role);
        meta[nmeta++] = (uint8_t)nn;
        memcpy(meta + nmeta, NAME, nn);
        nmeta += nn;
        for (int shift = 24; shift >= 0; shift -= 8)
            meta[nmeta++] = (uint8_t)(nv >> shift);
        memcpy(meta + nmeta, role, nv);
        nmeta += nv;
    }
    int rc = zmq_send(self->sock, "1.0", 3, ZMQ_SNDMORE);
    if (rc >= 0)
        rc = zmq_send(self->sock, request_id ? zmq_msg_data(request_id) : "",
                      request_id ? zmq_msg_size(request_id) : 0, ZMQ_SNDMORE);
    const char *rest[] = {status, text, user_id};
    for (int i = 0; i < 3 && rc >= 0; i++)
        rc = zmq_send(self->sock, rest[i], strlen(rest[i]), ZMQ_SNDMORE);
    if (rc >= 0)
        rc = zmq_send(self->sock, meta, nmeta, 0);
    if (rc < 0)
        zlog(self, "ZAP: cannot answer libzmq: %s", zmq_strerror(zmq_errno()));
}

static void refresh_ring(zap_t *self, curve_ring_t *ring, bool force)
{
    err_t err;
    bool reloaded;
    size_t before = curve_ring_size(ring);
    if (curve_ring_refresh(ring, force, &reloaded, &err) < 0) {
        zlog(self, "%s", err.msg);
    } else if (reloaded) {
        if (force && curve_ring_size(ring) == before)
            return; /* a stranger made us look: nothing to report */
        zlog(self, "authorised keys read again from %s: %zu keys", curve_ring_dir(ring),
             curve_ring_size(ring));
    }
}

static size_t total_keys(const zap_t *self)
{
    size_t n = 0;
    for (int r = 0; r < NRINGS; r++)
        n += self->rings[r] ? curve_ring_size(self->rings[r]) : 0;
    return n;
}

static void refresh(zap_t *self, bool force)
{
    for (int r = 0; r < NRINGS; r++)
        if (self->rings[r])
            refresh_ring(self, self->rings[r], force);
    atomic_store(&self->keys, total_keys(self));
}

/* The key's name in the first of the domain's folders that lists it; *role its ring. */
static const char *find_key(const zap_t *self, const char *domain, const uint8_t *key, int *role)
{
    static const int WORKERS[] = {RING_ANY, RING_WORKERS, -1};
    static const int CLIENTS[] = {RING_ANY, RING_CLIENTS, RING_ADMINS, -1};
    const int *order = !strcmp(domain, "workers") ? WORKERS : !strcmp(domain, "clients") ? CLIENTS : NULL;
    for (int i = 0; order && order[i] >= 0; i++) {
        const curve_ring_t *ring = self->rings[order[i]];
        const char *name = ring ? curve_ring_find(ring, key) : NULL;
        if (name) {
            *role = order[i];
            return name;
        }
    }
    return NULL;
}

/* Receives one request and answers it. Returns -1 when the socket is unusable. */
static int handle(zap_t *self)
{
    zmq_msg_t f[ZAP_FRAMES];
    int n = 0, more = 1, rc = 0;
    while (more) {
        zmq_msg_t part;
        if (zmq_msg_init(&part) != 0 || zmq_msg_recv(&part, self->sock, 0) < 0) {
            int e = zmq_errno();
            (void)zmq_msg_close(&part);
            rc = e == ETERM || e == ENOTSOCK ? -1 : 0;
            if (rc == 0)
                zlog(self, "ZAP: receiving a request: %s", zmq_strerror(e));
            goto out; /* a failed receive leaves the REP socket waiting for a request */
        }
        more = zmq_msg_more(&part);
        if (n < ZAP_FRAMES)
            f[n++] = part;
        else
            (void)zmq_msg_close(&part);
    }
    char domain[64], address[96];
    if (n < 6 || !frame_is(&f[0], "1.0")) {
        zlog_refusal(self, "ZAP: a malformed request (%d frames): refused", n);
        send_reply(self, n >= 2 ? &f[1] : NULL, "500", "malformed ZAP request", "", NULL);
        atomic_fetch_add(&self->refused, 1);
        goto out;
    }
    frame_text(&f[2], domain, sizeof domain);
    frame_text(&f[3], address, sizeof address);
    if (!frame_is(&f[5], "CURVE") || n != 7 || zmq_msg_size(&f[6]) != CURVE_BINARY) {
        char mech[32];
        zlog_refusal(self, "refused a connection to the %s endpoint from %s: mechanism %s, not CURVE",
             domain, address, frame_text(&f[5], mech, sizeof mech));
        send_reply(self, &f[1], "400", "CURVE required", "", NULL);
        atomic_fetch_add(&self->refused, 1);
        goto out;
    }
    const uint8_t *key = zmq_msg_data(&f[6]);
    /* A changed folder is read again; an unknown key makes it read again at most once a
     * second, which bounds what a flood of strangers costs. */
    refresh(self, false);
    int role = RING_ANY;
    const char *name = find_key(self, domain, key, &role);
    if (!name) {
        refresh(self, true);
        name = find_key(self, domain, key, &role);
    }
    char z85[CURVE_Z85 + 1];
    if (!zmq_z85_encode(z85, key, CURVE_BINARY))
        snprintf(z85, sizeof z85, "(unprintable)");
    if (!name) {
        /* A key of another role (a client's on the workers endpoint: issue 16) is named. */
        const char *other = NULL;
        int r = 0;
        for (; r < NRINGS && !other; r++)
            other = self->rings[r] ? curve_ring_find(self->rings[r], key) : NULL;
        if (other)
            zlog_refusal(self,
                         "refused a connection to the %s endpoint from %s: key '%s' is a%s %s "
                         "key (in "
                 "%s), not allowed on this endpoint",
                 domain, address, other, r - 1 == RING_ADMINS ? "n" : "", ROLE[r - 1],
                 curve_ring_dir(self->rings[r - 1]));
        else
            zlog_refusal(self, "refused a connection to the %s endpoint from %s: key %s is not in %s",
                 domain, address, z85,
                 self->rings[RING_ANY] ? curve_ring_dir(self->rings[RING_ANY])
                                       : "the authorised folders");
        send_reply(self, &f[1], "400", "key not authorised", "", NULL);
        atomic_fetch_add(&self->refused, 1);
    } else {
        zlog(self, "accepted key '%s' on the %s endpoint from %s", name, domain, address);
        send_reply(self, &f[1], "200", "OK", name, ZAP_ROLE[role]);
        atomic_fetch_add(&self->accepted, 1);
    }
out:
    for (int i = 0; i < n; i++)
        (void)zmq_msg_close(&f[i]);
    return rc;
}

static void *zap_thread(void *arg)
{
    zap_t *self = arg;
    while (!atomic_load(&self->stop)) {
        zmq_pollitem_t item = {.socket = self->sock, .events = ZMQ_POLLIN};
        int n = zmq_poll(&item, 1, ZAP_POLL_MS);
        if (n < 0 && zmq_errno() == ETERM)
            break;
        if (n > 0 && handle(self) < 0)
            break;
        /* The count of refusals held back, once their window is over, even if no more come. */
        double now = clock_now_s();
        if (self->refusals.held > 0 && now - self->refusals.start >= REFUSALS_WINDOW_S) {
            log_held(self, self->refusals.held);
            self->refusals.held = 0;
        }
    }
    return NULL;
}

static void destroy_rings(zap_t *self)
{
    for (int r = 0; r < NRINGS; r++)
        curve_ring_destroy(&self->rings[r]);
}

zap_t *zap_new(void *zmq_ctx, const zap_folders_t *folders, zap_log_fn log, void *user,
               err_t *err)
{
    if (curve_available(err) < 0)
        return NULL;
    zap_t *self = calloc(1, sizeof *self);
    if (!self) {
        err_set(err, "ZAP: out of memory");
        return NULL;
    }
    self->log = log;
    self->refusals = ratelimit_make(REFUSALS_BURST, REFUSALS_WINDOW_S);
    self->user = user;
    atomic_init(&self->stop, false);
    atomic_init(&self->accepted, 0);
    atomic_init(&self->refused, 0);
    const char *dirs[NRINGS] = {folders->any, folders->workers, folders->clients,
                                folders->admins};
    for (int r = 0; r < NRINGS; r++)
        if (dirs[r] && !(self->rings[r] = curve_ring_new(dirs[r], err))) {
            destroy_rings(self);
            free(self);
            return NULL;
        }
    atomic_init(&self->keys, total_keys(self));
    int linger = 0;
    self->sock = zmq_socket(zmq_ctx, ZMQ_REP);
    if (!self->sock) {
        err_set(err, "ZAP: zmq_socket(REP): %s", zmq_strerror(zmq_errno()));
        goto fail;
    }
    if (zmq_setsockopt(self->sock, ZMQ_LINGER, &linger, sizeof linger) != 0) {
        err_set(err, "ZAP: zmq_setsockopt(ZMQ_LINGER): %s", zmq_strerror(zmq_errno()));
        goto fail;
    }
    if (zmq_bind(self->sock, ZAP_ENDPOINT) != 0) {
        err_set(err, "ZAP: cannot bind %s: %s%s", ZAP_ENDPOINT, zmq_strerror(zmq_errno()),
                zmq_errno() == EADDRINUSE ? " (another handler runs on this ZeroMQ context)" : "");
        goto fail;
    }
    int e = pthread_create(&self->thread, NULL, zap_thread, self);
    if (e != 0) {
        err_set(err, "ZAP: cannot start its thread: %s", strerror(e));
        goto fail;
    }
    return self;
fail:
    if (self->sock)
        (void)zmq_close(self->sock);
    destroy_rings(self);
    free(self);
    return NULL;
}

void zap_destroy(zap_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    zap_t *self = *self_p;
    atomic_store(&self->stop, true);
    (void)pthread_join(self->thread, NULL);
    (void)zmq_close(self->sock);
    destroy_rings(self);
    free(self);
    *self_p = NULL;
}

zap_stats_t zap_stats(zap_t *self)
{
    return (zap_stats_t){.accepted = atomic_load(&self->accepted),
                               .refused = atomic_load(&self->refused),
                               .keys = atomic_load(&self->keys)};
}
