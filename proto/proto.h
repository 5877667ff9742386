/* proto: every message that master, workers and clients exchange, defined once, with its
 * msgpack encoding and a strict decoder for untrusted bytes. The decoder never crashes, never
 * allocates more than a small multiple of its input, and accepts only messages that proto_encode
 * could have produced (same ranges, finite numbers, safe bundle paths). Wire format and field
 * meanings: docs/protocol.md. */
#ifndef PRISMFARM_PROTO_H
#define PRISMFARM_PROTO_H

#include "bundle.h"
#include "err.h"
#include "job_settings.h"
#include "proto_limits.h"

#include <msgpack.h>

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* The version carried by every message ("v"). A peer speaking another version is refused.
 * 2: camera_tile results carry sums_bits and float32 sums.
 * 3: camera_tile results carry the pixels' XYZ sums ("xyz") beside the bucket sums. */
#define PROTO_VERSION 3

/* Return codes of proto_decode (and of net.h's functions, which add their own). */
#define PROTO_EMALFORMED (-1) /* the bytes are not a valid message; err says which field */
#define PROTO_EVERSION (-2)   /* a well-formed envelope with another "v": refuse the peer */

typedef enum proto_type {
    PROTO_NONE = 0,
    /* worker -> master */
    PROTO_HELLO,
    PROTO_HEARTBEAT, /* also master -> worker */
    PROTO_RESULT,
    PROTO_TASK_FAILED,
    PROTO_SCENE_REQUEST,
    /* master -> worker */
    PROTO_WELCOME,
    PROTO_TASK,
    PROTO_SCENE,
    PROTO_CANCEL, /* also client -> master */
    PROTO_REFUSE, /* to any peer; its layout never changes between versions */
    /* client -> master */
    PROTO_SUBMIT,
    PROTO_STATUS,
    PROTO_JOBS,
    PROTO_WORKERS,
    PROTO_FETCH,
    /* master -> client */
    PROTO_SUBMITTED,
    PROTO_STATUS_REPLY,
    PROTO_JOBS_REPLY,
    PROTO_WORKERS_REPLY,
    PROTO_FILE,
    PROTO_ERROR, /* its layout never changes between versions */
    /* the photon pass's store (after the other types so that their numbers stay) */
    PROTO_STORE_REQUEST, /* worker -> master: send me this photon store */
    PROTO_STORE,         /* master -> worker: a job's merged photon store */
    PROTO_REFINE,        /* client -> master: more photons for a job; answered by SUBMITTED */
    PROTO_PROGRESS,      /* master -> client: still working on the request (a scene loading);
                          * its answer follows */
    /* operating a farm (docs/farm.md, "Operating a farm") */
    PROTO_ACT,     /* client -> master: priority, pause, resume, requeue, unblock */
    PROTO_LOGS,    /* client -> master: a job's task log; answered by FILE */
    PROTO_METRICS, /* client -> master: the Prometheus text; answered by FILE */
    PROTO_TYPE_COUNT
} proto_type_t;

/* What a task asks for and what its result carries. A job runs in phases of tasks of one kind:
 * a photon job's photon batches, then its camera tiles. */
typedef enum proto_kind {
    PROTO_KIND_NONE = 0,
    PROTO_KIND_CAMERA_TILE,  /* "camera_tile": a pixel rectangle times a range of sample indices */
    PROTO_KIND_PHOTON_BATCH, /* "photon_batch": a range of the job's photon indices */
    PROTO_KIND_COUNT
} proto_kind_t;

/* A job's state: the one enum of the scheduler, the master's job record, the journal (its
 * integer), the wire and the dashboard (its name, proto_job_state_name). */
typedef enum job_state {
    JOB_QUEUED,
    JOB_RUNNING,
    JOB_DONE,
    JOB_FAILED,
    JOB_CANCELLED,
    JOB_PAUSED, /* queued or running, paused: no new task is handed out */
    JOB_STATE_COUNT
} job_state_t;

typedef enum proto_worker_state {
    PROTO_WORKER_IDLE,
    PROTO_WORKER_BUSY,
    PROTO_WORKER_LOST, /* stopped heartbeating; its tasks went back to the queue */
    PROTO_WORKER_BLOCKED, /* connected, but given no task (failures in a row; `unblock`) */
    PROTO_WORKER_STATE_COUNT
} proto_worker_state_t;

/* Why a job that is done ended before its last pass (docs/farm.md, "Accuracy"). */
typedef enum proto_stop {
    PROTO_STOP_NONE,   /* every pass ran (absent on the wire) */
    PROTO_STOP_TARGET, /* "target": the error estimate reached the settings' target_error */
    PROTO_STOP_TIME,   /* "time": the settings' time_limit passed */
    PROTO_STOP_COUNT
} proto_stop_t;

/* What an ACT asks of the master; answered by STATUS_REPLY with the job (priority, pause,
 * resume, requeue) or WORKERS_REPLY (unblock), or ERROR. */
typedef enum proto_act {
    PROTO_ACT_NONE,
    PROTO_ACT_PRIORITY, /* "priority": the job's priority becomes .priority */
    PROTO_ACT_PAUSE,    /* "pause" */
    PROTO_ACT_RESUME,   /* "resume" */
    PROTO_ACT_REQUEUE,  /* "requeue": the job's running task .task back to the queue */
    PROTO_ACT_UNBLOCK,  /* "unblock": the worker named .worker (its name or id) */
    PROTO_ACT_COUNT
} proto_act_t;

#define PROTO_MAX_PRIORITY 1000 /* priorities are -1000..1000 */

typedef enum proto_fetch_what {
    PROTO_FETCH_EXR,
    PROTO_FETCH_PNG,
    PROTO_FETCH_COUNT
} proto_fetch_what_t;

/* Job settings, declared once in job_settings.h (name, type, default, wire key and checks,
 * flag and help, journal column): the fields mirror scene_overrides_t (scene/overrides.h;
 * settings/settings.h converts: 0 / NULL / -1 keep the scene file's value), then the stopping
 * rules of a progressive job (0: none), which only the master reads. */
typedef struct proto_settings {
#define PROTO_SETTING_FIELD(field, kind, ...) JOB_SETTING_CTYPE_##kind field;
    JOB_SETTINGS(PROTO_SETTING_FIELD)
#undef PROTO_SETTING_FIELD
} proto_settings_t;

/* A job's settings before any is given: each the scene file's, no stopping rule (each
 * setting's KEEP). */
#define PROTO_SETTING_KEEP(field, kind, keep, ...) .field = (keep),
#define PROTO_SETTINGS_FILE ((proto_settings_t){JOB_SETTINGS(PROTO_SETTING_KEEP)})

/* The longest name (a NAME setting: integrator, dispersion) a SETTINGS map may carry (the
 * decoder refuses longer). */
#define PROTO_SETTING_NAME_MAX 64

/* Room for a copy of each NAME setting (proto_settings_copy). */
typedef struct proto_setting_names {
#define PROTO_SETTING_NAMEBUF_INT(field)
#define PROTO_SETTING_NAMEBUF_LLONG(field)
#define PROTO_SETTING_NAMEBUF_DOUBLE(field)
#define PROTO_SETTING_NAMEBUF_NAME(field) char field[PROTO_SETTING_NAME_MAX + 1];
#define PROTO_SETTING_NAMEBUF(field, kind, ...) PROTO_SETTING_NAMEBUF_##kind(field)
    JOB_SETTINGS(PROTO_SETTING_NAMEBUF)
#undef PROTO_SETTING_NAMEBUF
} proto_setting_names_t;

/* Copies src into *dst with its names copied into *names (cut at PROTO_SETTING_NAME_MAX bytes),
 * so that *dst outlives what src points into (a message, a journal row): the one deep copy of a
 * job's settings. */
void proto_settings_copy(proto_settings_t *dst, const proto_settings_t *src,
                         proto_setting_names_t *names);

/* A camera tile: pixels [x0, x0+w) x [y0, y0+h), sample indices [sample_begin, sample_end). */
typedef struct proto_tile {
    int x0, y0, w, h;
    uint32_t sample_begin, sample_end;
} proto_tile_t;

/* Colour sums per pixel of a tile result: X, Y, Z (film/tilebuf.h's TILEBUF_XYZ). */
#define PROTO_TILE_XYZ 3

/* A camera tile's result: a tilebuf's contents (film/tilebuf.h), in its layout. The bucket and
 * XYZ sums travel as float32 when every one of them is a float32 value (zero or a normal float:
 * what tilebuf_round_sums leaves in the common case), else both as float64; lum and lum_sq
 * always as float64. */
typedef struct proto_tile_result {
    proto_tile_t rect;
    int nbuckets;
    const double *sums;     /* [h][w][nbuckets], all finite */
    const double *xyz;      /* [h][w][3] sums of per-sample CIE XYZ, finite; same width as sums */
    const uint64_t *counts; /* [h][w] samples taken */
    const double *lum;      /* [h][w] sum of per-sample luminance, finite */
    const double *lum_sq;   /* [h][w] sum of squared per-sample luminance, finite */
    uint64_t nonfinite;     /* samples dropped for a NaN or Inf contribution */
    /* Width of sums on the wire. Encode: 0 picks 32 when every sum is a float32 value, else 64;
     * 32 (refused unless every sum is a float32 value) or 64 forces it. Decode: what came, 32 or
     * 64 (the sums are handed out as doubles either way, equal to the values sent). */
    int sums_bits;
} proto_tile_result_t;

/* A photon batch: photon indices [first, end) of the job's photon pass (render/photon.h). */
typedef struct proto_photon_batch {
    uint64_t first, end;
} proto_photon_batch_t;

/* A photon batch's result: the partial store in its wire form (worker/photon_store.h: raw
 * power, nothing normalised), which the master decodes and checks against the job's scene. */
typedef struct proto_photon_result {
    proto_photon_batch_t range;
    uint64_t emitted;    /* monochrome photons emitted: (end - first) x the job's lanes */
    const uint8_t *data; /* the store's wire form */
    size_t size;
    uint64_t nonfinite;  /* photons dropped for a NaN or Inf power */
} proto_photon_result_t;

typedef struct proto_task_stats {
    uint64_t samples, rays, dispersive;
    double elapsed; /* seconds of wall-clock time, finite, >= 0 */
} proto_task_stats_t;

/* A frame of a sequence job (SUBMIT's frames): its scene file, one of the bundle's files, and
 * its number (what an output pattern such as f%04d.exr is given). */
typedef struct proto_frame {
    const char *main;
    uint32_t number;
} proto_frame_t;

typedef struct proto_job_info {
    uint64_t id;
    const char *name;
    job_state_t state;
    uint64_t samples_done, samples_total; /* progress, in pixel samples */
    double elapsed;                       /* seconds since the job started, finite, >= 0 */
    const char *error;                    /* NULL unless failed */
    uint64_t nonfinite;
    /* Accuracy (optional on the wire): samples per pixel of the whole passes merged so far, the
     * relative RMSE estimate after the last one (film/error_estimate.h; only when
     * has_rel_error: a zeroed struct means "no estimate yet"), and why a done job stopped
     * before its last pass. */
    uint32_t spp;
    bool has_rel_error;
    double rel_error; /* finite, >= 0 */
    proto_stop_t stop;
    const char *owner; /* the submitting key's name; NULL or "" (omitted): submitted without keys */
    long long priority; /* -PROTO_MAX_PRIORITY..PROTO_MAX_PRIORITY; absent on the wire: 0 */
    /* Frame sequences (optional on the wire; docs/farm.md, "Frame sequences"): a sequence job
     * has frames > 0 frames, each a job of its own whose info has parent (the sequence's id,
     * absent: 0) and frame (its number, only with a parent). */
    uint32_t frames;
    uint64_t parent;
    uint32_t frame;
    /* A job with a photon pass (optional on the wire; absent: none): the photons of its batches
     * merged so far and of every batch (a refinement adds to both), photons_done <=
     * photons_total. The client's photon progress line (docs/farm.md, "Photon jobs"). */
    uint64_t photons_done, photons_total;
} proto_job_info_t;

typedef struct proto_worker_info {
    const char *name;
    uint64_t id;
    int threads;
    proto_worker_state_t state;
    uint64_t tasks_done;
    double last_seen; /* seconds since its last message, finite, >= 0 */
    /* Optional on the wire (absent: 0): tasks it failed, its failures since it last returned a
     * task, the unfinished jobs it is blocked from, and its samples per second lately. */
    uint64_t tasks_failed;
    uint32_t fail_streak, blocked_jobs;
    double samples_per_s; /* finite, >= 0 */
} proto_worker_info_t;

/* One message. To send, fill the member named after the type and call proto_encode; pointers are
 * only read. proto_decode fills it with copies it owns (nothing points into the input buffer, and
 * arrays are aligned, host-endian); proto_msg_free releases them. proto_msg_free is harmless on a
 * message the caller built, so every message can be freed the same way. */
typedef struct proto_msg {
    proto_type_t type;
    int version; /* decode: the sender's; encode: 0 means PROTO_VERSION (others only for tests) */
    /* HEARTBEAT (both ways), JOBS, WORKERS and METRICS (client -> master) have no fields. */
    union {
        struct {
            const char *name;
            int threads;
            const char *software;
        } hello; /* worker -> master, first message of a connection */
        struct {
            uint64_t worker_id;
            uint32_t heartbeat_ms; /* how often each side sends HEARTBEAT */
        } welcome;                 /* master -> worker, answers HELLO */
        struct {
            uint64_t job, task;
            uint32_t attempt;
            char scene[PROTO_HASH_HEX + 1]; /* the bundle's proto_bundle_hash */
            proto_settings_t settings;
            proto_kind_t kind;
            proto_tile_t tile; /* kind CAMERA_TILE */
            /* kind CAMERA_TILE of a job with a photon pass: the hash of the merged store the
             * tile must gather from (STORE_REQUEST fetches it); "" for other jobs */
            char store[PROTO_HASH_HEX + 1];
            proto_photon_batch_t photons; /* kind PHOTON_BATCH */
            /* The scene file to load, one of the bundle's files (a frame of a sequence);
             * NULL (absent): the bundle's main */
            const char *main;
        } task; /* master -> worker */
        struct {
            uint64_t job, task;
            uint32_t attempt;
            proto_kind_t kind;
            proto_tile_result_t tile;      /* kind CAMERA_TILE */
            proto_photon_result_t photons; /* kind PHOTON_BATCH */
            proto_task_stats_t stats;      /* PHOTON_BATCH: samples are photons traced */
        } result; /* worker -> master */
        struct {
            uint64_t job, task;
            uint32_t attempt;
            const char *error;
        } task_failed; /* worker -> master */
        struct {
            char scene[PROTO_HASH_HEX + 1];
        } scene_request; /* worker -> master: send me this bundle */
        struct {
            char scene[PROTO_HASH_HEX + 1];
            proto_bundle_t bundle;
        } scene; /* master -> worker: scene must be the bundle's hash */
        struct {
            uint64_t job;
        } cancel; /* client -> master, master -> worker */
        struct {
            const char *reason;
        } refuse; /* master -> any peer; the peer should stop */
        struct {
            const char *name;
            proto_settings_t settings;
            proto_bundle_t bundle;
            long long priority; /* -PROTO_MAX_PRIORITY..PROTO_MAX_PRIORITY; absent: 0 */
            /* A frame sequence: nframes (1..PROTO_MAX_FRAMES; 0, absent: a single scene, the
             * bundle's main) frames, each main one of the bundle's files and used once */
            const proto_frame_t *frames;
            size_t nframes;
        } submit; /* client -> master */
        struct {
            bool all;
            uint64_t job;     /* when !all */
            uint32_t wait_ms; /* when !all: answer once the job is over or after this long,
                               * at most PROTO_MAX_WAIT_MS; 0 answers at once */
        } status;             /* client -> master; answered by STATUS_REPLY */
        struct {
            uint64_t job;
            proto_fetch_what_t what;
        } fetch; /* client -> master; answered by FILE */
        struct {
            uint64_t job;
        } submitted; /* master -> client, answers SUBMIT */
        struct {
            const proto_job_info_t *jobs;
            size_t njobs;
        } status_reply, jobs_reply; /* master -> client, answer STATUS and JOBS */
        struct {
            const proto_worker_info_t *workers;
            size_t nworkers;
        } workers_reply; /* master -> client, answers WORKERS */
        struct {
            const char *name;
            const uint8_t *data;
            size_t size;
        } file; /* master -> client */
        struct {
            const char *message;
        } error; /* master -> client: a request failed */
        struct {
            char store[PROTO_HASH_HEX + 1];
        } store_request; /* worker -> master */
        struct {
            char store[PROTO_HASH_HEX + 1]; /* SHA-256 of data */
            const uint8_t *data;           /* the store's wire form */
            size_t size;
        } store; /* master -> worker */
        struct {
            uint64_t job;
            uint64_t photons; /* photons to add to the job's photon pass, > 0 */
        } refine;             /* client -> master */
        struct {
            const char *message; /* what the master is doing, for the user */
            double elapsed;      /* seconds since it began, finite, >= 0 */
        } progress;              /* master -> client, before the answer to a request */
        struct {
            proto_act_t act;
            uint64_t job;       /* every act but unblock */
            uint32_t task;      /* requeue */
            long long priority; /* priority */
            const char *worker; /* unblock: a worker's name or id */
        } act;                  /* client -> master */
        struct {
            uint64_t job;
            bool has_task;
            uint32_t task; /* when has_task: that task's lines only */
        } logs;            /* client -> master; answered by FILE */
    };
    /* The bytes proto_decode_lent decoded the message from, while it holds them (a RESULT, or
     * a message with a lent field), until proto_msg_free: the master journals a result as
     * received rather than encoding it again. NULL otherwise. */
    const void *wire;
    size_t wire_size;
    struct proto_owned *owned; /* private: what proto_decode allocated */
    void (*release)(void *arg); /* private: proto_decode_lent's input, released with the message */
    void *release_arg;
} proto_msg_t;

/* Appends the encoding of msg to out (initialised by the caller with msgpack_sbuffer_init).
 * Checks msg as the decoder would (ranges, finite values, bundle paths and limits) so that a
 * peer never receives what it must reject; on failure out is left as it was. limits may be NULL
 * (defaults). */
int proto_encode(const proto_msg_t *msg, const proto_limits_t *limits, msgpack_sbuffer *out,
                 err_t *err);

/* Decodes one message from untrusted bytes. Returns 0; PROTO_EMALFORMED with err naming the
 * message type and field ("RESULT: field 'sums' has 1000 bytes, expected 2048"); or
 * PROTO_EVERSION when the envelope is well formed but "v" is not PROTO_VERSION: out->version is
 * then the peer's, out->type PROTO_NONE, and proto_refuse_version builds the answer. REFUSE and
 * ERROR decode whatever their version, so a refused peer can read why. On failure out holds
 * nothing to free (proto_msg_free is still harmless). limits may be NULL (defaults). */
int proto_decode(const void *data, size_t len, const proto_limits_t *limits, proto_msg_t *out,
                 err_t *err);

/* As proto_decode, but byte fields (a bundle's file data, a stored file's bytes) point into data
 * instead of being copied, so that a large bundle is not held twice: data must stay unchanged
 * until proto_msg_free(out). On success the message owns data: proto_msg_free calls
 * release(release_arg) once, after which nothing may read the fields or out->wire -- or, when
 * no field of the message points into data and it is not a RESULT (whose bytes out->wire
 * keeps), release is called before this returns, so that a message proto_decode would have
 * left owning nothing still needs no freeing. release may be NULL when
 * the caller frees data itself, after the message. On failure release is not called and data
 * stays the caller's. Strings and arrays of numbers are still copied (they are small, or must
 * be aligned and host-endian). */
int proto_decode_lent(const void *data, size_t len, const proto_limits_t *limits,
                      proto_msg_t *out, void (*release)(void *arg), void *release_arg,
                      err_t *err);

/* Releases what proto_decode allocated (and proto_decode_lent's input) and zeroes the message. */
void proto_msg_free(proto_msg_t *msg);

/* "HELLO", "RESULT", ...: the type's name on the wire and in error messages ("?" if invalid). */
const char *proto_type_name(proto_type_t type);
const char *proto_kind_name(proto_kind_t kind);              /* "camera_tile" */
const char *proto_job_state_name(job_state_t state);   /* "queued", "running", ... */
const char *proto_worker_state_name(proto_worker_state_t s); /* "idle", "busy", "lost" */
const char *proto_fetch_what_name(proto_fetch_what_t what);  /* "exr", "png" */
const char *proto_stop_name(proto_stop_t stop);              /* "none", "target", "time" */
const char *proto_act_name(proto_act_t act);                 /* "priority", "pause", ... */

/* Task numbers, as the wire carries them: a camera task is pass * ntiles + tile, from 0; photon
 * batch b of a job is PROTO_PHOTON_TASK | b. People read and type them as "12" and "p3" (the
 * logs, `requeue`, `logs JOB TASK`): proto_task_label writes that form into buf and returns it,
 * proto_task_parse reads either form (a plain number of the photon range is refused, so there
 * is one spelling) and returns 0, or -1 for anything else. */
#define PROTO_PHOTON_TASK 0x80000000u
#define PROTO_TASK_LABEL_MAX 16
const char *proto_task_label(uint32_t task, char buf[PROTO_TASK_LABEL_MAX]);
int proto_task_parse(const char *s, uint32_t *task);

/* A REFUSE for a peer that speaks peer_version, its reason written into *text:
 * "protocol version 2 not supported by this master (speaks 1)". role names the refuser. */
proto_msg_t proto_refuse_version(int peer_version, const char *role, err_t *text);

#endif
