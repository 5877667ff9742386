#define _XOPEN_SOURCE 700 /* realpath */
#include "submit.h"

#include "bundle.h"
#include "clock.h"
#include "jobs.h"
#include "loader.h"
#include "ops.h"
#include "overrides.h"
#include "persist.h"
#include "polar_seq.h"
#include "pool.h"

#include <limits.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void strip_all(char *msg, const char *prefix)
{
    size_t n = strlen(prefix);
    char *p;
    while (n > 0 && (p = strstr(msg, prefix)))
        memmove(p, p + n, strlen(p + n) + 1);
}

/* A submission between its bundle's arrival and its scene's load (loader.h): the master keeps
 * it in m->loading, the loader's thread fills job or err, and submit_loads finishes it. */
struct submission {
    proto_peer_t peer;
    char *name, *main;
    char hash[PROTO_HASH_HEX + 1];
    char dir[PATH_MAX];
    bool staged;
    proto_settings_t settings; /* its names point into setting_names */
    proto_setting_names_t setting_names;
    int priority; /* SUBMIT's (ops.h) */
    scene_budget_t budget;
    int load_threads; /* frames loaded at once (master_opts_t) */
    proto_limits_t limits;
    spool_t *spool;       /* staged and committed into on the loader's thread (spool.h) */
    scene_shelf_t *shelf; /* the process's scenes (master_opts_t), or NULL */
    uint8_t *scene_msg;   /* the SCENE message workers will be sent, stored once the scene loads */
    size_t scene_size;
    double accepted, last_progress;
    /* A frame sequence (SUBMIT's frames; nframes 0: a single scene, job): each frame's main
     * and number, and its job once loaded. */
    size_t nframes;
    char **frame_main;
    uint32_t *frame_number;
    job_t **frames;
    /* Filled on the loader's thread. */
    job_t *job;
    err_t err;
    double load_s;
    char polar_why[512]; /* a sequence's polarisation decision, for the log ("" when forced) */
};

static void submission_free(void *arg);

void submit_drop(void *arg)
{
    submission_t *s = arg;
    if (s)
        spool_scene_discard(s->spool, s->dir, s->staged);
    submission_free(s);
}

static void submission_free(void *arg)
{
    submission_t *s = arg;
    if (!s)
        return;
    job_destroy(&s->job);
    for (size_t k = 0; k < s->nframes; k++) {
        if (s->frames)
            job_destroy(&s->frames[k]);
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
    /* Each frame's part of the sequence's one polarisation decision (polar_seq.h): the pilot
     * measures a few frames spread over the sequence, on the load threads. */
    job_polar_mode_t polar =
        polar_seq_pilots(k, s->nframes) ? JOB_POLAR_FRAME_PILOT : JOB_POLAR_FRAME;
    s->frames[k] = job_new(0, s->frame_main[k], s->hash, s->frame_main[k], &s->settings, s->dir,
                           &budget, s->shelf, fl->inner, polar, &e);
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
static job_t *load_frames(submission_t *s)
{
    int cores = pool_cores();
    int outer = s->load_threads > 0 ? s->load_threads : cores;
    if ((size_t)outer > s->nframes)
        outer = (int)s->nframes;
    frame_loads_t fl = {.s = s,
                        .inner = outer > 1 ? (cores / outer > 0 ? cores / outer : 1) : 0,
                        .first_failed = s->nframes};
    pthread_mutex_init(&fl.lock, NULL);
    err_t err;
    int rc = pool_for(outer, (int)s->nframes, load_frame, &fl, &err);
    pthread_mutex_destroy(&fl.lock);
    if (rc < 0)
        return NULL; /* s->err: the first failing frame's (the frames loaded are freed with s) */
    /* One polarisation decision for every frame, from their parts (unless --polarized forced
     * one): the frames' settings carry it to the workers and into the journal, so a restart
     * resumes each frame with it. The sequence's record shows it too. */
    if (s->settings.polarized == SCENE_POLARIZED_FILE) {
        polar_seq_t ps = polar_seq_make(s->settings.target_error);
        for (size_t k = 0; k < s->nframes; k++) {
            const job_polar_t *jp = &s->frames[k]->polar;
            polar_decision_t d = {.cause_file = jp->cause_file,
                                  .measured = jp->measured,
                                  .pilot = {.change = jp->change, .change_hi = jp->change_hi}};
            polar_seq_add(&ps, k, &d);
        }
        for (size_t k = 0; k < s->nframes; k++)
            s->frames[k]->settings.polarized = ps.setting;
        s->settings.polarized = ps.setting;
        polar_seq_why(&ps, s->frame_number, s->polar_why, sizeof s->polar_why);
    }
    /* The sequence's own record, which job_new_sequence fills without a scene. */
    job_t *seq =
        job_new_sequence(s->name, s->hash, s->frame_main[0], &s->settings, (uint32_t)s->nframes);
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
    /* Lent: the files point into s->scene_msg, which outlives the message (freed below). */
    if (proto_decode_lent(s->scene_msg, s->scene_size, &s->limits, &scene, NULL, NULL, &s->err) <
        0) {
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
                                      &s->budget, s->shelf, 0, JOB_POLAR_DECIDE, &s->err);
    if (s->job) {
        if (spool_scene_commit(s->spool, s->scene_msg, s->scene_size, s->hash, s->dir, s->staged,
                               &s->err) < 0) {
            job_destroy(&s->job);
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
static void submit_accept(master_t *m, const proto_peer_t *from, const proto_msg_t *msg, double now)
{
    const proto_bundle_t *b = &msg->submit.bundle;
    char who[PROTO_PEER_STR];
    proto_peer_str(from, who);
    err_t err;
    char hash[PROTO_HASH_HEX + 1];
    if (proto_bundle_check(b, &m->limits, &err) < 0 || proto_bundle_hash(b, hash, &err) < 0) {
        master_log(m, "submission '%s' from %s refused: %s", msg->submit.name, who, err.msg);
        master_reply_error(m, from, "scene bundle refused: %s", err.msg);
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
        submission_free(s);
        master_reply_error(m, from, "the master is out of memory");
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
            submission_free(s);
            master_reply_error(m, from, "the master is out of memory");
            return;
        }
    }
    if (spool_scene_encode(b, hash, &m->limits, &s->scene_msg, &s->scene_size, &err) < 0) {
        submission_free(s);
        master_log(m, "cannot store scene %.12s: %s", hash, err.msg);
        master_reply_error(m, from, "the master cannot store the scene: %s", err.msg);
        return;
    }
    s->peer = *from;
    memcpy(s->hash, hash, sizeof s->hash);
    proto_settings_copy(&s->settings, &msg->submit.settings, &s->setting_names);
    s->priority = (int)msg->submit.priority;
    s->budget = m->opts->budget;
    s->load_threads = m->opts->load_threads;
    s->limits = m->limits;
    s->spool = m->spool;
    s->shelf = m->opts->shelf;
    s->accepted = s->last_progress = now;
    if (loader_run(m->loader, submission_load, s, &err) < 0) {
        submission_free(s);
        master_reply_error(m, from, "the master cannot load the scene: %s", err.msg);
        return;
    }
    m->loading[m->nloading++] = s;
    master_log(m,
               "submission '%s' from %s: scene %.12s (%zu files, %zu frames) loading off the loop",
               s->name, who, hash, b->nfiles, nf ? nf : 1);
    size_t bytes = 0;
    for (size_t i = 0; i < b->nfiles; i++)
        bytes += b->files[i].size;
    char text[200];
    snprintf(text, sizeof text,
             "the master received the scene (%zu file%s, %.1f %s) and is loading it%s", b->nfiles,
             b->nfiles == 1 ? "" : "s", bytes >= 1000000 ? bytes / 1e6 : bytes / 1e3,
             bytes >= 1000000 ? "MB" : "kB",
             m->nloading > 1 ? ", after the scenes submitted before it" : "");
    proto_msg_t pm = {.type = PROTO_PROGRESS, .progress = {.message = text, .elapsed = 0}};
    master_reply(m, from, &pm);
}

/* A job just journaled is copied from the WAL into journal.db before its client hears
 * SUBMITTED (journal_checkpoint_wal): a deleted journal.db-wal loses no acknowledged job. A
 * failure is logged and the job goes on (it is committed; only a lost WAL would lose it). */
static void checkpoint_wal(master_t *m, uint64_t job)
{
    err_t err;
    if (m->journal && journal_checkpoint_wal(m->journal, &err) < 0)
        master_log(m,
                   "job %llu is journaled in the WAL only (a deleted journal.db-wal would lose "
                   "it): %s",
                   (unsigned long long)job, err.msg);
}

/* A frame sequence whose frames have loaded: the sequence takes the next id and its frames the
 * ids after it (jobs_frame), each frame is scheduled as a job of its own, and all are journaled
 * in one transaction before the client is answered, so a restart finds all or none. */
static void sequence_finish(master_t *m, submission_t *s, const char *who, double now)
{
    const proto_peer_t *from = &s->peer;
    err_t err;
    job_t *seq = s->job;
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
        job_destroy(&seq);
        seq = NULL;
    }
    for (size_t k = 0; rc == 0 && k < n; k++) {
        job_t *f = s->frames[k];
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
    if (rc == 0)
        checkpoint_wal(m, id);
    if (rc < 0) {
        for (size_t k = scheduled; k-- > 0;)
            job_unschedule(m, jobs_find(m, id + 1 + k));
        if (seq)
            job_unschedule(m, seq);
        master_log(m, "submission '%s' from %s refused: %s", s->name, who, err.msg);
        master_reply_error(m, from, "%s", err.msg);
        return;
    }
    m->last_job = id + n;
    for (size_t k = 0; k <= n; k++) {
        char jobdir[PATH_MAX];
        if (spool_job_dir(m->spool, id + k, jobdir, sizeof jobdir, &err) < 0)
            master_log(m, "job %llu: %s", (unsigned long long)(id + k), err.msg);
    }
    proto_msg_t ok = {.type = PROTO_SUBMITTED, .submitted = {.job = id}};
    master_reply(m, from, &ok);
    const job_t *f0 = jobs_find(m, id + 1);
    master_log(m,
               "job %llu '%s' submitted by %s: %zu frames (jobs %llu..%llu), the first %dx%d, %d "
               "spp, scene %.12s loaded in %.2f s (off the loop)%s%s",
               (unsigned long long)id, seq->name, who, n, (unsigned long long)(id + 1),
               (unsigned long long)(id + n), f0->scene.xres, f0->scene.yres, f0->scene.spp, s->hash,
               s->load_s, s->polar_why[0] ? "; " : "", s->polar_why);
}

/* A submission whose scene has loaded (or failed to): scheduled, journaled and answered. */
static void submission_finish(master_t *m, submission_t *s, double now)
{
    const proto_peer_t *from = &s->peer;
    char who[PROTO_PEER_STR];
    proto_peer_str(from, who);
    err_t err;
    job_t *j = s->job;
    if (!j) {
        master_log(m, "submission '%s' from %s refused: %s", s->name, who, s->err.msg);
        master_reply_error(m, from, "%s", s->err.msg);
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
        job_destroy(&j);
        master_log(m, "submission '%s' from %s refused: %s", s->name, who, err.msg);
        master_reply_error(m, from, "%s", err.msg);
        return;
    }
    j->submitted = now;
    /* Journaled before it is acknowledged: a job the client was told about survives a
     * restart. */
    journal_job_t rec = persist_record(m, j, now);
    if (m->journal && journal_add_job(m->journal, &rec, &err) < 0) {
        master_log(m, "submission '%s' from %s refused: %s", s->name, who, err.msg);
        job_unschedule(m, j);
        master_reply_error(m, from, "the master cannot journal the job: %s", err.msg);
        return;
    }
    checkpoint_wal(m, id);
    m->last_job = id;
    /* The job's folder marks its id as used, so a restarted master never gives it out again
     * (spool_last_job_id counts these folders), even if nothing was rendered yet. */
    char jobdir[PATH_MAX];
    if (spool_job_dir(m->spool, id, jobdir, sizeof jobdir, &err) < 0)
        master_log(m, "job %llu: %s", (unsigned long long)id, err.msg);
    proto_msg_t ok = {.type = PROTO_SUBMITTED, .submitted = {.job = id}};
    master_reply(m, from, &ok);
    sched_job_info_t info;
    (void)sched_job_info(m->sched, id, &info);
    const proto_settings_t *set = &s->settings;
    char rules[96] = "";
    if (set->target_error > 0)
        snprintf(rules, sizeof rules, ", target error %g", set->target_error);
    if (set->time_limit > 0)
        snprintf(rules + strlen(rules), sizeof rules - strlen(rules), ", time limit %g s",
                 set->time_limit);
    /* The plan's polarisation decision, made once at the load (jobs.c job_new), with the
     * pilot's figure where it measured one. */
    char polar[160] = "";
    if (j->polar.measured)
        snprintf(polar, sizeof polar,
                 ", polarisation %s (the pilot measured %.2f %%, up to %.2f %%, against %g %%)",
                 j->settings.polarized == SCENE_POLARIZED_ON ? "on" : "off",
                 100.0 * j->polar.change, 100.0 * j->polar.change_hi, 100.0 * j->polar.target);
    else if (j->settings.polarized == SCENE_POLARIZED_ON)
        snprintf(polar, sizeof polar, ", polarisation on");
    master_log(m,
               "job %llu '%s' submitted by %s: %dx%d, %d spp, %d buckets, %d tiles x %d passes, "
               "%u photon batches, scene %.12s loaded in %.2f s (off the loop)%s%s",
               (unsigned long long)id, j->name, who, j->scene.xres, j->scene.yres, j->scene.spp,
               j->scene.grid.n, info.ntiles, info.npasses, info.photon_batches, s->hash, s->load_s,
               rules, polar);
}

void submit_loads(master_t *m, double now)
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
        submission_free(s);
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
        master_reply(m, &p->peer, &pm);
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
        master_reply_error(
            m, from,
            "the master holds %zu unfinished jobs and this sequence has %zu frames, more "
            "than its limit (--max-jobs %zu; each frame counts as a job)",
            open, asked, m->opts->max_jobs);
    else
        master_reply_error(
            m, from,
            "the master holds %zu unfinished jobs, its limit (--max-jobs %zu): submit "
            "again when one is done",
            open, m->opts->max_jobs);
    return false;
}

void submit_start(master_t *m, const proto_peer_t *from, const proto_msg_t *msg, double now)
{
    if (submit_room(m, from, msg))
        submit_accept(m, from, msg, now);
}
