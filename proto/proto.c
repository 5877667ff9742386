#include "proto.h"

#include "sha256.h"

#include <float.h>
#include <inttypes.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---------------------------------------------------------------- names */

static const char *const TYPE_NAMES[PROTO_TYPE_COUNT] = {
    [PROTO_NONE] = "NONE",
    [PROTO_HELLO] = "HELLO",
    [PROTO_HEARTBEAT] = "HEARTBEAT",
    [PROTO_RESULT] = "RESULT",
    [PROTO_TASK_FAILED] = "TASK_FAILED",
    [PROTO_SCENE_REQUEST] = "SCENE_REQUEST",
    [PROTO_WELCOME] = "WELCOME",
    [PROTO_TASK] = "TASK",
    [PROTO_SCENE] = "SCENE",
    [PROTO_CANCEL] = "CANCEL",
    [PROTO_REFUSE] = "REFUSE",
    [PROTO_SUBMIT] = "SUBMIT",
    [PROTO_STATUS] = "STATUS",
    [PROTO_JOBS] = "JOBS",
    [PROTO_WORKERS] = "WORKERS",
    [PROTO_FETCH] = "FETCH",
    [PROTO_SUBMITTED] = "SUBMITTED",
    [PROTO_STATUS_REPLY] = "STATUS_REPLY",
    [PROTO_JOBS_REPLY] = "JOBS_REPLY",
    [PROTO_WORKERS_REPLY] = "WORKERS_REPLY",
    [PROTO_FILE] = "FILE",
    [PROTO_ERROR] = "ERROR",
    [PROTO_STORE_REQUEST] = "STORE_REQUEST",
    [PROTO_STORE] = "STORE",
    [PROTO_REFINE] = "REFINE",
};
static const char *const KIND_NAMES[PROTO_KIND_COUNT] = {
    [PROTO_KIND_NONE] = "none", [PROTO_KIND_CAMERA_TILE] = "camera_tile",
    [PROTO_KIND_PHOTON_BATCH] = "photon_batch"};
static const char *const JOB_STATE_NAMES[PROTO_JOB_STATE_COUNT] = {"queued", "running", "done",
                                                                   "failed", "cancelled"};
static const char *const WORKER_STATE_NAMES[PROTO_WORKER_STATE_COUNT] = {"idle", "busy", "lost"};
static const char *const FETCH_NAMES[PROTO_FETCH_COUNT] = {"exr", "png"};
static const char *const STOP_NAMES[PROTO_STOP_COUNT] = {"none", "target", "time"};

static const char *name_of(const char *const *names, int count, int i)
{
    return i >= 0 && i < count ? names[i] : "?";
}

const char *proto_type_name(proto_type_t t)
{
    return name_of(TYPE_NAMES, PROTO_TYPE_COUNT, (int)t);
}
const char *proto_kind_name(proto_kind_t k)
{
    return name_of(KIND_NAMES, PROTO_KIND_COUNT, (int)k);
}
const char *proto_job_state_name(proto_job_state_t s)
{
    return name_of(JOB_STATE_NAMES, PROTO_JOB_STATE_COUNT, (int)s);
}
const char *proto_worker_state_name(proto_worker_state_t s)
{
    return name_of(WORKER_STATE_NAMES, PROTO_WORKER_STATE_COUNT, (int)s);
}
const char *proto_fetch_what_name(proto_fetch_what_t w)
{
    return name_of(FETCH_NAMES, PROTO_FETCH_COUNT, (int)w);
}
const char *proto_stop_name(proto_stop_t s)
{
    return name_of(STOP_NAMES, PROTO_STOP_COUNT, (int)s);
}

proto_msg_t proto_refuse_version(int peer_version, const char *role, err_t *text)
{
    err_set(text, "protocol version %d not supported by this %s (speaks %d)", peer_version, role,
            PROTO_VERSION);
    return (proto_msg_t){.type = PROTO_REFUSE, .refuse = {.reason = text->msg}};
}

/* ---------------------------------------------------------------- owned memory */

/* Everything proto_decode allocates hangs on one list, so that proto_msg_free can release a
 * message of any type without knowing its layout. */
struct proto_owned {
    struct proto_owned *next;
    max_align_t data[];
};

static void *own_alloc(proto_msg_t *m, size_t n)
{
    struct proto_owned *o = malloc(sizeof *o + (n ? n : 1));
    if (!o)
        return NULL;
    o->next = m->owned;
    m->owned = o;
    return o->data;
}

void proto_msg_free(proto_msg_t *msg)
{
    if (!msg)
        return;
    for (struct proto_owned *o = msg->owned, *next; o; o = next) {
        next = o->next;
        free(o);
    }
    memset(msg, 0, sizeof *msg);
}

/* ---------------------------------------------------------------- checks shared by both ways */

/* Context for error messages: "TYPE: field 'prefix.field' what is wrong". */
typedef struct cx {
    const char *type;
    char prefix[40]; /* "jobs[12]." inside lists, else "" */
    err_t *err;
} cx_t;

__attribute__((format(printf, 3, 4))) static int cx_fail(const cx_t *cx, const char *field,
                                                         const char *fmt, ...)
{
    char what[400];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    err_set(cx->err, "%s: field '%s%s' %s", cx->type, cx->prefix, field, what);
    return PROTO_EMALFORMED;
}

static int ck_range(const cx_t *cx, const char *field, long long v, long long lo, long long hi)
{
    if (v < lo || v > hi)
        return cx_fail(cx, field, "is %lld, expected %lld..%lld", v, lo, hi);
    return 0;
}

/* Free text (error messages, reasons): any bytes but NUL, bounded. */
static int ck_text(const cx_t *cx, const char *field, const char *s)
{
    if (!s)
        return cx_fail(cx, field, "is missing");
    size_t n = strlen(s);
    if (n > PROTO_MAX_STRING)
        return cx_fail(cx, field, "has %zu bytes, at most %d allowed", n, PROTO_MAX_STRING);
    return 0;
}

/* Names shown in tables and logs: non-empty, bounded, no control characters (a name must not be
 * able to move a terminal's cursor). */
static int ck_name(const cx_t *cx, const char *field, const char *s, size_t max)
{
    if (!s)
        return cx_fail(cx, field, "is missing");
    size_t n = strlen(s);
    if (n == 0)
        return cx_fail(cx, field, "is empty");
    if (n > max)
        return cx_fail(cx, field, "has %zu bytes, at most %zu allowed", n, max);
    for (size_t i = 0; i < n; i++) {
        unsigned char c = (unsigned char)s[i];
        if (c < 0x20 || c == 0x7f)
            return cx_fail(cx, field, "has a control character 0x%02x at byte %zu", c, i);
    }
    return 0;
}

static int ck_hash(const cx_t *cx, const char *field, const char *h)
{
    for (int i = 0; i < PROTO_HASH_HEX; i++)
        if (!((h[i] >= '0' && h[i] <= '9') || (h[i] >= 'a' && h[i] <= 'f')))
            return cx_fail(cx, field, "is not %d lower-case hex digits (SHA-256)", PROTO_HASH_HEX);
    if (h[PROTO_HASH_HEX] != 0)
        return cx_fail(cx, field, "is longer than %d hex digits", PROTO_HASH_HEX);
    return 0;
}

static int ck_seconds(const cx_t *cx, const char *field, double v)
{
    if (!isfinite(v) || v < 0)
        return cx_fail(cx, field, "is %g, expected a finite number of seconds >= 0", v);
    return 0;
}

static int ck_finite(const cx_t *cx, const char *field, const double *a, size_t n)
{
    if (n > 0 && !a)
        return cx_fail(cx, field, "is missing");
    for (size_t i = 0; i < n; i++)
        if (!isfinite(a[i]))
            return cx_fail(cx, field, "element %zu is %g: results carry finite numbers only", i,
                           a[i]);
    return 0;
}

#define SETTING_NAME_MAX 64

static int ck_settings(const cx_t *cx, const proto_settings_t *s)
{
    if (ck_range(cx, "set.spp", s->spp, 0, INT_MAX) ||
        ck_range(cx, "set.xres", s->xres, 0, PROTO_MAX_IMAGE_SIDE) ||
        ck_range(cx, "set.yres", s->yres, 0, PROTO_MAX_IMAGE_SIDE) ||
        ck_range(cx, "set.seed", s->seed, -1, LLONG_MAX))
        return PROTO_EMALFORMED;
    if (s->integrator && ck_name(cx, "set.integ", s->integrator, SETTING_NAME_MAX))
        return PROTO_EMALFORMED;
    if (s->dispersion && ck_name(cx, "set.disp", s->dispersion, SETTING_NAME_MAX))
        return PROTO_EMALFORMED;
    /* 0 means "no rule" and is never written; anything else must be a usable rule. */
    if (s->target_error != 0 && !(s->target_error > 0 && s->target_error < 1))
        return cx_fail(cx, "set.tgt", "is %g, expected a relative error in (0, 1)",
                       s->target_error);
    if (s->time_limit != 0 && !(s->time_limit > 0 && s->time_limit <= PROTO_MAX_TIME_LIMIT))
        return cx_fail(cx, "set.tlim", "is %g, expected seconds in (0, %g]", s->time_limit,
                       PROTO_MAX_TIME_LIMIT);
    return 0;
}

/* Bounds that keep every size derived from a tile (w*h*nbuckets*8 bytes) far from overflow. */
/* A photon range: non-empty, and below 2^62 photons so that counts times lanes fit. */
static int ck_photons(const cx_t *cx, const char *field, const proto_photon_batch_t *b)
{
    if (!(b->end > b->first) || b->end > ((uint64_t)1 << 62))
        return cx_fail(cx, field, "[%" PRIu64 ", %" PRIu64 ") is not a photon range", b->first,
                       b->end);
    return 0;
}

static int ck_tile(const cx_t *cx, const proto_tile_t *t)
{
    if (ck_range(cx, "tile.x0", t->x0, 0, PROTO_MAX_IMAGE_SIDE - 1) ||
        ck_range(cx, "tile.y0", t->y0, 0, PROTO_MAX_IMAGE_SIDE - 1) ||
        ck_range(cx, "tile.w", t->w, 1, PROTO_MAX_TILE_SIDE) ||
        ck_range(cx, "tile.h", t->h, 1, PROTO_MAX_TILE_SIDE))
        return PROTO_EMALFORMED;
    if (t->x0 + t->w > PROTO_MAX_IMAGE_SIDE || t->y0 + t->h > PROTO_MAX_IMAGE_SIDE)
        return cx_fail(cx, "tile", "%dx%d at (%d,%d) reaches beyond %d pixels", t->w, t->h, t->x0,
                       t->y0, PROTO_MAX_IMAGE_SIDE);
    if (t->sample_end <= t->sample_begin)
        return cx_fail(cx, "tile.se", "is %" PRIu32 ", expected more than tile.sb (%" PRIu32 ")",
                       t->sample_end, t->sample_begin);
    return 0;
}

static int ck_bundle(const cx_t *cx, const proto_bundle_t *b, const proto_limits_t *lim)
{
    if (proto_bundle_check(b, lim, cx->err) < 0)
        return err_prefix(cx->err, "%s: field 'bundle': ", cx->type), PROTO_EMALFORMED;
    return 0;
}

/* A double that 4 bytes carry exactly and that the decoder takes back: zero, or a normal float
 * (a subnormal float32 on the wire is refused). The same values as film/tilebuf.h's
 * tilebuf_is_float_value, which its rounding rule leaves; test_proto checks the two agree. Zero
 * is told by its bits: under denormals-are-zero (the render threads' mode) a subnormal double
 * compares equal to 0. The comparisons and the round trip act on normal numbers only, which
 * neither that mode nor flush-to-zero changes. */
static bool is_float32_value(double v)
{
    uint64_t bits;
    memcpy(&bits, &v, sizeof bits);
    if ((bits & ~((uint64_t)1 << 63)) == 0)
        return true;
    double a = fabs(v);
    return a >= FLT_MIN && a <= FLT_MAX && (double)(float)v == v;
}

/* The width the sums travel at: 32 when every one is a float32 value, else 64. */
static int sums_width(const proto_tile_result_t *r)
{
    if (r->sums_bits)
        return r->sums_bits;
    size_t n = (size_t)r->rect.w * (size_t)r->rect.h * (size_t)r->nbuckets;
    for (size_t i = 0; i < n; i++)
        if (!is_float32_value(r->sums[i]))
            return 64;
    return 32;
}

static int ck_tile_result(const cx_t *cx, const proto_tile_result_t *r)
{
    if (ck_tile(cx, &r->rect) || ck_range(cx, "tile.nb", r->nbuckets, 1, PROTO_MAX_BUCKETS))
        return PROTO_EMALFORMED;
    /* 0 ("pick") only reaches here from proto_encode: the decoder sets 32 or 64. */
    if (r->sums_bits != 0 && r->sums_bits != 32 && r->sums_bits != 64)
        return cx_fail(cx, "tile.sums_bits", "is %d, expected 32 or 64", r->sums_bits);
    size_t npix = (size_t)r->rect.w * (size_t)r->rect.h;
    if (ck_finite(cx, "tile.sums", r->sums, npix * (size_t)r->nbuckets) ||
        ck_finite(cx, "tile.lum", r->lum, npix) || ck_finite(cx, "tile.lum2", r->lum_sq, npix))
        return PROTO_EMALFORMED;
    /* Float32 sums hold zero or normal floats only (what tilebuf_round_sums leaves): a subnormal
     * would be a value the sender's rounding rule keeps as a double. */
    if (r->sums_bits == 32)
        for (size_t i = 0; i < npix * (size_t)r->nbuckets; i++)
            if (!is_float32_value(r->sums[i]))
                return cx_fail(cx, "tile.sums", "element %zu is %.17g, not a normal float32 value "
                               "(sums_bits is 32)", i, r->sums[i]);
    if (!r->counts)
        return cx_fail(cx, "tile.counts", "is missing");
    return 0;
}

static int ck_job_info(cx_t *cx, const proto_job_info_t *j)
{
    if (ck_name(cx, "name", j->name, PROTO_MAX_STRING) ||
        ck_range(cx, "state", j->state, 0, PROTO_JOB_STATE_COUNT - 1) ||
        ck_seconds(cx, "secs", j->elapsed) || (j->error && ck_text(cx, "err", j->error)) ||
        ck_range(cx, "spp", j->spp, 0, INT_MAX) ||
        ck_range(cx, "stop", j->stop, 0, PROTO_STOP_COUNT - 1))
        return PROTO_EMALFORMED;
    if (j->has_rel_error && !(isfinite(j->rel_error) && j->rel_error >= 0))
        return cx_fail(cx, "rmse", "is %g, expected a finite relative error >= 0", j->rel_error);
    return 0;
}

static int ck_worker_info(cx_t *cx, const proto_worker_info_t *w)
{
    if (ck_name(cx, "name", w->name, PROTO_MAX_STRING) ||
        ck_range(cx, "threads", w->threads, 1, PROTO_MAX_THREADS) ||
        ck_range(cx, "state", w->state, 0, PROTO_WORKER_STATE_COUNT - 1) ||
        ck_seconds(cx, "seen", w->last_seen))
        return PROTO_EMALFORMED;
    return 0;
}

/* The message's values as the protocol allows them: the same checks run before encoding and
 * after decoding, so that encode never produces what decode rejects. */
static int msg_check(const proto_msg_t *m, const proto_limits_t *lim, cx_t *cx)
{
    switch (m->type) {
    case PROTO_HELLO:
        return ck_name(cx, "name", m->hello.name, PROTO_MAX_STRING) ||
                       ck_range(cx, "threads", m->hello.threads, 1, PROTO_MAX_THREADS) ||
                       ck_name(cx, "sw", m->hello.software, PROTO_MAX_STRING)
                   ? PROTO_EMALFORMED
                   : 0;
    case PROTO_STATUS:
        return m->status.all ? 0 : ck_range(cx, "wait", m->status.wait_ms, 0, PROTO_MAX_WAIT_MS);
    case PROTO_HEARTBEAT:
    case PROTO_CANCEL:
    case PROTO_JOBS:
    case PROTO_WORKERS:
    case PROTO_SUBMITTED:
        return 0;
    case PROTO_WELCOME:
        return ck_range(cx, "hb", m->welcome.heartbeat_ms, 1, 3600000);
    case PROTO_TASK:
        if (ck_hash(cx, "scene", m->task.scene) || ck_settings(cx, &m->task.settings))
            return PROTO_EMALFORMED;
        if (m->task.kind == PROTO_KIND_PHOTON_BATCH)
            return ck_photons(cx, "photons", &m->task.photons);
        if (m->task.kind != PROTO_KIND_CAMERA_TILE)
            return cx_fail(cx, "kind", "is %d, not a task kind of version %d", (int)m->task.kind,
                           PROTO_VERSION);
        if (m->task.store[0] && ck_hash(cx, "store", m->task.store))
            return PROTO_EMALFORMED;
        return ck_tile(cx, &m->task.tile);
    case PROTO_RESULT:
        if (ck_seconds(cx, "stats.secs", m->result.stats.elapsed))
            return PROTO_EMALFORMED;
        if (m->result.kind == PROTO_KIND_PHOTON_BATCH) {
            const proto_photon_result_t *r = &m->result.photons;
            if (ck_photons(cx, "photons", &r->range))
                return PROTO_EMALFORMED;
            if (r->size > 0 && !r->data)
                return cx_fail(cx, "photons.data", "is missing");
            /* At most 64 lanes a photon (render/photon.h); more would scale the store down. */
            if (r->emitted < r->range.end - r->range.first ||
                (r->emitted - (r->range.end - r->range.first)) / 63 > r->range.end - r->range.first)
                return cx_fail(cx, "photons.emitted", "is %" PRIu64 " for %" PRIu64 " photons",
                               r->emitted, r->range.end - r->range.first);
            return 0;
        }
        if (m->result.kind != PROTO_KIND_CAMERA_TILE)
            return cx_fail(cx, "kind", "is %d, not a task kind of version %d", (int)m->result.kind,
                           PROTO_VERSION);
        return ck_tile_result(cx, &m->result.tile);
    case PROTO_TASK_FAILED:
        return ck_text(cx, "error", m->task_failed.error);
    case PROTO_SCENE_REQUEST:
        return ck_hash(cx, "scene", m->scene_request.scene);
    case PROTO_SCENE: {
        if (ck_hash(cx, "scene", m->scene.scene) || ck_bundle(cx, &m->scene.bundle, lim))
            return PROTO_EMALFORMED;
        /* Workers cache scenes by this hash: a SCENE whose bundle does not match it would
         * poison the cache of every later job that names the same hash. */
        char hex[PROTO_HASH_HEX + 1];
        if (proto_bundle_hash(&m->scene.bundle, hex, cx->err) < 0)
            return err_prefix(cx->err, "%s: ", cx->type), PROTO_EMALFORMED;
        if (strcmp(hex, m->scene.scene) != 0)
            return cx_fail(cx, "scene", "is %.12s..., but the bundle hashes to %.12s...",
                           m->scene.scene, hex);
        return 0;
    }
    case PROTO_REFUSE:
        return ck_text(cx, "reason", m->refuse.reason);
    case PROTO_SUBMIT:
        return ck_name(cx, "name", m->submit.name, PROTO_MAX_STRING) ||
                       ck_settings(cx, &m->submit.settings) || ck_bundle(cx, &m->submit.bundle, lim)
                   ? PROTO_EMALFORMED
                   : 0;
    case PROTO_FETCH:
        return ck_range(cx, "what", m->fetch.what, 0, PROTO_FETCH_COUNT - 1);
    case PROTO_STATUS_REPLY:
    case PROTO_JOBS_REPLY: {
        /* status_reply and jobs_reply share one layout. */
        size_t n = m->jobs_reply.njobs;
        if (n > PROTO_MAX_LIST)
            return cx_fail(cx, "jobs", "has %zu entries, at most %d allowed", n, PROTO_MAX_LIST);
        if (n > 0 && !m->jobs_reply.jobs)
            return cx_fail(cx, "jobs", "is missing");
        int rc = 0;
        for (size_t i = 0; i < n && rc == 0; i++) {
            snprintf(cx->prefix, sizeof cx->prefix, "jobs[%zu].", i);
            rc = ck_job_info(cx, &m->jobs_reply.jobs[i]);
        }
        cx->prefix[0] = 0;
        return rc;
    }
    case PROTO_WORKERS_REPLY: {
        size_t n = m->workers_reply.nworkers;
        if (n > PROTO_MAX_LIST)
            return cx_fail(cx, "workers", "has %zu entries, at most %d allowed", n, PROTO_MAX_LIST);
        if (n > 0 && !m->workers_reply.workers)
            return cx_fail(cx, "workers", "is missing");
        int rc = 0;
        for (size_t i = 0; i < n && rc == 0; i++) {
            snprintf(cx->prefix, sizeof cx->prefix, "workers[%zu].", i);
            rc = ck_worker_info(cx, &m->workers_reply.workers[i]);
        }
        cx->prefix[0] = 0;
        return rc;
    }
    case PROTO_FILE:
        if (ck_name(cx, "name", m->file.name, PROTO_MAX_STRING))
            return PROTO_EMALFORMED;
        if (m->file.size > 0 && !m->file.data)
            return cx_fail(cx, "data", "is missing");
        return 0;
    case PROTO_ERROR:
        return ck_text(cx, "msg", m->error.message);
    case PROTO_STORE_REQUEST:
        return ck_hash(cx, "store", m->store_request.store);
    case PROTO_REFINE:
        if (m->refine.photons == 0 || m->refine.photons > ((uint64_t)1 << 40))
            return cx_fail(cx, "photons", "is %" PRIu64 ", expected 1 to 2^40", m->refine.photons);
        return 0;
    case PROTO_STORE: {
        if (ck_hash(cx, "store", m->store.store))
            return PROTO_EMALFORMED;
        if (m->store.size > 0 && !m->store.data)
            return cx_fail(cx, "data", "is missing");
        /* Workers keep stores by this hash, as they keep scenes. */
        char hex[PROTO_HASH_HEX + 1];
        sha256_hex_of(m->store.size ? m->store.data : (const uint8_t *)"", m->store.size, hex);
        if (strcmp(hex, m->store.store) != 0)
            return cx_fail(cx, "store", "is %.12s..., but the data hash to %.12s...",
                           m->store.store, hex);
        return 0;
    }
    case PROTO_NONE:
    case PROTO_TYPE_COUNT:
        break;
    }
    return err_set(cx->err, "message type %d is not a protocol message", (int)m->type),
           PROTO_EMALFORMED;
}

/* ---------------------------------------------------------------- bounded msgpack walker */

/* msgpack-c trusts counts: an array header claiming 2^28 elements makes it allocate gigabytes
 * before reading one. This walk visits every object of data[0..len) with a cursor and a stack of
 * at most PROTO_MAX_DEPTH levels, and checks at each container header that all objects announced
 * so far could still fit (each needs at least one byte). After it, the unpacker allocates at most
 * one msgpack_object per input byte and never more than PROTO_MAX_OBJECTS of them; maps are
 * small, so looking keys up stays cheap. It also rejects truncation, trailing bytes and the types
 * the protocol never uses (ext, 0xc1). */
static int walk(const uint8_t *p, size_t len, err_t *err)
{
    uint64_t remain[PROTO_MAX_DEPTH + 1];
    int depth = 0;
    remain[0] = 1;
    uint64_t pending = 1; /* objects announced and not yet read: the sum of remain[] */
    uint64_t objects = 1; /* objects announced so far */
    size_t pos = 0;
    while (pending > 0) {
        while (remain[depth] == 0)
            depth--;
        remain[depth]--;
        pending--;
        if (pos >= len)
            return err_set(err, "message truncated: %zu bytes, more announced", len);
        size_t at = pos;
        uint8_t b = p[pos++];
        uint64_t payload = 0; /* bytes after the header */
        size_t lenbytes = 0;  /* a big-endian length field after the tag */
        int container = 0;    /* 1 array, 2 map */
        uint64_t count = 0;
        if (b <= 0x7f || b >= 0xe0 || b == 0xc0 || b == 0xc2 || b == 0xc3) {
            /* fixint, nil, bool: the tag is the whole object */
        } else if (b <= 0x8f) {
            container = 2;
            count = b & 0x0f;
        } else if (b <= 0x9f) {
            container = 1;
            count = b & 0x0f;
        } else if (b <= 0xbf) {
            payload = b & 0x1f;
        } else {
            switch (b) {
            case 0xc4:
            case 0xd9:
                lenbytes = 1;
                break;
            case 0xc5:
            case 0xda:
                lenbytes = 2;
                break;
            case 0xc6:
            case 0xdb:
                lenbytes = 4;
                break;
            case 0xca:
                payload = 4;
                break;
            case 0xcb:
                payload = 8;
                break;
            case 0xcc:
            case 0xd0:
                payload = 1;
                break;
            case 0xcd:
            case 0xd1:
                payload = 2;
                break;
            case 0xce:
            case 0xd2:
                payload = 4;
                break;
            case 0xcf:
            case 0xd3:
                payload = 8;
                break;
            case 0xdc:
                container = 1;
                lenbytes = 2;
                break;
            case 0xdd:
                container = 1;
                lenbytes = 4;
                break;
            case 0xde:
                container = 2;
                lenbytes = 2;
                break;
            case 0xdf:
                container = 2;
                lenbytes = 4;
                break;
            default:
                return err_set(err, "msgpack tag 0x%02x at byte %zu is not used by this protocol",
                               b, at);
            }
        }
        if (lenbytes) {
            if (len - pos < lenbytes)
                return err_set(err, "message truncated in the header at byte %zu", at);
            uint64_t n = 0;
            for (size_t i = 0; i < lenbytes; i++)
                n = n << 8 | p[pos + i];
            pos += lenbytes;
            if (container)
                count = n;
            else
                payload = n;
        }
        if (payload > len - pos)
            return err_set(err, "object at byte %zu has %" PRIu64 " bytes, only %zu remain", at,
                           payload, len - pos);
        pos += (size_t)payload;
        if (container) {
            if (depth + 1 > PROTO_MAX_DEPTH)
                return err_set(err, "containers nested deeper than %d at byte %zu", PROTO_MAX_DEPTH,
                               at);
            if (container == 2 && count > PROTO_MAX_MAP_ENTRIES)
                return err_set(err, "map at byte %zu has %" PRIu64 " entries, at most %d allowed",
                               at, count, PROTO_MAX_MAP_ENTRIES);
            uint64_t items = container == 2 ? 2 * count : count;
            if (len - pos < pending || items > len - pos - pending)
                return err_set(err,
                               "%s at byte %zu announces %" PRIu64 " elements, only %zu bytes "
                               "remain",
                               container == 2 ? "map" : "array", at, count, len - pos);
            objects += items;
            if (objects > PROTO_MAX_OBJECTS)
                return err_set(err, "message has more than %d objects", PROTO_MAX_OBJECTS);
            if (items > 0) {
                remain[++depth] = items;
                pending += items;
            }
        }
    }
    if (pos != len)
        return err_set(err, "%zu trailing bytes after the message", len - pos);
    return 0;
}

/* ---------------------------------------------------------------- typed readers */

typedef struct rd {
    cx_t cx;
    proto_msg_t *m; /* owner of the copies */
    const proto_limits_t *lim;
} rd_t;

static const char *obj_kind(const msgpack_object *o)
{
    switch (o->type) {
    case MSGPACK_OBJECT_NIL:
        return "nil";
    case MSGPACK_OBJECT_BOOLEAN:
        return "a boolean";
    case MSGPACK_OBJECT_POSITIVE_INTEGER:
        return "an unsigned integer";
    case MSGPACK_OBJECT_NEGATIVE_INTEGER:
        return "a negative integer";
    case MSGPACK_OBJECT_FLOAT32:
    case MSGPACK_OBJECT_FLOAT64:
        return "a float";
    case MSGPACK_OBJECT_STR:
        return "a string";
    case MSGPACK_OBJECT_ARRAY:
        return "an array";
    case MSGPACK_OBJECT_MAP:
        return "a map";
    case MSGPACK_OBJECT_BIN:
        return "a bin";
    case MSGPACK_OBJECT_EXT:
        return "an ext";
    }
    return "unknown";
}

static int rd_oom(rd_t *rd, const char *field, size_t n)
{
    return cx_fail(&rd->cx, field, "needs %zu bytes: out of memory", n);
}

static int rd_expect(rd_t *rd, const char *field, const msgpack_object *o, msgpack_object_type t,
                     const char *what)
{
    if (!o)
        return cx_fail(&rd->cx, field, "is missing");
    if (o->type != t)
        return cx_fail(&rd->cx, field, "is %s, expected %s", obj_kind(o), what);
    return 0;
}

/* Finds keys[i]'s value in a map (vals[i], NULL if absent). Keys must be strings and a known key
 * may appear once; unknown keys are ignored, so that a newer peer can add optional fields. */
static int rd_map(rd_t *rd, const char *field, const msgpack_object *o, const char *const *keys,
                  size_t nkeys, const msgpack_object **vals)
{
    for (size_t k = 0; k < nkeys; k++)
        vals[k] = NULL;
    if (rd_expect(rd, field, o, MSGPACK_OBJECT_MAP, "a map"))
        return PROTO_EMALFORMED;
    for (uint32_t i = 0; i < o->via.map.size; i++) {
        const msgpack_object *key = &o->via.map.ptr[i].key;
        if (key->type != MSGPACK_OBJECT_STR)
            return cx_fail(&rd->cx, field, "has a key that is %s, expected a string",
                           obj_kind(key));
        for (size_t k = 0; k < nkeys; k++) {
            if (key->via.str.size == strlen(keys[k]) &&
                memcmp(key->via.str.ptr, keys[k], key->via.str.size) == 0) {
                if (vals[k])
                    return cx_fail(&rd->cx, field, "has the key '%s' twice", keys[k]);
                vals[k] = &o->via.map.ptr[i].val;
                break;
            }
        }
    }
    return 0;
}

static int rd_uint(rd_t *rd, const char *field, const msgpack_object *o, uint64_t max,
                   uint64_t *out)
{
    if (rd_expect(rd, field, o, MSGPACK_OBJECT_POSITIVE_INTEGER, "an unsigned integer"))
        return PROTO_EMALFORMED;
    if (o->via.u64 > max)
        return cx_fail(&rd->cx, field, "is %" PRIu64 ", at most %" PRIu64 " allowed", o->via.u64,
                       max);
    *out = o->via.u64;
    return 0;
}

static int rd_u32(rd_t *rd, const char *field, const msgpack_object *o, uint32_t *out)
{
    uint64_t v = 0;
    if (rd_uint(rd, field, o, UINT32_MAX, &v))
        return PROTO_EMALFORMED;
    *out = (uint32_t)v;
    return 0;
}

static int rd_int(rd_t *rd, const char *field, const msgpack_object *o, int *out)
{
    uint64_t v = 0;
    if (rd_uint(rd, field, o, INT_MAX, &v))
        return PROTO_EMALFORMED;
    *out = (int)v;
    return 0;
}

static int rd_sint(rd_t *rd, const char *field, const msgpack_object *o, long long *out)
{
    if (!o)
        return cx_fail(&rd->cx, field, "is missing");
    if (o->type == MSGPACK_OBJECT_NEGATIVE_INTEGER) {
        *out = o->via.i64;
        return 0;
    }
    if (o->type != MSGPACK_OBJECT_POSITIVE_INTEGER)
        return cx_fail(&rd->cx, field, "is %s, expected an integer", obj_kind(o));
    if (o->via.u64 > LLONG_MAX)
        return cx_fail(&rd->cx, field, "is %" PRIu64 ", at most %lld allowed", o->via.u64,
                       LLONG_MAX);
    *out = (long long)o->via.u64;
    return 0;
}

static int rd_float(rd_t *rd, const char *field, const msgpack_object *o, double *out)
{
    if (!o)
        return cx_fail(&rd->cx, field, "is missing");
    if (o->type != MSGPACK_OBJECT_FLOAT64 && o->type != MSGPACK_OBJECT_FLOAT32)
        return cx_fail(&rd->cx, field, "is %s, expected a float", obj_kind(o));
    *out = o->via.f64;
    return 0;
}

/* A string copied into the message, NUL-terminated; embedded NULs are refused because every
 * consumer sees a C string. */
static int rd_str(rd_t *rd, const char *field, const msgpack_object *o, const char **out)
{
    if (rd_expect(rd, field, o, MSGPACK_OBJECT_STR, "a string"))
        return PROTO_EMALFORMED;
    uint32_t n = o->via.str.size;
    if (n > PROTO_MAX_STRING)
        return cx_fail(&rd->cx, field, "has %" PRIu32 " bytes, at most %d allowed", n,
                       PROTO_MAX_STRING);
    if (memchr(o->via.str.ptr, 0, n))
        return cx_fail(&rd->cx, field, "contains a NUL byte");
    char *s = own_alloc(rd->m, (size_t)n + 1);
    if (!s)
        return rd_oom(rd, field, n);
    memcpy(s, o->via.str.ptr, n);
    s[n] = 0;
    *out = s;
    return 0;
}

static int rd_opt_str(rd_t *rd, const char *field, const msgpack_object *o, const char **out)
{
    *out = NULL;
    return o ? rd_str(rd, field, o, out) : 0;
}

static int rd_enum(rd_t *rd, const char *field, const msgpack_object *o, const char *const *names,
                   int count, int first, int *out)
{
    if (rd_expect(rd, field, o, MSGPACK_OBJECT_STR, "a string"))
        return PROTO_EMALFORMED;
    for (int i = first; i < count; i++)
        if (o->via.str.size == strlen(names[i]) &&
            memcmp(o->via.str.ptr, names[i], o->via.str.size) == 0) {
            *out = i;
            return 0;
        }
    char known[200] = "";
    for (int i = first; i < count; i++) {
        size_t used = strlen(known);
        snprintf(known + used, sizeof known - used, "%s%s", i > first ? ", " : "", names[i]);
    }
    return cx_fail(&rd->cx, field, "is '%.*s', expected one of: %s",
                   (int)(o->via.str.size < 40 ? o->via.str.size : 40), o->via.str.ptr, known);
}

static int rd_hash(rd_t *rd, const char *field, const msgpack_object *o,
                   char out[PROTO_HASH_HEX + 1])
{
    if (rd_expect(rd, field, o, MSGPACK_OBJECT_STR, "a string"))
        return PROTO_EMALFORMED;
    if (o->via.str.size != PROTO_HASH_HEX)
        return cx_fail(&rd->cx, field, "has %" PRIu32 " bytes, expected %d hex digits",
                       o->via.str.size, PROTO_HASH_HEX);
    memcpy(out, o->via.str.ptr, PROTO_HASH_HEX);
    out[PROTO_HASH_HEX] = 0;
    return ck_hash(&rd->cx, field, out);
}

/* A bin of exactly `expected` bytes (when expected != SIZE_MAX); returns its bytes in *raw. */
static int rd_bin(rd_t *rd, const char *field, const msgpack_object *o, uint64_t expected,
                  const msgpack_object_bin **raw)
{
    if (rd_expect(rd, field, o, MSGPACK_OBJECT_BIN, "a bin"))
        return PROTO_EMALFORMED;
    if (expected != UINT64_MAX && o->via.bin.size != expected)
        return cx_fail(&rd->cx, field, "has %" PRIu32 " bytes, expected %" PRIu64, o->via.bin.size,
                       expected);
    *raw = &o->via.bin;
    return 0;
}

static int rd_bytes(rd_t *rd, const char *field, const msgpack_object *o, const uint8_t **data,
                    size_t *size)
{
    const msgpack_object_bin *b;
    if (rd_bin(rd, field, o, UINT64_MAX, &b))
        return PROTO_EMALFORMED;
    uint8_t *copy = own_alloc(rd->m, b->size);
    if (!copy)
        return rd_oom(rd, field, b->size);
    if (b->size > 0)
        memcpy(copy, b->ptr, b->size);
    *data = copy;
    *size = b->size;
    return 0;
}

/* Arrays of doubles and uint64 travel as bins of little-endian 8-byte words; the copy is
 * aligned and in host order. */
static void *rd_words(rd_t *rd, const char *field, const msgpack_object_bin *b)
{
    uint64_t *w = own_alloc(rd->m, b->size);
    if (!w) {
        rd_oom(rd, field, b->size);
        return NULL;
    }
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
    memcpy(w, b->ptr, b->size);
#else
    for (size_t i = 0; i < b->size / 8; i++) {
        uint64_t v = 0;
        for (int k = 7; k >= 0; k--)
            v = v << 8 | (uint8_t)b->ptr[8 * i + (size_t)k];
        w[i] = v;
    }
#endif
    return w;
}

/* An array of float32 travels as a bin of little-endian 4-byte words; it is handed out as
 * doubles (exact: every float is a double), aligned. */
static double *rd_floats(rd_t *rd, const char *field, const msgpack_object_bin *b)
{
    size_t n = b->size / 4;
    double *d = own_alloc(rd->m, n * sizeof *d);
    if (!d) {
        rd_oom(rd, field, n * sizeof *d);
        return NULL;
    }
    const uint8_t *p = (const uint8_t *)b->ptr;
    for (size_t i = 0; i < n; i++) {
        uint32_t u = (uint32_t)p[4 * i] | (uint32_t)p[4 * i + 1] << 8 |
                     (uint32_t)p[4 * i + 2] << 16 | (uint32_t)p[4 * i + 3] << 24;
        float f;
        memcpy(&f, &u, sizeof f);
        d[i] = (double)f;
    }
    return d;
}

/* An array of maps each with at least `min_fields` entries: checked before anything is
 * allocated for it, so that a list costs at most a small multiple of its bytes. */
static int rd_list(rd_t *rd, const char *field, const msgpack_object *o, uint64_t max,
                   uint32_t min_fields, uint32_t *n)
{
    if (rd_expect(rd, field, o, MSGPACK_OBJECT_ARRAY, "an array"))
        return PROTO_EMALFORMED;
    if (o->via.array.size > max)
        return cx_fail(&rd->cx, field, "has %" PRIu32 " entries, at most %" PRIu64 " allowed",
                       o->via.array.size, max);
    for (uint32_t i = 0; i < o->via.array.size; i++) {
        const msgpack_object *e = &o->via.array.ptr[i];
        if (e->type != MSGPACK_OBJECT_MAP || e->via.map.size < min_fields)
            return cx_fail(&rd->cx, field,
                           "entry %" PRIu32 " is %s, expected a map of at least %" PRIu32 " fields",
                           i, e->type == MSGPACK_OBJECT_MAP ? "a smaller map" : obj_kind(e),
                           min_fields);
    }
    *n = o->via.array.size;
    return 0;
}

/* ---------------------------------------------------------------- per-type readers */

/* An optional float: absent leaves *out as it is (the caller's "none"). */
static int rd_opt_float(rd_t *rd, const char *field, const msgpack_object *o, double *out)
{
    return o ? rd_float(rd, field, o, out) : 0;
}

enum { S_SPP, S_XRES, S_YRES, S_SEED, S_INTEG, S_DISP, S_TGT, S_TLIM, S_N };
static const char *const SETTINGS_KEYS[S_N] = {"spp",   "xres", "yres", "seed",
                                               "integ", "disp", "tgt",  "tlim"};

static int rd_settings(rd_t *rd, const msgpack_object *o, proto_settings_t *s)
{
    const msgpack_object *v[S_N];
    s->target_error = s->time_limit = 0;
    if (rd_map(rd, "set", o, SETTINGS_KEYS, S_N, v) || rd_int(rd, "set.spp", v[S_SPP], &s->spp) ||
        rd_int(rd, "set.xres", v[S_XRES], &s->xres) ||
        rd_int(rd, "set.yres", v[S_YRES], &s->yres) ||
        rd_sint(rd, "set.seed", v[S_SEED], &s->seed) ||
        rd_opt_str(rd, "set.integ", v[S_INTEG], &s->integrator) ||
        rd_opt_str(rd, "set.disp", v[S_DISP], &s->dispersion) ||
        rd_opt_float(rd, "set.tgt", v[S_TGT], &s->target_error) ||
        rd_opt_float(rd, "set.tlim", v[S_TLIM], &s->time_limit))
        return PROTO_EMALFORMED;
    /* Present means a rule: an explicit 0 is something the encoder never writes. */
    if (v[S_TGT] && s->target_error == 0)
        return cx_fail(&rd->cx, "set.tgt", "is 0: absent means no target");
    if (v[S_TLIM] && s->time_limit == 0)
        return cx_fail(&rd->cx, "set.tlim", "is 0: absent means no time limit");
    return 0;
}

enum { B_MAIN, B_FILES, B_N };
static const char *const BUNDLE_KEYS[B_N] = {"main", "files"};
enum { F_PATH, F_DATA, F_N };
static const char *const FILE_KEYS[F_N] = {"path", "data"};

static int rd_bundle(rd_t *rd, const msgpack_object *o, proto_bundle_t *b)
{
    const msgpack_object *v[B_N];
    uint32_t n;
    if (rd_map(rd, "bundle", o, BUNDLE_KEYS, B_N, v) ||
        rd_str(rd, "bundle.main", v[B_MAIN], &b->main) ||
        rd_list(rd, "bundle.files", v[B_FILES], rd->lim->max_bundle_files, F_N, &n))
        return PROTO_EMALFORMED;
    proto_bundle_file_t *files = own_alloc(rd->m, (size_t)n * sizeof *files);
    if (!files)
        return rd_oom(rd, "bundle.files", (size_t)n * sizeof *files);
    for (uint32_t i = 0; i < n; i++) {
        const msgpack_object *f[F_N];
        snprintf(rd->cx.prefix, sizeof rd->cx.prefix, "bundle.files[%" PRIu32 "].", i);
        if (rd_map(rd, "", &v[B_FILES]->via.array.ptr[i], FILE_KEYS, F_N, f) ||
            rd_str(rd, "path", f[F_PATH], &files[i].path) ||
            rd_bytes(rd, "data", f[F_DATA], &files[i].data, &files[i].size))
            return PROTO_EMALFORMED;
    }
    rd->cx.prefix[0] = 0;
    b->files = files;
    b->nfiles = n;
    return 0;
}

enum {
    T_X0, T_Y0, T_W, T_H, T_SB, T_SE, T_NB, T_SUMS, T_COUNTS, T_LUM, T_LUM2, T_NONFINITE, T_BITS, T_N
};
static const char *const TILE_KEYS[T_N] = {"x0",  "y0",        "w",        "h",     "sb",
                                           "se",  "nb",        "sums",     "counts", "lum",
                                           "lum2", "nonfinite", "sums_bits"};
#define TILE_TASK_KEYS 6 /* a task's tile has the first six */

static int rd_tile_rect(rd_t *rd, const msgpack_object **v, proto_tile_t *t)
{
    if (rd_int(rd, "tile.x0", v[T_X0], &t->x0) || rd_int(rd, "tile.y0", v[T_Y0], &t->y0) ||
        rd_int(rd, "tile.w", v[T_W], &t->w) || rd_int(rd, "tile.h", v[T_H], &t->h) ||
        rd_u32(rd, "tile.sb", v[T_SB], &t->sample_begin) ||
        rd_u32(rd, "tile.se", v[T_SE], &t->sample_end))
        return PROTO_EMALFORMED;
    return ck_tile(&rd->cx, t);
}

static int rd_tile_result(rd_t *rd, const msgpack_object *o, proto_tile_result_t *r)
{
    const msgpack_object *v[T_N];
    if (rd_map(rd, "tile", o, TILE_KEYS, T_N, v) || rd_tile_rect(rd, v, &r->rect) ||
        rd_int(rd, "tile.nb", v[T_NB], &r->nbuckets) ||
        ck_range(&rd->cx, "tile.nb", r->nbuckets, 1, PROTO_MAX_BUCKETS) ||
        rd_uint(rd, "tile.nonfinite", v[T_NONFINITE], UINT64_MAX, &r->nonfinite))
        return PROTO_EMALFORMED;
    uint64_t bits;
    if (rd_uint(rd, "tile.sums_bits", v[T_BITS], UINT64_MAX, &bits))
        return PROTO_EMALFORMED;
    if (bits != 32 && bits != 64)
        return cx_fail(&rd->cx, "tile.sums_bits", "is %" PRIu64 ", expected 32 or 64", bits);
    r->sums_bits = (int)bits;
    /* The ranges above bound these below 2^37 bytes: no overflow. */
    uint64_t npix = (uint64_t)r->rect.w * (uint64_t)r->rect.h;
    const msgpack_object_bin *sums = NULL, *counts = NULL, *lum = NULL, *lum2 = NULL;
    if (rd_bin(rd, "tile.sums", v[T_SUMS], npix * (uint64_t)r->nbuckets * (bits / 8), &sums) ||
        rd_bin(rd, "tile.counts", v[T_COUNTS], npix * 8, &counts) ||
        rd_bin(rd, "tile.lum", v[T_LUM], npix * 8, &lum) ||
        rd_bin(rd, "tile.lum2", v[T_LUM2], npix * 8, &lum2))
        return PROTO_EMALFORMED;
    if (!(r->sums = bits == 32 ? rd_floats(rd, "tile.sums", sums) : rd_words(rd, "tile.sums", sums)) ||
        !(r->counts = rd_words(rd, "tile.counts", counts)) ||
        !(r->lum = rd_words(rd, "tile.lum", lum)) || !(r->lum_sq = rd_words(rd, "tile.lum2", lum2)))
        return PROTO_EMALFORMED;
    return 0;
}

enum { ST_SAMPLES, ST_RAYS, ST_DISP, ST_SECS, ST_N };
static const char *const STATS_KEYS[ST_N] = {"samples", "rays", "disp", "secs"};

static int rd_stats(rd_t *rd, const msgpack_object *o, proto_task_stats_t *s)
{
    const msgpack_object *v[ST_N];
    if (rd_map(rd, "stats", o, STATS_KEYS, ST_N, v) ||
        rd_uint(rd, "stats.samples", v[ST_SAMPLES], UINT64_MAX, &s->samples) ||
        rd_uint(rd, "stats.rays", v[ST_RAYS], UINT64_MAX, &s->rays) ||
        rd_uint(rd, "stats.disp", v[ST_DISP], UINT64_MAX, &s->dispersive) ||
        rd_float(rd, "stats.secs", v[ST_SECS], &s->elapsed))
        return PROTO_EMALFORMED;
    return 0;
}

enum {
    J_ID, J_NAME, J_STATE, J_DONE, J_TOTAL, J_SECS, J_NONFINITE, J_ERR, J_SPP, J_RMSE, J_STOP, J_N
};
static const char *const JOB_KEYS[J_N] = {"id",   "name", "state",     "done", "total", "secs",
                                          "nonfinite", "err", "spp", "rmse", "stop"};
#define JOB_REQUIRED_KEYS 7 /* all but "err", "spp", "rmse" and "stop" */

static int rd_jobs(rd_t *rd, const msgpack_object *o, const proto_job_info_t **out, size_t *nout)
{
    uint32_t n;
    if (rd_list(rd, "jobs", o, PROTO_MAX_LIST, JOB_REQUIRED_KEYS, &n))
        return PROTO_EMALFORMED;
    proto_job_info_t *jobs = own_alloc(rd->m, (size_t)n * sizeof *jobs);
    if (!jobs)
        return rd_oom(rd, "jobs", (size_t)n * sizeof *jobs);
    for (uint32_t i = 0; i < n; i++) {
        const msgpack_object *v[J_N];
        proto_job_info_t *j = &jobs[i];
        int state = 0;
        snprintf(rd->cx.prefix, sizeof rd->cx.prefix, "jobs[%" PRIu32 "].", i);
        if (rd_map(rd, "", &o->via.array.ptr[i], JOB_KEYS, J_N, v) ||
            rd_uint(rd, "id", v[J_ID], UINT64_MAX, &j->id) ||
            rd_str(rd, "name", v[J_NAME], &j->name) ||
            rd_enum(rd, "state", v[J_STATE], JOB_STATE_NAMES, PROTO_JOB_STATE_COUNT, 0, &state) ||
            rd_uint(rd, "done", v[J_DONE], UINT64_MAX, &j->samples_done) ||
            rd_uint(rd, "total", v[J_TOTAL], UINT64_MAX, &j->samples_total) ||
            rd_float(rd, "secs", v[J_SECS], &j->elapsed) ||
            rd_uint(rd, "nonfinite", v[J_NONFINITE], UINT64_MAX, &j->nonfinite) ||
            rd_opt_str(rd, "err", v[J_ERR], &j->error))
            return PROTO_EMALFORMED;
        j->state = (proto_job_state_t)state;
        /* Accuracy: absent is "0 spp", "no estimate", "not stopped early"; present is never
         * those (the encoder omits them), so an explicit one is refused. */
        uint64_t spp = 0;
        int stop = PROTO_STOP_NONE;
        if ((v[J_SPP] && (rd_uint(rd, "spp", v[J_SPP], INT_MAX, &spp) ||
                          (spp == 0 && cx_fail(&rd->cx, "spp", "is 0: absent means none")))) ||
            (v[J_RMSE] && rd_float(rd, "rmse", v[J_RMSE], &j->rel_error)) ||
            (v[J_STOP] && rd_enum(rd, "stop", v[J_STOP], STOP_NAMES, PROTO_STOP_COUNT,
                                  PROTO_STOP_TARGET, &stop)))
            return PROTO_EMALFORMED;
        j->spp = (uint32_t)spp;
        j->has_rel_error = v[J_RMSE] != NULL; /* its range: ck_job_info, after decoding */
        j->stop = (proto_stop_t)stop;
    }
    rd->cx.prefix[0] = 0;
    *out = jobs;
    *nout = n;
    return 0;
}

enum { W_NAME, W_ID, W_THREADS, W_STATE, W_DONE, W_SEEN, W_N };
static const char *const WORKER_KEYS[W_N] = {"name", "id", "threads", "state", "done", "seen"};

static int rd_workers(rd_t *rd, const msgpack_object *o, const proto_worker_info_t **out,
                      size_t *nout)
{
    uint32_t n;
    if (rd_list(rd, "workers", o, PROTO_MAX_LIST, W_N, &n))
        return PROTO_EMALFORMED;
    proto_worker_info_t *ws = own_alloc(rd->m, (size_t)n * sizeof *ws);
    if (!ws)
        return rd_oom(rd, "workers", (size_t)n * sizeof *ws);
    for (uint32_t i = 0; i < n; i++) {
        const msgpack_object *v[W_N];
        proto_worker_info_t *w = &ws[i];
        int state = 0;
        snprintf(rd->cx.prefix, sizeof rd->cx.prefix, "workers[%" PRIu32 "].", i);
        if (rd_map(rd, "", &o->via.array.ptr[i], WORKER_KEYS, W_N, v) ||
            rd_str(rd, "name", v[W_NAME], &w->name) ||
            rd_uint(rd, "id", v[W_ID], UINT64_MAX, &w->id) ||
            rd_int(rd, "threads", v[W_THREADS], &w->threads) ||
            rd_enum(rd, "state", v[W_STATE], WORKER_STATE_NAMES, PROTO_WORKER_STATE_COUNT, 0,
                    &state) ||
            rd_uint(rd, "done", v[W_DONE], UINT64_MAX, &w->tasks_done) ||
            rd_float(rd, "seen", v[W_SEEN], &w->last_seen))
            return PROTO_EMALFORMED;
        w->state = (proto_worker_state_t)state;
    }
    rd->cx.prefix[0] = 0;
    *out = ws;
    *nout = n;
    return 0;
}

enum { PH_FIRST, PH_END, PH_EMITTED, PH_DATA, PH_NONFINITE, PH_N };
static const char *const PHOTON_KEYS[PH_N] = {"first", "end", "emitted", "data", "nonfinite"};
#define PHOTON_TASK_KEYS 2 /* a task's range has the first two */

/* The "photons" map's range; vals (when not NULL) receives every key's value for the result. */
static int rd_photon_range(rd_t *rd, const msgpack_object *o, const msgpack_object **vals,
                           proto_photon_batch_t *b)
{
    const msgpack_object *own[PH_N];
    const msgpack_object **v = vals ? vals : own;
    if (rd_map(rd, "photons", o, PHOTON_KEYS, vals ? PH_N : PHOTON_TASK_KEYS, v) ||
        rd_uint(rd, "photons.first", v[PH_FIRST], UINT64_MAX, &b->first) ||
        rd_uint(rd, "photons.end", v[PH_END], UINT64_MAX, &b->end))
        return PROTO_EMALFORMED;
    return ck_photons(&rd->cx, "photons", b);
}

static int rd_photon_result(rd_t *rd, const msgpack_object *o, proto_photon_result_t *r)
{
    const msgpack_object *v[PH_N];
    if (rd_photon_range(rd, o, v, &r->range) ||
        rd_uint(rd, "photons.emitted", v[PH_EMITTED], UINT64_MAX, &r->emitted) ||
        rd_uint(rd, "photons.nonfinite", v[PH_NONFINITE], UINT64_MAX, &r->nonfinite) ||
        rd_bytes(rd, "photons.data", v[PH_DATA], &r->data, &r->size))
        return PROTO_EMALFORMED;
    return 0;
}

/* Every key any message body uses; each reader picks its own by index. */
enum {
    K_NAME,
    K_THREADS,
    K_SW,
    K_WID,
    K_HB,
    K_JOB,
    K_TASK,
    K_ATT,
    K_SCENE,
    K_SET,
    K_KIND,
    K_TILE,
    K_STATS,
    K_ERROR,
    K_BUNDLE,
    K_REASON,
    K_WHAT,
    K_JOBS,
    K_WORKERS,
    K_DATA,
    K_MSG,
    K_WAIT,
    K_STORE,
    K_PHOTONS,
    K_N
};
static const char *const BODY_KEYS[K_N] = {"name",    "threads", "sw",     "wid",    "hb",   "job",
                                           "task",    "att",     "scene",  "set",    "kind", "tile",
                                           "stats",   "error",   "bundle", "reason", "what", "jobs",
                                           "workers", "data",    "msg",    "wait",   "store", "photons"};

static int rd_kind(rd_t *rd, const msgpack_object *o, proto_kind_t *kind)
{
    int k = 0;
    if (rd_enum(rd, "kind", o, KIND_NAMES, PROTO_KIND_COUNT, PROTO_KIND_CAMERA_TILE, &k))
        return PROTO_EMALFORMED;
    *kind = (proto_kind_t)k;
    return 0;
}

static int rd_body(rd_t *rd, const msgpack_object *root)
{
    proto_msg_t *m = rd->m;
    const msgpack_object *v[K_N];
    if (rd_map(rd, "(message)", root, BODY_KEYS, K_N, v))
        return PROTO_EMALFORMED;
    int what = 0;
    switch (m->type) {
    case PROTO_HELLO:
        return rd_str(rd, "name", v[K_NAME], &m->hello.name) ||
                       rd_int(rd, "threads", v[K_THREADS], &m->hello.threads) ||
                       rd_str(rd, "sw", v[K_SW], &m->hello.software)
                   ? PROTO_EMALFORMED
                   : 0;
    case PROTO_HEARTBEAT:
    case PROTO_JOBS:
    case PROTO_WORKERS:
        return 0;
    case PROTO_WELCOME:
        return rd_uint(rd, "wid", v[K_WID], UINT64_MAX, &m->welcome.worker_id) ||
                       rd_u32(rd, "hb", v[K_HB], &m->welcome.heartbeat_ms)
                   ? PROTO_EMALFORMED
                   : 0;
    case PROTO_TASK: {
        const msgpack_object *t[T_N];
        if (rd_uint(rd, "job", v[K_JOB], UINT64_MAX, &m->task.job) ||
            rd_uint(rd, "task", v[K_TASK], UINT64_MAX, &m->task.task) ||
            rd_u32(rd, "att", v[K_ATT], &m->task.attempt) ||
            rd_hash(rd, "scene", v[K_SCENE], m->task.scene) ||
            rd_settings(rd, v[K_SET], &m->task.settings) || rd_kind(rd, v[K_KIND], &m->task.kind))
            return PROTO_EMALFORMED;
        if (m->task.kind == PROTO_KIND_PHOTON_BATCH)
            return rd_photon_range(rd, v[K_PHOTONS], NULL, &m->task.photons);
        if (v[K_STORE] && rd_hash(rd, "store", v[K_STORE], m->task.store))
            return PROTO_EMALFORMED;
        if (rd_map(rd, "tile", v[K_TILE], TILE_KEYS, TILE_TASK_KEYS, t) ||
            rd_tile_rect(rd, t, &m->task.tile))
            return PROTO_EMALFORMED;
        return 0;
    }
    case PROTO_RESULT:
        if (rd_uint(rd, "job", v[K_JOB], UINT64_MAX, &m->result.job) ||
            rd_uint(rd, "task", v[K_TASK], UINT64_MAX, &m->result.task) ||
            rd_u32(rd, "att", v[K_ATT], &m->result.attempt) ||
            rd_kind(rd, v[K_KIND], &m->result.kind) || rd_stats(rd, v[K_STATS], &m->result.stats))
            return PROTO_EMALFORMED;
        if (m->result.kind == PROTO_KIND_PHOTON_BATCH)
            return rd_photon_result(rd, v[K_PHOTONS], &m->result.photons);
        return rd_tile_result(rd, v[K_TILE], &m->result.tile);
    case PROTO_TASK_FAILED:
        return rd_uint(rd, "job", v[K_JOB], UINT64_MAX, &m->task_failed.job) ||
                       rd_uint(rd, "task", v[K_TASK], UINT64_MAX, &m->task_failed.task) ||
                       rd_u32(rd, "att", v[K_ATT], &m->task_failed.attempt) ||
                       rd_str(rd, "error", v[K_ERROR], &m->task_failed.error)
                   ? PROTO_EMALFORMED
                   : 0;
    case PROTO_SCENE_REQUEST:
        return rd_hash(rd, "scene", v[K_SCENE], m->scene_request.scene);
    case PROTO_SCENE:
        return rd_hash(rd, "scene", v[K_SCENE], m->scene.scene) ||
                       rd_bundle(rd, v[K_BUNDLE], &m->scene.bundle)
                   ? PROTO_EMALFORMED
                   : 0;
    case PROTO_CANCEL:
        return rd_uint(rd, "job", v[K_JOB], UINT64_MAX, &m->cancel.job);
    case PROTO_REFUSE:
        return rd_str(rd, "reason", v[K_REASON], &m->refuse.reason);
    case PROTO_SUBMIT:
        return rd_str(rd, "name", v[K_NAME], &m->submit.name) ||
                       rd_settings(rd, v[K_SET], &m->submit.settings) ||
                       rd_bundle(rd, v[K_BUNDLE], &m->submit.bundle)
                   ? PROTO_EMALFORMED
                   : 0;
    case PROTO_STATUS:
        m->status.all = v[K_JOB] == NULL;
        if (v[K_JOB] && rd_uint(rd, "job", v[K_JOB], UINT64_MAX, &m->status.job))
            return PROTO_EMALFORMED;
        /* wait: optional, and meaningful for one job only (docs/protocol.md). */
        return v[K_WAIT] && !m->status.all
                   ? rd_u32(rd, "wait", v[K_WAIT], &m->status.wait_ms)
                   : 0;
    case PROTO_FETCH:
        if (rd_uint(rd, "job", v[K_JOB], UINT64_MAX, &m->fetch.job) ||
            rd_enum(rd, "what", v[K_WHAT], FETCH_NAMES, PROTO_FETCH_COUNT, 0, &what))
            return PROTO_EMALFORMED;
        m->fetch.what = (proto_fetch_what_t)what;
        return 0;
    case PROTO_SUBMITTED:
        return rd_uint(rd, "job", v[K_JOB], UINT64_MAX, &m->submitted.job);
    case PROTO_STATUS_REPLY:
    case PROTO_JOBS_REPLY:
        return rd_jobs(rd, v[K_JOBS], &m->jobs_reply.jobs, &m->jobs_reply.njobs);
    case PROTO_WORKERS_REPLY:
        return rd_workers(rd, v[K_WORKERS], &m->workers_reply.workers, &m->workers_reply.nworkers);
    case PROTO_FILE:
        return rd_str(rd, "name", v[K_NAME], &m->file.name) ||
                       rd_bytes(rd, "data", v[K_DATA], &m->file.data, &m->file.size)
                   ? PROTO_EMALFORMED
                   : 0;
    case PROTO_ERROR:
        return rd_str(rd, "msg", v[K_MSG], &m->error.message);
    case PROTO_STORE_REQUEST:
        return rd_hash(rd, "store", v[K_STORE], m->store_request.store);
    case PROTO_REFINE:
        return rd_uint(rd, "job", v[K_JOB], UINT64_MAX, &m->refine.job) ||
                       rd_uint(rd, "photons", v[K_PHOTONS], UINT64_MAX, &m->refine.photons)
                   ? PROTO_EMALFORMED
                   : 0;
    case PROTO_STORE:
        return rd_hash(rd, "store", v[K_STORE], m->store.store) ||
                       rd_bytes(rd, "data", v[K_DATA], &m->store.data, &m->store.size)
                   ? PROTO_EMALFORMED
                   : 0;
    case PROTO_NONE:
    case PROTO_TYPE_COUNT:
        break;
    }
    return err_set(rd->cx.err, "message type %d has no reader", (int)m->type), PROTO_EMALFORMED;
}

enum { E_V, E_T, E_N };
static const char *const ENVELOPE_KEYS[E_N] = {"v", "t"};

static int decode_root(const msgpack_object *root, const proto_limits_t *lim, proto_msg_t *m,
                       err_t *err)
{
    rd_t rd = {.cx = {.type = "message", .err = err}, .m = m, .lim = lim};
    const msgpack_object *v[E_N];
    if (root->type != MSGPACK_OBJECT_MAP)
        return err_set(err, "message is %s, expected a map", obj_kind(root)), PROTO_EMALFORMED;
    uint64_t version;
    if (rd_map(&rd, "(message)", root, ENVELOPE_KEYS, E_N, v) ||
        rd_uint(&rd, "v", v[E_V], INT_MAX, &version) ||
        rd_expect(&rd, "t", v[E_T], MSGPACK_OBJECT_STR, "a string"))
        return PROTO_EMALFORMED;
    m->version = (int)version;
    const msgpack_object_str *t = &v[E_T]->via.str;
    proto_type_t type = PROTO_NONE;
    for (int i = PROTO_NONE + 1; i < PROTO_TYPE_COUNT; i++)
        if (t->size == strlen(TYPE_NAMES[i]) && memcmp(t->ptr, TYPE_NAMES[i], t->size) == 0)
            type = (proto_type_t)i;
    if (type == PROTO_NONE)
        return err_set(err, "message type '%.*s' is unknown", (int)(t->size < 40 ? t->size : 40),
                       t->ptr),
               PROTO_EMALFORMED;
    /* REFUSE and ERROR keep their layout in every version, so that a peer refused for its
     * version still learns why. */
    if (m->version != PROTO_VERSION && type != PROTO_REFUSE && type != PROTO_ERROR)
        return err_set(err, "%s: protocol version %d not supported (speaks %d)", TYPE_NAMES[type],
                       m->version, PROTO_VERSION),
               PROTO_EVERSION;
    m->type = type;
    rd.cx.type = TYPE_NAMES[type];
    if (rd_body(&rd, root))
        return PROTO_EMALFORMED;
    return msg_check(m, lim, &rd.cx);
}

int proto_decode(const void *data, size_t len, const proto_limits_t *limits, proto_msg_t *out,
                 err_t *err)
{
    proto_limits_t lim = limits ? *limits : proto_limits_default();
    memset(out, 0, sizeof *out);
    if (!data && len > 0)
        return err_set(err, "message: no data"), PROTO_EMALFORMED;
    if (len > lim.max_message_bytes)
        return err_set(err, "message has %zu bytes, at most %zu allowed", len,
                       lim.max_message_bytes),
               PROTO_EMALFORMED;
    if (walk(data, len, err) < 0)
        return err_prefix(err, "malformed msgpack: "), PROTO_EMALFORMED;
    msgpack_unpacked u;
    msgpack_unpacked_init(&u);
    size_t off = 0;
    msgpack_unpack_return r = msgpack_unpack_next(&u, data, len, &off);
    int rc;
    if (r != MSGPACK_UNPACK_SUCCESS || off != len)
        rc = err_set(err, "msgpack-c could not unpack the message (code %d at byte %zu)", (int)r,
                     off);
    else
        rc = decode_root(&u.data, &lim, out, err);
    msgpack_unpacked_destroy(&u);
    if (rc < 0) {
        int version = out->version;
        proto_msg_free(out);
        if (rc == PROTO_EVERSION)
            out->version = version;
    }
    return rc;
}

/* ---------------------------------------------------------------- encoder */

/* A packer with a sticky failure flag: every msgpack-c return is checked, once, at the end. */
typedef struct enc {
    msgpack_packer pk;
    int failed;
} enc_t;

static void e_check(enc_t *e, int rc)
{
    if (rc != 0)
        e->failed = 1;
}

static void e_key(enc_t *e, const char *key)
{
    if (key && !e->failed)
        e_check(e, msgpack_pack_str_with_body(&e->pk, key, strlen(key)));
}

static void e_uint(enc_t *e, const char *key, uint64_t v)
{
    e_key(e, key);
    if (!e->failed)
        e_check(e, msgpack_pack_uint64(&e->pk, v));
}

static void e_sint(enc_t *e, const char *key, long long v)
{
    e_key(e, key);
    if (!e->failed)
        e_check(e, msgpack_pack_int64(&e->pk, v));
}

static void e_float(enc_t *e, const char *key, double v)
{
    e_key(e, key);
    if (!e->failed)
        e_check(e, msgpack_pack_double(&e->pk, v));
}

static void e_str(enc_t *e, const char *key, const char *s)
{
    e_key(e, key);
    if (!e->failed)
        e_check(e, msgpack_pack_str_with_body(&e->pk, s, strlen(s)));
}

static void e_map(enc_t *e, const char *key, size_t n)
{
    e_key(e, key);
    if (!e->failed)
        e_check(e, msgpack_pack_map(&e->pk, n));
}

static void e_array(enc_t *e, const char *key, size_t n)
{
    e_key(e, key);
    if (!e->failed)
        e_check(e, msgpack_pack_array(&e->pk, n));
}

static void e_bin(enc_t *e, const char *key, const void *data, size_t n)
{
    e_key(e, key);
    if (n > UINT32_MAX)
        e->failed = 1;
    if (!e->failed)
        e_check(e, msgpack_pack_bin_with_body(&e->pk, n ? data : "", n));
}

/* 8-byte words (doubles or uint64) as a bin of little-endian words. */
static void e_words(enc_t *e, const char *key, const void *words, size_t n)
{
    if (n > UINT32_MAX / 8) {
        e->failed = 1;
        return;
    }
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
    e_bin(e, key, words, n * 8);
#else
    e_key(e, key);
    if (!e->failed)
        e_check(e, msgpack_pack_bin(&e->pk, n * 8));
    for (size_t i = 0; i < n && !e->failed; i++) {
        uint64_t w;
        uint8_t le[8];
        memcpy(&w, (const uint8_t *)words + 8 * i, 8);
        for (int b = 0; b < 8; b++)
            le[b] = (uint8_t)(w >> (8 * b));
        e_check(e, msgpack_pack_bin_body(&e->pk, le, 8));
    }
#endif
}

/* Doubles that are float32 values (is_float32_value) as a bin of little-endian float32s,
 * packed a chunk at a time. */
static void e_floats(enc_t *e, const char *key, const double *v, size_t n)
{
    if (n > UINT32_MAX / 4) {
        e->failed = 1;
        return;
    }
    e_key(e, key);
    if (!e->failed)
        e_check(e, msgpack_pack_bin(&e->pk, n * 4));
    uint8_t le[4 * 512];
    for (size_t i = 0; i < n && !e->failed;) {
        size_t k = 0;
        for (; k < 512 && i < n; k++, i++) {
            float f = (float)v[i];
            uint32_t u;
            memcpy(&u, &f, sizeof u);
            for (int b = 0; b < 4; b++)
                le[4 * k + (size_t)b] = (uint8_t)(u >> (8 * b));
        }
        e_check(e, msgpack_pack_bin_body(&e->pk, le, 4 * k));
    }
}

static void e_settings(enc_t *e, const proto_settings_t *s)
{
    e_map(e, "set", 4 + (s->integrator != NULL) + (s->dispersion != NULL) +
                        (s->target_error != 0) + (s->time_limit != 0));
    e_uint(e, "spp", (uint64_t)s->spp);
    e_uint(e, "xres", (uint64_t)s->xres);
    e_uint(e, "yres", (uint64_t)s->yres);
    e_sint(e, "seed", s->seed);
    if (s->integrator)
        e_str(e, "integ", s->integrator);
    if (s->dispersion)
        e_str(e, "disp", s->dispersion);
    if (s->target_error != 0)
        e_float(e, "tgt", s->target_error);
    if (s->time_limit != 0)
        e_float(e, "tlim", s->time_limit);
}

static void e_bundle(enc_t *e, const proto_bundle_t *b)
{
    e_map(e, "bundle", 2);
    e_str(e, "main", b->main);
    e_array(e, "files", b->nfiles);
    for (size_t i = 0; i < b->nfiles; i++) {
        e_map(e, NULL, 2);
        e_str(e, "path", b->files[i].path);
        e_bin(e, "data", b->files[i].data, b->files[i].size);
    }
}

static void e_tile_rect(enc_t *e, const proto_tile_t *t)
{
    e_uint(e, "x0", (uint64_t)t->x0);
    e_uint(e, "y0", (uint64_t)t->y0);
    e_uint(e, "w", (uint64_t)t->w);
    e_uint(e, "h", (uint64_t)t->h);
    e_uint(e, "sb", t->sample_begin);
    e_uint(e, "se", t->sample_end);
}

/* The number of body fields of each type, for the map header. */
static size_t body_fields(const proto_msg_t *m)
{
    switch (m->type) {
    case PROTO_HELLO:
        return 3;
    case PROTO_WELCOME:
        return 2;
    case PROTO_TASK:
        /* camera tiles: the tile, and the store when the job has one; batches: the range */
        return 7 + (m->task.kind == PROTO_KIND_CAMERA_TILE && m->task.store[0]);
    case PROTO_RESULT:
        return 6;
    case PROTO_STORE:
    case PROTO_REFINE:
        return 2;
    case PROTO_STORE_REQUEST:
        return 1;
    case PROTO_TASK_FAILED:
        return 4;
    case PROTO_SCENE:
        return 2;
    case PROTO_SUBMIT:
        return 3;
    case PROTO_STATUS:
        return m->status.all ? 0 : 1 + (m->status.wait_ms > 0);
    case PROTO_FETCH:
        return 2;
    case PROTO_FILE:
        return 2;
    case PROTO_SCENE_REQUEST:
    case PROTO_CANCEL:
    case PROTO_REFUSE:
    case PROTO_SUBMITTED:
    case PROTO_STATUS_REPLY:
    case PROTO_JOBS_REPLY:
    case PROTO_WORKERS_REPLY:
    case PROTO_ERROR:
        return 1;
    default:
        return 0;
    }
}

static void e_body(enc_t *e, const proto_msg_t *m)
{
    switch (m->type) {
    case PROTO_HELLO:
        e_str(e, "name", m->hello.name);
        e_uint(e, "threads", (uint64_t)m->hello.threads);
        e_str(e, "sw", m->hello.software);
        break;
    case PROTO_WELCOME:
        e_uint(e, "wid", m->welcome.worker_id);
        e_uint(e, "hb", m->welcome.heartbeat_ms);
        break;
    case PROTO_TASK:
        e_uint(e, "job", m->task.job);
        e_uint(e, "task", m->task.task);
        e_uint(e, "att", m->task.attempt);
        e_str(e, "scene", m->task.scene);
        e_settings(e, &m->task.settings);
        e_str(e, "kind", proto_kind_name(m->task.kind));
        if (m->task.kind == PROTO_KIND_PHOTON_BATCH) {
            e_map(e, "photons", PHOTON_TASK_KEYS);
            e_uint(e, "first", m->task.photons.first);
            e_uint(e, "end", m->task.photons.end);
            break;
        }
        if (m->task.store[0])
            e_str(e, "store", m->task.store);
        e_map(e, "tile", TILE_TASK_KEYS);
        e_tile_rect(e, &m->task.tile);
        break;
    case PROTO_RESULT: {
        if (m->result.kind == PROTO_KIND_PHOTON_BATCH) {
            const proto_photon_result_t *r = &m->result.photons;
            e_uint(e, "job", m->result.job);
            e_uint(e, "task", m->result.task);
            e_uint(e, "att", m->result.attempt);
            e_str(e, "kind", proto_kind_name(m->result.kind));
            e_map(e, "photons", PH_N);
            e_uint(e, "first", r->range.first);
            e_uint(e, "end", r->range.end);
            e_uint(e, "emitted", r->emitted);
            e_bin(e, "data", r->data, r->size);
            e_uint(e, "nonfinite", r->nonfinite);
            e_map(e, "stats", ST_N);
            e_uint(e, "samples", m->result.stats.samples);
            e_uint(e, "rays", m->result.stats.rays);
            e_uint(e, "disp", m->result.stats.dispersive);
            e_float(e, "secs", m->result.stats.elapsed);
            break;
        }
        const proto_tile_result_t *r = &m->result.tile;
        size_t npix = (size_t)r->rect.w * (size_t)r->rect.h;
        e_uint(e, "job", m->result.job);
        e_uint(e, "task", m->result.task);
        e_uint(e, "att", m->result.attempt);
        e_str(e, "kind", proto_kind_name(m->result.kind));
        e_map(e, "tile", T_N);
        e_tile_rect(e, &r->rect);
        e_uint(e, "nb", (uint64_t)r->nbuckets);
        int bits = sums_width(r);
        e_uint(e, "sums_bits", (uint64_t)bits);
        if (bits == 32)
            e_floats(e, "sums", r->sums, npix * (size_t)r->nbuckets);
        else
            e_words(e, "sums", r->sums, npix * (size_t)r->nbuckets);
        e_words(e, "counts", r->counts, npix);
        e_words(e, "lum", r->lum, npix);
        e_words(e, "lum2", r->lum_sq, npix);
        e_uint(e, "nonfinite", r->nonfinite);
        e_map(e, "stats", ST_N);
        e_uint(e, "samples", m->result.stats.samples);
        e_uint(e, "rays", m->result.stats.rays);
        e_uint(e, "disp", m->result.stats.dispersive);
        e_float(e, "secs", m->result.stats.elapsed);
        break;
    }
    case PROTO_TASK_FAILED:
        e_uint(e, "job", m->task_failed.job);
        e_uint(e, "task", m->task_failed.task);
        e_uint(e, "att", m->task_failed.attempt);
        e_str(e, "error", m->task_failed.error);
        break;
    case PROTO_SCENE_REQUEST:
        e_str(e, "scene", m->scene_request.scene);
        break;
    case PROTO_SCENE:
        e_str(e, "scene", m->scene.scene);
        e_bundle(e, &m->scene.bundle);
        break;
    case PROTO_CANCEL:
        e_uint(e, "job", m->cancel.job);
        break;
    case PROTO_REFUSE:
        e_str(e, "reason", m->refuse.reason);
        break;
    case PROTO_SUBMIT:
        e_str(e, "name", m->submit.name);
        e_settings(e, &m->submit.settings);
        e_bundle(e, &m->submit.bundle);
        break;
    case PROTO_STATUS:
        if (!m->status.all)
            e_uint(e, "job", m->status.job);
        if (!m->status.all && m->status.wait_ms > 0)
            e_uint(e, "wait", m->status.wait_ms);
        break;
    case PROTO_FETCH:
        e_uint(e, "job", m->fetch.job);
        e_str(e, "what", proto_fetch_what_name(m->fetch.what));
        break;
    case PROTO_SUBMITTED:
        e_uint(e, "job", m->submitted.job);
        break;
    case PROTO_STATUS_REPLY:
    case PROTO_JOBS_REPLY:
        e_array(e, "jobs", m->jobs_reply.njobs);
        for (size_t i = 0; i < m->jobs_reply.njobs; i++) {
            const proto_job_info_t *j = &m->jobs_reply.jobs[i];
            e_map(e, NULL, JOB_REQUIRED_KEYS + (j->error != NULL) + (j->spp > 0) +
                               j->has_rel_error + (j->stop != PROTO_STOP_NONE));
            e_uint(e, "id", j->id);
            e_str(e, "name", j->name);
            e_str(e, "state", proto_job_state_name(j->state));
            e_uint(e, "done", j->samples_done);
            e_uint(e, "total", j->samples_total);
            e_float(e, "secs", j->elapsed);
            e_uint(e, "nonfinite", j->nonfinite);
            if (j->error)
                e_str(e, "err", j->error);
            if (j->spp > 0)
                e_uint(e, "spp", j->spp);
            if (j->has_rel_error)
                e_float(e, "rmse", j->rel_error);
            if (j->stop != PROTO_STOP_NONE)
                e_str(e, "stop", proto_stop_name(j->stop));
        }
        break;
    case PROTO_WORKERS_REPLY:
        e_array(e, "workers", m->workers_reply.nworkers);
        for (size_t i = 0; i < m->workers_reply.nworkers; i++) {
            const proto_worker_info_t *w = &m->workers_reply.workers[i];
            e_map(e, NULL, W_N);
            e_str(e, "name", w->name);
            e_uint(e, "id", w->id);
            e_uint(e, "threads", (uint64_t)w->threads);
            e_str(e, "state", proto_worker_state_name(w->state));
            e_uint(e, "done", w->tasks_done);
            e_float(e, "seen", w->last_seen);
        }
        break;
    case PROTO_FILE:
        e_str(e, "name", m->file.name);
        e_bin(e, "data", m->file.data, m->file.size);
        break;
    case PROTO_ERROR:
        e_str(e, "msg", m->error.message);
        break;
    case PROTO_STORE_REQUEST:
        e_str(e, "store", m->store_request.store);
        break;
    case PROTO_STORE:
        e_str(e, "store", m->store.store);
        e_bin(e, "data", m->store.data, m->store.size);
        break;
    case PROTO_REFINE:
        e_uint(e, "job", m->refine.job);
        e_uint(e, "photons", m->refine.photons);
        break;
    default:
        break;
    }
}

int proto_encode(const proto_msg_t *msg, const proto_limits_t *limits, msgpack_sbuffer *out,
                 err_t *err)
{
    proto_limits_t lim = limits ? *limits : proto_limits_default();
    cx_t cx = {.type = proto_type_name(msg->type), .err = err};
    if (msg->version < 0)
        return err_set(err, "%s: version %d is negative", cx.type, msg->version);
    if (msg_check(msg, &lim, &cx) < 0)
        return -1;
    size_t start = out->size;
    enc_t e = {.failed = 0};
    msgpack_packer_init(&e.pk, out, msgpack_sbuffer_write);
    e_map(&e, NULL, 2 + body_fields(msg));
    e_uint(&e, "v", (uint64_t)(msg->version ? msg->version : PROTO_VERSION));
    e_str(&e, "t", proto_type_name(msg->type));
    e_body(&e, msg);
    if (e.failed) {
        out->size = start;
        return err_set(err, "%s: out of memory while encoding", cx.type);
    }
    if (out->size - start > lim.max_message_bytes) {
        size_t n = out->size - start;
        out->size = start;
        return err_set(err, "%s: encoded message has %zu bytes, at most %zu allowed", cx.type, n,
                       lim.max_message_bytes);
    }
    return 0;
}
