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
    [PROTO_PROGRESS] = "PROGRESS",
    [PROTO_ACT] = "ACT",
    [PROTO_LOGS] = "LOGS",
    [PROTO_METRICS] = "METRICS",
};
static const char *const KIND_NAMES[PROTO_KIND_COUNT] = {[PROTO_KIND_NONE] = "none",
                                                         [PROTO_KIND_CAMERA_TILE] = "camera_tile",
                                                         [PROTO_KIND_PHOTON_BATCH] =
                                                             "photon_batch"};
static const char *const ACT_NAMES[PROTO_ACT_COUNT] = {"none",   "priority", "pause",
                                                       "resume", "requeue",  "unblock"};
static const char *const JOB_STATE_NAMES[JOB_STATE_COUNT] = {"queued", "running",   "done",
                                                             "failed", "cancelled", "paused"};
static const char *const WORKER_STATE_NAMES[PROTO_WORKER_STATE_COUNT] = {"idle", "busy", "lost",
                                                                         "blocked"};
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
const char *proto_job_state_name(job_state_t s)
{
    return name_of(JOB_STATE_NAMES, JOB_STATE_COUNT, (int)s);
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
const char *proto_act_name(proto_act_t a)
{
    return name_of(ACT_NAMES, PROTO_ACT_COUNT, (int)a);
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
    if (msg->release)
        msg->release(msg->release_arg);
    memset(msg, 0, sizeof *msg);
}

/* ---------------------------------------------------------------- error context */

/* Context for error messages: "TYPE: field 'prefix.field' what is wrong". */
typedef struct cx {
    const char *type;
    char prefix[40]; /* the maps and list entries around the field: "tile.", "jobs[12].", "" */
    const proto_limits_t *lim;
    err_t *err;
} cx_t;

/* Fails naming prefix + field, or, when field is NULL, the enclosing map itself ("tile"). */
__attribute__((format(printf, 3, 4))) static int cx_fail(const cx_t *cx, const char *field,
                                                         const char *fmt, ...)
{
    char what[400];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    if (field)
        err_set(cx->err, "%s: field '%s%s' %s", cx->type, cx->prefix, field, what);
    else
        err_set(cx->err, "%s: field '%.*s' %s", cx->type, (int)strlen(cx->prefix) - 1, cx->prefix,
                what);
    return PROTO_EMALFORMED;
}

/* Enters the map under key, or its list entry index (when >= 0); returns what cx_leave needs. */
static size_t cx_enter(cx_t *cx, const char *key, long long index)
{
    size_t n = strlen(cx->prefix);
    if (index < 0)
        snprintf(cx->prefix + n, sizeof cx->prefix - n, "%s.", key);
    else
        snprintf(cx->prefix + n, sizeof cx->prefix - n, "%s[%lld].", key, index);
    return n;
}

static void cx_leave(cx_t *cx, size_t n)
{
    cx->prefix[n] = 0;
}

/* ---------------------------------------------------------------- the field tables */

/* Every message body, and every map inside one, is described once, by a table of its fields:
 * the key, how the value is stored and sent, where it is in its struct, when it is on the wire
 * and which values it may hold. Generic walks over a table encode it (write_fields), decode it
 * (read_fields), check it (check_fields, on both sides) and count a map's entries
 * (count_fields), so adding a field is adding its line. What is not a plain value (blobs, arrays
 * of words, the float32-or-float64 tile sums, maps, lists of maps) has a type of its own, handled
 * in one case of each walk. Rules that span fields (a tile inside the image, a SCENE's hash)
 * belong to the table as a whole (shape_t.check). */

typedef enum ftype {
    FT_U64,       /* uint64_t: uint */
    FT_U32,       /* uint32_t: uint <= UINT32_MAX */
    FT_INT,       /* int: uint <= INT_MAX (every int field's range starts at 0 or more) */
    FT_SINT,      /* long long: int */
    FT_FLOAT,     /* double: float64 (float32 accepted) */
    FT_STR,       /* const char *: str, copied NUL-terminated */
    FT_HASH,      /* char[PROTO_HASH_HEX + 1]: str of PROTO_HASH_HEX bytes */
    FT_ENUM,      /* an enum: str, one of .names from .names->first on */
    FT_BYTES,     /* const uint8_t *, with its size_t size at .aux: bin */
    FT_WORDS,     /* const double * or const uint64_t *, .count of them: bin of LE 8-byte words */
    FT_SUMS_BITS, /* int: the width of the FT_SUMS at .aux, 32 or 64 (in C, 0 lets it pick) */
    FT_SUMS,      /* const double *, .count of them: bin of LE float32s or float64s, as the
                   * FT_SUMS_BITS at .aux says */
    FT_MAP,       /* a struct: a map of .sub's fields */
    FT_LIST,      /* const T *, with its size_t count at .aux: an array of maps of .sub's fields */
    FT_FLAT,      /* a struct whose fields (.sub) sit among this map's own (a result's tile rect) */
} ftype_t;

/* When a field is on the wire. An absent optional field decodes as zero or clears its flag. */
typedef enum presence {
    ALWAYS,      /* required */
    UNLESS_ZERO, /* omitted when 0, NULL or "" (an enum: its value 0) */
    IF_FLAG,     /* there when the bool at .flag is true; decoding sets the flag */
    UNLESS_FLAG, /* there when the bool at .flag is false; decoding sets the flag */
} presence_t;

typedef struct names {
    const char *const *names;
    int count;
    int first; /* the wire carries names[first..count); those before are for C only ("none") */
} names_t;

typedef struct field field_t;
typedef struct shape shape_t;

struct field {
    const char *key; /* also its name in errors, after the enclosing maps' */
    ftype_t type;
    size_t at;  /* offset of the value in the struct the table describes */
    size_t aux; /* FT_BYTES, FT_LIST: offset of the size_t length; FT_SUMS(_BITS): of its twin */
    presence_t presence;
    size_t flag;                   /* IF_FLAG, UNLESS_FLAG: offset of the bool */
    const char *absent;            /* UNLESS_ZERO: when set, a 0 on the wire is refused,
                                    * "absent means <absent>" (the encoder omits it instead) */
    bool (*when)(const void *obj); /* NULL, or the field belongs to the struct only when true
                                    * (a TASK's tile only in a camera task); else never sent and
                                    * ignored when received */
    int (*check)(const cx_t *cx, const field_t *f, const void *obj); /* the value's rule */
    long long lo, hi;                 /* ck_range's bounds; ck_name's, ck_list's maximum */
    const names_t *names;             /* FT_ENUM */
    const shape_t *sub;               /* FT_MAP, FT_LIST, FT_FLAT */
    size_t (*count)(const void *obj); /* FT_WORDS, FT_SUMS, FT_SUMS_BITS: the array's length */
    /* FT_SUMS, FT_SUMS_BITS (encoding): the width, 32 or 64, that every FT_SUMS of the struct
     * travels at, so that arrays sharing one FT_SUMS_BITS agree on it */
    int (*width)(const void *obj);
};

struct shape {
    const field_t *fields;
    size_t nfields;
    size_t size;                                   /* sizeof the struct: a list's stride */
    int (*check)(const cx_t *cx, const void *obj); /* across fields, after them; or NULL */
};

/* FT_LIST's .hi for the files of a bundle: the caller's proto_limits_t.max_bundle_files. */
#define CALLER_BUNDLE_FILES (-1)
/* Keys in one map, its flat sub-tables included (a RESULT's tile has 13, a job map 18). */
#define MAX_KEYS 24

/* The value of a field, by its type, in the struct obj. */
#define VALUE(type, obj, off) (*(type *)((char *)(obj) + (off)))
#define CVALUE(type, obj, off) (*(const type *)((const char *)(obj) + (off)))

/* Enums are read and written as the int they are. */
_Static_assert(sizeof(proto_kind_t) == sizeof(int) && sizeof(job_state_t) == sizeof(int) &&
                   sizeof(proto_worker_state_t) == sizeof(int) &&
                   sizeof(proto_fetch_what_t) == sizeof(int) &&
                   sizeof(proto_stop_t) == sizeof(int) && sizeof(proto_act_t) == sizeof(int),
               "enum fields are accessed as int");

/* Pointer members have many types (const double *, const proto_job_info_t *, ...): they are
 * copied as bytes rather than accessed through another pointer type. */
static const void *ptr_of(const void *obj, size_t off)
{
    const void *p;
    memcpy(&p, (const char *)obj + off, sizeof p);
    return p;
}

static void set_ptr(void *obj, size_t off, const void *p)
{
    memcpy((char *)obj + off, &p, sizeof p);
}

static long long int_of(const field_t *f, const void *obj)
{
    switch (f->type) {
    case FT_U32:
        return CVALUE(uint32_t, obj, f->at);
    case FT_SINT:
        return CVALUE(long long, obj, f->at);
    default: /* FT_INT, FT_ENUM, FT_SUMS_BITS */
        return CVALUE(int, obj, f->at);
    }
}

static bool is_zero(const field_t *f, const void *obj)
{
    switch (f->type) {
    case FT_U64:
        return CVALUE(uint64_t, obj, f->at) == 0;
    case FT_FLOAT:
        return CVALUE(double, obj, f->at) == 0;
    case FT_STR:
        return ptr_of(obj, f->at) == NULL;
    case FT_HASH:
        return CVALUE(char, obj, f->at) == 0;
    case FT_LIST:
        return CVALUE(size_t, obj, f->aux) == 0;
    default:
        return int_of(f, obj) == 0;
    }
}

/* Whether f is in the encoding of obj. */
static bool present(const field_t *f, const void *obj)
{
    if (f->when && !f->when(obj))
        return false;
    switch (f->presence) {
    case UNLESS_ZERO:
        return !is_zero(f, obj);
    case IF_FLAG:
        return CVALUE(bool, obj, f->flag);
    case UNLESS_FLAG:
        return !CVALUE(bool, obj, f->flag);
    case ALWAYS:
        break;
    }
    return true;
}

/* The entries of the map that obj encodes to. */
static size_t count_fields(const shape_t *s, const void *obj)
{
    size_t n = 0;
    for (size_t i = 0; i < s->nfields; i++) {
        const field_t *f = &s->fields[i];
        if (f->type == FT_FLAT)
            n += count_fields(f->sub, (const char *)obj + f->at);
        else
            n += present(f, obj);
    }
    return n;
}

/* The entries every map of this table has, whatever its values. */
static uint32_t required_fields(const shape_t *s)
{
    uint32_t n = 0;
    for (size_t i = 0; i < s->nfields; i++) {
        const field_t *f = &s->fields[i];
        if (f->type == FT_FLAT)
            n += required_fields(f->sub);
        else
            n += f->presence == ALWAYS && !f->when;
    }
    return n;
}

/* ---------------------------------------------------------------- value rules */

static int ck_range(const cx_t *cx, const field_t *f, const void *obj)
{
    long long v = int_of(f, obj);
    if (v < f->lo || v > f->hi)
        return cx_fail(cx, f->key, "is %lld, expected %lld..%lld", v, f->lo, f->hi);
    return 0;
}

/* An enum set by the caller: one of its values. */
static int ck_enum(const cx_t *cx, const field_t *f, const void *obj)
{
    long long v = int_of(f, obj);
    if (v < 0 || v >= f->names->count)
        return cx_fail(cx, f->key, "is %lld, expected 0..%d", v, f->names->count - 1);
    return 0;
}

/* A task's or a result's kind, which decides the fields after it. */
static int ck_kind(const cx_t *cx, const field_t *f, const void *obj)
{
    long long v = int_of(f, obj);
    if (v != PROTO_KIND_CAMERA_TILE && v != PROTO_KIND_PHOTON_BATCH)
        return cx_fail(cx, f->key, "is %lld, not a task kind of version %d", v, PROTO_VERSION);
    return 0;
}

/* Free text (error messages, reasons): any bytes but NUL, bounded. */
static int ck_text(const cx_t *cx, const field_t *f, const void *obj)
{
    const char *s = ptr_of(obj, f->at);
    if (!s)
        return cx_fail(cx, f->key, "is missing");
    size_t n = strlen(s);
    if (n > PROTO_MAX_STRING)
        return cx_fail(cx, f->key, "has %zu bytes, at most %d allowed", n, PROTO_MAX_STRING);
    return 0;
}

/* Names shown in tables and logs: non-empty, at most .hi bytes, no control characters (a name
 * must not be able to move a terminal's cursor). */
static int ck_name(const cx_t *cx, const field_t *f, const void *obj)
{
    const char *s = ptr_of(obj, f->at);
    if (!s)
        return cx_fail(cx, f->key, "is missing");
    size_t n = strlen(s);
    if (n == 0)
        return cx_fail(cx, f->key, "is empty");
    if (n > (size_t)f->hi)
        return cx_fail(cx, f->key, "has %zu bytes, at most %lld allowed", n, f->hi);
    for (size_t i = 0; i < n; i++) {
        unsigned char c = (unsigned char)s[i];
        if (c < 0x20 || c == 0x7f)
            return cx_fail(cx, f->key, "has a control character 0x%02x at byte %zu", c, i);
    }
    return 0;
}

static int ck_hash(const cx_t *cx, const field_t *f, const void *obj)
{
    const char *h = (const char *)obj + f->at;
    for (int i = 0; i < PROTO_HASH_HEX; i++)
        if (!((h[i] >= '0' && h[i] <= '9') || (h[i] >= 'a' && h[i] <= 'f')))
            return cx_fail(cx, f->key, "is not %d lower-case hex digits (SHA-256)", PROTO_HASH_HEX);
    if (h[PROTO_HASH_HEX] != 0)
        return cx_fail(cx, f->key, "is longer than %d hex digits", PROTO_HASH_HEX);
    return 0;
}

static int ck_rate(const cx_t *cx, const field_t *f, const void *obj)
{
    double v = CVALUE(double, obj, f->at);
    if (!isfinite(v) || v < 0)
        return cx_fail(cx, f->key, "is %g, expected a finite rate >= 0", v);
    return 0;
}

static int ck_seconds(const cx_t *cx, const field_t *f, const void *obj)
{
    double v = CVALUE(double, obj, f->at);
    if (!isfinite(v) || v < 0)
        return cx_fail(cx, f->key, "is %g, expected a finite number of seconds >= 0", v);
    return 0;
}

static int ck_target_error(const cx_t *cx, const field_t *f, const void *obj)
{
    double v = CVALUE(double, obj, f->at);
    if (!(v > 0 && v < 1))
        return cx_fail(cx, f->key, "is %g, expected a relative error in (0, 1)", v);
    return 0;
}

static int ck_time_limit(const cx_t *cx, const field_t *f, const void *obj)
{
    double v = CVALUE(double, obj, f->at);
    if (!(v > 0 && v <= PROTO_MAX_TIME_LIMIT))
        return cx_fail(cx, f->key, "is %g, expected seconds in (0, %g]", v, PROTO_MAX_TIME_LIMIT);
    return 0;
}

static int ck_rel_error(const cx_t *cx, const field_t *f, const void *obj)
{
    double v = CVALUE(double, obj, f->at);
    if (!(isfinite(v) && v >= 0))
        return cx_fail(cx, f->key, "is %g, expected a finite relative error >= 0", v);
    return 0;
}

static int ck_photon_count(const cx_t *cx, const field_t *f, const void *obj)
{
    uint64_t v = CVALUE(uint64_t, obj, f->at);
    if (v == 0 || v > ((uint64_t)1 << 40))
        return cx_fail(cx, f->key, "is %" PRIu64 ", expected 1 to 2^40", v);
    return 0;
}

static int ck_bytes(const cx_t *cx, const field_t *f, const void *obj)
{
    if (CVALUE(size_t, obj, f->aux) > 0 && !ptr_of(obj, f->at))
        return cx_fail(cx, f->key, "is missing");
    return 0;
}

static int ck_list(const cx_t *cx, const field_t *f, const void *obj)
{
    size_t n = CVALUE(size_t, obj, f->aux);
    if (n > (size_t)f->hi)
        return cx_fail(cx, f->key, "has %zu entries, at most %lld allowed", n, f->hi);
    if (n > 0 && !ptr_of(obj, f->at))
        return cx_fail(cx, f->key, "is missing");
    return 0;
}

/* An array of words of any value (counts). */
static int ck_words(const cx_t *cx, const field_t *f, const void *obj)
{
    if (f->count(obj) > 0 && !ptr_of(obj, f->at))
        return cx_fail(cx, f->key, "is missing");
    return 0;
}

static int ck_finite(const cx_t *cx, const field_t *f, const void *obj)
{
    const double *a = ptr_of(obj, f->at);
    size_t n = f->count(obj);
    if (n > 0 && !a)
        return cx_fail(cx, f->key, "is missing");
    for (size_t i = 0; i < n; i++)
        if (!isfinite(a[i]))
            return cx_fail(cx, f->key, "element %zu is %g: results carry finite numbers only", i,
                           a[i]);
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

static bool all_float32(const double *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!is_float32_value(v[i]))
            return false;
    return true;
}

/* 0 ("pick") only reaches here from proto_encode: the decoder takes 32 or 64 only. */
static int ck_sums_bits(const cx_t *cx, const field_t *f, const void *obj)
{
    int bits = CVALUE(int, obj, f->at);
    if (bits != 0 && bits != 32 && bits != 64)
        return cx_fail(cx, f->key, "is %d, expected 32 or 64", bits);
    return 0;
}

static int ck_sums(const cx_t *cx, const field_t *f, const void *obj)
{
    if (ck_finite(cx, f, obj))
        return PROTO_EMALFORMED;
    /* Float32 sums hold zero or normal floats only (what tilebuf_round_sums leaves): a subnormal
     * would be a value the sender's rounding rule keeps as a double. */
    const double *a = ptr_of(obj, f->at);
    if (CVALUE(int, obj, f->aux) == 32)
        for (size_t i = 0, n = f->count(obj); i < n; i++)
            if (!is_float32_value(a[i]))
                return cx_fail(cx, f->key,
                               "element %zu is %.17g, not a normal float32 value (sums_bits is "
                               "32)",
                               i, a[i]);
    return 0;
}

/* ---------------------------------------------------------------- rules across fields */

/* The bounds of the fields keep every size derived from a tile (w*h*nbuckets*8 bytes) far from
 * overflow; here the tile must also lie inside the image and take samples. */
static int ck_tile_rect(const cx_t *cx, const void *obj)
{
    const proto_tile_t *t = obj;
    if (t->x0 + t->w > PROTO_MAX_IMAGE_SIDE || t->y0 + t->h > PROTO_MAX_IMAGE_SIDE)
        return cx_fail(cx, NULL, "%dx%d at (%d,%d) reaches beyond %d pixels", t->w, t->h, t->x0,
                       t->y0, PROTO_MAX_IMAGE_SIDE);
    if (t->sample_end <= t->sample_begin)
        return cx_fail(cx, "se", "is %" PRIu32 ", expected more than %ssb (%" PRIu32 ")",
                       t->sample_end, cx->prefix, t->sample_begin);
    return 0;
}

/* A photon range: non-empty, and below 2^62 photons so that counts times lanes fit. */
static int ck_photon_range(const cx_t *cx, const void *obj)
{
    const proto_photon_batch_t *b = obj;
    if (!(b->end > b->first) || b->end > ((uint64_t)1 << 62))
        return cx_fail(cx, NULL, "[%" PRIu64 ", %" PRIu64 ") is not a photon range", b->first,
                       b->end);
    return 0;
}

/* A job map's photon progress: never more photons merged than the pass has. */
static int check_job_info(const cx_t *cx, const void *obj)
{
    const proto_job_info_t *j = obj;
    if (j->photons_done > j->photons_total)
        return cx_fail(cx, "pdone", "%" PRIu64 " photons merged of a pass of %" PRIu64,
                       j->photons_done, j->photons_total);
    return 0;
}

/* At most 64 lanes a photon (render/photon.h); more would scale the store down. */
static int ck_photon_result(const cx_t *cx, const void *obj)
{
    const proto_photon_result_t *r = obj;
    uint64_t n = r->range.end - r->range.first;
    if (r->emitted < n || (r->emitted - n) / 63 > n)
        return cx_fail(cx, "emitted", "is %" PRIu64 " for %" PRIu64 " photons", r->emitted, n);
    return 0;
}

/* bundle.c's rules, which cover its fields: paths, each once, main among them, the caller's
 * limits. */
static int ck_bundle(const cx_t *cx, const void *obj)
{
    if (proto_bundle_check(obj, cx->lim, cx->err) < 0)
        return err_prefix(cx->err, "%s: field '%.*s': ", cx->type, (int)strlen(cx->prefix) - 1,
                          cx->prefix),
               PROTO_EMALFORMED;
    return 0;
}

/* A scene file named apart from its bundle (a TASK's or a frame's main): a bundle path. */
static int ck_path(const cx_t *cx, const field_t *f, const void *obj)
{
    const char *s = ptr_of(obj, f->at);
    if (!s)
        return cx_fail(cx, f->key, "is missing");
    err_t why;
    if (proto_bundle_path_check(s, &why) < 0)
        return cx_fail(cx, f->key, "is not a bundle path: %s", why.msg);
    return 0;
}

/* A sequence's frames: each one of the bundle's files, each file and number used once. Sorted
 * copies of the names make it O(n log n): up to PROTO_MAX_FRAMES frames against
 * PROTO_MAX_BUNDLE_FILES files would be 4e7 comparisons pairwise, on the master's loop. */
static int cmp_str(const void *a, const void *b)
{
    return strcmp(*(const char *const *)a, *(const char *const *)b);
}
static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return x < y ? -1 : x > y;
}

static int ck_submit_frames(const cx_t *cx, const void *obj)
{
    const proto_msg_t *m = obj;
    const proto_frame_t *fr = m->submit.frames;
    const proto_bundle_t *b = &m->submit.bundle;
    size_t n = m->submit.nframes;
    if (n == 0)
        return 0;
    const char **paths = malloc((b->nfiles ? b->nfiles : 1) * sizeof *paths);
    const char **mains = malloc(n * sizeof *mains);
    uint32_t *numbers = malloc(n * sizeof *numbers);
    int rc = 0;
    if (!paths || !mains || !numbers) {
        rc = cx_fail(cx, "frames", "cannot be checked: out of memory");
        goto out;
    }
    for (size_t k = 0; k < b->nfiles; k++)
        paths[k] = b->files[k].path;
    qsort(paths, b->nfiles, sizeof *paths, cmp_str);
    for (size_t i = 0; i < n; i++) {
        if (!bsearch(&fr[i].main, paths, b->nfiles, sizeof *paths, cmp_str)) {
            rc = cx_fail(cx, "frames", "entry %zu names '%.200s', which is not in the bundle", i,
                         fr[i].main);
            goto out;
        }
        mains[i] = fr[i].main;
        numbers[i] = fr[i].number;
    }
    qsort(mains, n, sizeof *mains, cmp_str);
    qsort(numbers, n, sizeof *numbers, cmp_u32);
    for (size_t i = 1; i < n && rc == 0; i++) {
        if (!strcmp(mains[i - 1], mains[i]))
            rc = cx_fail(cx, "frames", "has '%.200s' twice", mains[i]);
        else if (numbers[i - 1] == numbers[i])
            rc = cx_fail(cx, "frames", "has the number %u twice", numbers[i]);
    }
out:
    free(paths);
    free(mains);
    free(numbers);
    return rc;
}

/* Workers cache scenes by this hash: a SCENE whose bundle does not match it would poison the
 * cache of every later job that names the same hash. */
static int ck_scene_hash(const cx_t *cx, const void *obj)
{
    const proto_msg_t *m = obj;
    char hex[PROTO_HASH_HEX + 1];
    if (proto_bundle_hash(&m->scene.bundle, hex, cx->err) < 0)
        return err_prefix(cx->err, "%s: ", cx->type), PROTO_EMALFORMED;
    if (strcmp(hex, m->scene.scene) != 0)
        return cx_fail(cx, "scene", "is %.12s..., but the bundle hashes to %.12s...",
                       m->scene.scene, hex);
    return 0;
}

/* Workers keep stores by this hash, as they keep scenes. */
static int ck_store_hash(const cx_t *cx, const void *obj)
{
    const proto_msg_t *m = obj;
    char hex[PROTO_HASH_HEX + 1];
    sha256_hex_of(m->store.size ? m->store.data : (const uint8_t *)"", m->store.size, hex);
    if (strcmp(hex, m->store.store) != 0)
        return cx_fail(cx, "store", "is %.12s..., but the data hash to %.12s...", m->store.store,
                       hex);
    return 0;
}

/* ---------------------------------------------------------------- the tables */

#define N(a) (sizeof(a) / sizeof(a)[0])
#define F(k, t, offset) .key = (k), .type = (t), .at = (offset)
#define RANGE(a, b) .check = ck_range, .lo = (a), .hi = (b)
#define NAME(max) .check = ck_name, .hi = (max)
#define ENUM(n) .names = &(n), .check = ck_enum
/* A shape_t's initializer: {SHAPE(...)} */
#define SHAPE(type, fields, rule) (fields), N(fields), sizeof(type), (rule)

static const names_t KINDS = {KIND_NAMES, PROTO_KIND_COUNT, PROTO_KIND_CAMERA_TILE};
static const names_t JOB_STATES = {JOB_STATE_NAMES, JOB_STATE_COUNT, 0};
static const names_t WORKER_STATES = {WORKER_STATE_NAMES, PROTO_WORKER_STATE_COUNT, 0};
static const names_t FETCH_WHATS = {FETCH_NAMES, PROTO_FETCH_COUNT, 0};
static const names_t STOPS = {STOP_NAMES, PROTO_STOP_COUNT, PROTO_STOP_TARGET};
static const names_t ACTS = {ACT_NAMES, PROTO_ACT_COUNT, PROTO_ACT_PRIORITY};

/* The SETTINGS map: each setting's key, wire type and check (job_settings.h). */
#define FT_OF_INT FT_INT
#define FT_OF_LLONG FT_SINT
#define FT_OF_DOUBLE FT_FLOAT
#define FT_OF_NAME FT_STR
#define SETTING_FIELD(field, kind, keep, key, wire, ...)                                           \
    {F(key, FT_OF_##kind, offsetof(proto_settings_t, field)), JOB_SETTING_UNPAREN wire},
static const field_t SETTINGS_FIELDS[] = {JOB_SETTINGS(SETTING_FIELD)};
#undef SETTING_FIELD
static const shape_t SETTINGS = {SHAPE(proto_settings_t, SETTINGS_FIELDS, NULL)};

#define RECT(m) offsetof(proto_tile_t, m)
static const field_t RECT_FIELDS[] = {
    {F("x0", FT_INT, RECT(x0)), RANGE(0, PROTO_MAX_IMAGE_SIDE - 1)},
    {F("y0", FT_INT, RECT(y0)), RANGE(0, PROTO_MAX_IMAGE_SIDE - 1)},
    {F("w", FT_INT, RECT(w)), RANGE(1, PROTO_MAX_TILE_SIDE)},
    {F("h", FT_INT, RECT(h)), RANGE(1, PROTO_MAX_TILE_SIDE)},
    {F("sb", FT_U32, RECT(sample_begin))},
    {F("se", FT_U32, RECT(sample_end))},
};
static const shape_t TILE_RECT = {SHAPE(proto_tile_t, RECT_FIELDS, ck_tile_rect)};

static size_t tile_pixels(const void *obj)
{
    const proto_tile_result_t *r = obj;
    return (size_t)r->rect.w * (size_t)r->rect.h;
}

static size_t tile_values(const void *obj)
{
    return tile_pixels(obj) * (size_t)((const proto_tile_result_t *)obj)->nbuckets;
}

static size_t tile_xyz_values(const void *obj)
{
    return tile_pixels(obj) * PROTO_TILE_XYZ;
}

/* The width a tile's bucket and XYZ sums travel at (one sums_bits for both): the one asked for,
 * else 32 when every one of them is a float32 value, else 64. */
static int tile_sums_width(const void *obj)
{
    const proto_tile_result_t *r = obj;
    if (r->sums_bits)
        return r->sums_bits;
    return all_float32(r->sums, tile_values(obj)) && all_float32(r->xyz, tile_xyz_values(obj)) ? 32
                                                                                               : 64;
}

/* The rect and nb come first, checked, so that the bins' lengths derived from them (below 2^37
 * bytes) are known before the bins are read. */
#define TR(m) offsetof(proto_tile_result_t, m)
static const field_t TILE_RESULT_FIELDS[] = {
    {F(NULL, FT_FLAT, TR(rect)), .sub = &TILE_RECT},
    {F("nb", FT_INT, TR(nbuckets)), RANGE(1, PROTO_MAX_BUCKETS)},
    {F("sums_bits", FT_SUMS_BITS, TR(sums_bits)), .aux = TR(sums), .count = tile_values,
     .check = ck_sums_bits, .width = tile_sums_width},
    {F("sums", FT_SUMS, TR(sums)), .aux = TR(sums_bits), .count = tile_values, .check = ck_sums,
     .width = tile_sums_width},
    {F("xyz", FT_SUMS, TR(xyz)), .aux = TR(sums_bits), .count = tile_xyz_values, .check = ck_sums,
     .width = tile_sums_width},
    {F("counts", FT_WORDS, TR(counts)), .count = tile_pixels, .check = ck_words},
    {F("lum", FT_WORDS, TR(lum)), .count = tile_pixels, .check = ck_finite},
    {F("lum2", FT_WORDS, TR(lum_sq)), .count = tile_pixels, .check = ck_finite},
    {F("nonfinite", FT_U64, TR(nonfinite))},
};
static const shape_t TILE_RESULT = {SHAPE(proto_tile_result_t, TILE_RESULT_FIELDS, NULL)};

#define PB(m) offsetof(proto_photon_batch_t, m)
static const field_t PHOTON_RANGE_FIELDS[] = {
    {F("first", FT_U64, PB(first))},
    {F("end", FT_U64, PB(end))},
};
static const shape_t PHOTON_RANGE = {
    SHAPE(proto_photon_batch_t, PHOTON_RANGE_FIELDS, ck_photon_range)};

#define PR(m) offsetof(proto_photon_result_t, m)
static const field_t PHOTON_RESULT_FIELDS[] = {
    {F(NULL, FT_FLAT, PR(range)), .sub = &PHOTON_RANGE},
    {F("emitted", FT_U64, PR(emitted))},
    {F("data", FT_BYTES, PR(data)), .aux = PR(size), .check = ck_bytes},
    {F("nonfinite", FT_U64, PR(nonfinite))},
};
static const shape_t PHOTON_RESULT = {
    SHAPE(proto_photon_result_t, PHOTON_RESULT_FIELDS, ck_photon_result)};

#define ST(m) offsetof(proto_task_stats_t, m)
static const field_t STATS_FIELDS[] = {
    {F("samples", FT_U64, ST(samples))},
    {F("rays", FT_U64, ST(rays))},
    {F("disp", FT_U64, ST(dispersive))},
    {F("secs", FT_FLOAT, ST(elapsed)), .check = ck_seconds},
};
static const shape_t STATS = {SHAPE(proto_task_stats_t, STATS_FIELDS, NULL)};

/* A bundle's fields have no rules of their own: bundle.c's cover them all (ck_bundle). */
#define BF(m) offsetof(proto_bundle_file_t, m)
static const field_t BUNDLE_FILE_FIELDS[] = {
    {F("path", FT_STR, BF(path))},
    {F("data", FT_BYTES, BF(data)), .aux = BF(size)},
};
static const shape_t BUNDLE_FILE = {SHAPE(proto_bundle_file_t, BUNDLE_FILE_FIELDS, NULL)};

#define BU(m) offsetof(proto_bundle_t, m)
static const field_t BUNDLE_FIELDS[] = {
    {F("main", FT_STR, BU(main))},
    {F("files", FT_LIST, BU(files)), .aux = BU(nfiles), .sub = &BUNDLE_FILE,
     .hi = CALLER_BUNDLE_FILES},
};
static const shape_t BUNDLE = {SHAPE(proto_bundle_t, BUNDLE_FIELDS, ck_bundle)};

/* A job's frame number belongs to a frame of a sequence only. */
static bool job_is_frame(const void *ji)
{
    return ((const proto_job_info_t *)ji)->parent != 0;
}

static bool job_has_photons(const void *ji)
{
    return ((const proto_job_info_t *)ji)->photons_total != 0;
}

#define FR(m) offsetof(proto_frame_t, m)
static const field_t FRAME_FIELDS[] = {
    {F("main", FT_STR, FR(main)), .check = ck_path},
    {F("n", FT_U32, FR(number))},
};
static const shape_t FRAME = {SHAPE(proto_frame_t, FRAME_FIELDS, NULL)};

/* Accuracy (spp, rmse, stop): absent is "0 spp", "no estimate", "not stopped early"; present is
 * never those (the encoder omits them), so an explicit one is refused. */
#define JI(m) offsetof(proto_job_info_t, m)
static const field_t JOB_FIELDS[] = {
    {F("id", FT_U64, JI(id))},
    {F("name", FT_STR, JI(name)), NAME(PROTO_MAX_STRING)},
    {F("state", FT_ENUM, JI(state)), ENUM(JOB_STATES)},
    {F("done", FT_U64, JI(samples_done))},
    {F("total", FT_U64, JI(samples_total))},
    {F("secs", FT_FLOAT, JI(elapsed)), .check = ck_seconds},
    {F("nonfinite", FT_U64, JI(nonfinite))},
    {F("err", FT_STR, JI(error)), .presence = UNLESS_ZERO, .check = ck_text},
    {F("spp", FT_U32, JI(spp)), .presence = UNLESS_ZERO, .absent = "none", RANGE(0, INT_MAX)},
    {F("rmse", FT_FLOAT, JI(rel_error)), .presence = IF_FLAG, .flag = JI(has_rel_error),
     .check = ck_rel_error},
    {F("stop", FT_ENUM, JI(stop)), .presence = UNLESS_ZERO, ENUM(STOPS)},
    {F("owner", FT_STR, JI(owner)), .presence = UNLESS_ZERO, NAME(PROTO_MAX_STRING)},
    {F("prio", FT_SINT, JI(priority)), .presence = UNLESS_ZERO, .absent = "priority 0",
     RANGE(-PROTO_MAX_PRIORITY, PROTO_MAX_PRIORITY)},
    {F("frames", FT_U32, JI(frames)), .presence = UNLESS_ZERO, .absent = "not a sequence",
     RANGE(0, PROTO_MAX_FRAMES)},
    {F("parent", FT_U64, JI(parent)), .presence = UNLESS_ZERO, .absent = "not a frame"},
    {F("frame", FT_U32, JI(frame)), .when = job_is_frame},
    {F("ptotal", FT_U64, JI(photons_total)), .presence = UNLESS_ZERO, .absent = "no photon pass"},
    {F("pdone", FT_U64, JI(photons_done)), .when = job_has_photons},
};
static const shape_t JOB_INFO = {SHAPE(proto_job_info_t, JOB_FIELDS, check_job_info)};

#define WI(m) offsetof(proto_worker_info_t, m)
static const field_t WORKER_FIELDS[] = {
    {F("name", FT_STR, WI(name)), NAME(PROTO_MAX_STRING)},
    {F("id", FT_U64, WI(id))},
    {F("threads", FT_INT, WI(threads)), RANGE(1, PROTO_MAX_THREADS)},
    {F("state", FT_ENUM, WI(state)), ENUM(WORKER_STATES)},
    {F("done", FT_U64, WI(tasks_done))},
    {F("seen", FT_FLOAT, WI(last_seen)), .check = ck_seconds},
    {F("failed", FT_U64, WI(tasks_failed)), .presence = UNLESS_ZERO, .absent = "none"},
    {F("streak", FT_U32, WI(fail_streak)), .presence = UNLESS_ZERO, .absent = "none"},
    {F("bjobs", FT_U32, WI(blocked_jobs)), .presence = UNLESS_ZERO, .absent = "none"},
    {F("sps", FT_FLOAT, WI(samples_per_s)), .presence = UNLESS_ZERO, .absent = "none",
     .check = ck_rate},
};
static const shape_t WORKER_INFO = {SHAPE(proto_worker_info_t, WORKER_FIELDS, NULL)};

/* Which fields a task and a result have: those of their kind. */
static bool task_is_tile(const void *m)
{
    return ((const proto_msg_t *)m)->task.kind == PROTO_KIND_CAMERA_TILE;
}
static bool task_is_batch(const void *m)
{
    return ((const proto_msg_t *)m)->task.kind == PROTO_KIND_PHOTON_BATCH;
}
static bool result_is_tile(const void *m)
{
    return ((const proto_msg_t *)m)->result.kind == PROTO_KIND_CAMERA_TILE;
}
static bool result_is_batch(const void *m)
{
    return ((const proto_msg_t *)m)->result.kind == PROTO_KIND_PHOTON_BATCH;
}
/* A STATUS's wait is for one job only (docs/protocol.md). */
static bool status_of_one_job(const void *m)
{
    return !((const proto_msg_t *)m)->status.all;
}

/* The bodies, in the order of their keys on the wire. */
#define M(m) offsetof(proto_msg_t, m)
static const field_t HELLO_FIELDS[] = {
    {F("name", FT_STR, M(hello.name)), NAME(PROTO_MAX_STRING)},
    {F("threads", FT_INT, M(hello.threads)), RANGE(1, PROTO_MAX_THREADS)},
    {F("sw", FT_STR, M(hello.software)), NAME(PROTO_MAX_STRING)},
};
static const field_t WELCOME_FIELDS[] = {
    {F("wid", FT_U64, M(welcome.worker_id))},
    {F("hb", FT_U32, M(welcome.heartbeat_ms)), RANGE(1, 3600000)},
};
static const field_t TASK_FIELDS[] = {
    {F("job", FT_U64, M(task.job))},
    {F("task", FT_U64, M(task.task))},
    {F("att", FT_U32, M(task.attempt))},
    {F("scene", FT_HASH, M(task.scene)), .check = ck_hash},
    {F("set", FT_MAP, M(task.settings)), .sub = &SETTINGS},
    {F("kind", FT_ENUM, M(task.kind)), .names = &KINDS, .check = ck_kind},
    {F("photons", FT_MAP, M(task.photons)), .when = task_is_batch, .sub = &PHOTON_RANGE},
    {F("store", FT_HASH, M(task.store)), .when = task_is_tile, .presence = UNLESS_ZERO,
     .check = ck_hash},
    {F("tile", FT_MAP, M(task.tile)), .when = task_is_tile, .sub = &TILE_RECT},
    {F("main", FT_STR, M(task.main)), .presence = UNLESS_ZERO, .absent = "the bundle's main",
     .check = ck_path},
};
static const field_t RESULT_FIELDS[] = {
    {F("job", FT_U64, M(result.job))},
    {F("task", FT_U64, M(result.task))},
    {F("att", FT_U32, M(result.attempt))},
    {F("kind", FT_ENUM, M(result.kind)), .names = &KINDS, .check = ck_kind},
    {F("tile", FT_MAP, M(result.tile)), .when = result_is_tile, .sub = &TILE_RESULT},
    {F("photons", FT_MAP, M(result.photons)), .when = result_is_batch, .sub = &PHOTON_RESULT},
    {F("stats", FT_MAP, M(result.stats)), .sub = &STATS},
};
static const field_t TASK_FAILED_FIELDS[] = {
    {F("job", FT_U64, M(task_failed.job))},
    {F("task", FT_U64, M(task_failed.task))},
    {F("att", FT_U32, M(task_failed.attempt))},
    {F("error", FT_STR, M(task_failed.error)), .check = ck_text},
};
static const field_t SCENE_REQUEST_FIELDS[] = {
    {F("scene", FT_HASH, M(scene_request.scene)), .check = ck_hash},
};
static const field_t SCENE_FIELDS[] = {
    {F("scene", FT_HASH, M(scene.scene)), .check = ck_hash},
    {F("bundle", FT_MAP, M(scene.bundle)), .sub = &BUNDLE},
};
static const field_t CANCEL_FIELDS[] = {
    {F("job", FT_U64, M(cancel.job))},
};
static const field_t REFUSE_FIELDS[] = {
    {F("reason", FT_STR, M(refuse.reason)), .check = ck_text},
};
static const field_t SUBMIT_FIELDS[] = {
    {F("name", FT_STR, M(submit.name)), NAME(PROTO_MAX_STRING)},
    {F("set", FT_MAP, M(submit.settings)), .sub = &SETTINGS},
    {F("bundle", FT_MAP, M(submit.bundle)), .sub = &BUNDLE},
    {F("prio", FT_SINT, M(submit.priority)), .presence = UNLESS_ZERO, .absent = "priority 0",
     RANGE(-PROTO_MAX_PRIORITY, PROTO_MAX_PRIORITY)},
    {F("frames", FT_LIST, M(submit.frames)), .aux = M(submit.nframes), .sub = &FRAME,
     .presence = UNLESS_ZERO, .absent = "a single scene", .check = ck_list, .hi = PROTO_MAX_FRAMES},
};
static const field_t STATUS_FIELDS[] = {
    {F("job", FT_U64, M(status.job)), .presence = UNLESS_FLAG, .flag = M(status.all)},
    {F("wait", FT_U32, M(status.wait_ms)), .when = status_of_one_job, .presence = UNLESS_ZERO,
     RANGE(0, PROTO_MAX_WAIT_MS)},
};
static const field_t FETCH_FIELDS[] = {
    {F("job", FT_U64, M(fetch.job))},
    {F("what", FT_ENUM, M(fetch.what)), ENUM(FETCH_WHATS)},
};
static const field_t SUBMITTED_FIELDS[] = {
    {F("job", FT_U64, M(submitted.job))},
};
/* status_reply and jobs_reply share one layout. */
static const field_t JOBS_REPLY_FIELDS[] = {
    {F("jobs", FT_LIST, M(jobs_reply.jobs)), .aux = M(jobs_reply.njobs), .sub = &JOB_INFO,
     .check = ck_list, .hi = PROTO_MAX_LIST},
};
static const field_t WORKERS_REPLY_FIELDS[] = {
    {F("workers", FT_LIST, M(workers_reply.workers)), .aux = M(workers_reply.nworkers),
     .sub = &WORKER_INFO, .check = ck_list, .hi = PROTO_MAX_LIST},
};
static const field_t FILE_FIELDS[] = {
    {F("name", FT_STR, M(file.name)), NAME(PROTO_MAX_STRING)},
    {F("data", FT_BYTES, M(file.data)), .aux = M(file.size), .check = ck_bytes},
};
static const field_t ERROR_FIELDS[] = {
    {F("msg", FT_STR, M(error.message)), .check = ck_text},
};
static const field_t STORE_REQUEST_FIELDS[] = {
    {F("store", FT_HASH, M(store_request.store)), .check = ck_hash},
};
static const field_t STORE_FIELDS[] = {
    {F("store", FT_HASH, M(store.store)), .check = ck_hash},
    {F("data", FT_BYTES, M(store.data)), .aux = M(store.size), .check = ck_bytes},
};
static const field_t REFINE_FIELDS[] = {
    {F("job", FT_U64, M(refine.job))},
    {F("photons", FT_U64, M(refine.photons)), .check = ck_photon_count},
};
static const field_t ACT_FIELDS[] = {
    {F("act", FT_ENUM, M(act.act)), ENUM(ACTS)},
    {F("job", FT_U64, M(act.job)), .presence = UNLESS_ZERO, .absent = "no job"},
    {F("task", FT_U32, M(act.task))},
    {F("prio", FT_SINT, M(act.priority)), RANGE(-PROTO_MAX_PRIORITY, PROTO_MAX_PRIORITY)},
    {F("worker", FT_STR, M(act.worker)), .presence = UNLESS_ZERO, NAME(PROTO_MAX_STRING)},
};
static const field_t LOGS_FIELDS[] = {
    {F("job", FT_U64, M(logs.job))},
    {F("task", FT_U32, M(logs.task)), .presence = IF_FLAG, .flag = M(logs.has_task)},
};

static const field_t PROGRESS_FIELDS[] = {
    {F("msg", FT_STR, M(progress.message)), .check = ck_text},
    {F("secs", FT_FLOAT, M(progress.elapsed)), .check = ck_seconds},
};

/* HEARTBEAT, JOBS, WORKERS and METRICS have no fields: their entries stay zero. */
#define BODY(fields, rule) SHAPE(proto_msg_t, fields, rule)
static const shape_t BODIES[PROTO_TYPE_COUNT] = {
    [PROTO_HELLO] = {BODY(HELLO_FIELDS, NULL)},
    [PROTO_RESULT] = {BODY(RESULT_FIELDS, NULL)},
    [PROTO_TASK_FAILED] = {BODY(TASK_FAILED_FIELDS, NULL)},
    [PROTO_SCENE_REQUEST] = {BODY(SCENE_REQUEST_FIELDS, NULL)},
    [PROTO_WELCOME] = {BODY(WELCOME_FIELDS, NULL)},
    [PROTO_TASK] = {BODY(TASK_FIELDS, NULL)},
    [PROTO_SCENE] = {BODY(SCENE_FIELDS, ck_scene_hash)},
    [PROTO_CANCEL] = {BODY(CANCEL_FIELDS, NULL)},
    [PROTO_REFUSE] = {BODY(REFUSE_FIELDS, NULL)},
    [PROTO_SUBMIT] = {BODY(SUBMIT_FIELDS, ck_submit_frames)},
    [PROTO_STATUS] = {BODY(STATUS_FIELDS, NULL)},
    [PROTO_FETCH] = {BODY(FETCH_FIELDS, NULL)},
    [PROTO_SUBMITTED] = {BODY(SUBMITTED_FIELDS, NULL)},
    [PROTO_STATUS_REPLY] = {BODY(JOBS_REPLY_FIELDS, NULL)},
    [PROTO_JOBS_REPLY] = {BODY(JOBS_REPLY_FIELDS, NULL)},
    [PROTO_WORKERS_REPLY] = {BODY(WORKERS_REPLY_FIELDS, NULL)},
    [PROTO_FILE] = {BODY(FILE_FIELDS, NULL)},
    [PROTO_ERROR] = {BODY(ERROR_FIELDS, NULL)},
    [PROTO_STORE_REQUEST] = {BODY(STORE_REQUEST_FIELDS, NULL)},
    [PROTO_STORE] = {BODY(STORE_FIELDS, ck_store_hash)},
    [PROTO_REFINE] = {BODY(REFINE_FIELDS, NULL)},
    [PROTO_PROGRESS] = {BODY(PROGRESS_FIELDS, NULL)},
    [PROTO_ACT] = {BODY(ACT_FIELDS, NULL)},
    [PROTO_LOGS] = {BODY(LOGS_FIELDS, NULL)},
};

/* The body of a message type, NULL for none (PROTO_NONE, out of range). */
static const shape_t *body_of(proto_type_t type)
{
    return type > PROTO_NONE && type < PROTO_TYPE_COUNT ? &BODIES[type] : NULL;
}

/* ---------------------------------------------------------------- checking */

static int check_fields(cx_t *cx, const shape_t *s, const void *obj);

/* One field's rule, and those of what it holds. */
static int check_field(cx_t *cx, const field_t *f, const void *obj)
{
    const char *p = (const char *)obj + f->at;
    switch (f->type) {
    case FT_FLAT:
        return check_fields(cx, f->sub, p);
    case FT_MAP: {
        size_t at = cx_enter(cx, f->key, -1);
        int rc = check_fields(cx, f->sub, p);
        cx_leave(cx, at);
        return rc;
    }
    case FT_LIST: {
        if (f->check && f->check(cx, f, obj))
            return PROTO_EMALFORMED;
        /* No table: nothing inside to check (the list's own rule or its map's says so). */
        const char *items = ptr_of(obj, f->at);
        for (size_t i = 0, n = CVALUE(size_t, obj, f->aux); items && i < n; i++) {
            size_t at = cx_enter(cx, f->key, (long long)i);
            if (check_fields(cx, f->sub, items + i * f->sub->size))
                return PROTO_EMALFORMED;
            cx_leave(cx, at);
        }
        return 0;
    }
    default:
        return f->check ? f->check(cx, f, obj) : 0;
    }
}

/* The values of obj as the protocol allows them, field by field in table order, then across
 * them. proto_encode runs this before writing a byte; the decoder runs the same rules as it
 * reads (read_fields), so that encode never produces what decode rejects. */
static int check_fields(cx_t *cx, const shape_t *s, const void *obj)
{
    for (size_t i = 0; i < s->nfields; i++)
        if (present(&s->fields[i], obj) && check_field(cx, &s->fields[i], obj))
            return PROTO_EMALFORMED;
    return s->check ? s->check(cx, obj) : 0;
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
    bool lend;      /* byte fields point into the input (proto_decode_lent) */
    size_t *lent;   /* counts the fields that do */
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

static int rd_enum(rd_t *rd, const char *field, const msgpack_object *o, const names_t *e, int *out)
{
    if (rd_expect(rd, field, o, MSGPACK_OBJECT_STR, "a string"))
        return PROTO_EMALFORMED;
    for (int i = e->first; i < e->count; i++)
        if (o->via.str.size == strlen(e->names[i]) &&
            memcmp(o->via.str.ptr, e->names[i], o->via.str.size) == 0) {
            *out = i;
            return 0;
        }
    char known[200] = "";
    for (int i = e->first; i < e->count; i++) {
        size_t used = strlen(known);
        snprintf(known + used, sizeof known - used, "%s%s", i > e->first ? ", " : "", e->names[i]);
    }
    return cx_fail(&rd->cx, field, "is '%.*s', expected one of: %s",
                   (int)(o->via.str.size < 40 ? o->via.str.size : 40), o->via.str.ptr, known);
}

/* A hash's bytes; its digits are the field's rule (ck_hash). */
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
    return 0;
}

/* A bin of exactly `expected` bytes (when expected != UINT64_MAX); returns its bytes in *raw. */
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
    if (rd->lend) {
        /* msgpack-c's msgpack_unpack_next leaves a bin's bytes in the input buffer. */
        *data = b->size > 0 ? (const uint8_t *)b->ptr : (const uint8_t *)"";
        *size = b->size;
        ++*rd->lent;
        return 0;
    }
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

/* ---------------------------------------------------------------- decoding by the tables */

/* The keys of s, its flat sub-tables' in their place: the order read_fields takes them in. */
static int shape_keys(rd_t *rd, const shape_t *s, const char **keys, size_t *n)
{
    for (size_t i = 0; i < s->nfields; i++) {
        const field_t *f = &s->fields[i];
        if (f->type == FT_FLAT) {
            if (shape_keys(rd, f->sub, keys, n))
                return PROTO_EMALFORMED;
        } else if (*n == MAX_KEYS) {
            return err_set(rd->cx.err, "%s: a map of more than %d keys (proto.c's MAX_KEYS)",
                           rd->cx.type, MAX_KEYS),
                   PROTO_EMALFORMED;
        } else {
            keys[(*n)++] = f->key;
        }
    }
    return 0;
}

/* The value of each of s's keys in the map o (named field in errors). */
static int map_values(rd_t *rd, const char *field, const msgpack_object *o, const shape_t *s,
                      const msgpack_object **vals)
{
    const char *keys[MAX_KEYS];
    size_t n = 0;
    if (shape_keys(rd, s, keys, &n))
        return PROTO_EMALFORMED;
    return rd_map(rd, field, o, keys, n, vals);
}

static int read_fields(rd_t *rd, const shape_t *s, const msgpack_object *const *vals, size_t *k,
                       void *obj);

/* A list of maps: its count and entries checked before anything is allocated for it (rd_list),
 * the entries zeroed so that absent optional fields read as zero. */
static int read_list(rd_t *rd, const field_t *f, const msgpack_object *o, void *obj)
{
    uint64_t max = f->hi == CALLER_BUNDLE_FILES ? rd->cx.lim->max_bundle_files : (uint64_t)f->hi;
    uint32_t n = 0;
    if (rd_list(rd, f->key, o, max, required_fields(f->sub), &n))
        return PROTO_EMALFORMED;
    size_t bytes = (size_t)n * f->sub->size;
    char *items = own_alloc(rd->m, bytes);
    if (!items)
        return rd_oom(rd, f->key, bytes);
    memset(items, 0, bytes);
    for (uint32_t i = 0; i < n; i++) {
        const msgpack_object *vals[MAX_KEYS];
        size_t k = 0, at = cx_enter(&rd->cx, f->key, i);
        if (map_values(rd, "", &o->via.array.ptr[i], f->sub, vals) ||
            read_fields(rd, f->sub, vals, &k, items + (size_t)i * f->sub->size))
            return PROTO_EMALFORMED;
        cx_leave(&rd->cx, at);
    }
    set_ptr(obj, f->at, items);
    VALUE(size_t, obj, f->aux) = n;
    return 0;
}

/* One value, present in the map, into obj. */
static int read_value(rd_t *rd, const field_t *f, const msgpack_object *v, void *obj)
{
    void *p = (char *)obj + f->at;
    const msgpack_object_bin *bin = NULL;
    uint64_t u = 0;
    switch (f->type) {
    case FT_U64:
        return rd_uint(rd, f->key, v, UINT64_MAX, p);
    case FT_U32:
        if (rd_uint(rd, f->key, v, UINT32_MAX, &u))
            return PROTO_EMALFORMED;
        *(uint32_t *)p = (uint32_t)u;
        return 0;
    case FT_INT:
        if (rd_uint(rd, f->key, v, INT_MAX, &u))
            return PROTO_EMALFORMED;
        *(int *)p = (int)u;
        return 0;
    case FT_SINT:
        return rd_sint(rd, f->key, v, p);
    case FT_FLOAT:
        return rd_float(rd, f->key, v, p);
    case FT_STR:
        return rd_str(rd, f->key, v, p);
    case FT_HASH:
        return rd_hash(rd, f->key, v, p);
    case FT_ENUM:
        return rd_enum(rd, f->key, v, f->names, p);
    case FT_BYTES:
        return rd_bytes(rd, f->key, v, p, &VALUE(size_t, obj, f->aux));
    case FT_WORDS: {
        /* The ranges of the fields before bound this below 2^37 bytes: no overflow. */
        if (rd_bin(rd, f->key, v, (uint64_t)f->count(obj) * 8, &bin))
            return PROTO_EMALFORMED;
        const void *words = rd_words(rd, f->key, bin);
        set_ptr(obj, f->at, words);
        return words ? 0 : PROTO_EMALFORMED;
    }
    case FT_SUMS_BITS:
        /* Refused at once, not by the rule after it: the sums' length depends on it. */
        if (rd_uint(rd, f->key, v, UINT64_MAX, &u))
            return PROTO_EMALFORMED;
        if (u != 32 && u != 64)
            return cx_fail(&rd->cx, f->key, "is %" PRIu64 ", expected 32 or 64", u);
        *(int *)p = (int)u;
        return 0;
    case FT_SUMS: {
        int bits = VALUE(int, obj, f->aux);
        if (rd_bin(rd, f->key, v, (uint64_t)f->count(obj) * (uint64_t)(bits / 8), &bin))
            return PROTO_EMALFORMED;
        const void *sums = bits == 32 ? rd_floats(rd, f->key, bin) : rd_words(rd, f->key, bin);
        set_ptr(obj, f->at, sums);
        return sums ? 0 : PROTO_EMALFORMED;
    }
    case FT_MAP: {
        const msgpack_object *vals[MAX_KEYS];
        size_t k = 0;
        if (map_values(rd, f->key, v, f->sub, vals))
            return PROTO_EMALFORMED;
        size_t at = cx_enter(&rd->cx, f->key, -1);
        if (read_fields(rd, f->sub, vals, &k, p))
            return PROTO_EMALFORMED;
        cx_leave(&rd->cx, at);
        return 0;
    }
    case FT_LIST:
        return read_list(rd, f, v, obj);
    case FT_FLAT:
        break; /* read by read_fields, from the same map */
    }
    return err_set(rd->cx.err, "%s: field '%s' has no reader", rd->cx.type, f->key),
           PROTO_EMALFORMED;
}

/* Reads s's fields from vals (the values of shape_keys(s), from *k on) into obj, each checked as
 * soon as it is read, as check_fields would, so that what a later field's length depends on is
 * known to be in range; then the rule across them. */
static int read_fields(rd_t *rd, const shape_t *s, const msgpack_object *const *vals, size_t *k,
                       void *obj)
{
    for (size_t i = 0; i < s->nfields; i++) {
        const field_t *f = &s->fields[i];
        if (f->type == FT_FLAT) {
            if (read_fields(rd, f->sub, vals, k, (char *)obj + f->at))
                return PROTO_EMALFORMED;
            continue;
        }
        const msgpack_object *v = vals[(*k)++];
        if (f->when && !f->when(obj))
            continue; /* another kind's field: ignored */
        switch (f->presence) {
        case ALWAYS: /* absent: rd_* say "is missing" */
        case UNLESS_ZERO:
            break;
        case IF_FLAG:
            VALUE(bool, obj, f->flag) = v != NULL;
            break;
        case UNLESS_FLAG:
            VALUE(bool, obj, f->flag) = v == NULL;
            break;
        }
        if (!v && f->presence != ALWAYS)
            continue;
        if (read_value(rd, f, v, obj))
            return PROTO_EMALFORMED;
        if (f->absent && is_zero(f, obj))
            return cx_fail(&rd->cx, f->key, "is 0: absent means %s", f->absent);
        if (f->check && f->check(&rd->cx, f, obj))
            return PROTO_EMALFORMED;
    }
    return s->check ? s->check(&rd->cx, obj) : 0;
}

/* A key that any message body uses may appear once in every message, of a type that uses it
 * or not; other keys are ignored, so that a newer peer can add optional fields. */
static bool is_body_key(const msgpack_object_str *key)
{
    for (int t = PROTO_NONE + 1; t < PROTO_TYPE_COUNT; t++)
        for (size_t i = 0; i < BODIES[t].nfields; i++) {
            const char *k = BODIES[t].fields[i].key;
            if (key->size == strlen(k) && memcmp(key->ptr, k, key->size) == 0)
                return true;
        }
    return false;
}

static int rd_body_keys(rd_t *rd, const msgpack_object *root)
{
    const msgpack_object_kv *kv = root->via.map.ptr;
    for (uint32_t i = 0; i < root->via.map.size; i++) {
        const msgpack_object_str *key = &kv[i].key.via.str; /* a string: decode_root checked */
        if (!is_body_key(key))
            continue;
        for (uint32_t j = 0; j < i; j++)
            if (kv[j].key.via.str.size == key->size &&
                memcmp(kv[j].key.via.str.ptr, key->ptr, key->size) == 0)
                return cx_fail(&rd->cx, "(message)", "has the key '%.*s' twice", (int)key->size,
                               key->ptr);
    }
    return 0;
}

enum { E_V, E_T, E_N };
static const char *const ENVELOPE_KEYS[E_N] = {"v", "t"};

static int decode_root(const msgpack_object *root, const proto_limits_t *lim, size_t *lent,
                       proto_msg_t *m, err_t *err)
{
    rd_t rd = {.cx = {.type = "message", .lim = lim, .err = err},
               .m = m,
               .lend = lent != NULL,
               .lent = lent};
    const msgpack_object *v[E_N];
    if (root->type != MSGPACK_OBJECT_MAP)
        return err_set(err, "message is %s, expected a map", obj_kind(root)), PROTO_EMALFORMED;
    uint64_t version = 0;
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
    const msgpack_object *vals[MAX_KEYS];
    size_t k = 0;
    if (rd_body_keys(&rd, root) || map_values(&rd, "(message)", root, body_of(type), vals))
        return PROTO_EMALFORMED;
    return read_fields(&rd, body_of(type), vals, &k, m);
}

static int decode(const void *data, size_t len, const proto_limits_t *limits, size_t *lent,
                  proto_msg_t *out, err_t *err)
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
        rc = decode_root(&u.data, &lim, lent, out, err);
    msgpack_unpacked_destroy(&u);
    if (rc < 0) {
        int version = out->version;
        proto_msg_free(out);
        if (rc == PROTO_EVERSION)
            out->version = version;
    }
    return rc;
}

int proto_decode(const void *data, size_t len, const proto_limits_t *limits, proto_msg_t *out,
                 err_t *err)
{
    return decode(data, len, limits, NULL, out, err);
}

int proto_decode_lent(const void *data, size_t len, const proto_limits_t *limits, proto_msg_t *out,
                      void (*release)(void *arg), void *release_arg, err_t *err)
{
    size_t lent = 0;
    int rc = decode(data, len, limits, &lent, out, err);
    if (rc == 0 && lent == 0 && out->type != PROTO_RESULT && release)
        release(release_arg); /* nothing points into data: a HEARTBEAT needs no freeing */
    else if (rc == 0) {
        out->wire = data;
        out->wire_size = len;
        out->release = release;
        out->release_arg = release_arg;
    }
    return rc;
}

/* ---------------------------------------------------------------- encoding by the tables */

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

static void e_str(enc_t *e, const char *s)
{
    if (!e->failed)
        e_check(e, msgpack_pack_str_with_body(&e->pk, s, strlen(s)));
}

static void e_uint(enc_t *e, uint64_t v)
{
    if (!e->failed)
        e_check(e, msgpack_pack_uint64(&e->pk, v));
}

static void e_sint(enc_t *e, long long v)
{
    if (!e->failed)
        e_check(e, msgpack_pack_int64(&e->pk, v));
}

static void e_float(enc_t *e, double v)
{
    if (!e->failed)
        e_check(e, msgpack_pack_double(&e->pk, v));
}

static void e_map(enc_t *e, size_t n)
{
    if (!e->failed)
        e_check(e, msgpack_pack_map(&e->pk, n));
}

static void e_array(enc_t *e, size_t n)
{
    if (!e->failed)
        e_check(e, msgpack_pack_array(&e->pk, n));
}

static void e_bin(enc_t *e, const void *data, size_t n)
{
    if (n > UINT32_MAX)
        e->failed = 1;
    if (!e->failed)
        e_check(e, msgpack_pack_bin_with_body(&e->pk, n ? data : "", n));
}

/* 8-byte words (doubles or uint64) as a bin of little-endian words. */
static void e_words(enc_t *e, const void *words, size_t n)
{
    if (n > UINT32_MAX / 8) {
        e->failed = 1;
        return;
    }
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
    e_bin(e, words, n * 8);
#else
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
static void e_floats(enc_t *e, const double *v, size_t n)
{
    if (n > UINT32_MAX / 4) {
        e->failed = 1;
        return;
    }
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

static void write_fields(enc_t *e, const shape_t *s, const void *obj);

static void write_value(enc_t *e, const field_t *f, const void *obj)
{
    const char *p = (const char *)obj + f->at;
    switch (f->type) {
    case FT_U64:
        e_uint(e, CVALUE(uint64_t, obj, f->at));
        break;
    case FT_U32:
    case FT_INT: /* >= 0: its rule said so */
        e_uint(e, (uint64_t)int_of(f, obj));
        break;
    case FT_SINT:
        e_sint(e, CVALUE(long long, obj, f->at));
        break;
    case FT_FLOAT:
        e_float(e, CVALUE(double, obj, f->at));
        break;
    case FT_STR:
        e_str(e, ptr_of(obj, f->at));
        break;
    case FT_HASH:
        e_str(e, p);
        break;
    case FT_ENUM:
        e_str(e, f->names->names[int_of(f, obj)]);
        break;
    case FT_BYTES:
        e_bin(e, ptr_of(obj, f->at), CVALUE(size_t, obj, f->aux));
        break;
    case FT_WORDS:
        e_words(e, ptr_of(obj, f->at), f->count(obj));
        break;
    case FT_SUMS_BITS:
        e_uint(e, (uint64_t)f->width(obj));
        break;
    case FT_SUMS: {
        const double *sums = ptr_of(obj, f->at);
        size_t n = f->count(obj);
        if (f->width(obj) == 32)
            e_floats(e, sums, n);
        else
            e_words(e, sums, n);
        break;
    }
    case FT_MAP:
        e_map(e, count_fields(f->sub, p));
        write_fields(e, f->sub, p);
        break;
    case FT_LIST: {
        const char *items = ptr_of(obj, f->at);
        size_t n = CVALUE(size_t, obj, f->aux);
        e_array(e, n);
        for (size_t i = 0; i < n; i++) {
            const char *item = items + i * f->sub->size;
            e_map(e, count_fields(f->sub, item));
            write_fields(e, f->sub, item);
        }
        break;
    }
    case FT_FLAT:
        write_fields(e, f->sub, p);
        break;
    }
}

/* The entries of obj's map, in table order (so equal messages give equal bytes). */
static void write_fields(enc_t *e, const shape_t *s, const void *obj)
{
    for (size_t i = 0; i < s->nfields; i++) {
        const field_t *f = &s->fields[i];
        if (!present(f, obj))
            continue;
        if (f->type != FT_FLAT)
            e_str(e, f->key);
        write_value(e, f, obj);
    }
}

int proto_encode(const proto_msg_t *msg, const proto_limits_t *limits, msgpack_sbuffer *out,
                 err_t *err)
{
    proto_limits_t lim = limits ? *limits : proto_limits_default();
    cx_t cx = {.type = proto_type_name(msg->type), .lim = &lim, .err = err};
    const shape_t *body = body_of(msg->type);
    if (msg->version < 0)
        return err_set(err, "%s: version %d is negative", cx.type, msg->version);
    if (!body)
        return err_set(err, "message type %d is not a protocol message", (int)msg->type);
    if (check_fields(&cx, body, msg) < 0)
        return -1;
    size_t start = out->size;
    enc_t e = {.failed = 0};
    msgpack_packer_init(&e.pk, out, msgpack_sbuffer_write);
    e_map(&e, 2 + count_fields(body, msg));
    e_str(&e, "v");
    e_uint(&e, (uint64_t)(msg->version ? msg->version : PROTO_VERSION));
    e_str(&e, "t");
    e_str(&e, proto_type_name(msg->type));
    write_fields(&e, body, msg);
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

const char *proto_task_label(uint32_t task, char buf[PROTO_TASK_LABEL_MAX])
{
    if (task & PROTO_PHOTON_TASK)
        snprintf(buf, PROTO_TASK_LABEL_MAX, "p%" PRIu32, task & ~PROTO_PHOTON_TASK);
    else
        snprintf(buf, PROTO_TASK_LABEL_MAX, "%" PRIu32, task);
    return buf;
}

int proto_task_parse(const char *s, uint32_t *task)
{
    if (!s)
        return -1;
    const int photon = s[0] == 'p';
    const char *digits = photon ? s + 1 : s;
    if (!*digits)
        return -1;
    uint64_t v = 0;
    for (const char *c = digits; *c; c++) {
        if (*c < '0' || *c > '9')
            return -1;
        v = v * 10 + (uint64_t)(*c - '0');
        if (v >= PROTO_PHOTON_TASK)
            return -1;
    }
    *task = photon ? (uint32_t)v | PROTO_PHOTON_TASK : (uint32_t)v;
    return 0;
}

void proto_settings_copy(proto_settings_t *dst, const proto_settings_t *src,
                         proto_setting_names_t *names)
{
    *dst = *src;
#define COPY_INT(field)
#define COPY_LLONG(field)
#define COPY_DOUBLE(field)
#define COPY_NAME(field)                                                                           \
    if (src->field) {                                                                              \
        snprintf(names->field, sizeof names->field, "%s", src->field);                             \
        dst->field = names->field;                                                                 \
    }
#define COPY(field, kind, ...) COPY_##kind(field)
    JOB_SETTINGS(COPY)
#undef COPY
}
