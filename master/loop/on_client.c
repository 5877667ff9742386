#include "on_client.h"

#include "access.h"
#include "clock.h"
#include "files.h"
#include "jobs.h"
#include "metrics.h"
#include "ops.h"
#include "submit.h"
#include "peers.h"
#include "persist.h"
#include "tasklog.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define FILE_OVERHEAD (64 << 10) /* room for a FILE message's envelope and name */

static proto_job_info_t job_wire_info(const master_t *m, const job_t *j, double now)
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
    if (j->photons.phase) {
        photon_phase_stats_t ps = photon_phase_stats(j->photons.phase);
        o.photons_done = ps.photons;
        o.photons_total = ps.total;
    } else if (j->photons.enabled) {
        o.photons_done = o.photons_total = j->photons.saved; /* merged, kept on disk */
    }
    o.parent = j->seq.parent;
    o.frame = j->seq.frame;
    o.frames = j->seq.nframes;
    if (j->seq.nframes > 0) {
        /* A sequence's figures are its frames' summed; its spp the least of theirs. */
        o.samples_done = o.samples_total = o.nonfinite = 0;
        o.photons_done = o.photons_total = 0;
        o.spp = 0;
        for (uint32_t k = 0; k < j->seq.nframes; k++) {
            const job_t *f = jobs_frame(m, j, k);
            if (!f)
                continue;
            proto_job_info_t fi = job_wire_info(m, f, now);
            o.samples_done += fi.samples_done;
            o.samples_total += fi.samples_total;
            o.nonfinite += fi.nonfinite;
            o.photons_done += fi.photons_done;
            o.photons_total += fi.photons_total;
            o.spp = k == 0 || fi.spp < o.spp ? fi.spp : o.spp;
        }
    }
    return o;
}

/* Removes every occurrence of prefix from msg (the spool folder from the loader's messages, so
 * that the client sees paths as they are in its bundle). */
/* One job (a sequence with its frames after it), or the list: every job but the frames of a
 * sequence, which their sequence stands for. */
static void reply_jobs(master_t *m, const proto_peer_t *to, proto_type_t type, const job_t *only,
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
        master_reply_error(m, to, "the master is out of memory");
        return;
    }
    if (only) {
        size_t k = 0;
        infos[k++] = job_wire_info(m, only, now);
        for (uint32_t f = 0; f < only->seq.nframes && k < n; f++) {
            const job_t *fj = jobs_frame(m, only, f);
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
    master_reply(m, to, &r);
    free(infos);
}

static void reply_workers(master_t *m, const proto_peer_t *to, double now)
{
    size_t ns = peers_sched_table(m), n = m->nworkers;
    proto_worker_info_t *infos = n ? calloc(n, sizeof *infos) : NULL;
    if (n && !infos) {
        master_reply_error(m, to, "the master is out of memory");
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
    master_reply(m, to, &r);
    free(infos);
}

static void on_status(master_t *m, const proto_peer_t *from, const proto_msg_t *msg, double now)
{
    if (msg->status.all) {
        reply_jobs(m, from, PROTO_STATUS_REPLY, NULL, now);
        return;
    }
    const job_t *j = jobs_find(m, msg->status.job);
    if (!j)
        master_reply_error(m, from, "no job %llu", (unsigned long long)msg->status.job);
    else if (msg->status.wait_ms == 0 || job_over(j) || m->nwaiters == MAX_WAITERS)
        reply_jobs(m, from, PROTO_STATUS_REPLY, j, now);
    else
        m->waiters[m->nwaiters++] =
            (waiter_t){.peer = *from, .job = j->id, .deadline = now + msg->status.wait_ms / 1000.0};
}

/* The job a client asks to act on (fetch, refine, cancel), after the owner's or an admin's key
 * (access.h); NULL once the refusal is sent. */
static job_t *job_to_act_on(master_t *m, const proto_peer_t *from, uint64_t id,
                             const char *action)
{
    job_t *j = jobs_find(m, id);
    if (!j) {
        master_reply_error(m, from, "no job %llu", (unsigned long long)id);
        return NULL;
    }
    char why[PROTO_MAX_STRING];
    if (!access_check(m, j, from, action, why, sizeof why)) {
        master_reply_error(m, from, "%s", why);
        return NULL;
    }
    return j;
}

static void on_fetch(master_t *m, const proto_peer_t *from, const proto_msg_t *msg)
{
    job_t *j = job_to_act_on(m, from, msg->fetch.job, "fetch");
    if (!j)
        return;
    if (j->seq.nframes > 0) {
        master_reply_error(m, from,
                    "job %llu is a sequence of %u frames: fetch each frame's job (%llu..%llu; "
                    "prismfarm fetch does)",
                    (unsigned long long)j->id, j->seq.nframes, (unsigned long long)(j->id + 1),
                    (unsigned long long)(j->id + j->seq.nframes));
        return;
    }
    char path[PATH_MAX + 200], name[128];
    const char *state = proto_job_state_name(j->state);
    if (j->outputs.final) {
        const char *ext = msg->fetch.what == PROTO_FETCH_EXR ? "exr" : "png";
        snprintf(path, sizeof path, "%s/jobs/%llu/%s.%s", spool_path(m->spool),
                 (unsigned long long)j->id, j->stem, ext);
        snprintf(name, sizeof name, "%s.%s", j->stem, ext);
    } else if (msg->fetch.what == PROTO_FETCH_EXR) {
        master_reply_error(m, from, "job %llu is %s: its EXR exists once it is done",
                    (unsigned long long)j->id, state);
        return;
    } else if (j->outputs.preview) {
        snprintf(path, sizeof path, "%s/jobs/%llu/preview.png", spool_path(m->spool),
                 (unsigned long long)j->id);
        snprintf(name, sizeof name, "%s-preview.png", j->stem);
    } else {
        master_reply_error(m, from, "job %llu is %s and has no image yet (a preview follows each pass)",
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
        master_reply_error(m, from, "job %llu: %s", (unsigned long long)j->id, err.msg);
        return;
    }
    proto_msg_t f = {.type = PROTO_FILE, .file = {.name = name, .data = data, .size = size}};
    master_reply(m, from, &f);
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
static const char *refine_refusal(const job_t *j, char *why, size_t size)
{
    if (!j->photons.enabled)
        snprintf(why, size,
                 "job %llu has no photon pass to refine (its integrator is not \"photon\")",
                 (unsigned long long)j->id);
    else if (j->state != JOB_DONE || j->sched.known)
        snprintf(why, size, "job %llu is %s: only a finished job can be refined",
                 (unsigned long long)j->id, proto_job_state_name(j->state));
    else
        return NULL;
    return why;
}

/* A finished photon job's new round (refine_refusal said yes): more photons, then its camera
 * phase again, journaled and audited as asked by from. -1 with err (the job failed when its
 * round could not be scheduled). */
static int refine_job(master_t *m, job_t *j, uint64_t photons, const proto_peer_t *from,
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
                      j->scene.nbuckets, err) < 0 ||
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
                 "refined job %llu '%s': %llu more photons in %u batch%s (%llu so far), then "
                 "the camera phase again",
                 (unsigned long long)j->id, j->name, (unsigned long long)photons, added,
                 added == 1 ? "" : "es", (unsigned long long)ps.photons);
    /* In the job's own log too, with every other action on it (`prismfarm logs`). */
    tasklog_add(m->tasklog, j->id,
                "job refined by %s: %llu more photons in %u batch%s (%llu so far), then the "
                "camera phase again",
                from->user[0] ? from->user : "(no key)", (unsigned long long)photons, added,
                added == 1 ? "" : "es", (unsigned long long)ps.photons);
    return 0;
}

/* REFINE: a finished photon job, or each photon frame of a finished sequence (docs/farm.md,
 * "Frame sequences"), after the owner's or an admin's key (access.h). A sequence's frames are
 * all checked before any is refined, so a refusal leaves every frame as it was. */
static void on_refine(master_t *m, const proto_peer_t *from, const proto_msg_t *msg, double now)
{
    job_t *j = job_to_act_on(m, from, msg->refine.job, "refine");
    if (!j)
        return;
    char why[PROTO_MAX_STRING];
    err_t err;
    if (j->seq.nframes == 0) {
        if (refine_refusal(j, why, sizeof why))
            master_reply_error(m, from, "%s", why);
        else if (refine_job(m, j, msg->refine.photons, from, now, &err) < 0)
            master_reply_error(m, from, "%s", err.msg);
        else {
            job_t *seq = j->seq.parent ? jobs_find(m, j->seq.parent) : NULL;
            if (seq && seq->seq.nframes > 0) /* running again, not done */
                jobs_sequence_refresh(m, seq, now);
            proto_msg_t ok = {.type = PROTO_SUBMITTED, .submitted = {.job = j->id}};
            master_reply(m, from, &ok);
        }
        return;
    }
    uint32_t nphoton = 0;
    for (uint32_t k = 0; k < j->seq.nframes; k++) {
        const job_t *f = jobs_frame(m, j, k);
        if (!f || !f->photons.enabled)
            continue;
        nphoton++;
        if (refine_refusal(f, why, sizeof why)) {
            master_reply_error(m, from, "job %llu: frame %u: %s", (unsigned long long)j->id,
                        f->seq.frame, why);
            return;
        }
    }
    if (nphoton == 0) {
        master_reply_error(m, from,
                    "job %llu is a sequence of %u frames, none with a photon pass to refine "
                    "(their integrator is not \"photon\")",
                    (unsigned long long)j->id, j->seq.nframes);
        return;
    }
    int rc = 0;
    for (uint32_t k = 0; k < j->seq.nframes && rc == 0; k++) {
        job_t *f = jobs_frame(m, j, k);
        if (f && f->photons.enabled &&
            (rc = refine_job(m, f, msg->refine.photons, from, now, &err)) < 0)
            (void)err_prefix(&err, "frame %u: ", f->seq.frame);
    }
    jobs_sequence_refresh(m, j, now);
    if (rc < 0) {
        master_reply_error(m, from, "job %llu: %s", (unsigned long long)j->id, err.msg);
        return;
    }
    access_audit(m, from, "refined job %llu '%s': %u photon frames of %u",
                 (unsigned long long)j->id, j->name, nphoton, j->seq.nframes);
    proto_msg_t ok = {.type = PROTO_SUBMITTED, .submitted = {.job = j->id}};
    master_reply(m, from, &ok);
}

static void on_cancel(master_t *m, const proto_peer_t *from, const proto_msg_t *msg, double now)
{
    job_t *j = job_to_act_on(m, from, msg->cancel.job, "cancel");
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
        master_reply_error(m, from, "%s", err.msg); /* the client names the action */
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
static int sequence_logs(master_t *m, const job_t *seq, size_t max, char **text, size_t *len,
                         err_t *err)
{
    size_t share = max / seq->seq.nframes, n = 0;
    char *out = malloc(max + 1);
    if (!out)
        return err_set(err, "out of memory for job %llu's log", (unsigned long long)seq->id);
    for (uint32_t k = 0; k < seq->seq.nframes; k++) {
        const job_t *f = jobs_frame(m, seq, k);
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
    const job_t *j = jobs_find(m, msg->logs.job);
    master_actor_t who = ops_actor_of_peer(m, from);
    err_t err;
    if (!j) {
        master_reply_error(m, from, "no job %llu", (unsigned long long)msg->logs.job);
        return;
    }
    if (!ops_may_act(m, j, &who, &err)) {
        master_log(m, "task log of job %llu refused to %s: %s", (unsigned long long)j->id,
                   who.name[0] ? who.name : "(no key)", err.msg);
        master_reply_error(m, from, "%s", err.msg);
        return;
    }
    size_t max = m->limits.max_message_bytes > FILE_OVERHEAD
                     ? m->limits.max_message_bytes - FILE_OVERHEAD
                     : 4096;
    if (max > (size_t)8 << 20)
        max = (size_t)8 << 20;
    if (j->seq.nframes > 0 && msg->logs.has_task) {
        master_reply_error(m, from,
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
        master_reply_error(m, from, "job %llu: %s", (unsigned long long)j->id, err.msg);
        return;
    }
    char name[64];
    snprintf(name, sizeof name, "job-%llu.log", (unsigned long long)j->id);
    proto_msg_t f = {.type = PROTO_FILE,
                     .file = {.name = name, .data = (const uint8_t *)text, .size = len}};
    master_reply(m, from, &f);
    free(text);
}

static void on_metrics(master_t *m, const proto_peer_t *from, double now)
{
    char *text;
    size_t len;
    err_t err;
    if (master_metrics_text(m, now, &text, &len, &err) < 0) {
        master_reply_error(m, from, "%s", err.msg);
        return;
    }
    proto_msg_t f = {.type = PROTO_FILE,
                     .file = {.name = "metrics.txt", .data = (const uint8_t *)text, .size = len}};
    master_reply(m, from, &f);
    free(text);
}

void on_client_message(master_t *m, const proto_peer_t *from, const proto_msg_t *msg, double now)
{
    switch (msg->type) {
    case PROTO_SUBMIT:
        submit_start(m, from, msg, now);
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
        master_reply_error(m, from, "%s is not a request the master's client endpoint answers",
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
        const job_t *j = jobs_find(m, wt.job);
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
