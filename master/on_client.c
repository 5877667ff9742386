#define _XOPEN_SOURCE 700 /* realpath */
#include "on_client.h"

#include "access.h"
#include "bundle.h"
#include "clock.h"
#include "files.h"
#include "jobs.h"
#include "metrics.h"
#include "ops.h"
#include "loader.h"
#include "peers.h"
#include "persist.h"
#include "pool.h"
#include "tasklog.h"

#include <limits.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define FILE_OVERHEAD (64 << 10) /* room for a FILE message's envelope and name */

static void reply(master_t *m, const proto_peer_t *to, const proto_msg_t *msg)
{
    err_t err;
    if (net_send(m->cnet, to, msg, &err) < 0)
        master_log(m, "cannot answer a client: %s", err.msg);
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

static proto_job_info_t job_wire_info(const master_t *m, const mjob_t *j, double now)
{
    proto_job_info_t o = {.id = j->id,
                          .name = j->name,
                          .state = jobs_wire_state(j),
                          .priority = j->ops.priority,
                          .samples_done = j->sched.samples_done,
                          .samples_total = j->sched.samples_total,
                          .nonfinite = j->sched.nonfinite,
                          .owner = j->owner[0] ? j->owner : NULL};
    o.spp = (uint32_t)j->accuracy.spp_done;
    sched_job_info_t info;
    if (j->sched.known && sched_job_info(m->sched, j->id, &info) == 0) {
        o.samples_done = info.samples_done;
        o.samples_total = info.samples_total;
        o.nonfinite = info.nonfinite;
        o.spp = (uint32_t)info.spp_done;
    }
    const pass_record_t *last =
        j->accuracy.nhistory > 0 ? &j->accuracy.history[j->accuracy.nhistory - 1] : NULL;
    if (last && last->valid) {
        o.has_rel_error = true;
        o.rel_error = last->rel_error;
    }
    o.stop = j->accuracy.stop;
    o.elapsed = job_elapsed(m, j, now);
    if (j->state == JOB_FAILED)
        o.error = j->error ? j->error : "failed";
    else if (j->outputs.waiting)
        o.error = j->outputs.why;
    o.parent = j->seq.parent;
    o.frame = j->seq.frame;
    o.frames = j->seq.nframes;
    if (j->seq.nframes > 0) {
        /* A sequence's figures are its frames' summed; its spp the least of theirs. */
        o.samples_done = o.samples_total = o.nonfinite = 0;
        o.spp = 0;
        for (uint32_t k = 0; k < j->seq.nframes; k++) {
            const mjob_t *f = jobs_frame(m, j, k);
            if (!f)
                continue;
            proto_job_info_t fi = job_wire_info(m, f, now);
            o.samples_done += fi.samples_done;
            o.samples_total += fi.samples_total;
            o.nonfinite += fi.nonfinite;
            o.spp = k == 0 || fi.spp < o.spp ? fi.spp : o.spp;
        }
    }
    return o;
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

/* A submission between its bundle's arrival and its scene's load (loader.h): the master keeps
 * it in m->loading, the loader's thread fills job or err, and on_client_loads finishes it. */
struct submission {
    proto_peer_t peer;
    char *name, *main;
    char hash[PROTO_HASH_HEX + 1];
    char dir[PATH_MAX];
    bool staged;
    proto_settings_t settings; /* its strings point into integrator / dispersion */
    char integrator[65], dispersion[65];
    int priority; /* SUBMIT's (ops.h) */
    scene_budget_t budget;
    int load_threads; /* frames loaded at once (master_opts_t) */
    proto_limits_t limits;
    spool_t *spool; /* staged and committed into on the loader's thread (spool.h) */
    scene_shelf_t *shelf; /* the process's scenes (master_opts_t), or NULL */
    uint8_t *scene_msg; /* the SCENE message workers will be sent, stored once the scene loads */
    size_t scene_size;
    double accepted, last_progress;
    /* A frame sequence (SUBMIT's frames; nframes 0: a single scene, job): each frame's main
     * and number, and its job once loaded. */
    size_t nframes;
    char **frame_main;
    uint32_t *frame_number;
    mjob_t **frames;
    /* Filled on the loader's thread. */
    mjob_t *job;
    err_t err;
    double load_s;
};

static void on_client_submission_free(void *arg);

void on_client_submission_drop(void *arg)
{
    submission_t *s = arg;
    if (s)
        spool_scene_discard(s->spool, s->dir, s->staged);
    on_client_submission_free(s);
}

static void on_client_submission_free(void *arg)
{
    submission_t *s = arg;
    if (!s)
        return;
    job_free(s->job);
    for (size_t k = 0; k < s->nframes; k++) {
        if (s->frames)
            job_free(s->frames[k]);
        if (s->frame_main)
            free(s->frame_main[k]);
    }
    free(s->frames);
    free(s->frame_main);
    free(s->frame_number);
    free(s->scene_msg);
    free(s->name);
    free(s->main);
    free(s);
}

/* One frame load of load_frames on a pool thread: the frames' jobs are their own slots, and
 * the failure kept is the one of the lowest frame index. */
typedef struct frame_loads {
    submission_t *s;
    int inner; /* threads each load runs on (scene overrides' threads; 0: all cores) */
    pthread_mutex_t lock;
    size_t first_failed; /* index of the lowest failed frame so far; nframes: none */
} frame_loads_t;

static int load_frame(void *user, int index, err_t *err)
{
    frame_loads_t *fl = user;
    submission_t *s = fl->s;
    size_t k = (size_t)index;
    err_t e;
    scene_budget_t budget = s->budget; /* each frame's parse has its own clock */
    scene_budget_start(&budget, clock_now_s());
    s->frames[k] = job_new(0, s->frame_main[k], s->hash, s->frame_main[k], &s->settings, s->dir,
                           &budget, s->shelf, fl->inner, &e);
    if (s->frames[k]) {
        s->frames[k]->seq.frame = s->frame_number[k];
        return 0;
    }
    err_prefix(&e, "frame %u (%s): ", s->frame_number[k], s->frame_main[k]);
    pthread_mutex_lock(&fl->lock);
    if (k < fl->first_failed) {
        fl->first_failed = k;
        s->err = e;
    }
    pthread_mutex_unlock(&fl->lock);
    *err = e;
    return -1;
}

/* Each frame of a sequence loaded as a job of its own from the one staged bundle, up to
 * load_threads frames at once on the pool (pool_for; each load then runs on its share of the
 * cores), so that N frames are not N loads in series. The outcome is that of loading them one
 * after another: a frame's scene does not depend on the threads it loads on
 * (tests/unit/test_load_threads.c), and the failure reported is the first in frame order --
 * pool_for hands the indices out in increasing order and, once one fails, starts no more, so
 * every frame before the first failing one has run and been seen. */
static mjob_t *load_frames(submission_t *s)
{
    int cores = pool_cores();
    int outer = s->load_threads > 0 ? s->load_threads : cores;
    if ((size_t)outer > s->nframes)
        outer = (int)s->nframes;
    frame_loads_t fl = {.s = s, .inner = outer > 1 ? (cores / outer > 0 ? cores / outer : 1) : 0,
                        .first_failed = s->nframes};
    pthread_mutex_init(&fl.lock, NULL);
    err_t err;
    int rc = pool_for(outer, (int)s->nframes, load_frame, &fl, &err);
    pthread_mutex_destroy(&fl.lock);
    if (rc < 0)
        return NULL; /* s->err: the first failing frame's (the frames loaded are freed with s) */
    /* The sequence's own record, which job_new_sequence fills without a scene. */
    mjob_t *seq = job_new_sequence(s->name, s->hash, s->frame_main[0], &s->settings,
                                   (uint32_t)s->nframes);
    if (!seq)
        err_set(&s->err, "the master is out of memory");
    return seq;
}

/* The loader's work (its thread): the bundle staged into the spool (each file synced: seconds
 * for a large one, which the loop must not wait for), its scene loaded within the budget, then
 * the bundle committed. Touches nothing but s and the spool's scene files. */
static void submission_load(void *arg)
{
    submission_t *s = arg;
    double t0 = clock_now_s();
    proto_msg_t scene;
    if (proto_decode(s->scene_msg, s->scene_size, &s->limits, &scene, &s->err) < 0) {
        err_prefix(&s->err, "the master cannot store the scene: ");
        s->load_s = clock_now_s() - t0;
        return;
    }
    int staged = spool_scene_stage(s->spool, &scene.scene.bundle, s->hash, s->dir, sizeof s->dir,
                                   &s->staged, &s->err);
    proto_msg_free(&scene);
    if (staged < 0) {
        spool_scene_discard(s->spool, s->dir, s->staged);
        s->staged = false;
        err_prefix(&s->err, "the master cannot store the scene: ");
        s->load_s = clock_now_s() - t0;
        return;
    }
    scene_budget_start(&s->budget, clock_now_s());
    s->job = s->nframes > 0 ? load_frames(s)
                            : job_new(0, s->name, s->hash, s->main, &s->settings, s->dir,
                                      &s->budget, s->shelf, 0, &s->err);
    if (s->job) {
        if (spool_scene_commit(s->spool, s->scene_msg, s->scene_size, s->hash, s->dir,
                               s->staged, &s->err) < 0) {
            job_free(s->job);
            s->job = NULL;
            err_prefix(&s->err, "the master cannot store the scene: ");
        } else {
            s->staged = false; /* committed: nothing to discard */
        }
    } else {
        /* The client named files of its bundle, not the master's spool folder. */
        char prefix[PATH_MAX + 1];
        char *real = realpath(s->dir, NULL);
        if (real) {
            snprintf(prefix, sizeof prefix, "%s/", real);
            strip_all(s->err.msg, prefix);
            free(real);
        }
        snprintf(prefix, sizeof prefix, "%s/", s->dir);
        strip_all(s->err.msg, prefix);
        spool_scene_discard(s->spool, s->dir, s->staged);
        s->staged = false;
    }
    free(s->scene_msg);
    s->scene_msg = NULL;
    s->load_s = clock_now_s() - t0;
}

/* A SUBMIT: the bundle is checked, staged and encoded for the workers here, and its scene
 * loaded on the loader's thread, so that a large scene never blocks the loop; the client is
 * sent a PROGRESS at once (its bundle arrived; issue 15: the client heard nothing until the
 * load ended) and every PROGRESS_S while it loads, and SUBMITTED or the load's error after. */
static void on_submit(master_t *m, const proto_peer_t *from, const proto_msg_t *msg, double now)
{
    const proto_bundle_t *b = &msg->submit.bundle;
    char who[PROTO_PEER_STR];
    proto_peer_str(from, who);
    err_t err;
    char hash[PROTO_HASH_HEX + 1];
    if (proto_bundle_check(b, &m->limits, &err) < 0 || proto_bundle_hash(b, hash, &err) < 0) {
        master_log(m, "submission '%s' from %s refused: %s", msg->submit.name, who, err.msg);
        reply_error(m, from, "scene bundle refused: %s", err.msg);
        return;
    }
    submission_t *s = calloc(1, sizeof *s);
    submission_t **grown =
        s && m->nloading == m->caploading
            ? realloc(m->loading, (m->caploading ? 2 * m->caploading : 8) * sizeof *grown)
            : NULL;
    if (grown) {
        m->loading = grown;
        m->caploading = m->caploading ? 2 * m->caploading : 8;
    }
    if (!s || m->nloading == m->caploading || !(s->name = master_strdup(msg->submit.name)) ||
        !(s->main = master_strdup(b->main))) {
        on_client_submission_free(s);
        reply_error(m, from, "the master is out of memory");
        return;
    }
    size_t nf = msg->submit.nframes;
    if (nf > 0) {
        s->nframes = nf;
        s->frame_main = calloc(nf, sizeof *s->frame_main);
        s->frame_number = calloc(nf, sizeof *s->frame_number);
        s->frames = calloc(nf, sizeof *s->frames);
        bool ok = s->frame_main && s->frame_number && s->frames;
        for (size_t k = 0; ok && k < nf; k++) {
            ok = (s->frame_main[k] = master_strdup(msg->submit.frames[k].main)) != NULL;
            if (ok)
                s->frame_number[k] = msg->submit.frames[k].number;
        }
        if (!ok) {
            on_client_submission_free(s);
            reply_error(m, from, "the master is out of memory");
            return;
        }
    }
    if (spool_scene_encode(b, hash, &m->limits, &s->scene_msg, &s->scene_size, &err) < 0) {
        on_client_submission_free(s);
        master_log(m, "cannot store scene %.12s: %s", hash, err.msg);
        reply_error(m, from, "the master cannot store the scene: %s", err.msg);
        return;
    }
    s->peer = *from;
    memcpy(s->hash, hash, sizeof s->hash);
    s->settings = msg->submit.settings;
    s->priority = (int)msg->submit.priority;
    s->settings.integrator = s->settings.dispersion = NULL;
    if (msg->submit.settings.integrator) {
        snprintf(s->integrator, sizeof s->integrator, "%s", msg->submit.settings.integrator);
        s->settings.integrator = s->integrator;
    }
    if (msg->submit.settings.dispersion) {
        snprintf(s->dispersion, sizeof s->dispersion, "%s", msg->submit.settings.dispersion);
        s->settings.dispersion = s->dispersion;
    }
    s->budget = m->opts->budget;
    s->load_threads = m->opts->load_threads;
    s->limits = m->limits;
    s->spool = m->spool;
    s->shelf = m->opts->shelf;
    s->accepted = s->last_progress = now;
    if (loader_run(m->loader, submission_load, s, &err) < 0) {
        on_client_submission_free(s);
        reply_error(m, from, "the master cannot load the scene: %s", err.msg);
        return;
    }
    m->loading[m->nloading++] = s;
    master_log(m, "submission '%s' from %s: scene %.12s (%zu files, %zu frames) loading off the loop",
               s->name, who, hash, b->nfiles, nf ? nf : 1);
    size_t bytes = 0;
    for (size_t i = 0; i < b->nfiles; i++)
        bytes += b->files[i].size;
    char text[200];
    snprintf(text, sizeof text, "the master received the scene (%zu file%s, %.1f %s) and is loading it%s",
             b->nfiles, b->nfiles == 1 ? "" : "s", bytes >= 1000000 ? bytes / 1e6 : bytes / 1e3,
             bytes >= 1000000 ? "MB" : "kB",
             m->nloading > 1 ? ", after the scenes submitted before it" : "");
    proto_msg_t pm = {.type = PROTO_PROGRESS, .progress = {.message = text, .elapsed = 0}};
    reply(m, from, &pm);
}

/* A frame sequence whose frames have loaded: the sequence takes the next id and its frames the
 * ids after it (jobs_frame), each frame is scheduled as a job of its own, and all are journaled
 * in one transaction before the client is answered, so a restart finds all or none. */
static void sequence_finish(master_t *m, submission_t *s, const char *who, double now)
{
    const proto_peer_t *from = &s->peer;
    err_t err;
    mjob_t *seq = s->job;
    s->job = NULL;
    size_t n = s->nframes, scheduled = 0;
    uint64_t id = m->last_job + 1;
    seq->id = id;
    seq->submitted = now;
    snprintf(seq->owner, sizeof seq->owner, "%s", from->user);
    ops_job_init(seq, s->priority);
    journal_job_t *recs = calloc(n + 1, sizeof *recs);
    int rc = recs && jobs_append(m, seq) == 0 ? 0 : err_set(&err, "the master is out of memory");
    if (rc < 0) {
        job_free(seq);
        seq = NULL;
    }
    for (size_t k = 0; rc == 0 && k < n; k++) {
        mjob_t *f = s->frames[k];
        f->id = id + 1 + k;
        f->seq.parent = id;
        f->submitted = now;
        snprintf(f->owner, sizeof f->owner, "%s", from->user);
        ops_job_init(f, s->priority);
        rc = job_schedule(m, f, f->photons.phase ? photon_phase_nbatches(f->photons.phase) : 0,
                          &err);
        if (rc == 0) {
            s->frames[k] = NULL; /* listed: the master's now */
            scheduled++;
        }
    }
    if (rc == 0) {
        recs[0] = persist_record(m, seq, now);
        for (size_t k = 0; k < n; k++)
            recs[k + 1] = persist_record(m, jobs_find(m, id + 1 + k), now);
        if (m->journal && journal_add_jobs(m->journal, recs, n + 1, &err) < 0) {
            err_prefix(&err, "the master cannot journal the job: ");
            rc = -1;
        }
    }
    free(recs);
    if (rc < 0) {
        for (size_t k = scheduled; k-- > 0;)
            job_unschedule(m, jobs_find(m, id + 1 + k));
        if (seq)
            job_unschedule(m, seq);
        master_log(m, "submission '%s' from %s refused: %s", s->name, who, err.msg);
        reply_error(m, from, "%s", err.msg);
        return;
    }
    m->last_job = id + n;
    for (size_t k = 0; k <= n; k++) {
        char jobdir[PATH_MAX];
        if (spool_job_dir(m->spool, id + k, jobdir, sizeof jobdir, &err) < 0)
            master_log(m, "job %llu: %s", (unsigned long long)(id + k), err.msg);
    }
    proto_msg_t ok = {.type = PROTO_SUBMITTED, .submitted = {.job = id}};
    reply(m, from, &ok);
    const mjob_t *f0 = jobs_find(m, id + 1);
    master_log(m,
               "job %llu '%s' submitted by %s: %zu frames (jobs %llu..%llu), the first %dx%d, %d "
               "spp, scene %.12s loaded in %.2f s (off the loop)",
               (unsigned long long)id, seq->name, who, n, (unsigned long long)(id + 1),
               (unsigned long long)(id + n), f0->scene.xres, f0->scene.yres, f0->scene.spp,
               s->hash, s->load_s);
}

/* A submission whose scene has loaded (or failed to): scheduled, journaled and answered. */
static void submission_finish(master_t *m, submission_t *s, double now)
{
    const proto_peer_t *from = &s->peer;
    char who[PROTO_PEER_STR];
    proto_peer_str(from, who);
    err_t err;
    mjob_t *j = s->job;
    if (!j) {
        master_log(m, "submission '%s' from %s refused: %s", s->name, who, s->err.msg);
        reply_error(m, from, "%s", s->err.msg);
        return;
    }
    if (s->nframes > 0) {
        sequence_finish(m, s, who, now);
        return;
    }
    s->job = NULL;
    uint64_t id = m->last_job + 1;
    j->id = id;
    snprintf(j->owner, sizeof j->owner, "%s", from->user);
    ops_job_init(j, s->priority);
    if (job_schedule(m, j, j->photons.phase ? photon_phase_nbatches(j->photons.phase) : 0, &err) <
        0) {
        job_free(j);
        master_log(m, "submission '%s' from %s refused: %s", s->name, who, err.msg);
        reply_error(m, from, "%s", err.msg);
        return;
    }
    j->submitted = now;
    /* Journaled before it is acknowledged: a job the client was told about survives a
     * restart. */
    journal_job_t rec = persist_record(m, j, now);
    if (m->journal && journal_add_job(m->journal, &rec, &err) < 0) {
        master_log(m, "submission '%s' from %s refused: %s", s->name, who, err.msg);
        job_unschedule(m, j);
        reply_error(m, from, "the master cannot journal the job: %s", err.msg);
        return;
    }
    m->last_job = id;
    /* The job's folder marks its id as used, so a restarted master never gives it out again
     * (spool_last_job_id counts these folders), even if nothing was rendered yet. */
    char jobdir[PATH_MAX];
    if (spool_job_dir(m->spool, id, jobdir, sizeof jobdir, &err) < 0)
        master_log(m, "job %llu: %s", (unsigned long long)id, err.msg);
    proto_msg_t ok = {.type = PROTO_SUBMITTED, .submitted = {.job = id}};
    reply(m, from, &ok);
    sched_job_info_t info;
    (void)sched_job_info(m->sched, id, &info);
    const proto_settings_t *set = &s->settings;
    char rules[96] = "";
    if (set->target_error > 0)
        snprintf(rules, sizeof rules, ", target error %g", set->target_error);
    if (set->time_limit > 0)
        snprintf(rules + strlen(rules), sizeof rules - strlen(rules), ", time limit %g s",
                 set->time_limit);
    master_log(m,
               "job %llu '%s' submitted by %s: %dx%d, %d spp, %d buckets, %d tiles x %d passes, "
               "%u photon batches, scene %.12s loaded in %.2f s (off the loop)%s",
               (unsigned long long)id, j->name, who, j->scene.xres, j->scene.yres, j->scene.spp,
               j->scene.grid.n, info.ntiles, info.npasses, info.photon_batches, s->hash,
               s->load_s, rules);
}

void on_client_loads(master_t *m, double now)
{
    submission_t *s;
    while ((s = loader_done(m->loader))) {
        for (size_t i = 0; i < m->nloading; i++)
            if (m->loading[i] == s) {
                memmove(&m->loading[i], &m->loading[i + 1],
                        (m->nloading - i - 1) * sizeof *m->loading);
                m->nloading--;
                break;
            }
        submission_finish(m, s, now);
        on_client_submission_free(s);
    }
    /* The clients still waiting hear that the master works on it: their wait starts again
     * (client_rpc.h), so a long load never looks like a dead master. */
    for (size_t i = 0; i < m->nloading; i++) {
        submission_t *p = m->loading[i];
        if (now - p->last_progress < PROGRESS_S)
            continue;
        p->last_progress = now;
        char text[200];
        snprintf(text, sizeof text, "the master is loading the scene (%.0f s so far%s)",
                 now - p->accepted, i > 0 ? ", after the scenes submitted before it" : "");
        proto_msg_t pm = {.type = PROTO_PROGRESS,
                          .progress = {.message = text, .elapsed = now - p->accepted}};
        reply(m, &p->peer, &pm);
    }
}

/* opts->max_jobs: each unfinished job holds its framebuffer and scheduler state, so a client
 * cannot make the master hold them without bound (docs/security.md). */
static bool submit_room(master_t *m, const proto_peer_t *from, const proto_msg_t *msg)
{
    size_t open = m->nloading; /* a scene loading becomes a job */
    for (size_t i = 0; i < m->njobs; i++)
        open += !job_over(m->jobs[i]) && m->jobs[i]->seq.nframes == 0; /* frames count */
    size_t asked = msg->submit.nframes ? msg->submit.nframes : 1;
    if (open + asked <= m->opts->max_jobs)
        return true;
    char who[PROTO_PEER_STR];
    master_log(m, "submission '%s' from %s refused: %zu unfinished jobs, the limit",
               msg->submit.name, proto_peer_str(from, who), open);
    if (asked > 1)
        reply_error(m, from,
                    "the master holds %zu unfinished jobs and this sequence has %zu frames, more "
                    "than its limit (--max-jobs %zu; each frame counts as a job)",
                    open, asked, m->opts->max_jobs);
    else
        reply_error(m, from,
                    "the master holds %zu unfinished jobs, its limit (--max-jobs %zu): submit "
                    "again when one is done",
                    open, m->opts->max_jobs);
    return false;
}

/* One job (a sequence with its frames after it), or the list: every job but the frames of a
 * sequence, which their sequence stands for. */
static void reply_jobs(master_t *m, const proto_peer_t *to, proto_type_t type, const mjob_t *only,
                       double now)
{
    size_t n = 0, first = 0;
    if (only) {
        n = 1;
        for (uint32_t k = 0; k < only->seq.nframes; k++)
            n += jobs_frame(m, only, k) != NULL;
    } else {
        for (size_t i = 0; i < m->njobs; i++)
            n += m->jobs[i]->seq.parent == 0;
    }
    if (n > PROTO_MAX_LIST) {
        first = n - PROTO_MAX_LIST; /* the most recent ones */
        n = PROTO_MAX_LIST;
    }
    proto_job_info_t *infos = n ? calloc(n, sizeof *infos) : NULL;
    if (n && !infos) {
        reply_error(m, to, "the master is out of memory");
        return;
    }
    if (only) {
        size_t k = 0;
        infos[k++] = job_wire_info(m, only, now);
        for (uint32_t f = 0; f < only->seq.nframes && k < n; f++) {
            const mjob_t *fj = jobs_frame(m, only, f);
            if (fj)
                infos[k++] = job_wire_info(m, fj, now);
        }
    } else {
        size_t k = 0, seen = 0;
        for (size_t i = 0; i < m->njobs && k < n; i++)
            if (m->jobs[i]->seq.parent == 0 && seen++ >= first)
                infos[k++] = job_wire_info(m, m->jobs[i], now);
    }
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
    size_t ns = peers_sched_table(m), n = m->nworkers;
    proto_worker_info_t *infos = n ? calloc(n, sizeof *infos) : NULL;
    if (n && !infos) {
        reply_error(m, to, "the master is out of memory");
        return;
    }
    for (size_t i = 0; i < n; i++) {
        const mworker_t *w = m->workers[i];
        const sched_worker_info_t *si = peers_sched_info(m, ns, w->id);
        double seen = now - w->last_seen;
        infos[i] = (proto_worker_info_t){.name = w->name,
                                         .id = w->id,
                                         .threads = w->threads,
                                         .state = peers_wire_state(w, si),
                                         .tasks_done = si ? si->tasks_done : 0,
                                         .last_seen = seen > 0 ? seen : 0,
                                         .tasks_failed = si ? si->tasks_failed : 0,
                                         .fail_streak = si ? si->fail_streak : 0,
                                         .blocked_jobs = si ? si->blocked_jobs : 0,
                                         .samples_per_s = peers_samples_per_s(w, now)};
    }
    proto_msg_t r = {.type = PROTO_WORKERS_REPLY,
                     .workers_reply = {.workers = infos, .nworkers = n}};
    reply(m, to, &r);
    free(infos);
}

static void on_status(master_t *m, const proto_peer_t *from, const proto_msg_t *msg, double now)
{
    if (msg->status.all) {
        reply_jobs(m, from, PROTO_STATUS_REPLY, NULL, now);
        return;
    }
    const mjob_t *j = jobs_find(m, msg->status.job);
    if (!j)
        reply_error(m, from, "no job %llu", (unsigned long long)msg->status.job);
    else if (msg->status.wait_ms == 0 || job_over(j) || m->nwaiters == MAX_WAITERS)
        reply_jobs(m, from, PROTO_STATUS_REPLY, j, now);
    else
        m->waiters[m->nwaiters++] =
            (waiter_t){.peer = *from, .job = j->id, .deadline = now + msg->status.wait_ms / 1000.0};
}

/* The job a client asks to act on (fetch, refine, cancel), after the owner's or an admin's key
 * (access.h); NULL once the refusal is sent. */
static mjob_t *job_to_act_on(master_t *m, const proto_peer_t *from, uint64_t id,
                             const char *action)
{
    mjob_t *j = jobs_find(m, id);
    if (!j) {
        reply_error(m, from, "no job %llu", (unsigned long long)id);
        return NULL;
    }
    char why[PROTO_MAX_STRING];
    if (!access_check(m, j, from, action, why, sizeof why)) {
        reply_error(m, from, "%s", why);
        return NULL;
    }
    return j;
}

static void on_fetch(master_t *m, const proto_peer_t *from, const proto_msg_t *msg)
{
    mjob_t *j = job_to_act_on(m, from, msg->fetch.job, "fetch");
    if (!j)
        return;
    if (j->seq.nframes > 0) {
        reply_error(m, from,
                    "job %llu is a sequence of %u frames: fetch each frame's job (%llu..%llu; "
                    "prismfarm fetch does)",
                    (unsigned long long)j->id, j->seq.nframes, (unsigned long long)(j->id + 1),
                    (unsigned long long)(j->id + j->seq.nframes));
        return;
    }
    char path[PATH_MAX + 200], name[128];
    const char *state = job_state_name(j->state);
    if (j->outputs.final) {
        const char *ext = msg->fetch.what == PROTO_FETCH_EXR ? "exr" : "png";
        snprintf(path, sizeof path, "%s/jobs/%llu/%s.%s", spool_path(m->spool),
                 (unsigned long long)j->id, j->stem, ext);
        snprintf(name, sizeof name, "%s.%s", j->stem, ext);
    } else if (msg->fetch.what == PROTO_FETCH_EXR) {
        reply_error(m, from, "job %llu is %s: its EXR exists once it is done",
                    (unsigned long long)j->id, state);
        return;
    } else if (j->outputs.preview) {
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
    if (files_read(path, max, &data, &size, &err) < 0) {
        master_log(m, "fetch of job %llu: %s", (unsigned long long)j->id, err.msg);
        reply_error(m, from, "job %llu: %s", (unsigned long long)j->id, err.msg);
        return;
    }
    proto_msg_t f = {.type = PROTO_FILE, .file = {.name = name, .data = data, .size = size}};
    reply(m, from, &f);
    free(data);
    access_audit(m, from, "fetched %s of job %llu (%zu bytes)", name, (unsigned long long)j->id,
                 size);
}

/* More photons for a finished photon job: the phase appends batches, a fresh scheduler job
 * runs them and then the whole camera phase again, gathering from the grown store; the job's
 * outputs are rewritten when it is done. Tasks carry the new round, so late results of the old
 * one are ignored. */
/* Why job j cannot be refined (written into why), or NULL when it can: it must be a finished
 * photon job. */
static const char *refine_refusal(const mjob_t *j, char *why, size_t size)
{
    if (!j->photons.enabled)
        snprintf(why, size,
                 "job %llu has no photon pass to refine (its integrator is not \"photon\")",
                 (unsigned long long)j->id);
    else if (j->state != JOB_DONE || j->sched.known)
        snprintf(why, size, "job %llu is %s: only a finished job can be refined",
                 (unsigned long long)j->id, job_state_name(j->state));
    else
        return NULL;
    return why;
}

/* A finished photon job's new round (refine_refusal said yes): more photons, then its camera
 * phase again, journaled and audited as asked by from. -1 with err (the job failed when its
 * round could not be scheduled). */
static int refine_job(master_t *m, mjob_t *j, uint64_t photons, const proto_peer_t *from,
                      double now, err_t *err)
{
    if (!j->photons.phase && job_restore_photons(m, j, err) < 0) {
        master_log(m, "job %llu: cannot refine: %s", (unsigned long long)j->id, err->msg);
        return err_prefix(err, "job %llu: cannot restore its photon pass: ",
                          (unsigned long long)j->id);
    }
    uint32_t base = photon_phase_nbatches(j->photons.phase);
    if (photon_phase_refine(j->photons.phase, photons, err) < 0)
        return err_prefix(err, "job %llu: ", (unsigned long long)j->id);
    uint32_t added = photon_phase_nbatches(j->photons.phase) - base;
    if (sched_add_job(m->sched, j->id, j->scene.xres, j->scene.yres, j->scene.spp, j->scene.grid,
                      err) < 0 ||
        jobs_apply_ops(m, j, err) < 0 || jobs_apply_stopping(m, j, err) < 0 ||
        sched_add_photon_batches(m->sched, j->id, added, err) < 0) {
        err_t ignore;
        /* A queued job cannot be removed: cancel it first (as job_schedule does), or its
         * tasks would go on being dispatched to nobody. */
        (void)sched_cancel_job(m->sched, j->id, &ignore);
        (void)sched_remove_job(m->sched, j->id, &ignore);
        /* The phase has batches nobody will run: the job can be neither rendered nor refined
         * again, so it fails with the reason. */
        master_log(m, "job %llu: refinement failed: %s", (unsigned long long)j->id, err->msg);
        job_set_error(j, err->msg);
        j->state = JOB_FAILED;
        persist_state(m, j, now);
        return err_prefix(err, "job %llu: ", (unsigned long long)j->id);
    }
    sched_job_info_t info;
    if (sched_job_info(m->sched, j->id, &info) == 0)
        j->sched.ntiles = info.ntiles;
    j->photons.base = base;
    j->journal.refine_photons = photons;
    j->journal.round_photons = photon_phase_stats(j->photons.phase).photons + photons;
    j->sched.round++;
    j->photons.store_ready = false;
    j->sched.known = true;
    j->state = JOB_QUEUED;
    j->started = j->finished = 0;
    j->sched.samples_done = 0;
    j->accuracy.nhistory = j->accuracy.spp_done =
        0; /* the round's accuracy, with its own stopping rules */
    j->accuracy.stop = PROTO_STOP_NONE;
    free(j->accuracy.tile_passes);
    j->accuracy.tile_passes = NULL;
    j->submitted = now;
    j->journal.checkpoint = 0;
    j->journal.bytes = 0;
    j->journal.checkpoint_samples = 0;
    journal_job_t rec = persist_record(m, j, now);
    if (m->journal && journal_set_round(m->journal, &rec, err) < 0)
        persist_failed(m, j, err);
    photon_phase_stats_t ps = photon_phase_stats(j->photons.phase);
    access_audit(m, from,
                 "refined job %llu '%s': %llu more photons in %u batches (%llu so far), then "
                 "the camera phase again",
                 (unsigned long long)j->id, j->name, (unsigned long long)photons,
                 added, (unsigned long long)ps.photons);
    /* In the job's own log too, with every other action on it (`prismfarm logs`). */
    tasklog_add(m->tasklog, j->id,
                "job refined by %s: %llu more photons in %u batches (%llu so far), then the "
                "camera phase again",
                from->user[0] ? from->user : "(no key)", (unsigned long long)photons, added,
                (unsigned long long)ps.photons);
    return 0;
}

/* REFINE: a finished photon job, or each photon frame of a finished sequence (docs/farm.md,
 * "Frame sequences"), after the owner's or an admin's key (access.h). A sequence's frames are
 * all checked before any is refined, so a refusal leaves every frame as it was. */
static void on_refine(master_t *m, const proto_peer_t *from, const proto_msg_t *msg, double now)
{
    mjob_t *j = job_to_act_on(m, from, msg->refine.job, "refine");
    if (!j)
        return;
    char why[PROTO_MAX_STRING];
    err_t err;
    if (j->seq.nframes == 0) {
        if (refine_refusal(j, why, sizeof why))
            reply_error(m, from, "%s", why);
        else if (refine_job(m, j, msg->refine.photons, from, now, &err) < 0)
            reply_error(m, from, "%s", err.msg);
        else {
            mjob_t *seq = j->seq.parent ? jobs_find(m, j->seq.parent) : NULL;
            if (seq && seq->seq.nframes > 0) /* running again, not done */
                jobs_sequence_refresh(m, seq, now);
            proto_msg_t ok = {.type = PROTO_SUBMITTED, .submitted = {.job = j->id}};
            reply(m, from, &ok);
        }
        return;
    }
    uint32_t nphoton = 0;
    for (uint32_t k = 0; k < j->seq.nframes; k++) {
        const mjob_t *f = jobs_frame(m, j, k);
        if (!f || !f->photons.enabled)
            continue;
        nphoton++;
        if (refine_refusal(f, why, sizeof why)) {
            reply_error(m, from, "job %llu: frame %u: %s", (unsigned long long)j->id,
                        f->seq.frame, why);
            return;
        }
    }
    if (nphoton == 0) {
        reply_error(m, from,
                    "job %llu is a sequence of %u frames, none with a photon pass to refine "
                    "(their integrator is not \"photon\")",
                    (unsigned long long)j->id, j->seq.nframes);
        return;
    }
    int rc = 0;
    for (uint32_t k = 0; k < j->seq.nframes && rc == 0; k++) {
        mjob_t *f = jobs_frame(m, j, k);
        if (f && f->photons.enabled &&
            (rc = refine_job(m, f, msg->refine.photons, from, now, &err)) < 0)
            (void)err_prefix(&err, "frame %u: ", f->seq.frame);
    }
    jobs_sequence_refresh(m, j, now);
    if (rc < 0) {
        reply_error(m, from, "job %llu: %s", (unsigned long long)j->id, err.msg);
        return;
    }
    access_audit(m, from, "refined job %llu '%s': %u photon frames of %u",
                 (unsigned long long)j->id, j->name, nphoton, j->seq.nframes);
    proto_msg_t ok = {.type = PROTO_SUBMITTED, .submitted = {.job = j->id}};
    reply(m, from, &ok);
}

static void on_cancel(master_t *m, const proto_peer_t *from, const proto_msg_t *msg, double now)
{
    mjob_t *j = job_to_act_on(m, from, msg->cancel.job, "cancel");
    if (!j)
        return;
    bool live = j->sched.known || (j->seq.nframes > 0 && !job_over(j));
    access_audit(m, from, "cancelled job %llu '%s' (%s)", (unsigned long long)j->id, j->name,
                 live ? "running or queued" : "already over: nothing to stop");
    job_cancel(m, j, now);
    reply_jobs(m, from, PROTO_STATUS_REPLY, j, now);
}

/* Priority, pause, resume, requeue, unblock: ops.h does them (the dashboard calls the same
 * functions); the answer is the job as STATUS shows it, or the workers. */
static void on_act(master_t *m, const proto_peer_t *from, const proto_msg_t *msg, double now)
{
    master_actor_t who = ops_actor_of_peer(m, from);
    uint64_t id = msg->act.job;
    err_t err;
    int rc;
    switch (msg->act.act) {
    case PROTO_ACT_PRIORITY:
        rc = master_job_set_priority(m, id, (int)msg->act.priority, &who, &err);
        break;
    case PROTO_ACT_PAUSE:
        rc = master_job_pause(m, id, &who, &err);
        break;
    case PROTO_ACT_RESUME:
        rc = master_job_resume(m, id, &who, &err);
        break;
    case PROTO_ACT_REQUEUE:
        rc = master_task_requeue(m, id, msg->act.task, &who, &err);
        break;
    case PROTO_ACT_UNBLOCK:
        rc = msg->act.worker ? master_worker_unblock(m, msg->act.worker, &who, &err)
                             : err_set(&err, "unblock needs a worker's name or id");
        break;
    default:
        rc = err_set(&err, "unknown action");
    }
    if (rc < 0) {
        reply_error(m, from, "%s", err.msg); /* the client names the action */
        return;
    }
    if (msg->act.act == PROTO_ACT_UNBLOCK)
        reply_workers(m, from, now);
    else
        reply_jobs(m, from, PROTO_STATUS_REPLY, jobs_find(m, id), now);
}

/* A sequence's log (docs/farm.md, "Frame sequences"): it has no tasks of its own, so its log is
 * its frames' logs in frame order, each line prefixed "frame N (job ID) ". Each frame gets an
 * equal share of max and keeps its most recent whole lines that fit in it, prefix included, so
 * one busy frame cannot push the others out. *text is malloc'ed and NUL-terminated. */
static int sequence_logs(master_t *m, const mjob_t *seq, size_t max, char **text, size_t *len,
                         err_t *err)
{
    size_t share = max / seq->seq.nframes, n = 0;
    char *out = malloc(max + 1);
    if (!out)
        return err_set(err, "out of memory for job %llu's log", (unsigned long long)seq->id);
    for (uint32_t k = 0; k < seq->seq.nframes; k++) {
        const mjob_t *f = jobs_frame(m, seq, k);
        if (!f)
            continue;
        char *part;
        size_t plen;
        if (tasklog_read(m->tasklog, f->id, -1, share, &part, &plen, err) < 0) {
            free(out);
            return err_prefix(err, "frame %u (job %llu): ", f->seq.frame,
                              (unsigned long long)f->id);
        }
        char prefix[64];
        size_t pre = (size_t)snprintf(prefix, sizeof prefix, "frame %u (job %llu) ", f->seq.frame,
                                      (unsigned long long)f->id);
        /* The prefixed lines from the newest back, to find the oldest line that still fits. */
        size_t need = 0, start = plen;
        while (start > 0) {
            size_t b = start - 1; /* the last byte of the line before start: its newline */
            while (b > 0 && part[b - 1] != '\n')
                b--;
            if (need + pre + (start - b) > share)
                break;
            need += pre + (start - b);
            start = b;
        }
        for (size_t a = start; a < plen;) {
            const char *nl = memchr(part + a, '\n', plen - a);
            size_t l = nl ? (size_t)(nl - (part + a)) + 1 : plen - a;
            memcpy(out + n, prefix, pre);
            memcpy(out + n + pre, part + a, l);
            n += pre + l;
            a += l;
        }
        free(part);
    }
    out[n] = 0;
    *text = out;
    *len = n;
    return 0;
}

/* The job's task log (tasklog.h), all or one task's lines: the most recent that fit in a
 * message; a sequence's, its frames' (sequence_logs). Reading a log is reading the job: its
 * owner or an admin. */
static void on_logs(master_t *m, const proto_peer_t *from, const proto_msg_t *msg)
{
    const mjob_t *j = jobs_find(m, msg->logs.job);
    master_actor_t who = ops_actor_of_peer(m, from);
    err_t err;
    if (!j) {
        reply_error(m, from, "no job %llu", (unsigned long long)msg->logs.job);
        return;
    }
    if (!ops_may_act(m, j, &who, &err)) {
        master_log(m, "task log of job %llu refused to %s: %s", (unsigned long long)j->id,
                   who.name[0] ? who.name : "(no key)", err.msg);
        reply_error(m, from, "%s", err.msg);
        return;
    }
    size_t max = m->limits.max_message_bytes > FILE_OVERHEAD
                     ? m->limits.max_message_bytes - FILE_OVERHEAD
                     : 4096;
    if (max > (size_t)8 << 20)
        max = (size_t)8 << 20;
    if (j->seq.nframes > 0 && msg->logs.has_task) {
        reply_error(m, from,
                    "job %llu is a sequence of %u frames: its tasks are its frames', give a "
                    "frame's id (jobs %llu..%llu) with the task",
                    (unsigned long long)j->id, j->seq.nframes, (unsigned long long)(j->id + 1),
                    (unsigned long long)(j->id + j->seq.nframes));
        return;
    }
    char *text;
    size_t len;
    if ((j->seq.nframes > 0
             ? sequence_logs(m, j, max, &text, &len, &err)
             : tasklog_read(m->tasklog, j->id, msg->logs.has_task ? (long long)msg->logs.task : -1,
                            max, &text, &len, &err)) < 0) {
        reply_error(m, from, "job %llu: %s", (unsigned long long)j->id, err.msg);
        return;
    }
    char name[64];
    snprintf(name, sizeof name, "job-%llu.log", (unsigned long long)j->id);
    proto_msg_t f = {.type = PROTO_FILE,
                     .file = {.name = name, .data = (const uint8_t *)text, .size = len}};
    reply(m, from, &f);
    free(text);
}

static void on_metrics(master_t *m, const proto_peer_t *from, double now)
{
    char *text;
    size_t len;
    err_t err;
    if (master_metrics_text(m, now, &text, &len, &err) < 0) {
        reply_error(m, from, "%s", err.msg);
        return;
    }
    proto_msg_t f = {.type = PROTO_FILE,
                     .file = {.name = "metrics.txt", .data = (const uint8_t *)text, .size = len}};
    reply(m, from, &f);
    free(text);
}

void on_client_message(master_t *m, const proto_peer_t *from, const proto_msg_t *msg, double now)
{
    switch (msg->type) {
    case PROTO_SUBMIT:
        if (submit_room(m, from, msg))
            on_submit(m, from, msg, now);
        break;
    case PROTO_STATUS:
        on_status(m, from, msg, now);
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
    case PROTO_CANCEL:
        on_cancel(m, from, msg, now);
        break;
    case PROTO_ACT:
        on_act(m, from, msg, now);
        break;
    case PROTO_LOGS:
        on_logs(m, from, msg);
        break;
    case PROTO_METRICS:
        on_metrics(m, from, now);
        break;
    default: {
        char who[PROTO_PEER_STR];
        master_log(m, "%s from client %s: not a client request", proto_type_name(msg->type),
                   proto_peer_str(from, who));
        reply_error(m, from, "%s is not a request the master's client endpoint answers",
                    proto_type_name(msg->type));
    }
    }
}

int on_client_answer_waiters(master_t *m, double now)
{
    double next = now + POLL_MS / 1000.0;
    size_t k = 0;
    for (size_t i = 0; i < m->nwaiters; i++) {
        waiter_t wt = m->waiters[i];
        const mjob_t *j = jobs_find(m, wt.job);
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
