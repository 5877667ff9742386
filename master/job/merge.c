#include "merge.h"

#include "error_estimate.h"
#include "jobs.h"
#include "passes.h"
#include "persist.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* After a result that completed one or more passes. At each pass boundary: the error estimate
 * of the image (exactly the passes merged when the job may end early: sched.h, whole passes),
 * its record and log line, and the stopping rules, which end the job at the first boundary
 * where the estimate is <= target_error or time_limit has passed. A job that goes on gets a
 * preview, at most every preview_interval_s. */
static void passes_merged(master_t *m, job_t *j, int rc, double now)
{
    err_t err;
    sched_job_info_t info;
    while ((rc & SCHED_PASS_DONE) && sched_job_info(m->sched, j->id, &info) == 0) {
        error_estimate_t e = error_estimate_image(sched_job_image(m->sched, j->id));
        double elapsed = job_elapsed(m, j, now);
        /* A restarted master merging the journal's results again meets passes it recorded. */
        bool known = j->accuracy.nhistory > 0 &&
                     j->accuracy.history[j->accuracy.nhistory - 1].pass >= info.passes_done;
        if (!known && j->accuracy.nhistory < STOPPING_MAX_RECORDS) {
            pass_record_t rec = stopping_record(info.passes_done, info.spp_done, elapsed, &e);
            j->accuracy.history[j->accuracy.nhistory++] = rec;
            journal_pass_t jp = {.pass = rec.pass,
                                 .spp = rec.spp,
                                 .elapsed = rec.elapsed,
                                 .valid = rec.valid,
                                 .rel_error = rec.rel_error};
            if (m->journal && journal_add_pass(m->journal, j->id, j->sched.round, &jp, &err) < 0)
                persist_failed(m, j, &err);
        }
        char est[64] = "no error estimate yet (1 sample per pixel)";
        if (e.valid)
            snprintf(est, sizeof est, "relative error %.4g", e.rel_rmse);
        else if (e.saturated > 0)
            snprintf(est, sizeof est, "no error estimate (%llu pixels beyond range)",
                     (unsigned long long)e.saturated);
        else if (e.pixels > 0)
            snprintf(est, sizeof est, "no relative error (image mean %.3g)", e.mean);
        char tiles[64] = "";
        if (info.adaptive)
            snprintf(tiles, sizeof tiles, "; %d of %d tiles running", info.tiles_active,
                     info.ntiles);
        master_log(m, "job %llu pass %d of %d merged: %d spp, %s after %.2f s%s",
                   (unsigned long long)j->id, info.passes_done, info.npasses, info.spp_done, est,
                   elapsed, tiles);
        proto_stop_t stop = PROTO_STOP_NONE;
        if (info.state == JOB_RUNNING && info.whole_passes) {
            stopping_rule_t rule = job_stopping_rule(j);
            stop = (proto_stop_t)stopping_decide(&rule, &e, elapsed);
        }
        if (stop != PROTO_STOP_NONE) {
            if (sched_finish_job_at_pass(m->sched, j->id, &err) < 0) {
                master_log(m, "job %llu: cannot end it at pass %d: %s", (unsigned long long)j->id,
                           info.passes_done, err.msg);
            } else {
                j->accuracy.stop = stop;
                return; /* job_refresh writes the outputs and tells the workers */
            }
        }
        if (!(rc & SCHED_PASS_READY))
            break;
        rc = sched_merge_next_pass(m->sched, j->id, &err);
        if (rc < 0) {
            master_log(m, "job %llu: %s", (unsigned long long)j->id, err.msg);
            sched_fail_job(m->sched, j->id, err.msg);
            return;
        }
    }
    /* Short passes would write a PNG each, costing the master's CPU (which shares the cores
     * with the workers' threads) for images nobody looks at that often; the final image is
     * written when the job is done whatever the interval. */
    if (sched_job_info(m->sched, j->id, &info) < 0 || info.state != JOB_RUNNING ||
        now - (j->outputs.last_preview > 0 ? j->outputs.last_preview : j->started) <
            m->opts->preview_interval_s)
        return;
    if (job_write_image(m, j, false, &err) < 0) {
        master_log(m, "job %llu: cannot write the preview: %s", (unsigned long long)j->id, err.msg);
    } else {
        j->outputs.preview = true;
        j->outputs.last_preview = now;
        master_log(m, "job %llu preview written at %d spp", (unsigned long long)j->id,
                   info.spp_done);
    }
}

/* A result from a worker the task was not issued to (issue 16: a key forged a job's pixels):
 * dropped and logged with the worker and its key's name; it counts as no failure of the task. */
/* The task log's line for a result a worker returned: merged, a duplicate (a re-issued copy's
 * twin), refused or bad. Results replayed from the journal were logged when they came. */
static void log_result(master_t *m, const job_t *j, const merge_source_t *src, uint32_t task,
                       uint32_t attempt, const char *outcome)
{
    char label[PROTO_TASK_LABEL_MAX];
    if (!src->replay)
        tasklog_add(m->tasklog, j->id,
                    "task %s attempt %u from worker %llu '%s' (%.3f s, %llu samples): %s",
                    proto_task_label(task, label), attempt, (unsigned long long)src->id,
                    src->name, src->elapsed, (unsigned long long)src->samples, outcome);
}

static void merge_refused(master_t *m, const job_t *j, const merge_source_t *src, uint32_t task,
                          const err_t *why)
{
    char label[PROTO_TASK_LABEL_MAX];
    proto_task_label(task, label);
    if (!src->replay)
        tasklog_add(m->tasklog, j->id, "task %s: a result from worker %llu '%s' refused: %s", label,
                    (unsigned long long)src->id, src->name, why->msg);
    master_log(m, "refused a result from worker %llu '%s' (key '%s') for job %llu task %s: %s",
               (unsigned long long)src->id, src->name,
               src->key && src->key[0] ? src->key : "none: no CURVE", (unsigned long long)j->id,
               label, why->msg);
    /* A strike in its row: a worker that sends refused results and nothing else is blocked
     * (finding 6 of issue 26: hundreds of them were never cut off). */
    if (!src->replay)
        sched_worker_strike(m->sched, src->id);
}

/* A result the scheduler refused (rc has SCHED_REFUSED: a strike, merge_refused) or found bad
 * (rc < 0: logged and counted as the task's failure), for photon batches and camera tiles
 * alike. Returns true when the result was one of those and nothing is to be merged. */
static bool merge_rejected(master_t *m, const job_t *j, const merge_source_t *src, uint32_t task,
                           uint32_t attempt, int rc, const char *kind, err_t *err)
{
    if (rc >= 0 && (rc & SCHED_REFUSED)) {
        merge_refused(m, j, src, task, err);
        return true;
    }
    if (rc >= 0)
        return false;
    master_log(m, "bad %s from %s %llu '%s' for job %llu: %s", kind,
               src->replay ? "the journal" : "worker", (unsigned long long)src->id, src->name,
               (unsigned long long)j->id, err->msg);
    char what[600];
    snprintf(what, sizeof what, "bad, counted as a failure: %s", err->msg);
    log_result(m, j, src, task, attempt, what);
    sched_task_failed(m->sched, src->id, j->id, task, attempt, err->msg);
    return true;
}

void merge_photon_phase_done(master_t *m, job_t *j)
{
    err_t err;
    const uint8_t *data;
    size_t size;
    const char *hash;
    if (photon_phase_store(j->photons.phase, &data, &size, &hash, &err) < 0) {
        master_log(m, "job %llu: the merged photon store: %s", (unsigned long long)j->id, err.msg);
        sched_fail_job(m->sched, j->id, err.msg);
        return;
    }
    memcpy(j->photons.store, hash, sizeof j->photons.store);
    j->photons.store_ready = true;
    photon_phase_stats_t ps = photon_phase_stats(j->photons.phase);
    master_log(m,
               "job %llu photon pass merged: %llu photons in %u batch%s, %llu emitted, %.1f MB "
               "store %.12s",
               (unsigned long long)j->id, (unsigned long long)ps.photons, ps.batches,
               ps.batches == 1 ? "" : "es", (unsigned long long)ps.emitted, size / 1e6, hash);
    if (m->journal && persist_save_photons(m, j, &err) < 0)
        persist_failed(m, j, &err);
}

/* Appends a merged result to the journal as it was received (src->wire: the RESULT message's
 * bytes, already checked by its decoder and by the merge); a replayed one is there already. */
static void journal_result(master_t *m, job_t *j, const merge_source_t *src, uint32_t task,
                           int kind, int index, int pass)
{
    err_t err;
    if (!m->journal || src->replay)
        return;
    if (!src->wire) {
        err_set(&err, "task %u's result came without its message bytes", task);
        persist_failed(m, j, &err);
    } else if (journal_add_result(m->journal, j->id, j->sched.round, task, kind, index, pass,
                                  src->wire, src->wire_size, &err) < 0) {
        persist_failed(m, j, &err);
    } else if (kind == 0) {
        j->journal.bytes += src->wire_size;
    }
}

/* A photon batch's result for task (SCHED_PHOTON_TASK | batch). */
static void merge_photon_batch(master_t *m, job_t *j, const merge_source_t *src, uint32_t task,
                               uint32_t attempt, const proto_photon_result_t *r, double now)
{
    err_t err;
    int rc = -1;
    uint32_t b = task & ~SCHED_PHOTON_TASK;
    if (!(task & SCHED_PHOTON_TASK) || !j->photons.phase) {
        err_set(&err, "task %u is not a photon batch of the job, or its result is not one", task);
    } else if (!sched_may_return(m->sched, src->id, j->id, task, attempt, &err)) {
        merge_refused(m, j, src, task, &err);
        return;
    } else if ((rc = photon_phase_add(j->photons.phase, j->photons.base + b, r, &err)) >= 0)
        rc = sched_photon_done(m->sched, src->id, j->id, task, attempt, now, &err);
    if (merge_rejected(m, j, src, task, attempt, rc, "photon batch", &err))
        return;
    log_result(m, j, src, task, attempt,
               (rc & SCHED_MERGED) ? "merged" : "a duplicate of a result merged already");
    if (rc & SCHED_MERGED)
        journal_result(m, j, src, task, 1, (int)b, -1);
    if (rc & SCHED_PHASE_DONE)
        merge_photon_phase_done(m, j);
}

/* A camera tile's result: tb (taken) covers samples [sb, se). */
static void merge_camera_tile(master_t *m, job_t *j, const merge_source_t *src, uint32_t task,
                              uint32_t attempt, tilebuf_t *tb, uint32_t sb, uint32_t se, double now)
{
    uint64_t pass = j->sched.ntiles > 0 ? task / (uint64_t)j->sched.ntiles : 0;
    if (pass >= 40) {
        master_log(m, "%s %llu sent a result for job %llu task %u, which does not exist",
                   src->replay ? "the journal" : "worker", (unsigned long long)src->id,
                   (unsigned long long)j->id, task);
        tilebuf_destroy(&tb);
        return;
    }
    uint32_t pb, pe;
    passes_range(j->scene.spp, pass, &pb, &pe);
    err_t err;
    int rc = -1;
    if (sb != pb || se != pe) {
        tilebuf_destroy(&tb);
        err_set(&err, "the result covers samples [%u, %u), task %u is samples [%u, %u)", sb, se,
                task, pb, pe);
    } else {
        rc = sched_task_done(m->sched, src->id, j->id, task, attempt, &tb, now, &err);
    }
    if (merge_rejected(m, j, src, task, attempt, rc, "result", &err))
        return;
    log_result(m, j, src, task, attempt,
               (rc & SCHED_MERGED) ? "merged" : "a duplicate of a result merged already");
    if (rc & SCHED_MERGED)
        journal_result(m, j, src, task, 0, (int)(task % (uint32_t)j->sched.ntiles), (int)pass);
    if (rc & SCHED_PASS_DONE)
        passes_merged(m, j, rc, now);
    persist_maybe_checkpoint(m, j, now);
}

void merge_result(master_t *m, job_t *j, const merge_source_t *src, uint32_t task, uint32_t attempt,
                  const proto_msg_t *msg, double now)
{
    if (msg->result.kind == PROTO_KIND_PHOTON_BATCH || (task & SCHED_PHOTON_TASK)) {
        if (msg->result.kind != PROTO_KIND_PHOTON_BATCH) {
            err_t err;
            err_set(&err, "a camera result for a photon batch");
            merge_rejected(m, j, src, task, attempt, -1, "result", &err);
        } else {
            merge_photon_batch(m, j, src, task, attempt, &msg->result.photons, now);
        }
        return;
    }
    const proto_tile_result_t *r = &msg->result.tile;
    err_t err;
    tilebuf_t *tb =
        tilebuf_new_from(r->rect.x0, r->rect.y0, r->rect.w, r->rect.h, r->nbuckets, r->sums, r->xyz,
                         r->counts, r->lum, r->lum_sq, r->nonfinite, &err);
    if (!tb)
        merge_rejected(m, j, src, task, attempt, -1, "result", &err);
    else
        merge_camera_tile(m, j, src, task, attempt, tb, r->rect.sample_begin, r->rect.sample_end,
                          now);
}

int merge_replay_v8(master_t *m, job_t *j, uint32_t task, int kind, const void *data, size_t size,
                    double now, err_t *err)
{
    merge_source_t src = {.id = SCHED_JOURNAL, .name = "journal", .replay = true};
    if (kind == 1) {
        proto_photon_result_t r;
        if (journal_unpack_photons(data, size, &r, err) < 0)
            return -1;
        merge_photon_batch(m, j, &src, task, 0, &r, now);
        return 0;
    }
    uint32_t sb, se;
    tilebuf_t *tb = journal_unpack_tile(data, size, &sb, &se, err);
    if (!tb)
        return -1;
    merge_camera_tile(m, j, &src, task, 0, tb, sb, se, now);
    return 0;
}
