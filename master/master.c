#define _XOPEN_SOURCE 700 /* realpath */
#include "master.h"

#include "bundle.h"
#include "curve.h"
#include "error_estimate.h"
#include "film.h"
#include "journal.h"
#include "net.h"
#include "photon_phase.h"
#include "scene_load.h"
#include "settings.h"
#include "spool.h"
#include "zap.h"

#include <dirent.h>
#include <errno.h>
#include <limits.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include <zmq.h>

#define POLL_MS 100              /* longest wait on the sockets: the stop flag's latency */
#define RECV_BURST 1000          /* messages taken from one socket per loop turn */
#define MAX_LOST_WORKERS 256     /* lost workers still listed by WORKERS */
#define FILE_OVERHEAD (64 << 10) /* room for a FILE message's envelope and name */
#define MAX_WAITERS 1024         /* STATUS long polls held at once; more are answered at once */

typedef struct mworker {
    uint64_t id;
    proto_peer_t peer;
    char *name;
    int threads;
    bool alive;
    double last_seen;
    /* A task the scheduler issued whose TASK found the peer's queue full: sent before any
     * other. Only one, because dispatch stops at the first full queue. */
    bool has_unsent;
    sched_task_t unsent;
} mworker_t;

/* One merged pass of a job and the error estimate after it (docs/farm.md, "Accuracy"). */
typedef struct pass_record {
    int pass, spp;    /* passes merged (1-based) and samples per pixel they hold */
    double elapsed;   /* seconds since the job started */
    bool valid;       /* an estimate exists (not after the first pass: 1 sample per pixel) */
    double rel_error; /* relative RMSE of the mean luminance, film/error_estimate.h */
} pass_record_t;

#define MAX_PASS_RECORDS 40 /* passes of a job: log2(2^24 spp) + 1 = 25, with room */

typedef struct mjob {
    uint64_t id;
    char *name;
    char stem[88]; /* file-name form of the name: outputs are <stem>.exr and <stem>.png */
    char hash[PROTO_HASH_HEX + 1];
    proto_settings_t settings;           /* strings point into integrator / dispersion */
    char integrator[65], dispersion[65]; /* protocol.md: names of at most 64 bytes */
    int xres, yres, spp, ntiles;
    uint64_t seed; /* the scene's, after the settings' override */
    const char *integrator_used, *dispersion_used; /* what the loaded scene runs with */
    spectral_grid_t grid;
    double submitted, started, finished; /* monotonic seconds; 0: not yet */
    job_state_t state;
    bool in_sched; /* false once finished: its image is on disk and the scheduler forgot it */
    bool preview;  /* jobs/<id>/preview.png exists */
    double last_preview; /* when it was written; 0: never */
    bool outputs;  /* jobs/<id>/<stem>.exr and .png exist */
    uint64_t samples_done, samples_total, nonfinite; /* kept when the scheduler forgets it */
    char *error;
    /* A job with a photon pass: its batches, their merge and the merged store (kept for
     * refinement after the job is done). The scheduler's batch b is the phase's batch
     * photon_base + b: a refinement adds its batches to a fresh scheduler job. */
    photon_phase_t *photons;
    bool photon_job;        /* the scene has a photon pass (photons may be on disk, below) */
    char *main;             /* the bundle's main file, to load the scene again (a refinement, a
                             * restarted master) */
    uint64_t photons_saved; /* photons in jobs/<id>/photons.store when photons is NULL */
    uint32_t photon_base;
    bool store_ready;
    char store[PROTO_HASH_HEX + 1];
    /* Bumped by each refinement and carried in the upper 32 bits of every task id on the wire,
     * so a late result of an earlier round is told from the current one's. */
    uint32_t round;
    /* Accuracy of the current round: a record per merged pass, the spp of the passes merged
     * (kept when the scheduler forgets the job) and why it ended before its last pass. */
    pass_record_t history[MAX_PASS_RECORDS];
    int nhistory;
    int spp_done;
    proto_stop_t stop;
    /* The journal's view (journal.h): what the round's photon store holds when its phase is
     * done, the photons this round added, the checkpoint file's generation, and the bytes of
     * results journaled since it (a new checkpoint once they outgrow the image). */
    uint64_t round_photons, refine_photons;
    uint64_t checkpoint;
    size_t journaled_bytes;
    uint64_t checkpoint_samples; /* samples merged at the last checkpoint */
    double last_checkpoint;      /* when it was written (monotonic seconds; 0: none yet) */
} mjob_t;

/* A client's STATUS with a wait: answered when its job is over or at the deadline. */
typedef struct waiter {
    proto_peer_t peer;
    uint64_t job;
    double deadline; /* monotonic seconds */
} waiter_t;

typedef struct master {
    const master_opts_t *opts;
    proto_limits_t limits;
    sched_t *sched;
    spool_t *spool;
    journal_t *journal; /* NULL without opts->journal */
    proto_net_t *wnet, *cnet;
    mworker_t **workers;
    size_t nworkers, cap_workers;
    mjob_t **jobs; /* in id order */
    size_t njobs, cap_jobs;
    uint64_t last_job, last_worker;
    sched_worker_info_t *winfo; /* scratch for sched_workers */
    size_t cap_winfo;
    double heartbeat_s, last_heartbeat;
    waiter_t waiters[MAX_WAITERS];
    size_t nwaiters;
} master_t;

static bool job_over(const mjob_t *j);

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

__attribute__((format(printf, 2, 3))) static void mlog(const master_t *m, const char *fmt, ...)
{
    if (!m->opts->verbose)
        return;
    char line[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    fprintf(stderr, "master: %s\n", line);
}

static char *dup_str(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = malloc(n);
    if (d)
        memcpy(d, s, n);
    return d;
}

master_opts_t master_opts_default(void)
{
    master_opts_t o = {
        .worker_endpoint = "tcp://*:5555",
        .client_endpoint = "tcp://*:5556",
        .spool_dir = "prismfarm-spool",
        .heartbeat_ms = 1000,
        .sched = sched_config_default(),
        .limits = proto_limits_default(),
        .task_prefetch = -1,
        .preview_interval_s = 1.0,
        .max_jobs = 256,
        .journal = 1,
        .verbose = 1,
    };
    /* farm.md: a worker silent for 3 heartbeat intervals is dead (zguide's liveness 3). */
    o.sched.worker_timeout_s = 3.0;
    return o;
}

/* ---------------------------------------------------------------- lookups */

static mworker_t *worker_by_peer(const master_t *m, const proto_peer_t *p)
{
    for (size_t i = 0; i < m->nworkers; i++)
        if (m->workers[i]->peer.len == p->len && !memcmp(m->workers[i]->peer.id, p->id, p->len))
            return m->workers[i];
    return NULL;
}

static mjob_t *job_by_id(const master_t *m, uint64_t id)
{
    size_t lo = 0, hi = m->njobs;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (m->jobs[mid]->id < id)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < m->njobs && m->jobs[lo]->id == id ? m->jobs[lo] : NULL;
}

/* The scheduler's view of every worker, in m->winfo; returns the count. */
static size_t sched_worker_table(master_t *m)
{
    size_t n = sched_workers(m->sched, m->winfo, m->cap_winfo);
    if (n > m->cap_winfo) {
        sched_worker_info_t *p = realloc(m->winfo, n * sizeof *p);
        if (!p)
            return m->cap_winfo;
        m->winfo = p;
        m->cap_winfo = n;
        n = sched_workers(m->sched, m->winfo, m->cap_winfo);
    }
    return n;
}

static const sched_worker_info_t *sched_worker_of(master_t *m, size_t n, uint64_t id)
{
    for (size_t i = 0; i < n; i++)
        if (m->winfo[i].id == id)
            return &m->winfo[i];
    return NULL;
}

/* ---------------------------------------------------------------- workers */

static void worker_free(mworker_t *w)
{
    if (w) {
        free(w->name);
        free(w);
    }
}

/* Forgets the lost worker seen longest ago once more than MAX_LOST_WORKERS are listed, so that
 * workers that come and go do not grow the table for ever. Called between loops over the
 * table only, never inside one. */
static void prune_lost(master_t *m)
{
    size_t lost = 0, oldest = SIZE_MAX;
    for (size_t i = 0; i < m->nworkers; i++)
        if (!m->workers[i]->alive) {
            lost++;
            if (oldest == SIZE_MAX || m->workers[i]->last_seen < m->workers[oldest]->last_seen)
                oldest = i;
        }
    if (lost <= MAX_LOST_WORKERS)
        return;
    worker_free(m->workers[oldest]);
    memmove(&m->workers[oldest], &m->workers[oldest + 1],
            (m->nworkers - oldest - 1) * sizeof *m->workers);
    m->nworkers--;
}

static void worker_lost(master_t *m, mworker_t *w, const char *why)
{
    if (!w->alive)
        return;
    size_t n = sched_worker_table(m);
    const sched_worker_info_t *si = sched_worker_of(m, n, w->id);
    int busy = si ? si->busy : 0;
    sched_worker_leave(m->sched, w->id);
    w->alive = false;
    w->has_unsent = false;
    mlog(m, "worker %llu '%s' lost (%s); %d task%s back in the queue", (unsigned long long)w->id,
         w->name, why, busy, busy == 1 ? "" : "s");
}

/* Sends to a worker; a peer that is no longer connected is lost. */
static int send_worker(master_t *m, mworker_t *w, const proto_msg_t *msg)
{
    err_t err;
    int rc = proto_net_send(m->wnet, &w->peer, msg, &err);
    if (rc == PROTO_EUNREACHABLE)
        worker_lost(m, w, "disconnected");
    else if (rc < 0 && rc != PROTO_EAGAIN)
        mlog(m, "cannot send to worker %llu: %s", (unsigned long long)w->id, err.msg);
    return rc;
}

static void send_refuse(master_t *m, proto_net_t *net, const proto_peer_t *to, const char *reason)
{
    proto_msg_t r = {.type = PROTO_REFUSE, .refuse = {.reason = reason}};
    err_t err;
    if (to->len > 0 && proto_net_send(net, to, &r, &err) < 0)
        mlog(m, "cannot send REFUSE: %s", err.msg);
}

static void cancel_on_workers(master_t *m, uint64_t job)
{
    proto_msg_t c = {.type = PROTO_CANCEL, .cancel = {.job = job}};
    for (size_t i = 0; i < m->nworkers; i++) {
        mworker_t *w = m->workers[i];
        if (w->alive && w->has_unsent && w->unsent.job == job)
            w->has_unsent = false;
        if (w->alive)
            (void)send_worker(m, w, &c);
    }
}

/* ---------------------------------------------------------------- jobs */

static void job_free(mjob_t *j)
{
    if (j) {
        photon_phase_destroy(&j->photons);
        free(j->main);
        free(j->name);
        free(j->error);
        free(j);
    }
}

static void job_set_error(mjob_t *j, const char *msg)
{
    free(j->error);
    j->error = dup_str(msg);
}

/* The job's name as a file name: its last path component without ".pbrt", with anything but
 * letters, digits, '.', '-' and '_' replaced, no leading '.', never "preview" (the progressive
 * image's name). */
static void make_stem(const char *name, char *out, size_t size)
{
    const char *base = strrchr(name, '/');
    base = base && base[1] ? base + 1 : name;
    size_t n = strlen(base);
    if (n > 5 && !strcmp(base + n - 5, ".pbrt"))
        n -= 5;
    size_t k = 0;
    for (size_t i = 0; i < n && k + 2 < size; i++) {
        char c = base[i];
        bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                  c == '-' || c == '_' || (c == '.' && k > 0);
        out[k++] = ok ? c : '_';
    }
    out[k] = 0;
    if (k == 0)
        snprintf(out, size, "job");
    else if (!strcmp(out, "preview"))
        snprintf(out, size, "preview_");
}

/* The job's accuracy for the EXR's "prismfarm" attribute, appended to out:
 * ";spp_done=S;rel_rmse=E|none;stop=none|target|time;target_error=..;time_limit=..;
 * history=PASS:SPP:SECONDS:REL_RMSE,..." with "-" for a pass without an estimate. */
static void accuracy_info(const mjob_t *j, int spp_done, char *out, size_t size)
{
    size_t n = strlen(out);
    const pass_record_t *last = j->nhistory > 0 ? &j->history[j->nhistory - 1] : NULL;
    char rel[32] = "none";
    if (last && last->valid)
        snprintf(rel, sizeof rel, "%.6g", last->rel_error);
    n += (size_t)snprintf(out + n, n < size ? size - n : 0,
                          ";spp_done=%d;rel_rmse=%s;stop=%s;target_error=%g;time_limit=%g;history=",
                          spp_done, rel, proto_stop_name(j->stop), j->settings.target_error,
                          j->settings.time_limit);
    for (int i = 0; i < j->nhistory && n < size; i++) {
        const pass_record_t *r = &j->history[i];
        char e[32] = "-";
        if (r->valid)
            snprintf(e, sizeof e, "%.6g", r->rel_error);
        n += (size_t)snprintf(out + n, size - n, "%s%d:%d:%.3f:%s", i ? "," : "", r->pass, r->spp,
                              r->elapsed, e);
    }
}

static int write_image(master_t *m, mjob_t *j, bool final, err_t *err)
{
    char dir[PATH_MAX], exr[PATH_MAX + 100], png[PATH_MAX + 100];
    if (spool_job_dir(m->spool, j->id, dir, sizeof dir, err) < 0)
        return -1;
    const tilebuf_t *image = sched_job_image(m->sched, j->id);
    if (!image)
        return err_set(err, "job %llu has no image", (unsigned long long)j->id);
    sched_job_info_t si;
    if (sched_job_info(m->sched, j->id, &si) < 0)
        return err_set(err, "job %llu is unknown to the scheduler", (unsigned long long)j->id);
    char info[4096];
    snprintf(info, sizeof info,
             "job=%llu;name=%s;scene=%s;spp=%d;xres=%d;yres=%d;seed=%llu;integrator=%s;"
             "dispersion=%s;samples=%llu;nonfinite=%llu;photons=%llu;seconds=%.3f",
             (unsigned long long)j->id, j->stem, j->hash, j->spp, j->xres, j->yres,
             (unsigned long long)j->seed, j->integrator_used, j->dispersion_used,
             (unsigned long long)si.samples_done, (unsigned long long)si.nonfinite,
             (unsigned long long)(j->photons ? photon_phase_stats(j->photons).photons : 0),
             j->started > 0 ? now_s() - j->started : 0.0);
    accuracy_info(j, si.spp_done, info, sizeof info);
    film_output_t out = {
        .spectral = 1, .tonemap = {.exposure_stops = 0, .curve = COLOUR_CURVE_ACES}, .info = info};
    if (final) {
        snprintf(exr, sizeof exr, "%s/%s.exr", dir, j->stem);
        snprintf(png, sizeof png, "%s/%s.png", dir, j->stem);
        out.exr_path = exr;
    } else {
        snprintf(png, sizeof png, "%s/preview.png", dir);
    }
    out.png_path = png;
    return film_write(image, j->grid, &out, err);
}

/* ---------------------------------------------------------------- the journal */

/* The job as journal.h keeps it; the strings point into j. */
static journal_job_t job_record(const mjob_t *j, double now)
{
    journal_job_t r = {.id = j->id,
                       .name = j->name,
                       .hash = (char *)j->hash,
                       .main = j->main,
                       .settings = j->settings,
                       .state = (int)j->state,
                       .error = j->error,
                       .round = j->round,
                       .photon_base = j->photon_base,
                       .photons_saved = j->photons_saved,
                       .round_photons = j->round_photons,
                       .refine_photons = j->refine_photons,
                       .checkpoint = j->checkpoint,
                       .stop = (int)j->stop,
                       .outputs = j->outputs,
                       .samples_done = j->samples_done,
                       .samples_total = j->samples_total,
                       .nonfinite = j->nonfinite,
                       .spp_done = j->spp_done};
    double end = j->finished > 0 ? j->finished : now;
    r.elapsed = j->started > 0 && end > j->started ? end - j->started : 0;
    return r;
}

static void checkpoint_path(const master_t *m, uint64_t job, uint64_t gen, char *buf, size_t size)
{
    snprintf(buf, size, "%s/jobs/%llu/checkpoint-%llu.bin", spool_path(m->spool),
             (unsigned long long)job, (unsigned long long)gen);
}

/* A journal that cannot be written does not stop the farm: the job goes on and the log says
 * what a restart would lose. */
static void journal_failed(const master_t *m, const mjob_t *j, const err_t *err)
{
    mlog(m, "job %llu: journal: %s (a restarted master would not resume this job's latest "
         "progress)", (unsigned long long)j->id, err->msg);
}

/* The job's state in the journal; a job that is over leaves no checkpoint behind. */
static void journal_state(master_t *m, mjob_t *j, double now)
{
    if (!m->journal)
        return;
    err_t err;
    journal_job_t r = job_record(j, now);
    if (journal_set_state(m->journal, &r, &err) < 0) {
        journal_failed(m, j, &err);
        return;
    }
    if (job_over(j) && j->checkpoint > 0) {
        char path[PATH_MAX + 64];
        checkpoint_path(m, j->id, j->checkpoint, path, sizeof path);
        (void)unlink(path); /* a leftover is removed at the next start (resume_jobs) */
        j->checkpoint = 0;
    }
}

/* Once the results journaled since the last checkpoint outgrow the image, the merged image is
 * written as a new checkpoint and the results in it leave the journal. Not more often than
 * every CHECKPOINT_INTERVAL_S unless they outgrow it fourfold: a large image's checkpoint takes
 * the master's loop a while (315 MB at 1920x1080 with 16 buckets), and early passes are short.
 * So the spool holds at most about five images' worth per running job, and a restart replays
 * at most four. */
#define CHECKPOINT_INTERVAL_S 10.0
static void maybe_checkpoint(master_t *m, mjob_t *j, double now)
{
    sched_job_info_t info;
    if (!m->journal || sched_job_info(m->sched, j->id, &info) < 0 || info.state != JOB_RUNNING ||
        info.samples_done == j->checkpoint_samples)
        return;
    size_t image_bytes = (size_t)j->xres * (size_t)j->yres * ((size_t)j->grid.n + 3) * 8;
    if (j->journaled_bytes < image_bytes ||
        (j->journaled_bytes < 4 * image_bytes && now - j->last_checkpoint < CHECKPOINT_INTERVAL_S))
        return;
    err_t err;
    int *next = malloc((size_t)info.ntiles * sizeof *next);
    char path[PATH_MAX + 64], old[PATH_MAX + 64];
    uint64_t gen = j->checkpoint + 1;
    checkpoint_path(m, j->id, gen, path, sizeof path);
    checkpoint_path(m, j->id, j->checkpoint, old, sizeof old);
    journal_job_t r = job_record(j, now);
    if (!next) {
        err_set(&err, "out of memory for a checkpoint");
    } else if (sched_job_next_pass(m->sched, j->id, next, info.ntiles) < 0) {
        err_set(&err, "the scheduler has no pass table for the job");
    } else if (journal_write_checkpoint(path, sched_job_image(m->sched, j->id), next, info.ntiles,
                                        &err) == 0 &&
               journal_set_checkpoint(m->journal, j->id, j->round, gen, next, info.ntiles,
                                      r.elapsed, &err) == 0) {
        if (j->checkpoint > 0)
            (void)unlink(old);
        j->checkpoint = gen;
        j->journaled_bytes = 0;
        j->checkpoint_samples = info.samples_done;
        j->last_checkpoint = now;
        free(next);
        return;
    } else {
        (void)unlink(path);
    }
    free(next);
    journal_failed(m, j, &err);
    j->journaled_bytes = 0; /* try again after as many bytes, not after every result */
    j->last_checkpoint = now;
}

/* The merged photon store on disk as jobs/<id>/photons.store (atomically), and in the journal
 * when there is one: a restarted master or a refinement loads it instead of tracing again. */
static int save_store(master_t *m, mjob_t *j, err_t *err)
{
    char dir[PATH_MAX], path[PATH_MAX + 32];
    const uint8_t *data;
    size_t size;
    const char *hash;
    uint64_t photons = photon_phase_stats(j->photons).photons;
    if (j->photons_saved == photons && photons > 0)
        return 0;
    if (spool_job_dir(m->spool, j->id, dir, sizeof dir, err) < 0 ||
        photon_phase_store(j->photons, &data, &size, &hash, err) < 0)
        return -1;
    snprintf(path, sizeof path, "%s/photons.store", dir);
    if (spool_write_file(path, data, size, err) < 0)
        return -1;
    j->photons_saved = photons;
    if (m->journal && journal_set_photons_saved(m->journal, j->id, photons, err) < 0)
        journal_failed(m, j, err);
    return 0;
}

/* A photon job that is over gives back its store's memory: a finished job's merged store goes
 * to jobs/<id>/photons.store (for a refinement, which loads the scene again and restores it),
 * and the scene and batches are dropped; a failed or cancelled one cannot be refined. Kept in
 * memory only if it cannot be written. */
static void release_photons(master_t *m, mjob_t *j)
{
    if (!j->photons)
        return;
    err_t err;
    if (j->state == JOB_DONE && save_store(m, j, &err) < 0) {
        mlog(m, "job %llu: keeping its photon store in memory: %s", (unsigned long long)j->id,
             err.msg);
        return;
    }
    photon_phase_destroy(&j->photons);
    j->store_ready = false;
}

/* Follows the scheduler's state of a job: logs the change and, once the job is over, writes
 * its outputs (done), tells the workers to drop its tasks (failed, cancelled) and frees its
 * image in the scheduler, keeping only the figures STATUS reports. */
static void job_refresh(master_t *m, mjob_t *j, double now)
{
    sched_job_info_t info;
    if (!j->in_sched || sched_job_info(m->sched, j->id, &info) < 0 || info.state == j->state)
        return;
    j->state = info.state;
    if (info.state == JOB_RUNNING || info.state == JOB_QUEUED) {
        if (info.state == JOB_RUNNING && j->started == 0)
            j->started = now;
        return;
    }
    if (j->started == 0)
        j->started = now;
    j->finished = now;
    if (info.state == JOB_DONE) {
        err_t err;
        /* Ended before its last pass (target error, time limit): the tasks still out are of
         * passes that will never be merged, so the workers drop them, as for a cancel. */
        if (j->stop != PROTO_STOP_NONE)
            cancel_on_workers(m, j->id);
        if (write_image(m, j, true, &err) < 0) {
            char msg[600];
            snprintf(msg, sizeof msg, "writing the outputs: %s", err.msg);
            job_set_error(j, msg);
            j->state = JOB_FAILED;
            mlog(m, "job %llu '%s' failed: %s", (unsigned long long)j->id, j->name, msg);
        } else {
            j->outputs = true;
            const pass_record_t *last = j->nhistory > 0 ? &j->history[j->nhistory - 1] : NULL;
            char acc[160] = "";
            if (last && last->valid)
                snprintf(acc, sizeof acc, ", relative error %.4g", last->rel_error);
            mlog(m, "job %llu '%s' done in %.2f s at %d of %d spp%s%s: %s/jobs/%llu/%s.exr",
                 (unsigned long long)j->id, j->name, j->finished - j->started, info.spp_done,
                 j->spp, acc,
                 j->stop == PROTO_STOP_TARGET ? " (target error reached)"
                 : j->stop == PROTO_STOP_TIME ? " (time limit reached)"
                                              : "",
                 spool_path(m->spool), (unsigned long long)j->id, j->stem);
        }
    } else if (info.state == JOB_FAILED) {
        job_set_error(j, info.error[0] ? info.error : "failed");
        mlog(m, "job %llu '%s' failed: %s", (unsigned long long)j->id, j->name, j->error);
        cancel_on_workers(m, j->id);
    } else {
        mlog(m, "job %llu '%s' cancelled", (unsigned long long)j->id, j->name);
        cancel_on_workers(m, j->id);
    }
    release_photons(m, j);
    j->samples_done = info.samples_done;
    j->samples_total = info.samples_total;
    j->nonfinite = info.nonfinite;
    j->spp_done = info.spp_done;
    journal_state(m, j, now);
    err_t err;
    if (sched_remove_job(m->sched, j->id, &err) < 0)
        mlog(m, "job %llu: %s", (unsigned long long)j->id, err.msg);
    else
        j->in_sched = false;
}

static proto_job_state_t wire_state(job_state_t s)
{
    switch (s) {
    case JOB_QUEUED:
        return PROTO_JOB_QUEUED;
    case JOB_RUNNING:
        return PROTO_JOB_RUNNING;
    case JOB_DONE:
        return PROTO_JOB_DONE;
    case JOB_FAILED:
        return PROTO_JOB_FAILED;
    case JOB_CANCELLED:
        return PROTO_JOB_CANCELLED;
    }
    return PROTO_JOB_FAILED;
}

static proto_job_info_t job_wire_info(const master_t *m, const mjob_t *j, double now)
{
    proto_job_info_t o = {.id = j->id,
                          .name = j->name,
                          .state = wire_state(j->state),
                          .samples_done = j->samples_done,
                          .samples_total = j->samples_total,
                          .nonfinite = j->nonfinite};
    o.spp = (uint32_t)j->spp_done;
    sched_job_info_t info;
    if (j->in_sched && sched_job_info(m->sched, j->id, &info) == 0) {
        o.samples_done = info.samples_done;
        o.samples_total = info.samples_total;
        o.nonfinite = info.nonfinite;
        o.spp = (uint32_t)info.spp_done;
    }
    const pass_record_t *last = j->nhistory > 0 ? &j->history[j->nhistory - 1] : NULL;
    if (last && last->valid) {
        o.has_rel_error = true;
        o.rel_error = last->rel_error;
    }
    o.stop = j->stop;
    double secs = j->started > 0 ? (j->finished > 0 ? j->finished : now) - j->started : 0;
    o.elapsed = secs > 0 ? secs : 0;
    if (j->state == JOB_FAILED)
        o.error = j->error ? j->error : "failed";
    return o;
}

/* ---------------------------------------------------------------- dispatch */

static int send_task(master_t *m, mworker_t *w, const sched_task_t *t, double now)
{
    mjob_t *j = job_by_id(m, t->job);
    if (!j || !j->in_sched)
        return 0; /* cancelled meanwhile: the scheduler already took the task back */
    proto_msg_t msg = {.type = PROTO_TASK};
    msg.task.job = t->job;
    msg.task.task = (uint64_t)j->round << 32 | t->task;
    msg.task.attempt = t->attempt;
    memcpy(msg.task.scene, j->hash, sizeof msg.task.scene);
    msg.task.settings = j->settings;
    if (t->kind == SCHED_PHOTON) {
        msg.task.kind = PROTO_KIND_PHOTON_BATCH;
        msg.task.photons = photon_phase_batch(j->photons, j->photon_base + t->batch);
    } else {
        msg.task.kind = PROTO_KIND_CAMERA_TILE;
        msg.task.tile = (proto_tile_t){.x0 = t->x0,
                                       .y0 = t->y0,
                                       .w = t->w,
                                       .h = t->h,
                                       .sample_begin = t->sample_begin,
                                       .sample_end = t->sample_end};
        /* The camera phase starts only after every batch is merged (sched.h). */
        if (j->photons)
            memcpy(msg.task.store, j->store, sizeof msg.task.store);
    }
    int rc = send_worker(m, w, &msg);
    if (rc == 0 && j->started == 0) {
        j->started = now;
        j->state = JOB_RUNNING;
        mlog(m, "job %llu '%s' started", (unsigned long long)j->id, j->name);
    }
    return rc;
}

/* Keeps every live worker's task slots full. */
static void dispatch(master_t *m, double now)
{
    for (size_t i = 0; i < m->nworkers; i++) {
        mworker_t *w = m->workers[i];
        if (w->alive && w->has_unsent) {
            int rc = send_task(m, w, &w->unsent, now);
            if (rc == PROTO_EAGAIN)
                continue;
            w->has_unsent = false;
        }
        sched_task_t t;
        while (w->alive && sched_next_task(m->sched, w->id, now, &t) == 1) {
            int rc = send_task(m, w, &t, now);
            if (rc == PROTO_EAGAIN) {
                w->unsent = t;
                w->has_unsent = true;
            }
            if (rc < 0)
                break;
        }
    }
}

/* ---------------------------------------------------------------- worker messages */

static void on_hello(master_t *m, const proto_peer_t *from, mworker_t *w, const proto_msg_t *msg,
                     double now)
{
    bool again = w != NULL;
    char who[PROTO_PEER_STR];
    if (!w) {
        if (m->nworkers == m->cap_workers) {
            size_t cap = m->cap_workers ? 2 * m->cap_workers : 16;
            mworker_t **p = realloc(m->workers, cap * sizeof *p);
            if (!p) {
                mlog(m, "out of memory for worker %s", proto_peer_str(from, who));
                return;
            }
            m->workers = p;
            m->cap_workers = cap;
        }
        w = calloc(1, sizeof *w);
        if (!w) {
            mlog(m, "out of memory for worker %s", proto_peer_str(from, who));
            return;
        }
        w->id = ++m->last_worker;
        w->peer = *from;
        m->workers[m->nworkers++] = w;
    }
    char *name = dup_str(msg->hello.name);
    if (name) {
        free(w->name);
        w->name = name;
    } else if (!w->name) {
        w->name = dup_str("?");
    }
    w->threads = msg->hello.threads;
    /* Slots beyond the threads: a thread that finishes a tile starts on a queued one while its
     * result travels and the next TASK comes back (docs/performance.md). */
    int prefetch = m->opts->task_prefetch < 0 ? w->threads : m->opts->task_prefetch;
    err_t err;
    if (sched_worker_join(m->sched, w->id, w->threads + prefetch, now, &err) < 0 ||
        sched_worker_set_threads(m->sched, w->id, w->threads, &err) < 0) {
        mlog(m, "worker %s refused: %s", proto_peer_str(from, who), err.msg);
        w->alive = false;
        send_refuse(m, m->wnet, from, err.msg);
        return;
    }
    w->alive = true;
    w->last_seen = now;
    w->has_unsent = false;
    proto_msg_t welcome = {
        .type = PROTO_WELCOME,
        .welcome = {.worker_id = w->id, .heartbeat_ms = (uint32_t)m->opts->heartbeat_ms}};
    if (send_worker(m, w, &welcome) == 0)
        mlog(m, "worker %llu '%s' %s from %s with %d thread%s (%s)", (unsigned long long)w->id,
             w->name, again ? "joined again" : "joined", proto_peer_str(from, who), w->threads,
             w->threads == 1 ? "" : "s", msg->hello.software);
}

/* The sample range of a task, as sched.c cuts passes: 0, 1, 2, 4, 8, ... up to spp. */
static void pass_range(int spp, uint64_t pass, uint32_t *begin, uint32_t *end)
{
    uint64_t b = pass == 0 ? 0 : (uint64_t)1 << (pass - 1), e = (uint64_t)1 << pass;
    *begin = (uint32_t)(b < (uint64_t)spp ? b : (uint64_t)spp);
    *end = (uint32_t)(e < (uint64_t)spp ? e : (uint64_t)spp);
}

/* After a result that completed one or more passes. At each pass boundary: the error estimate
 * of the image (exactly the passes merged when the job may end early: sched.h, whole passes),
 * its record and log line, and the stopping rules, which end the job at the first boundary
 * where the estimate is <= target_error or time_limit has passed. A job that goes on gets a
 * preview, at most every preview_interval_s. */
static void passes_merged(master_t *m, mjob_t *j, int rc, double now)
{
    err_t err;
    sched_job_info_t info;
    while ((rc & SCHED_PASS_DONE) && sched_job_info(m->sched, j->id, &info) == 0) {
        error_estimate_t e = error_estimate_image(sched_job_image(m->sched, j->id));
        double elapsed = j->started > 0 && now > j->started ? now - j->started : 0;
        /* A restarted master merging the journal's results again meets passes it recorded. */
        bool known = j->nhistory > 0 && j->history[j->nhistory - 1].pass >= info.passes_done;
        if (!known && j->nhistory < MAX_PASS_RECORDS) {
            pass_record_t rec = {.pass = info.passes_done, .spp = info.spp_done, .elapsed = elapsed,
                                 .valid = e.valid, .rel_error = e.valid ? e.rel_rmse : 0};
            j->history[j->nhistory++] = rec;
            journal_pass_t jp = {.pass = rec.pass, .spp = rec.spp, .elapsed = rec.elapsed,
                                 .valid = rec.valid, .rel_error = rec.rel_error};
            if (m->journal && journal_add_pass(m->journal, j->id, j->round, &jp, &err) < 0)
                journal_failed(m, j, &err);
        }
        char est[64] = "no error estimate yet (1 sample per pixel)";
        if (e.valid)
            snprintf(est, sizeof est, "relative error %.4g", e.rel_rmse);
        else if (e.saturated > 0)
            snprintf(est, sizeof est, "no error estimate (%llu pixels beyond range)",
                     (unsigned long long)e.saturated);
        else if (e.pixels > 0)
            snprintf(est, sizeof est, "no relative error (image mean %.3g)", e.mean);
        mlog(m, "job %llu pass %d of %d merged: %d spp, %s after %.2f s", (unsigned long long)j->id,
             info.passes_done, info.npasses, info.spp_done, est, elapsed);
        proto_stop_t stop = PROTO_STOP_NONE;
        if (info.state == JOB_RUNNING && info.whole_passes) {
            if (j->settings.target_error > 0 && e.valid && e.rel_rmse <= j->settings.target_error)
                stop = PROTO_STOP_TARGET;
            else if (j->settings.time_limit > 0 && elapsed >= j->settings.time_limit)
                stop = PROTO_STOP_TIME;
        }
        if (stop != PROTO_STOP_NONE) {
            if (sched_finish_job_at_pass(m->sched, j->id, &err) < 0) {
                mlog(m, "job %llu: cannot end it at pass %d: %s", (unsigned long long)j->id,
                     info.passes_done, err.msg);
            } else {
                j->stop = stop;
                return; /* job_refresh writes the outputs and tells the workers */
            }
        }
        if (!(rc & SCHED_PASS_READY))
            break;
        rc = sched_merge_next_pass(m->sched, j->id, &err);
        if (rc < 0) {
            mlog(m, "job %llu: %s", (unsigned long long)j->id, err.msg);
            sched_fail_job(m->sched, j->id, err.msg);
            return;
        }
    }
    /* Short passes would write a PNG each, costing the master's CPU (which shares the cores
     * with the workers' threads) for images nobody looks at that often; the final image is
     * written when the job is done whatever the interval. */
    if (sched_job_info(m->sched, j->id, &info) < 0 || info.state != JOB_RUNNING ||
        now - (j->last_preview > 0 ? j->last_preview : j->started) < m->opts->preview_interval_s)
        return;
    if (write_image(m, j, false, &err) < 0) {
        mlog(m, "job %llu: cannot write the preview: %s", (unsigned long long)j->id, err.msg);
    } else {
        j->preview = true;
        j->last_preview = now;
        mlog(m, "job %llu preview written at %d spp", (unsigned long long)j->id, info.spp_done);
    }
}

/* Who a result came from: a worker, or the journal (id 0) when a restarted master merges
 * what it had received before again. */
typedef struct source {
    uint64_t id;
    const char *name;
    bool replay;
} source_t;

/* The photon phase is merged: its store's hash names it in every camera task, and with a
 * journal it goes to disk at once, so that a restart does not trace it again. */
static void photon_phase_merged(master_t *m, mjob_t *j)
{
    err_t err;
    const uint8_t *data;
    size_t size;
    const char *hash;
    if (photon_phase_store(j->photons, &data, &size, &hash, &err) < 0) {
        mlog(m, "job %llu: the merged photon store: %s", (unsigned long long)j->id, err.msg);
        sched_fail_job(m->sched, j->id, err.msg);
        return;
    }
    memcpy(j->store, hash, sizeof j->store);
    j->store_ready = true;
    photon_phase_stats_t ps = photon_phase_stats(j->photons);
    mlog(m,
         "job %llu photon pass merged: %llu photons in %u batches, %llu emitted, %.1f MB store "
         "%.12s",
         (unsigned long long)j->id, (unsigned long long)ps.photons, ps.batches,
         (unsigned long long)ps.emitted, size / 1e6, hash);
    if (m->journal && save_store(m, j, &err) < 0)
        journal_failed(m, j, &err);
}

static void photon_result(master_t *m, mjob_t *j, const source_t *src, uint32_t task,
                          uint32_t attempt, const proto_photon_result_t *r, double now)
{
    err_t err;
    int rc = -1;
    uint32_t b = task & ~SCHED_PHOTON_TASK;
    if (!(task & SCHED_PHOTON_TASK) || !j->photons)
        err_set(&err, "task %u is not a photon batch of the job, or its result is not one", task);
    else if ((rc = photon_phase_add(j->photons, j->photon_base + b, r, &err)) >= 0)
        rc = sched_photon_done(m->sched, src->id, j->id, task, attempt, now, &err);
    if (rc < 0) {
        mlog(m, "bad photon batch from %s %llu '%s' for job %llu: %s",
             src->replay ? "the journal" : "worker", (unsigned long long)src->id, src->name,
             (unsigned long long)j->id, err.msg);
        sched_task_failed(m->sched, src->id, j->id, task, attempt, err.msg);
        return;
    }
    if ((rc & SCHED_MERGED) && m->journal && !src->replay) {
        uint8_t *blob;
        size_t size;
        if (journal_pack_photons(r, &blob, &size, &err) < 0) {
            journal_failed(m, j, &err);
        } else {
            if (journal_add_result(m->journal, j->id, j->round, task, 1, (int)b, -1, blob, size,
                                   &err) < 0)
                journal_failed(m, j, &err);
            free(blob);
        }
    }
    if (rc & SCHED_PHASE_DONE)
        photon_phase_merged(m, j);
}

/* A camera tile's result: tb (taken) covers samples [sb, se). wire is the result as received,
 * journaled once merged; NULL for one replayed from the journal. */
static void camera_result(master_t *m, mjob_t *j, const source_t *src, uint32_t task,
                          uint32_t attempt, tilebuf_t *tb, uint32_t sb, uint32_t se,
                          const proto_tile_result_t *wire, double now)
{
    uint64_t pass = j->ntiles > 0 ? task / (uint64_t)j->ntiles : 0;
    if (pass >= 40) {
        mlog(m, "%s %llu sent a result for job %llu task %u, which does not exist",
             src->replay ? "the journal" : "worker", (unsigned long long)src->id,
             (unsigned long long)j->id, task);
        tilebuf_destroy(&tb);
        return;
    }
    uint32_t pb, pe;
    pass_range(j->spp, pass, &pb, &pe);
    err_t err;
    int rc = -1;
    if (sb != pb || se != pe) {
        tilebuf_destroy(&tb);
        err_set(&err, "the result covers samples [%u, %u), task %u is samples [%u, %u)", sb, se,
                task, pb, pe);
    } else {
        rc = sched_task_done(m->sched, src->id, j->id, task, attempt, &tb, now, &err);
    }
    if (rc < 0) {
        mlog(m, "bad result from %s %llu '%s' for job %llu: %s",
             src->replay ? "the journal" : "worker", (unsigned long long)src->id, src->name,
             (unsigned long long)j->id, err.msg);
        sched_task_failed(m->sched, src->id, j->id, task, attempt, err.msg);
        return;
    }
    if ((rc & SCHED_MERGED) && m->journal && wire) {
        uint8_t *blob;
        size_t size;
        int tile = (int)(task % (uint32_t)j->ntiles);
        if (journal_pack_tile(wire, &blob, &size, &err) < 0) {
            journal_failed(m, j, &err);
        } else {
            if (journal_add_result(m->journal, j->id, j->round, task, 0, tile, (int)pass, blob,
                                   size, &err) < 0)
                journal_failed(m, j, &err);
            else
                j->journaled_bytes += size;
            free(blob);
        }
    }
    if (rc & SCHED_PASS_DONE)
        passes_merged(m, j, rc, now);
    maybe_checkpoint(m, j, now);
}

static void on_result(master_t *m, mworker_t *w, const proto_msg_t *msg, double now)
{
    const proto_tile_result_t *r = &msg->result.tile;
    uint64_t job = msg->result.job, task = msg->result.task;
    uint32_t attempt = msg->result.attempt;
    mjob_t *j = job_by_id(m, job);
    if (!j) {
        mlog(m, "worker %llu sent a result for job %llu, which does not exist",
             (unsigned long long)w->id, (unsigned long long)job);
        return;
    }
    if (!j->in_sched || task >> 32 != j->round)
        return; /* finished already, or of an earlier round: a late copy of a re-issued task */
    uint32_t t32 = (uint32_t)(task & UINT32_MAX);
    source_t src = {.id = w->id, .name = w->name};
    if (msg->result.kind == PROTO_KIND_PHOTON_BATCH || (t32 & SCHED_PHOTON_TASK)) {
        if (msg->result.kind != PROTO_KIND_PHOTON_BATCH) {
            mlog(m, "worker %llu '%s' sent a camera result for photon batch task %u of job %llu",
                 (unsigned long long)w->id, w->name, t32, (unsigned long long)job);
            sched_task_failed(m->sched, w->id, job, t32, attempt, "a camera result for a photon batch");
        } else {
            photon_result(m, j, &src, t32, attempt, &msg->result.photons, now);
        }
        job_refresh(m, j, now);
        return;
    }
    err_t err;
    tilebuf_t *tb = tilebuf_new_from(r->rect.x0, r->rect.y0, r->rect.w, r->rect.h, r->nbuckets,
                                     r->sums, r->counts, r->lum, r->lum_sq, r->nonfinite, &err);
    if (!tb) {
        mlog(m, "bad result from worker %llu '%s' for job %llu: %s", (unsigned long long)w->id,
             w->name, (unsigned long long)job, err.msg);
        sched_task_failed(m->sched, w->id, job, t32, attempt, err.msg);
    } else {
        camera_result(m, j, &src, t32, attempt, tb, r->rect.sample_begin, r->rect.sample_end, r,
                      now);
    }
    job_refresh(m, j, now);
}

static void on_task_failed(master_t *m, mworker_t *w, const proto_msg_t *msg, double now)
{
    mjob_t *j = job_by_id(m, msg->task_failed.job);
    if (!j || !j->in_sched || msg->task_failed.task >> 32 != j->round)
        return;
    mlog(m, "job %llu task %llu failed on worker %llu '%s': %s", (unsigned long long)j->id,
         (unsigned long long)msg->task_failed.task, (unsigned long long)w->id, w->name,
         msg->task_failed.error);
    sched_task_failed(m->sched, w->id, j->id, (uint32_t)(msg->task_failed.task & UINT32_MAX),
                      msg->task_failed.attempt, msg->task_failed.error);
    job_refresh(m, j, now);
}

static void on_scene_request(master_t *m, mworker_t *w, const proto_msg_t *msg)
{
    proto_msg_t scene;
    err_t err;
    if (spool_scene_read(m->spool, msg->scene_request.scene, &m->limits, &scene, &err) < 0) {
        mlog(m, "worker %llu asked for scene %.12s: %s", (unsigned long long)w->id,
             msg->scene_request.scene, err.msg);
        return;
    }
    if (send_worker(m, w, &scene) == 0)
        mlog(m, "scene %.12s sent to worker %llu '%s'", msg->scene_request.scene,
             (unsigned long long)w->id, w->name);
    proto_msg_free(&scene);
}

/* A worker asks for a job's merged photon store by its hash. */
static void on_store_request(master_t *m, mworker_t *w, const proto_msg_t *msg)
{
    for (size_t i = 0; i < m->njobs; i++) {
        mjob_t *j = m->jobs[i];
        if (!j->photons || !j->store_ready || strcmp(j->store, msg->store_request.store) != 0)
            continue;
        const uint8_t *data;
        size_t size;
        const char *hash;
        err_t err;
        if (photon_phase_store(j->photons, &data, &size, &hash, &err) < 0) {
            mlog(m, "worker %llu asked for photon store %.12s: %s", (unsigned long long)w->id,
                 msg->store_request.store, err.msg);
            return;
        }
        proto_msg_t out = {.type = PROTO_STORE, .store = {.data = data, .size = size}};
        memcpy(out.store.store, hash, sizeof out.store.store);
        if (send_worker(m, w, &out) == 0)
            mlog(m, "photon store %.12s (%.1f MB) sent to worker %llu '%s'", hash, size / 1e6,
                 (unsigned long long)w->id, w->name);
        return;
    }
    mlog(m, "worker %llu asked for photon store %.12s, which no job has", (unsigned long long)w->id,
         msg->store_request.store);
}

static void on_worker_message(master_t *m, const proto_peer_t *from, const proto_msg_t *msg,
                              double now)
{
    mworker_t *w = worker_by_peer(m, from);
    if (msg->type == PROTO_HELLO) {
        on_hello(m, from, w, msg, now);
        return;
    }
    char who[PROTO_PEER_STR];
    if (!w || !w->alive) {
        /* A worker the master forgot (restarted) or gave up on (silent too long): its work is
         * still good, but its slots were handed out again, so it must start afresh. */
        if (w && msg->type == PROTO_RESULT)
            on_result(m, w, msg, now);
        mlog(m, "%s from %s, which has not said HELLO: refused", proto_type_name(msg->type),
             proto_peer_str(from, who));
        send_refuse(m, m->wnet, from, "unknown worker: send HELLO");
        return;
    }
    w->last_seen = now;
    sched_worker_seen(m->sched, w->id, now);
    switch (msg->type) {
    case PROTO_HEARTBEAT:
        break;
    case PROTO_RESULT:
        on_result(m, w, msg, now);
        break;
    case PROTO_TASK_FAILED:
        on_task_failed(m, w, msg, now);
        break;
    case PROTO_SCENE_REQUEST:
        on_scene_request(m, w, msg);
        break;
    case PROTO_STORE_REQUEST:
        on_store_request(m, w, msg);
        break;
    default: {
        char reason[128];
        snprintf(reason, sizeof reason, "%s is not a message for the master's worker endpoint",
                 proto_type_name(msg->type));
        mlog(m, "%s from worker %s: refused", proto_type_name(msg->type),
             proto_peer_str(from, who));
        send_refuse(m, m->wnet, from, reason);
    }
    }
}

/* ---------------------------------------------------------------- client messages */

/* Done, failed or cancelled: what a STATUS long poll waits for. */
static bool job_over(const mjob_t *j)
{
    return j->state == JOB_DONE || j->state == JOB_FAILED || j->state == JOB_CANCELLED;
}

static void reply(master_t *m, const proto_peer_t *to, const proto_msg_t *msg)
{
    err_t err;
    if (proto_net_send(m->cnet, to, msg, &err) < 0)
        mlog(m, "cannot answer a client: %s", err.msg);
}

__attribute__((format(printf, 3, 4))) static void reply_error(master_t *m, const proto_peer_t *to,
                                                              const char *fmt, ...)
{
    char text[PROTO_MAX_STRING];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    proto_msg_t e = {.type = PROTO_ERROR, .error = {.message = text}};
    reply(m, to, &e);
}

/* Removes every occurrence of prefix from msg (the spool folder from the loader's messages, so
 * that the client sees paths as they are in its bundle). */
static void strip_all(char *msg, const char *prefix)
{
    size_t n = strlen(prefix);
    char *p;
    while (n > 0 && (p = strstr(msg, prefix)))
        memmove(p, p + n, strlen(p + n) + 1);
}

/* The figures a job takes from its loaded scene: sizes, seed, grid, what it runs with. */
static void job_take_scene(mjob_t *j, const scene_t *scene)
{
    static const char *integ_names[] = {"simplepath", "path", "whitted"};
    const render_settings_t *rs = &scene->settings;
    j->integrator_used = !rs->photon.enabled                     ? integ_names[rs->integrator]
                         : rs->integrator == INTEGRATOR_WHITTED ? "photon+whitted"
                                                                : "photon+path";
    j->dispersion_used = !scene->has_dispersion                 ? "off"
                         : rs->dispersion == DISPERSION_HERO ? "hero"
                                                             : "fanout";
    j->xres = rs->xres;
    j->yres = rs->yres;
    j->spp = rs->spp;
    j->seed = rs->seed;
    j->grid = rs->grid;
}

static void job_set_settings(mjob_t *j, const proto_settings_t *set)
{
    j->settings = *set;
    j->settings.integrator = NULL;
    j->settings.dispersion = NULL;
    if (set->integrator) {
        snprintf(j->integrator, sizeof j->integrator, "%s", set->integrator);
        j->settings.integrator = j->integrator;
    }
    if (set->dispersion) {
        snprintf(j->dispersion, sizeof j->dispersion, "%s", set->dispersion);
        j->settings.dispersion = j->dispersion;
    }
}

/* A job made from its scene, dir/main loaded with the settings and confined to dir (the scene
 * reads nothing else, so no message can show a client a file of the master's host); a photon
 * job gets a fresh photon phase, which keeps the scene to check and merge batches against.
 * Not yet scheduled (job_schedule). */
static mjob_t *job_new(uint64_t id, const char *name, const char *hash, const char *main,
                       const proto_settings_t *set, const char *dir, err_t *err)
{
    size_t main_size = strlen(dir) + strlen(main) + 2;
    char *main_path = malloc(main_size);
    mjob_t *j = calloc(1, sizeof *j);
    if (!main_path || !j || !(j->name = dup_str(name)) || !(j->main = dup_str(main))) {
        free(main_path);
        job_free(j);
        err_set(err, "the master is out of memory");
        return NULL;
    }
    snprintf(main_path, main_size, "%s/%s", dir, main);
    scene_overrides_t ov = settings_to_overrides(set);
    scene_t *scene = scene_load_file_confined(main_path, dir, &ov, err);
    free(main_path);
    if (!scene) {
        job_free(j);
        return NULL;
    }
    job_take_scene(j, scene);
    bool photon = scene->settings.photon.enabled;
    uint64_t photons = scene->settings.photon.photons;
    if (photon && !(j->photons = photon_phase_new(&scene, err))) {
        job_free(j);
        return NULL;
    }
    scene_destroy(&scene);
    j->id = id;
    make_stem(j->name, j->stem, sizeof j->stem);
    snprintf(j->hash, sizeof j->hash, "%s", hash);
    job_set_settings(j, set);
    j->photon_job = photon;
    j->round_photons = photon ? photons : 0;
    j->state = JOB_QUEUED;
    j->stop = PROTO_STOP_NONE;
    return j;
}

/* Adds a new job to the scheduler, with photon_batches batches before its camera phase and
 * whole passes when it may end early, and to the master's list. */
static int job_schedule(master_t *m, mjob_t *j, uint32_t photon_batches, err_t *err)
{
    if (m->njobs == m->cap_jobs) {
        size_t cap = m->cap_jobs ? 2 * m->cap_jobs : 16;
        mjob_t **p = realloc(m->jobs, cap * sizeof *p);
        if (!p)
            return err_set(err, "the master is out of memory");
        m->jobs = p;
        m->cap_jobs = cap;
    }
    bool may_stop = j->settings.target_error > 0 || j->settings.time_limit > 0;
    sched_job_info_t info;
    if (sched_add_job(m->sched, j->id, j->xres, j->yres, j->spp, j->grid, err) < 0)
        return -1;
    if ((may_stop && sched_set_whole_passes(m->sched, j->id, err) < 0) ||
        (photon_batches > 0 && sched_add_photon_batches(m->sched, j->id, photon_batches, err) < 0) ||
        sched_job_info(m->sched, j->id, &info) < 0) {
        err_t ignore;
        sched_cancel_job(m->sched, j->id, &ignore);
        (void)sched_remove_job(m->sched, j->id, &ignore);
        return -1;
    }
    j->ntiles = info.ntiles;
    j->samples_total = info.samples_total;
    j->in_sched = true;
    m->jobs[m->njobs++] = j;
    return 0;
}

/* Takes a job back out of the master's list and the scheduler (a submission that could not be
 * journaled). */
static void job_unschedule(master_t *m, mjob_t *j)
{
    err_t ignore;
    (void)sched_cancel_job(m->sched, j->id, &ignore);
    (void)sched_remove_job(m->sched, j->id, &ignore);
    for (size_t i = 0; i < m->njobs; i++)
        if (m->jobs[i] == j) {
            memmove(&m->jobs[i], &m->jobs[i + 1], (m->njobs - i - 1) * sizeof *m->jobs);
            m->njobs--;
            break;
        }
    job_free(j);
}

static void on_submit(master_t *m, const proto_peer_t *from, const proto_msg_t *msg, double now)
{
    const proto_bundle_t *b = &msg->submit.bundle;
    char who[PROTO_PEER_STR];
    proto_peer_str(from, who);
    err_t err;
    char hash[PROTO_HASH_HEX + 1];
    if (proto_bundle_check(b, &m->limits, &err) < 0 || proto_bundle_hash(b, hash, &err) < 0) {
        mlog(m, "submission '%s' from %s refused: %s", msg->submit.name, who, err.msg);
        reply_error(m, from, "scene bundle refused: %s", err.msg);
        return;
    }
    char dir[PATH_MAX];
    bool staged;
    if (spool_scene_stage(m->spool, b, hash, dir, sizeof dir, &staged, &err) < 0) {
        mlog(m, "cannot store scene %.12s: %s", hash, err.msg);
        reply_error(m, from, "the master cannot store the scene: %s", err.msg);
        return;
    }
    uint64_t id = m->last_job + 1;
    const proto_settings_t *set = &msg->submit.settings;
    mjob_t *j = job_new(id, msg->submit.name, hash, b->main, set, dir, &err);
    if (!j) {
        /* The client named files of its bundle, not the master's spool folder. */
        char prefix[PATH_MAX + 1];
        char *real = realpath(dir, NULL);
        if (real) {
            snprintf(prefix, sizeof prefix, "%s/", real);
            strip_all(err.msg, prefix);
            free(real);
        }
        snprintf(prefix, sizeof prefix, "%s/", dir);
        strip_all(err.msg, prefix);
        spool_scene_discard(m->spool, dir, staged);
        mlog(m, "submission '%s' from %s refused: %s", msg->submit.name, who, err.msg);
        reply_error(m, from, "%s", err.msg);
        return;
    }
    if (spool_scene_commit(m->spool, b, hash, dir, staged, &m->limits, &err) < 0) {
        job_free(j);
        spool_scene_discard(m->spool, dir, staged);
        mlog(m, "cannot store scene %.12s: %s", hash, err.msg);
        reply_error(m, from, "the master cannot store the scene: %s", err.msg);
        return;
    }
    if (job_schedule(m, j, j->photons ? photon_phase_nbatches(j->photons) : 0, &err) < 0) {
        job_free(j);
        mlog(m, "submission '%s' from %s refused: %s", msg->submit.name, who, err.msg);
        reply_error(m, from, "%s", err.msg);
        return;
    }
    j->submitted = now;
    /* Journaled before it is acknowledged: a job the client was told about survives a
     * restart. */
    journal_job_t rec = job_record(j, now);
    if (m->journal && journal_add_job(m->journal, &rec, &err) < 0) {
        mlog(m, "submission '%s' from %s refused: %s", msg->submit.name, who, err.msg);
        job_unschedule(m, j);
        reply_error(m, from, "the master cannot journal the job: %s", err.msg);
        return;
    }
    m->last_job = id;
    /* The job's folder marks its id as used, so a restarted master never gives it out again
     * (spool_last_job_id counts these folders), even if nothing was rendered yet. */
    char jobdir[PATH_MAX];
    if (spool_job_dir(m->spool, id, jobdir, sizeof jobdir, &err) < 0)
        mlog(m, "job %llu: %s", (unsigned long long)id, err.msg);
    proto_msg_t ok = {.type = PROTO_SUBMITTED, .submitted = {.job = id}};
    reply(m, from, &ok);
    sched_job_info_t info;
    (void)sched_job_info(m->sched, id, &info);
    char rules[96] = "";
    if (set->target_error > 0)
        snprintf(rules, sizeof rules, ", target error %g", set->target_error);
    if (set->time_limit > 0)
        snprintf(rules + strlen(rules), sizeof rules - strlen(rules), ", time limit %g s",
                 set->time_limit);
    mlog(m,
         "job %llu '%s' submitted by %s: %dx%d, %d spp, %d buckets, %d tiles x %d passes, %u "
         "photon batches, scene %.12s%s%s",
         (unsigned long long)id, j->name, who, j->xres, j->yres, j->spp, j->grid.n, info.ntiles,
         info.npasses, info.photon_batches, hash, staged ? "" : " (stored already)", rules);
}

static void reply_jobs(master_t *m, const proto_peer_t *to, proto_type_t type, const mjob_t *only,
                       double now)
{
    size_t n = only ? 1 : m->njobs, first = 0;
    if (n > PROTO_MAX_LIST) {
        first = n - PROTO_MAX_LIST; /* the most recent ones */
        n = PROTO_MAX_LIST;
    }
    proto_job_info_t *infos = n ? calloc(n, sizeof *infos) : NULL;
    if (n && !infos) {
        reply_error(m, to, "the master is out of memory");
        return;
    }
    for (size_t i = 0; i < n; i++)
        infos[i] = job_wire_info(m, only ? only : m->jobs[first + i], now);
    proto_msg_t r = {.type = type};
    if (type == PROTO_STATUS_REPLY)
        r.status_reply.jobs = infos, r.status_reply.njobs = n;
    else
        r.jobs_reply.jobs = infos, r.jobs_reply.njobs = n;
    reply(m, to, &r);
    free(infos);
}

static void reply_workers(master_t *m, const proto_peer_t *to, double now)
{
    size_t ns = sched_worker_table(m), n = m->nworkers;
    proto_worker_info_t *infos = n ? calloc(n, sizeof *infos) : NULL;
    if (n && !infos) {
        reply_error(m, to, "the master is out of memory");
        return;
    }
    for (size_t i = 0; i < n; i++) {
        const mworker_t *w = m->workers[i];
        const sched_worker_info_t *si = sched_worker_of(m, ns, w->id);
        double seen = now - w->last_seen;
        infos[i] = (proto_worker_info_t){.name = w->name,
                                         .id = w->id,
                                         .threads = w->threads,
                                         .state = !w->alive              ? PROTO_WORKER_LOST
                                                  : (si && si->busy > 0) ? PROTO_WORKER_BUSY
                                                                         : PROTO_WORKER_IDLE,
                                         .tasks_done = si ? si->tasks_done : 0,
                                         .last_seen = seen > 0 ? seen : 0};
    }
    proto_msg_t r = {.type = PROTO_WORKERS_REPLY,
                     .workers_reply = {.workers = infos, .nworkers = n}};
    reply(m, to, &r);
    free(infos);
}

static void on_fetch(master_t *m, const proto_peer_t *from, const proto_msg_t *msg)
{
    mjob_t *j = job_by_id(m, msg->fetch.job);
    if (!j) {
        reply_error(m, from, "no job %llu", (unsigned long long)msg->fetch.job);
        return;
    }
    char path[PATH_MAX + 200], name[128];
    const char *state = job_state_name(j->state);
    if (j->outputs) {
        const char *ext = msg->fetch.what == PROTO_FETCH_EXR ? "exr" : "png";
        snprintf(path, sizeof path, "%s/jobs/%llu/%s.%s", spool_path(m->spool),
                 (unsigned long long)j->id, j->stem, ext);
        snprintf(name, sizeof name, "%s.%s", j->stem, ext);
    } else if (msg->fetch.what == PROTO_FETCH_EXR) {
        reply_error(m, from, "job %llu is %s: its EXR exists once it is done",
                    (unsigned long long)j->id, state);
        return;
    } else if (j->preview) {
        snprintf(path, sizeof path, "%s/jobs/%llu/preview.png", spool_path(m->spool),
                 (unsigned long long)j->id);
        snprintf(name, sizeof name, "%s-preview.png", j->stem);
    } else {
        reply_error(m, from, "job %llu is %s and has no image yet (a preview follows each pass)",
                    (unsigned long long)j->id, state);
        return;
    }
    uint8_t *data;
    size_t size;
    err_t err;
    size_t max = m->limits.max_message_bytes > FILE_OVERHEAD
                     ? m->limits.max_message_bytes - FILE_OVERHEAD
                     : 0;
    if (spool_read_file(path, max, &data, &size, &err) < 0) {
        mlog(m, "fetch of job %llu: %s", (unsigned long long)j->id, err.msg);
        reply_error(m, from, "job %llu: %s", (unsigned long long)j->id, err.msg);
        return;
    }
    proto_msg_t f = {.type = PROTO_FILE, .file = {.name = name, .data = data, .size = size}};
    reply(m, from, &f);
    free(data);
}

/* The photon pass of a finished job back from disk: its scene loaded again from the spool (as
 * at submission, confined to the bundle's folder) and its merged store from photons.store. */
static int restore_photons(master_t *m, mjob_t *j, err_t *err)
{
    char dir[PATH_MAX], path[PATH_MAX + 32], scene_dir[PATH_MAX], main_path[2 * PATH_MAX];
    if (spool_job_dir(m->spool, j->id, dir, sizeof dir, err) < 0)
        return -1;
    snprintf(path, sizeof path, "%s/photons.store", dir);
    snprintf(scene_dir, sizeof scene_dir, "%s/scenes/%s", spool_path(m->spool), j->hash);
    snprintf(main_path, sizeof main_path, "%s/%s", scene_dir, j->main);
    scene_overrides_t ov = settings_to_overrides(&j->settings);
    scene_t *scene = scene_load_file_confined(main_path, scene_dir, &ov, err);
    if (!scene)
        return -1;
    job_take_scene(j, scene); /* a job a restarted master read from its journal has no figures */
    uint8_t *data = NULL;
    size_t size = 0;
    if (spool_read_file(path, m->limits.max_message_bytes, &data, &size, err) < 0) {
        scene_destroy(&scene);
        return -1;
    }
    j->photons = photon_phase_restore(&scene, data, size, j->photons_saved, err);
    free(data);
    return j->photons ? 0 : -1;
}

/* More photons for a finished photon job: the phase appends batches, a fresh scheduler job
 * runs them and then the whole camera phase again, gathering from the grown store; the job's
 * outputs are rewritten when it is done. Tasks carry the new round, so late results of the old
 * one are ignored. */
static void on_refine(master_t *m, const proto_peer_t *from, const proto_msg_t *msg, double now)
{
    mjob_t *j = job_by_id(m, msg->refine.job);
    if (!j) {
        reply_error(m, from, "no job %llu", (unsigned long long)msg->refine.job);
        return;
    }
    if (!j->photon_job) {
        reply_error(m, from, "job %llu has no photon pass to refine (its integrator is not \"photon\")",
                    (unsigned long long)j->id);
        return;
    }
    if (j->state != JOB_DONE || j->in_sched) {
        reply_error(m, from, "job %llu is %s: only a finished job can be refined",
                    (unsigned long long)j->id, job_state_name(j->state));
        return;
    }
    err_t err;
    if (!j->photons && restore_photons(m, j, &err) < 0) {
        mlog(m, "job %llu: cannot refine: %s", (unsigned long long)j->id, err.msg);
        reply_error(m, from, "job %llu: cannot restore its photon pass: %s", (unsigned long long)j->id,
                    err.msg);
        return;
    }
    uint32_t base = photon_phase_nbatches(j->photons);
    if (photon_phase_refine(j->photons, msg->refine.photons, &err) < 0) {
        reply_error(m, from, "job %llu: %s", (unsigned long long)j->id, err.msg);
        return;
    }
    uint32_t added = photon_phase_nbatches(j->photons) - base;
    bool may_stop = j->settings.target_error > 0 || j->settings.time_limit > 0;
    if (sched_add_job(m->sched, j->id, j->xres, j->yres, j->spp, j->grid, &err) < 0 ||
        (may_stop && sched_set_whole_passes(m->sched, j->id, &err) < 0) ||
        sched_add_photon_batches(m->sched, j->id, added, &err) < 0) {
        err_t ignore;
        (void)sched_remove_job(m->sched, j->id, &ignore);
        /* The phase has batches nobody will run: the job can be neither rendered nor refined
         * again, so it fails with the reason. */
        mlog(m, "job %llu: refinement failed: %s", (unsigned long long)j->id, err.msg);
        job_set_error(j, err.msg);
        j->state = JOB_FAILED;
        journal_state(m, j, now);
        reply_error(m, from, "job %llu: %s", (unsigned long long)j->id, err.msg);
        return;
    }
    sched_job_info_t info;
    if (sched_job_info(m->sched, j->id, &info) == 0)
        j->ntiles = info.ntiles;
    j->photon_base = base;
    j->refine_photons = msg->refine.photons;
    j->round_photons = photon_phase_stats(j->photons).photons + msg->refine.photons;
    j->round++;
    j->store_ready = false;
    j->in_sched = true;
    j->state = JOB_QUEUED;
    j->started = j->finished = 0;
    j->samples_done = 0;
    j->nhistory = j->spp_done = 0; /* the round's accuracy, with its own stopping rules */
    j->stop = PROTO_STOP_NONE;
    j->submitted = now;
    j->checkpoint = 0;
    j->journaled_bytes = 0;
    j->checkpoint_samples = 0;
    journal_job_t rec = job_record(j, now);
    if (m->journal && journal_set_round(m->journal, &rec, &err) < 0)
        journal_failed(m, j, &err);
    photon_phase_stats_t ps = photon_phase_stats(j->photons);
    mlog(m, "job %llu '%s' refined: %llu more photons in %u batches (%llu so far), then the camera "
         "phase again",
         (unsigned long long)j->id, j->name, (unsigned long long)msg->refine.photons, added,
         (unsigned long long)ps.photons);
    proto_msg_t ok = {.type = PROTO_SUBMITTED, .submitted = {.job = j->id}};
    reply(m, from, &ok);
}

/* opts->max_jobs: each unfinished job holds its framebuffer and scheduler state, so a client
 * cannot make the master hold them without bound (docs/security.md). */
static bool submit_room(master_t *m, const proto_peer_t *from, const proto_msg_t *msg)
{
    size_t open = 0;
    for (size_t i = 0; i < m->njobs; i++)
        open += !job_over(m->jobs[i]);
    if (open < m->opts->max_jobs)
        return true;
    char who[PROTO_PEER_STR];
    mlog(m, "submission '%s' from %s refused: %zu unfinished jobs, the limit", msg->submit.name,
         proto_peer_str(from, who), open);
    reply_error(m, from,
                "the master holds %zu unfinished jobs, its limit (--max-jobs %zu): submit again "
                "when one is done",
                open, m->opts->max_jobs);
    return false;
}

static void on_client_message(master_t *m, const proto_peer_t *from, const proto_msg_t *msg,
                              double now)
{
    switch (msg->type) {
    case PROTO_SUBMIT:
        if (submit_room(m, from, msg))
            on_submit(m, from, msg, now);
        break;
    case PROTO_STATUS:
        if (msg->status.all) {
            reply_jobs(m, from, PROTO_STATUS_REPLY, NULL, now);
        } else {
            const mjob_t *j = job_by_id(m, msg->status.job);
            if (!j)
                reply_error(m, from, "no job %llu", (unsigned long long)msg->status.job);
            else if (msg->status.wait_ms == 0 || job_over(j) || m->nwaiters == MAX_WAITERS)
                reply_jobs(m, from, PROTO_STATUS_REPLY, j, now);
            else
                m->waiters[m->nwaiters++] = (waiter_t){
                    .peer = *from, .job = j->id, .deadline = now + msg->status.wait_ms / 1000.0};
        }
        break;
    case PROTO_JOBS:
        reply_jobs(m, from, PROTO_JOBS_REPLY, NULL, now);
        break;
    case PROTO_WORKERS:
        reply_workers(m, from, now);
        break;
    case PROTO_FETCH:
        on_fetch(m, from, msg);
        break;
    case PROTO_REFINE:
        on_refine(m, from, msg, now);
        break;
    case PROTO_CANCEL: {
        mjob_t *j = job_by_id(m, msg->cancel.job);
        if (!j) {
            reply_error(m, from, "no job %llu", (unsigned long long)msg->cancel.job);
            break;
        }
        err_t err;
        if (j->in_sched && sched_cancel_job(m->sched, j->id, &err) < 0)
            mlog(m, "cancel: %s", err.msg);
        job_refresh(m, j, now);
        reply_jobs(m, from, PROTO_STATUS_REPLY, j, now);
        break;
    }
    default: {
        char who[PROTO_PEER_STR];
        mlog(m, "%s from client %s: not a client request", proto_type_name(msg->type),
             proto_peer_str(from, who));
        reply_error(m, from, "%s is not a request the master's client endpoint answers",
                    proto_type_name(msg->type));
    }
    }
}

/* ---------------------------------------------------------------- resuming from the journal */

/* Removes jobs/<id>/checkpoint-*.bin other than generation keep (0: all): files a master
 * killed between writing a checkpoint and journaling it, or between journaling the next one
 * and removing this one, left behind. */
static void remove_stale_checkpoints(master_t *m, uint64_t id, uint64_t keep)
{
    char dir[PATH_MAX];
    snprintf(dir, sizeof dir, "%s/jobs/%llu", spool_path(m->spool), (unsigned long long)id);
    DIR *d = opendir(dir);
    if (!d)
        return;
    struct dirent *e;
    while ((e = readdir(d))) {
        unsigned long long gen;
        char tail[8];
        if (sscanf(e->d_name, "checkpoint-%llu.bi%1s", &gen, tail) != 2 ||
            (gen == keep && !strstr(e->d_name, ".tmp")))
            continue;
        char path[PATH_MAX + 300];
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        (void)unlink(path);
    }
    (void)closedir(d);
}

/* A job of the journal as the master lists it without rendering it: one that is over, or one
 * that cannot be resumed. */
static mjob_t *job_from_record(const journal_job_t *r)
{
    mjob_t *j = calloc(1, sizeof *j);
    if (!j || !(j->name = dup_str(r->name)) || !(j->main = dup_str(r->main)) ||
        (r->error && !(j->error = dup_str(r->error)))) {
        job_free(j);
        return NULL;
    }
    j->id = r->id;
    make_stem(j->name, j->stem, sizeof j->stem);
    snprintf(j->hash, sizeof j->hash, "%s", r->hash);
    job_set_settings(j, &r->settings);
    j->state = (job_state_t)r->state;
    j->outputs = r->outputs;
    j->stop = (proto_stop_t)r->stop;
    j->samples_done = r->samples_done;
    j->samples_total = r->samples_total;
    j->nonfinite = r->nonfinite;
    j->spp_done = r->spp_done;
    j->round = r->round;
    j->photons_saved = r->photons_saved;
    j->photon_job = r->photons_saved > 0;
    j->round_photons = r->round_photons;
    j->integrator_used = j->dispersion_used = "?";
    return j;
}

static int jobs_append(master_t *m, mjob_t *j)
{
    if (m->njobs == m->cap_jobs) {
        size_t cap = m->cap_jobs ? 2 * m->cap_jobs : 16;
        mjob_t **p = realloc(m->jobs, cap * sizeof *p);
        if (!p)
            return -1;
        m->jobs = p;
        m->cap_jobs = cap;
    }
    m->jobs[m->njobs++] = j;
    return 0;
}

typedef struct replay {
    master_t *m;
    mjob_t *j;
    double now;
    size_t results;
} replay_t;

static int replay_result(void *user, uint32_t task, int kind, const void *data, size_t size,
                         err_t *err)
{
    replay_t *rp = user;
    source_t src = {.id = 0, .name = "journal", .replay = true};
    sched_job_info_t info;
    if (sched_job_info(rp->m->sched, rp->j->id, &info) < 0)
        return err_set(err, "the job left the scheduler during its replay");
    if (info.state == JOB_QUEUED && sched_restore_job(rp->m->sched, rp->j->id, NULL, NULL, 0, err) < 0)
        return -1;
    if (info.state != JOB_QUEUED && info.state != JOB_RUNNING)
        return 0; /* over already (the journal held more than it needed) */
    if (kind == 1) {
        proto_photon_result_t r;
        if (journal_unpack_photons(data, size, &r, err) < 0)
            return -1;
        photon_result(rp->m, rp->j, &src, task, 0, &r, rp->now);
    } else {
        uint32_t sb, se;
        tilebuf_t *tb = journal_unpack_tile(data, size, &sb, &se, err);
        if (!tb)
            return -1;
        camera_result(rp->m, rp->j, &src, task, 0, tb, sb, se, NULL, rp->now);
        rp->j->journaled_bytes += size;
    }
    rp->results++;
    return 0;
}

/* An unfinished job of the journal back in the scheduler where the journal leaves it: its
 * photon store from disk (or a fresh phase), its last checkpoint, its pass records, then every
 * result journaled since, merged again in the scheduler's order. */
static int resume_job(master_t *m, const journal_job_t *r, double now, err_t *err)
{
    char dir[PATH_MAX];
    snprintf(dir, sizeof dir, "%s/scenes/%s", spool_path(m->spool), r->hash);
    mjob_t *j = job_new(r->id, r->name, r->hash, r->main, &r->settings, dir, err);
    if (!j)
        return -1;
    j->round = r->round;
    j->photons_saved = r->photons_saved;
    j->round_photons = r->round_photons;
    j->refine_photons = r->refine_photons;
    j->submitted = now;
    uint32_t batches = 0, photons_done = 0;
    if (j->photons && r->photons_saved > 0) {
        photon_phase_destroy(&j->photons);
        if (restore_photons(m, j, err) < 0) {
            job_free(j);
            return -1;
        }
        uint32_t base = photon_phase_nbatches(j->photons);
        if (r->photons_saved >= r->round_photons) {
            batches = photons_done = base; /* the round's store is merged: camera phase */
        } else if (photon_phase_refine(j->photons, r->round_photons - r->photons_saved, err) < 0) {
            job_free(j);
            return -1;
        } else {
            j->photon_base = base;
            batches = photon_phase_nbatches(j->photons) - base;
        }
    } else if (j->photons) {
        batches = photon_phase_nbatches(j->photons);
    }
    if (job_schedule(m, j, batches, err) < 0) {
        job_free(j);
        return -1;
    }
    /* From here on the job is listed: a failure fails it, with the reason. */
    int rc = 0;
    tilebuf_t *image = NULL;
    int *next = NULL;
    if (r->checkpoint > 0) {
        char path[PATH_MAX + 64];
        checkpoint_path(m, j->id, r->checkpoint, path, sizeof path);
        if (!(next = malloc((size_t)j->ntiles * sizeof *next)))
            rc = err_set(err, "out of memory");
        else if ((rc = journal_read_checkpoint(path, j->xres, j->yres, j->grid.n, j->ntiles,
                                               &image, next, err)) == 0)
            j->checkpoint = r->checkpoint;
    }
    if (rc == 0 && (image || photons_done > 0))
        rc = sched_restore_job(m->sched, j->id, &image, image ? next : NULL, photons_done, err);
    free(next);
    tilebuf_destroy(&image);
    if (rc >= 0 && photons_done > 0)
        photon_phase_merged(m, j);
    if (rc >= 0) {
        journal_pass_t passes[MAX_PASS_RECORDS];
        int n = journal_passes(m->journal, j->id, j->round, passes, MAX_PASS_RECORDS, err);
        rc = n < 0 ? -1 : 0;
        for (int i = 0; i < n; i++)
            j->history[j->nhistory++] =
                (pass_record_t){.pass = passes[i].pass, .spp = passes[i].spp,
                                .elapsed = passes[i].elapsed, .valid = passes[i].valid,
                                .rel_error = passes[i].rel_error};
    }
    sched_job_info_t info;
    if (rc >= 0 && sched_job_info(m->sched, j->id, &info) == 0) {
        j->checkpoint_samples = info.samples_done;
        if (info.state == JOB_RUNNING) {
            j->started = now - r->elapsed;
            j->state = JOB_RUNNING;
        }
    }
    replay_t rp = {.m = m, .j = j, .now = now};
    size_t lost = 0;
    journal_prune(m->journal, j->id);
    if (rc >= 0)
        rc = journal_results(m->journal, j->id, j->round, replay_result, &rp, &lost, err);
    if (lost > 0)
        mlog(m, "job %llu: %zu journaled results lost their files (a power cut?): rendered again",
             (unsigned long long)j->id, lost);
    if (rc < 0) {
        char msg[600];
        snprintf(msg, sizeof msg, "cannot resume it after the master restarted: %s", err->msg);
        sched_fail_job(m->sched, j->id, msg);
        job_refresh(m, j, now);
        return 0; /* listed as failed, with the reason */
    }
    remove_stale_checkpoints(m, j->id, j->checkpoint);
    if (sched_job_info(m->sched, j->id, &info) == 0)
        mlog(m, "job %llu '%s' resumed: %d of %d passes merged, %llu of %llu samples, %u of %u "
             "photon batches, %zu results from the journal",
             (unsigned long long)j->id, j->name, info.passes_done, info.npasses,
             (unsigned long long)info.samples_done, (unsigned long long)info.samples_total,
             info.photon_batches_done, info.photon_batches, rp.results);
    job_refresh(m, j, now);
    return 0;
}

/* Every job of the journal: finished ones listed (their outputs stay fetchable, a photon job
 * refinable), unfinished ones resumed. Job ids continue after the highest. */
static int resume_jobs(master_t *m, err_t *err)
{
    journal_job_t *rows;
    size_t n;
    if (journal_jobs(m->journal, &rows, &n, err) < 0)
        return -1;
    double now = now_s();
    int rc = 0;
    for (size_t i = 0; i < n && rc == 0; i++) {
        journal_job_t *r = &rows[i];
        if (r->id > m->last_job)
            m->last_job = r->id;
        char jobdir[PATH_MAX];
        if (spool_job_dir(m->spool, r->id, jobdir, sizeof jobdir, err) < 0) {
            rc = -1;
            break;
        }
        if (r->state == JOB_QUEUED || r->state == JOB_RUNNING) {
            err_t jerr;
            if (resume_job(m, r, now, &jerr) == 0)
                continue;
            /* Not even listed by resume_job (its scene cannot be loaded, say): listed as failed. */
            char msg[600];
            snprintf(msg, sizeof msg, "cannot resume it after the master restarted: %s", jerr.msg);
            free(r->error);
            r->error = dup_str(msg);
            r->state = JOB_FAILED;
            mlog(m, "job %llu '%s': %s", (unsigned long long)r->id, r->name, msg);
        }
        mjob_t *j = job_from_record(r);
        if (!j || jobs_append(m, j) < 0) {
            job_free(j);
            rc = err_set(err, "out of memory for job %llu of the journal", (unsigned long long)r->id);
            break;
        }
        remove_stale_checkpoints(m, j->id, 0);
        journal_prune(m->journal, j->id);
        if (r->state == JOB_FAILED && r->error && strstr(r->error, "after the master restarted"))
            journal_state(m, j, now); /* failed just now: the journal learns why */
    }
    for (size_t i = 0; i < n; i++)
        journal_job_clear(&rows[i]);
    free(rows);
    return rc;
}

/* ---------------------------------------------------------------- the loop */

/* Answers the STATUS long polls whose job is over or whose wait ran out; returns the time
 * until the next deadline in ms (at most POLL_MS), for the poll. */
static int answer_waiters(master_t *m, double now)
{
    double next = now + POLL_MS / 1000.0;
    size_t k = 0;
    for (size_t i = 0; i < m->nwaiters; i++) {
        waiter_t wt = m->waiters[i];
        const mjob_t *j = job_by_id(m, wt.job);
        if (!j || job_over(j) || now >= wt.deadline) {
            if (j)
                reply_jobs(m, &wt.peer, PROTO_STATUS_REPLY, j, now);
            continue;
        }
        if (wt.deadline < next)
            next = wt.deadline;
        m->waiters[k++] = wt;
    }
    m->nwaiters = k;
    double ms = (next - now) * 1000.0;
    return ms <= 0 ? 0 : (int)ms + 1; /* rounded up: waking early would only poll again */
}

/* Takes what one socket holds (at most RECV_BURST messages). Returns -1 with err when the
 * socket is unusable. */
static int drain(master_t *m, bool workers, err_t *err)
{
    proto_net_t *net = workers ? m->wnet : m->cnet;
    for (int k = 0; k < RECV_BURST; k++) {
        proto_peer_t from;
        proto_msg_t msg;
        err_t rerr;
        int rc = proto_net_recv(net, &from, &msg, 0, &rerr);
        if (rc == PROTO_EAGAIN)
            return 0;
        if (rc == PROTO_ESOCKET)
            return err_set(err, "%s socket: %s", workers ? "workers" : "clients", rerr.msg);
        if (rc == PROTO_EVERSION) {
            err_t text;
            char who[PROTO_PEER_STR];
            proto_msg_t refuse = proto_refuse_version(msg.version, "master", &text);
            mlog(m, "%s %s speaks protocol version %d: refused", workers ? "worker" : "client",
                 proto_peer_str(&from, who), msg.version);
            if (from.len > 0 && proto_net_send(net, &from, &refuse, &rerr) < 0)
                mlog(m, "cannot send REFUSE: %s", rerr.msg);
            continue;
        }
        if (rc < 0) {
            char reason[600];
            mlog(m, "malformed message on the %s endpoint %s", workers ? "workers" : "clients",
                 rerr.msg);
            snprintf(reason, sizeof reason, "malformed message: %s", rerr.msg);
            send_refuse(m, net, &from, reason);
            continue;
        }
        double now = now_s();
        if (workers)
            on_worker_message(m, &from, &msg, now);
        else
            on_client_message(m, &from, &msg, now);
        proto_msg_free(&msg);
    }
    return 0;
}

/* The time limits: a job past its limit with at least one whole pass ends now with the passes
 * merged (the pass in flight is dropped, its tasks cancelled on the workers by job_refresh); one
 * without a pass yet ends at its first pass boundary (passes_merged). */
static void enforce_time_limits(master_t *m, double now)
{
    for (size_t i = 0; i < m->njobs; i++) {
        mjob_t *j = m->jobs[i];
        sched_job_info_t info;
        if (!j->in_sched || !(j->settings.time_limit > 0) || j->started <= 0 ||
            now - j->started < j->settings.time_limit ||
            sched_job_info(m->sched, j->id, &info) < 0 || info.state != JOB_RUNNING ||
            info.passes_done < 1)
            continue;
        err_t err;
        if (sched_finish_job_at_pass(m->sched, j->id, &err) < 0) {
            mlog(m, "job %llu: cannot end it at its time limit: %s", (unsigned long long)j->id,
                 err.msg);
            continue;
        }
        j->stop = PROTO_STOP_TIME;
        mlog(m, "job %llu time limit %g s reached during pass %d: ends with %d spp",
             (unsigned long long)j->id, j->settings.time_limit, info.passes_done + 1, info.spp_done);
        job_refresh(m, j, now);
    }
}

/* Dead workers, missed deadlines and heartbeats: the clock-driven part of a loop turn. busy is
 * how long this turn's messages took to handle. */
static void housekeeping(master_t *m, double now, double busy)
{
    /* A turn that took long (a big scene loaded, an EXR written) was time the master did not
     * listen: the workers' silence during it says nothing about them. */
    if (busy > 0.5 * m->opts->sched.worker_timeout_s)
        for (size_t i = 0; i < m->nworkers; i++)
            if (m->workers[i]->alive) {
                m->workers[i]->last_seen = now;
                sched_worker_seen(m->sched, m->workers[i]->id, now);
            }
    for (size_t i = 0; i < m->nworkers; i++) {
        mworker_t *w = m->workers[i];
        if (w->alive && now - w->last_seen > m->opts->sched.worker_timeout_s) {
            char why[64];
            snprintf(why, sizeof why, "silent for %.1f s", now - w->last_seen);
            worker_lost(m, w, why);
        }
    }
    int requeued = sched_tick(m->sched, now);
    if (requeued > 0)
        mlog(m, "%d task%s past the %.0f s deadline issued again", requeued,
             requeued == 1 ? "" : "s", m->opts->sched.task_deadline_s);
    /* The scheduler's and the master's idea of who is alive must agree. */
    size_t ns = sched_worker_table(m);
    for (size_t i = 0; i < m->nworkers; i++) {
        const sched_worker_info_t *si = sched_worker_of(m, ns, m->workers[i]->id);
        if (m->workers[i]->alive && (!si || !si->alive))
            worker_lost(m, m->workers[i], "timed out");
    }
    enforce_time_limits(m, now);
    if (now - m->last_heartbeat >= m->heartbeat_s) {
        proto_msg_t hb = {.type = PROTO_HEARTBEAT};
        for (size_t i = 0; i < m->nworkers; i++)
            if (m->workers[i]->alive)
                (void)send_worker(m, m->workers[i], &hb);
        m->last_heartbeat = now;
    }
}

/* Clients send one request at a time: a few queued per connection is plenty, and the bound
 * keeps what one connection can make the master buffer to this many messages (each at most
 * limits.max_message_bytes). */
#define CLIENT_RCVHWM 4

/* A bound ROUTER; with secret_key a CURVE server whose ZAP domain names the endpoint. */
static proto_net_t *open_router(master_t *m, void *ctx, const char *what, const char *endpoint,
                                const char *secret_key, char *bound, size_t size, err_t *err)
{
    proto_net_options_t no = proto_net_options_default();
    no.limits = m->limits;
    no.curve.secret_key = secret_key;
    no.curve.zap_domain = secret_key ? what : NULL;
    if (!strcmp(what, "clients"))
        no.rcvhwm = CLIENT_RCVHWM;
    proto_net_t *net = proto_net_new(ctx, PROTO_NET_ROUTER, &no, err);
    if (!net) {
        err_prefix(err, "%s endpoint: ", what);
        return NULL;
    }
    if (proto_net_bind(net, endpoint, err) < 0 || proto_net_endpoint(net, bound, size, err) < 0) {
        err_prefix(err, "%s endpoint: ", what);
        proto_net_destroy(&net);
        return NULL;
    }
    return net;
}

static int check_opts(const master_opts_t *o, err_t *err)
{
    if (!o || !o->worker_endpoint || !o->client_endpoint || !o->spool_dir || !o->stop)
        return err_set(
            err, "master: worker and client endpoints, spool folder and stop flag are required");
    if (o->heartbeat_ms < 1 || o->heartbeat_ms > 3600000)
        return err_set(err, "master: heartbeat %d ms is outside 1..3600000", o->heartbeat_ms);
    if (o->max_jobs < 1)
        return err_set(err, "master: max_jobs is 0: no job could ever be submitted");
    if (o->limits.max_bundle_bytes > o->limits.max_message_bytes)
        return err_set(err, "master: bundles of %zu bytes cannot fit in messages of at most %zu",
                       o->limits.max_bundle_bytes, o->limits.max_message_bytes);
    if (!o->key_file != !o->authorized_dir)
        return err_set(err, "master: %s",
                       o->key_file ? "--key needs --authorized DIR, the public keys let in: "
                                     "without it any peer that knows our public key would be"
                       : "--authorized needs --key FILE, the master's own key pair");
    const char *how = "the master --key FILE and --authorized DIR";
    if (proto_curve_require(o->worker_endpoint, o->key_file, o->insecure, how, err) < 0 ||
        proto_curve_require(o->client_endpoint, o->key_file, o->insecure, how, err) < 0)
        return err_prefix(err, "master: ");
    return 0;
}

static void zap_log(void *user, const char *line)
{
    const master_t *m = user;
    if (m->opts->verbose)
        fprintf(stderr, "master: %s\n", line);
}

int master_run(const master_opts_t *opts, err_t *err)
{
    if (check_opts(opts, err) < 0)
        return -1;
    master_t *m = calloc(1, sizeof *m);
    if (!m)
        return err_set(err, "master: out of memory");
    m->opts = opts;
    m->limits = opts->limits;
    m->heartbeat_s = opts->heartbeat_ms / 1000.0;
    void *ctx = opts->zmq_ctx ? opts->zmq_ctx : zmq_ctx_new();
    int rc = -1;
    char wbound[512] = "", cbound[512] = "";
    proto_curve_pair_t keys = {0};
    proto_zap_t *zap = NULL;
    if (!ctx) {
        err_set(err, "master: zmq_ctx_new: %s", zmq_strerror(zmq_errno()));
        goto out;
    }
    /* The handler first: a CURVE server bound without one would let in every client. */
    if (opts->key_file && (proto_curve_load_pair(opts->key_file, &keys, err) < 0 ||
                           !(zap = proto_zap_new(ctx, opts->authorized_dir, zap_log, m, err)))) {
        err_prefix(err, "master: ");
        goto out;
    }
    if (!(m->spool = spool_new(opts->spool_dir, err))) {
        err_prefix(err, "master: spool: ");
        goto out;
    }
    m->last_job = spool_last_job_id(m->spool);
    if (!(m->sched = sched_new(&opts->sched, err))) {
        err_prefix(err, "master: ");
        goto out;
    }
    if (opts->journal) {
        if (!(m->journal = journal_open(spool_path(m->spool), err)) || resume_jobs(m, err) < 0) {
            err_prefix(err, "master: ");
            goto out;
        }
    }
    const char *secret = opts->key_file ? keys.secret_key : NULL;
    if (!(m->wnet = open_router(m, ctx, "workers", opts->worker_endpoint, secret, wbound,
                                sizeof wbound, err)) ||
        !(m->cnet = open_router(m, ctx, "clients", opts->client_endpoint, secret, cbound,
                                sizeof cbound, err)))
        goto out;
    if (zap)
        mlog(m, "CURVE: public key %s; %zu keys authorised in %s", keys.public_key,
             proto_zap_stats(zap).keys, opts->authorized_dir);
    else if (opts->insecure)
        mlog(m, "plain text (--insecure): anyone who reaches the endpoints can connect");
    char text[1200], path[PATH_MAX];
    snprintf(text, sizeof text, "workers %s\nclients %s\n", wbound, cbound);
    snprintf(path, sizeof path, "%s/endpoints", spool_path(m->spool));
    if (spool_write_file(path, text, strlen(text), err) < 0) {
        err_prefix(err, "master: ");
        goto out;
    }
    mlog(m, "workers on %s, clients on %s, spool %s, next job %llu", wbound, cbound,
         spool_path(m->spool), (unsigned long long)m->last_job + 1);
    if (opts->ready)
        opts->ready(opts->user, wbound, cbound);

    m->last_heartbeat = now_s();
    rc = 0;
    int until_waiter = POLL_MS;
    while (!*opts->stop) {
        /* The stop descriptor, when given, ends the wait as soon as *stop is set. */
        zmq_pollitem_t items[3] = {{.socket = proto_net_socket(m->wnet), .events = ZMQ_POLLIN},
                                   {.socket = proto_net_socket(m->cnet), .events = ZMQ_POLLIN},
                                   {.fd = opts->stop_fd, .events = ZMQ_POLLIN}};
        double until_hb = m->last_heartbeat + m->heartbeat_s - now_s();
        int timeout = until_hb < POLL_MS / 1000.0 ? (int)(until_hb * 1000) : POLL_MS;
        if (until_waiter < timeout)
            timeout = until_waiter;
        int n = zmq_poll(items, opts->stop_fd > 0 ? 3 : 2, timeout > 0 ? timeout : 0);
        double polled = now_s();
        if (n < 0 && zmq_errno() != EINTR) {
            rc = err_set(err, "master: zmq_poll: %s", zmq_strerror(zmq_errno()));
            break;
        }
        if (n > 0 && (((items[0].revents & ZMQ_POLLIN) && drain(m, true, err) < 0) ||
                      ((items[1].revents & ZMQ_POLLIN) && drain(m, false, err) < 0))) {
            err_prefix(err, "master: ");
            rc = -1;
            break;
        }
        double now = now_s();
        housekeeping(m, now, now - polled);
        dispatch(m, now);
        prune_lost(m);
        until_waiter = answer_waiters(m, now);
    }
    if (rc == 0)
        mlog(m, "stopping");

out:
    proto_net_destroy(&m->wnet);
    proto_net_destroy(&m->cnet);
    proto_zap_destroy(&zap); /* after the servers it guards */
    memset(&keys, 0, sizeof keys);
    if (ctx && !opts->zmq_ctx)
        (void)zmq_ctx_term(ctx);
    sched_destroy(&m->sched);
    journal_close(&m->journal);
    spool_destroy(&m->spool);
    for (size_t i = 0; i < m->nworkers; i++)
        worker_free(m->workers[i]);
    free(m->workers);
    for (size_t i = 0; i < m->njobs; i++)
        job_free(m->jobs[i]);
    free(m->jobs);
    free(m->winfo);
    free(m);
    return rc;
}
