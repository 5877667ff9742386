/* dash_provider: what the dashboard asks of the daemon it shows (docs/dashboard.md). The master
 * implements these callbacks (master/dash_view.c) over the state its loop owns; the dashboard
 * calls them from that same thread, between two turns of the loop, so a callback reads the
 * state directly and never races it. What a callback fills in (strings included) need only stay
 * valid until it returns to the dashboard's next call: the dashboard copies it into the answer
 * at once. A callback left NULL is an operation the daemon does not have: its page field is
 * absent and its action is answered 501 with a message saying so. */
#ifndef PRISMFARM_DASH_PROVIDER_H
#define PRISMFARM_DASH_PROVIDER_H

#include "err.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define DASH_MAX_JOBS 1000    /* jobs listed at once: the most recent ones */
#define DASH_MAX_WORKERS 4096 /* workers listed at once */
#define DASH_MAX_PASSES 40    /* pass records of a job (film/stopping.h's STOPPING_MAX_RECORDS) */
#define DASH_MAX_TASKS 4096   /* running tasks of a job listed */
#define DASH_MAX_LOG 500      /* log lines of one answer */

/* A job as its list row and page show it. Unknown figures are flagged by has_* (absent from
 * the JSON), so a field the daemon gains later plugs in without changing the pages. */
typedef struct dash_job {
    uint64_t id;
    const char *name;
    const char *owner; /* key name of who submitted it; "" when unknown */
    const char *state; /* "queued", "running", "done", "failed", "cancelled", "paused" (as
                        * `prismfarm jobs` says it) */
    bool has_paused, paused;
    /* Figures the daemon may not know (a job restored after a restart before its scene is
     * loaded again, a finished job the scheduler forgot): absent from the JSON when false,
     * shown as unknown, never as 0. */
    bool has_size;  /* xres, yres, spp, npasses */
    bool has_tasks; /* tasks_total, tasks_done, tasks_running */
    bool has_priority;
    int priority;
    int xres, yres, spp; /* its size and target samples per pixel */
    const char *integrator;
    uint64_t samples_done, samples_total, nonfinite;
    int spp_done; /* samples per pixel of the passes merged */
    int passes_done, npasses;
    uint32_t tasks_total, tasks_done, tasks_running;
    bool has_rel_error;
    double rel_error;  /* the error estimate after the last pass (film/error_estimate.h) */
    double elapsed_s;  /* since it started (to its end when over); 0 before */
    const char *stop;  /* why it ended before its last pass: "" , "target", "time" */
    const char *error; /* "" unless failed */
    /* The progressive preview: version changes whenever a new image is written (the page
     * reloads the PNG then); 0: none yet. */
    uint64_t preview_version;
    /* The photon phase of a photon job. */
    bool photons;
    bool photons_complete; /* every batch merged (a finished phase kept on disk has no batch
                            * counts: photons_traced says its size) */
    uint32_t photon_batches, photon_batches_done;
    uint64_t photons_traced, photons_emitted;
    uint64_t photons_total; /* photons of every batch, merged or not (refinements included) */
    /* Frame sequences (docs/farm.md): a sequence's count of frames (its figures are theirs
     * summed); a frame's sequence (0: none) and frame number. */
    uint32_t nframes;
    uint64_t sequence;
    uint32_t frame;
} dash_job_t;

/* One merged pass: a point of the error-against-time curve. */
typedef struct dash_pass {
    int pass, spp;
    double elapsed_s;
    bool valid; /* an estimate exists (not after the first pass) */
    double rel_error;
} dash_pass_t;

/* A running task and the worker holding it. */
typedef struct dash_task {
    uint32_t task; /* the scheduler's index: camera pass * ntiles + tile, or a batch */
    bool photon;
    int tile, pass; /* camera; -1 for a photon batch */
    uint32_t batch; /* photon */
    uint32_t sample_begin, sample_end;
    uint32_t attempt;
    uint64_t worker;
    const char *worker_name;
    double running_s; /* since it was issued */
} dash_task_t;

/* The tile map of a job's camera phase: per tile the passes merged. tiles_x * tiles_y tiles of
 * tile x tile pixels, row-major from the top left; merged has ntiles entries (filled by the
 * provider into the dashboard's array of capacity ntiles, which the dashboard sizes from
 * tiles_x * tiles_y after a first call with merged = NULL). A job with adaptive sampling
 * (docs/rendering.md) says so: its tiles with fewer passes merged than passes_done stopped
 * there (converged); spp, filled beside merged, is each tile's samples per pixel. */
typedef struct dash_tilemap {
    int xres, yres, tile, tiles_x, tiles_y, npasses;
    int *merged;
    int *spp;        /* ntiles entries like merged (NULL: not asked) */
    bool adaptive;   /* tiles stop one by one */
    int passes_done; /* the passes the running tiles have merged */
} dash_tilemap_t;

typedef struct dash_worker {
    uint64_t id;
    const char *name; /* the host's worker name */
    const char *key;  /* its CURVE key name; "" without CURVE */
    int threads;
    const char *state; /* "idle", "busy", "lost" */
    int tasks_running;
    uint64_t tasks_done, tasks_failed;
    uint64_t samples_done; /* camera samples merged from its results */
    bool has_rate;
    double samples_per_s; /* its recent rate, as `prismfarm workers` shows it */
    double last_seen_s;   /* seconds since its last message */
    bool has_blocklisted, blocklisted;
} dash_worker_t;

typedef struct dash_log_line {
    uint64_t seq; /* increasing; ask for lines after one with ?since= */
    double age_s; /* seconds ago */
    const char *text;
} dash_log_line_t;

/* Who asks (dash_auth.h): the key name the token maps to, whether it is an administrator's,
 * and whether it is the scrapers' token (--metrics-token-file), which reads /metrics and
 * nothing else. */
typedef struct dash_identity {
    char name[80];
    bool admin;
    bool scraper;
} dash_identity_t;

/* Every callback gets user. A callback that can fail returns -1 with err (the message the
 * client sees, as a 4xx/5xx answer); "no such job" is DASH_ENOENT. */
#define DASH_ENOENT (-2)
typedef struct dash_provider {
    void *user;
    /* Up to max jobs, the most recent ones, in id order; returns how many (<= max). */
    size_t (*jobs)(void *user, dash_job_t *out, size_t max);
    int (*job)(void *user, uint64_t id, dash_job_t *out);
    /* A sequence's frames, up to max, in frame order; returns how many, or DASH_ENOENT. NULL:
     * no sequences. */
    int (*frames)(void *user, uint64_t id, dash_job_t *out, int max);
    /* The job's current image, PNG bytes malloc'ed into *png (the caller frees). */
    int (*preview)(void *user, uint64_t id, uint8_t **png, size_t *size, err_t *err);
    /* Up to max pass records; returns how many, or DASH_ENOENT. */
    int (*passes)(void *user, uint64_t id, dash_pass_t *out, int max);
    /* Fills map (merged when non-NULL, with map->tiles_x * tiles_y entries of room); returns 0,
     * DASH_ENOENT, or -1 with err (a job whose scene is not loaded has no tiles to show). */
    int (*tiles)(void *user, uint64_t id, dash_tilemap_t *map, err_t *err);
    /* Up to max running tasks; returns how many, or DASH_ENOENT. */
    int (*tasks)(void *user, uint64_t id, dash_task_t *out, int max);
    /* Up to max log lines after seq since (job 0: every line, else the job's); returns how
     * many. */
    int (*log)(void *user, uint64_t job, uint64_t since, dash_log_line_t *out, int max);
    size_t (*workers)(void *user, dash_worker_t *out, size_t max);
    /* The Prometheus text of /metrics (master/metrics.h), malloc'ed into *text (the caller
     * frees); -1 with err. NULL: /metrics answers 501. */
    int (*metrics)(void *user, char **text, size_t *len, err_t *err);

    /* Whether who may act on job (the daemon's own rule, so that the dashboard and its other
     * clients agree). NULL: the owner (a key name equal to job->owner, never "") or an
     * administrator. */
    bool (*allowed)(void *user, const dash_identity_t *who, const dash_job_t *job);

    /* Actions, checked for authority by the dashboard before they are called. Each returns 0
     * or -1 with err (the reason, shown to the user). */
    int (*cancel)(void *user, const dash_identity_t *who, uint64_t job, err_t *err);
    int (*pause)(void *user, const dash_identity_t *who, uint64_t job, bool pause, err_t *err);
    int (*set_priority)(void *user, const dash_identity_t *who, uint64_t job, int priority,
                        err_t *err);
    int (*requeue)(void *user, const dash_identity_t *who, uint64_t job, uint32_t task, err_t *err);
    int (*blocklist)(void *user, const dash_identity_t *who, uint64_t worker, bool block,
                     err_t *err);
} dash_provider_t;

#endif
