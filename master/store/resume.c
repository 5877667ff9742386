#include "resume.h"

#include "clock.h"
#include "jobs.h"
#include "merge.h"
#include "persist.h"

#include <dirent.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct replay {
    master_t *m;
    job_t *j;
    double now;
    size_t results;
} replay_t;

static int replay_result(void *user, uint32_t task, int kind, const void *data, size_t size,
                         err_t *err)
{
    replay_t *rp = user;
    merge_source_t src = {.id = SCHED_JOURNAL, .name = "journal", .replay = true};
    sched_job_info_t info;
    if (sched_job_info(rp->m->sched, rp->j->id, &info) < 0)
        return err_set(err, "the job left the scheduler during its replay");
    if (info.state == JOB_QUEUED &&
        sched_restore_job(rp->m->sched, rp->j->id, NULL, NULL, 0, err) < 0)
        return -1;
    if (info.state != JOB_QUEUED && info.state != JOB_RUNNING)
        return 0; /* over already (the journal held more than it needed) */
    if (journal_blob_is_v8(data, size)) {
        if (merge_replay_v8(rp->m, rp->j, task, kind, data, size, rp->now, err) < 0)
            return -1;
    } else {
        /* The RESULT as a worker sent it, checked again as when it came: a blob whose bytes
         * changed on disk but kept their CRC is still refused, never merged. */
        proto_msg_t msg;
        if (proto_decode(data, size, &rp->m->limits, &msg, err) < 0)
            return err_prefix(err, "a journaled result: ");
        if (msg.type != PROTO_RESULT || msg.result.job != rp->j->id ||
            (uint32_t)(msg.result.task & UINT32_MAX) != task ||
            (msg.result.kind == PROTO_KIND_PHOTON_BATCH) != (kind == 1)) {
            proto_msg_free(&msg);
            return err_set(err, "a journaled result is not job %llu's task %u's",
                           (unsigned long long)rp->j->id, task);
        }
        merge_result(rp->m, rp->j, &src, task, 0, &msg, rp->now);
        proto_msg_free(&msg);
    }
    if (kind != 1)
        rp->j->journal.bytes += size;
    rp->results++;
    return 0;
}

/* The job's pass records of its current round, from the journal. */
static int load_passes(master_t *m, job_t *j, err_t *err)
{
    journal_pass_t passes[STOPPING_MAX_RECORDS];
    int n = journal_passes(m->journal, j->id, j->sched.round, passes, STOPPING_MAX_RECORDS, err);
    if (n < 0)
        return -1;
    j->accuracy.nhistory = 0;
    for (int i = 0; i < n; i++)
        j->accuracy.history[j->accuracy.nhistory++] =
            (pass_record_t){.pass = passes[i].pass,
                            .spp = passes[i].spp,
                            .elapsed = passes[i].elapsed,
                            .valid = passes[i].valid,
                            .rel_error = passes[i].rel_error};
    return 0;
}

static int gen_desc(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? 1 : x > y ? -1 : 0;
}

/* The newest checkpoint of the job's folder that checks out (its SHA-256, size, round), into
 * *image and next; returns its generation, 0 for none. Any checkpoint of the round is a right
 * starting point whatever the journal names: it holds tile t's passes below next[t], merged in
 * pass order, and the journaled results below them are duplicates, those above are merged
 * again, and what neither holds is rendered again. So a damaged checkpoint falls back to the
 * previous one (persist.c keeps it) and a journal that lost its last commits uses the file it
 * no longer names; each one passed over is logged with the job and the file. */
static uint64_t restore_checkpoint(master_t *m, job_t *j, uint64_t named, tilebuf_t **image,
                                   int *next)
{
    char dir[PATH_MAX];
    snprintf(dir, sizeof dir, "%s/jobs/%llu", spool_path(m->spool), (unsigned long long)j->id);
    uint64_t gens[64];
    size_t n = 0;
    bool found_named = named == 0;
    DIR *d = opendir(dir);
    struct dirent *e;
    while (d && (e = readdir(d)) && n < sizeof gens / sizeof *gens) {
        unsigned long long gen;
        char tail[8];
        if (sscanf(e->d_name, "checkpoint-%llu.bi%7s", &gen, tail) == 2 && !strcmp(tail, "n") &&
            gen > 0) {
            gens[n++] = gen;
            found_named |= gen == named;
        }
    }
    if (d)
        (void)closedir(d);
    if (!found_named)
        master_log(m, "job %llu '%s': checkpoint-%llu.bin, which the journal names, is missing",
                   (unsigned long long)j->id, j->name, (unsigned long long)named);
    qsort(gens, n, sizeof *gens, gen_desc);
    for (size_t i = 0; i < n; i++) {
        char path[PATH_MAX + 64];
        err_t err;
        persist_checkpoint_path(m, j->id, gens[i], path, sizeof path);
        if (journal_read_checkpoint(path, j->sched.round, j->scene.xres, j->scene.yres,
                                    j->scene.nbuckets, j->sched.ntiles, image, next, &err) == 0) {
            if (gens[i] != named)
                master_log(m, "job %llu '%s': resumed from checkpoint-%llu.bin (the journal "
                              "names checkpoint-%llu.bin)",
                           (unsigned long long)j->id, j->name, (unsigned long long)gens[i],
                           (unsigned long long)named);
            return gens[i];
        }
        master_log(m, "job %llu '%s': %s: %s", (unsigned long long)j->id, j->name, err.msg,
                   i + 1 < n ? "trying the previous checkpoint"
                             : "its merged passes are rendered again");
    }
    return 0;
}

/* An unfinished job of the journal back in the scheduler where the journal leaves it: its
 * photon store from disk (or a fresh phase), its last checkpoint, its pass records, then every
 * result journaled since, merged again in the scheduler's order. */
static int resume_job(master_t *m, const journal_job_t *r, double now, err_t *err)
{
    char dir[PATH_MAX];
    snprintf(dir, sizeof dir, "%s/scenes/%s", spool_path(m->spool), r->hash);
    job_t *j = job_new(r->id, r->name, r->hash, r->main, &r->settings, dir, &m->opts->budget,
                       m->opts->shelf, 0, JOB_POLAR_KEEP, err);
    if (!j)
        return -1;
    snprintf(j->owner, sizeof j->owner, "%s", r->owner);
    j->seq.parent = r->parent;
    j->seq.frame = r->frame;
    j->sched.round = r->round;
    j->photons.saved = r->photons_saved;
    j->journal.round_photons = r->round_photons;
    j->journal.refine_photons = r->refine_photons;
    j->submitted = now;
    j->ops.priority = r->priority;
    j->ops.paused = r->paused;
    uint32_t batches = 0, photons_done = 0;
    if (j->photons.phase && r->photons_saved > 0) {
        photon_phase_destroy(&j->photons.phase);
        if (job_restore_photons(m, j, err) < 0) {
            job_destroy(&j);
            return -1;
        }
        uint32_t base = photon_phase_nbatches(j->photons.phase);
        if (r->photons_saved >= r->round_photons) {
            batches = photons_done = base; /* the round's store is merged: camera phase */
        } else if (photon_phase_refine(j->photons.phase, r->round_photons - r->photons_saved, err) <
                   0) {
            job_destroy(&j);
            return -1;
        } else {
            j->photons.base = base;
            batches = photon_phase_nbatches(j->photons.phase) - base;
        }
    } else if (j->photons.phase) {
        batches = photon_phase_nbatches(j->photons.phase);
    }
    if (job_schedule(m, j, batches, err) < 0) {
        job_destroy(&j);
        return -1;
    }
    /* From here on the job is listed: a failure fails it, with the reason. */
    int rc = 0;
    tilebuf_t *image = NULL;
    int *next = NULL;
    if (!(next = malloc((size_t)j->sched.ntiles * sizeof *next)))
        rc = err_set(err, "out of memory");
    else
        j->journal.checkpoint = restore_checkpoint(m, j, r->checkpoint, &image, next);
    if (rc == 0 && (image || photons_done > 0))
        rc = sched_restore_job(m->sched, j->id, &image, image ? next : NULL, photons_done, err);
    free(next);
    tilebuf_destroy(&image);
    if (rc >= 0 && photons_done > 0)
        merge_photon_phase_done(m, j);
    if (rc >= 0)
        rc = load_passes(m, j, err);
    sched_job_info_t info;
    if (rc >= 0 && sched_job_info(m->sched, j->id, &info) == 0) {
        j->journal.checkpoint_samples = info.samples_done;
        if (info.state == JOB_RUNNING) {
            j->started = now - r->elapsed;
            j->state = JOB_RUNNING;
        }
    }
    replay_t rp = {.m = m, .j = j, .now = now};
    size_t lost = 0;
    journal_prune(m->journal, j->id);
    if (rc >= 0)
        rc = journal_results(m->journal, j->id, j->sched.round, replay_result, &rp, &lost, err);
    if (lost > 0)
        master_log(m,
                   "job %llu: %zu journaled results lost their files (a power cut?): rendered "
                   "again",
                   (unsigned long long)j->id, lost);
    if (rc < 0) {
        char msg[600];
        snprintf(msg, sizeof msg, "cannot resume it after the master restarted: %s", err->msg);
        sched_fail_job(m->sched, j->id, msg);
        job_refresh(m, j, now);
        return 0; /* listed as failed, with the reason */
    }
    persist_remove_stale_checkpoints(m, j->id, j->journal.checkpoint);
    if (sched_job_info(m->sched, j->id, &info) == 0)
        master_log(m,
                   "job %llu '%s' resumed: %d of %d passes merged, %llu of %llu samples, %u of %u "
                   "photon batches, %zu results from the journal",
                   (unsigned long long)j->id, j->name, info.passes_done, info.npasses,
                   (unsigned long long)info.samples_done, (unsigned long long)info.samples_total,
                   info.photon_batches_done, info.photon_batches, rp.results);
    tasklog_add(m->tasklog, j->id, "job resumed by a restarted master: %d of %d passes merged%s",
                info.passes_done, info.npasses, j->ops.paused ? " (paused)" : "");
    job_refresh(m, j, now);
    return 0;
}

/* A folder jobs/<id> of the spool is made at submission, after the job's row is committed: one
 * the journal has no row for lost its record (a WAL garbled or deleted, a power cut, a damaged
 * database). It cannot be rendered without it, but it is never dropped in silence: the log
 * names it, and it is listed (and journaled) as failed with the reason. */
static void list_lost_jobs(master_t *m, const journal_job_t *rows, size_t n, const char *damage)
{
    char dir[PATH_MAX];
    snprintf(dir, sizeof dir, "%s/jobs", spool_path(m->spool));
    DIR *d = opendir(dir);
    if (!d)
        return;
    struct dirent *e;
    while ((e = readdir(d))) {
        const char *s = e->d_name;
        if (!*s || strspn(s, "0123456789") != strlen(s) || strlen(s) > 19)
            continue;
        uint64_t id = strtoull(s, NULL, 10);
        bool known = id == 0;
        for (size_t i = 0; i < n && !known; i++)
            known = rows[i].id == id;
        if (known)
            continue;
        char msg[800];
        snprintf(msg, sizeof msg,
                 "the journal lost its record (%s): the job cannot be resumed; submit it again",
                 damage[0] ? damage : "its last commits are missing");
        master_log(m, "job %llu: its folder %s/%s is in the spool but not in the journal: %s",
                   (unsigned long long)id, dir, s, msg);
        journal_job_t r = {.id = id, .name = "(lost)", .hash = "-", .main = "-",
                           .state = JOB_FAILED, .error = msg};
        err_t jerr;
        if (journal_add_job(m->journal, &r, &jerr) < 0 ||
            journal_set_state(m->journal, &r, &jerr) < 0)
            master_log(m, "job %llu: journal: %s", (unsigned long long)id, jerr.msg);
        job_t *j = job_from_record(&r);
        if (!j || jobs_append(m, j) < 0) {
            job_destroy(&j);
            continue;
        }
        if (id > m->last_job)
            m->last_job = id;
        persist_remove_stale_checkpoints(m, id, 0);
    }
    (void)closedir(d);
}

int resume_jobs(master_t *m, err_t *err)
{
    journal_job_t *rows;
    size_t n;
    char damage[512];
    err_t cerr;
    int problems = journal_check(m->journal, damage, sizeof damage, &cerr);
    if (problems < 0)
        snprintf(damage, sizeof damage, "its integrity check cannot run: %.400s", cerr.msg);
    if (problems != 0)
        master_log(m, "journal: the integrity check found damage: %s", damage);
    if (journal_jobs(m->journal, &rows, &n, err) < 0)
        return err_prefix(err, "%s%s", problems ? "the journal is damaged: " : "",
                          problems ? "move journal.db aside to start afresh: " : "");
    double now = clock_now_s();
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
        /* A sequence is never scheduled: its frames are (the rows after it), and it follows
         * them once they are all listed (below). */
        if ((r->state == JOB_QUEUED || r->state == JOB_RUNNING) && r->nframes == 0) {
            err_t jerr;
            if (resume_job(m, r, now, &jerr) == 0)
                continue;
            /* Not even listed by resume_job (its scene cannot be loaded, say): listed as failed. */
            char msg[600];
            snprintf(msg, sizeof msg, "cannot resume it after the master restarted: %s", jerr.msg);
            free(r->error);
            r->error = master_strdup(msg);
            r->state = JOB_FAILED;
            master_log(m, "job %llu '%s': %s", (unsigned long long)r->id, r->name, msg);
        }
        job_t *j = job_from_record(r);
        if (!j || jobs_append(m, j) < 0) {
            job_destroy(&j);
            rc = err_set(err, "out of memory for job %llu of the journal",
                         (unsigned long long)r->id);
            break;
        }
        /* A job that ended before the restart shows what it showed then: the time it ran and
         * its last error estimate. */
        if (r->elapsed > 0) {
            j->started = now - r->elapsed;
            j->finished = now;
        }
        err_t perr;
        if (job_over(j) && persist_load_figures(m, j, &perr) < 0)
            master_log(m, "job %llu: %s", (unsigned long long)j->id, perr.msg);
        if (load_passes(m, j, &perr) < 0)
            master_log(m, "job %llu: its pass records cannot be read: %s",
                       (unsigned long long)j->id, perr.msg);
        persist_remove_stale_checkpoints(m, j->id, 0);
        journal_prune(m->journal, j->id);
        if (r->state == JOB_FAILED && r->error && strstr(r->error, "after the master restarted"))
            persist_state(m, j, now); /* failed just now: the journal learns why */
    }
    for (size_t i = 0; i < m->njobs && rc == 0; i++)
        if (m->jobs[i]->seq.nframes > 0)
            jobs_sequence_refresh(m, m->jobs[i], now);
    if (rc == 0)
        list_lost_jobs(m, rows, n, problems > 0 ? damage : "");
    for (size_t i = 0; i < n; i++)
        journal_job_clear(&rows[i]);
    free(rows);
    return rc;
}
