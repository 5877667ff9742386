#include "persist.h"

#include "files.h"

#include <dirent.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

journal_job_t persist_record(const master_t *m, const mjob_t *j, double now)
{
    journal_job_t r = {.id = j->id,
                       .name = j->name,
                       .hash = (char *)j->hash,
                       .main = j->main,
                       .settings = j->settings,
                       .state = (int)j->state,
                       .error = j->error,
                       .round = j->sched.round,
                       .photon_base = j->photons.base,
                       .photons_saved = j->photons.saved,
                       .round_photons = j->journal.round_photons,
                       .refine_photons = j->journal.refine_photons,
                       .checkpoint = j->journal.checkpoint,
                       .stop = (int)j->accuracy.stop,
                       .outputs = j->outputs.final,
                       .samples_done = j->sched.samples_done,
                       .samples_total = j->sched.samples_total,
                       .nonfinite = j->sched.nonfinite,
                       .spp_done = j->accuracy.spp_done,
                       .priority = j->ops.priority,
                       .paused = j->ops.paused};
    snprintf(r.owner, sizeof r.owner, "%s", j->owner);
    r.elapsed = job_elapsed(m, j, now);
    return r;
}

void persist_checkpoint_path(const master_t *m, uint64_t job, uint64_t gen, char *buf, size_t size)
{
    snprintf(buf, size, "%s/jobs/%llu/checkpoint-%llu.bin", spool_path(m->spool),
             (unsigned long long)job, (unsigned long long)gen);
}

/* The files a master killed between writing a checkpoint and journaling it, or between
 * journaling the next one and removing this one, left behind; and the previous generation that
 * persist_maybe_checkpoint keeps, once it is not needed. */
static void remove_checkpoints_but(master_t *m, uint64_t id, uint64_t keep, uint64_t keep2)
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
            ((gen == keep || gen == keep2) && gen > 0 && !strstr(e->d_name, ".tmp")))
            continue;
        char path[PATH_MAX + 300];
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        (void)unlink(path);
    }
    (void)closedir(d);
}

void persist_remove_stale_checkpoints(master_t *m, uint64_t id, uint64_t keep)
{
    remove_checkpoints_but(m, id, keep, keep);
}

void persist_failed(const master_t *m, const mjob_t *j, const err_t *err)
{
    master_log(m,
               "job %llu: journal: %s (a restarted master would not resume this job's latest "
               "progress)",
               (unsigned long long)j->id, err->msg);
}

void persist_state(master_t *m, mjob_t *j, double now)
{
    if (!m->journal)
        return;
    err_t err;
    journal_job_t r = persist_record(m, j, now);
    if (journal_set_state(m->journal, &r, &err) < 0) {
        persist_failed(m, j, &err);
        return;
    }
    if (job_over(j) && j->journal.checkpoint > 0) {
        /* This one and the previous (a leftover is removed at the next start: resume_jobs). */
        persist_remove_stale_checkpoints(m, j->id, 0);
        j->journal.checkpoint = 0;
    }
}

/* Once the results journaled since the last checkpoint outgrow the image, the merged image is
 * written as a new checkpoint and the results in it leave the journal. Not more often than
 * every CHECKPOINT_INTERVAL_S unless they outgrow it fourfold: a large image's checkpoint takes
 * the master's loop a while (315 MB at 1920x1080 with 16 buckets), and early passes are short.
 * So the spool holds at most about five images' worth per running job, and a restart replays
 * at most four. */
#define CHECKPOINT_INTERVAL_S 10.0
void persist_maybe_checkpoint(master_t *m, mjob_t *j, double now)
{
    sched_job_info_t info;
    if (!m->journal || sched_job_info(m->sched, j->id, &info) < 0 || info.state != JOB_RUNNING ||
        info.samples_done == j->journal.checkpoint_samples)
        return;
    size_t image_bytes =
        (size_t)j->scene.xres * (size_t)j->scene.yres * ((size_t)j->scene.grid.n + 3) * 8;
    if (j->journal.bytes < image_bytes ||
        (j->journal.bytes < 4 * image_bytes &&
         now - j->journal.last_checkpoint < CHECKPOINT_INTERVAL_S))
        return;
    err_t err;
    int *next = malloc((size_t)info.ntiles * sizeof *next);
    char path[PATH_MAX + 64];
    uint64_t gen = j->journal.checkpoint + 1;
    persist_checkpoint_path(m, j->id, gen, path, sizeof path);
    journal_job_t r = persist_record(m, j, now);
    if (!next) {
        err_set(&err, "out of memory for a checkpoint");
    } else if (sched_job_next_pass(m->sched, j->id, next, info.ntiles) < 0) {
        err_set(&err, "the scheduler has no pass table for the job");
    } else if (journal_write_checkpoint(path, j->sched.round, sched_job_image(m->sched, j->id),
                                        next, info.ntiles, &err) == 0 &&
               journal_set_checkpoint(m->journal, j->id, j->sched.round, gen, next, info.ntiles,
                                      r.elapsed, &err) == 0) {
        /* The previous generation stays until this one's row is durable and beyond: a journal
         * that loses its last commits (a WAL cut short by a power cut) still names it, or the
         * new one is damaged (issue 16). resume.c takes the newest that checks out. */
        remove_checkpoints_but(m, j->id, gen, j->journal.checkpoint);
        j->journal.checkpoint = gen;
        j->journal.bytes = 0;
        j->journal.checkpoint_samples = info.samples_done;
        j->journal.last_checkpoint = now;
        free(next);
        return;
    } else {
        (void)unlink(path);
    }
    free(next);
    persist_failed(m, j, &err);
    j->journal.bytes = 0; /* try again after as many bytes, not after every result */
    j->journal.last_checkpoint = now;
}

/* A restarted master or a refinement loads the store instead of tracing again. */
int persist_save_photons(master_t *m, mjob_t *j, err_t *err)
{
    char dir[PATH_MAX], path[PATH_MAX + 32];
    const uint8_t *data;
    size_t size;
    const char *hash;
    uint64_t photons = photon_phase_stats(j->photons.phase).photons;
    if (j->photons.saved == photons && photons > 0)
        return 0;
    if (spool_job_dir(m->spool, j->id, dir, sizeof dir, err) < 0 ||
        photon_phase_store(j->photons.phase, &data, &size, &hash, err) < 0)
        return -1;
    snprintf(path, sizeof path, "%s/photons.store", dir);
    if (files_write_atomic(path, data, size, true, err) < 0)
        return -1;
    j->photons.saved = photons;
    if (m->journal && journal_set_photons_saved(m->journal, j->id, photons, err) < 0)
        persist_failed(m, j, err);
    return 0;
}
