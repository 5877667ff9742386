#include "persist.h"

#include "files.h"
#include "strbuf.h"
#include "tilegrid.h"

#include <dirent.h>
#include <pthread.h>
#include <stdatomic.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

journal_job_t persist_record(const master_t *m, const job_t *j, double now)
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
                       .paused = j->ops.paused,
                       .parent = j->seq.parent,
                       .frame = j->seq.frame,
                       .nframes = j->seq.nframes};
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

void persist_failed(const master_t *m, const job_t *j, const err_t *err)
{
    master_log(m,
               "job %llu: journal: %s (a restarted master would not resume this job's latest "
               "progress)",
               (unsigned long long)j->id, err->msg);
}

void persist_state(master_t *m, job_t *j, double now)
{
    if (!m->journal)
        return;
    err_t err;
    journal_job_t r = persist_record(m, j, now);
    if (journal_set_state(m->journal, &r, &err) < 0) {
        persist_failed(m, j, &err);
        return;
    }
    /* A checkpoint still being written for a job that ended is not waited for here (the loop
     * would stand still for the write): persist_checkpoints_collect removes its file once its
     * thread is done, as it is then no job's state. */
    if (job_over(j) && j->journal.checkpoint > 0) {
        /* This one and the previous (a leftover is removed at the next start: resume_jobs). */
        persist_remove_stale_checkpoints(m, j->id, 0);
        j->journal.checkpoint = 0;
    }
}

/* A checkpoint written off the loop: a copy of the image and its pass table taken on the loop,
 * the file written (packed, hashed, fsync'ed, renamed: seconds for a large image on a loaded
 * machine) by a thread of its own, and journaled on the loop once the thread is done, with the
 * pass table of the copy, so that exactly the results it holds leave the journal. Meanwhile the
 * loop reads messages and merges results (issue 17: a checkpoint written in the loop held
 * every message for its time: the p99 of the task latency). The copy costs an image of memory
 * while the file is written. */
struct checkpoint_writer {
    pthread_t thread;
    atomic_bool done;
    char path[PATH_MAX + 64];
    uint32_t round;
    tilebuf_t *image;
    int *next, ntiles;
    uint64_t gen, samples;
    size_t bytes; /* j->journal.bytes when the copy was taken */
    double elapsed;
    int rc;
    err_t err;
};

static void *checkpoint_thread(void *arg)
{
    struct checkpoint_writer *w = arg;
    w->rc = journal_write_checkpoint(w->path, w->round, w->image, w->next, w->ntiles, &w->err);
    atomic_store(&w->done, true);
    return NULL;
}

static void writer_free(struct checkpoint_writer *w)
{
    tilebuf_destroy(&w->image);
    free(w->next);
    free(w);
}

/* The file written: journaled (the previous generation kept until this one is durable and
 * beyond), or on failure removed and logged. */
static void checkpoint_written(master_t *m, job_t *j, struct checkpoint_writer *w, double now)
{
    err_t err;
    if (w->rc == 0 &&
        journal_set_checkpoint(m->journal, j->id, w->round, w->gen, w->next, w->ntiles,
                               w->elapsed, &err) == 0) {
        /* A journal that loses its last commits (a WAL cut short by a power cut) still names
         * the previous generation, or the new one is damaged (issue 16): resume.c takes the
         * newest that checks out. */
        remove_checkpoints_but(m, j->id, w->gen, j->journal.checkpoint);
        j->journal.checkpoint = w->gen;
        j->journal.bytes = j->journal.bytes > w->bytes ? j->journal.bytes - w->bytes : 0;
        j->journal.checkpoint_samples = w->samples;
        j->journal.last_checkpoint = now;
        return;
    }
    (void)unlink(w->path);
    persist_failed(m, j, w->rc < 0 ? &w->err : &err);
    j->journal.bytes = 0; /* try again after as many bytes, not after every result */
    j->journal.last_checkpoint = now;
}

void persist_checkpoints_collect(master_t *m, double now)
{
    for (size_t i = 0; i < m->njobs; i++) {
        job_t *j = m->jobs[i];
        struct checkpoint_writer *w = j->journal.writer;
        if (!w || !atomic_load(&w->done))
            continue;
        pthread_join(w->thread, NULL);
        j->journal.writer = NULL;
        /* A round the job left meanwhile (a refinement) or a job that ended: not its state. */
        if (j->sched.known && w->round == j->sched.round && !job_over(j))
            checkpoint_written(m, j, w, now);
        else
            (void)unlink(w->path);
        writer_free(w);
    }
}

void persist_checkpoint_drop(master_t *m, job_t *j)
{
    (void)m;
    struct checkpoint_writer *w = j->journal.writer;
    if (!w)
        return;
    pthread_join(w->thread, NULL);
    (void)unlink(w->path); /* never journaled: the journal names the previous generation */
    j->journal.writer = NULL;
    writer_free(w);
}

/* Once the results journaled since the last checkpoint outgrow the image, the merged image is
 * written as a new checkpoint and the results in it leave the journal. Not more often than
 * every CHECKPOINT_INTERVAL_S unless they outgrow it fourfold: early passes are short, and a
 * large image's checkpoint is a while of a thread and a copy of the image (315 MB at 1920x1080
 * with 16 buckets). So the spool holds at most about five images' worth per running job, and a
 * restart replays at most four. */
#define CHECKPOINT_INTERVAL_S 10.0
void persist_maybe_checkpoint(master_t *m, job_t *j, double now)
{
    sched_job_info_t info;
    if (!m->journal || j->journal.writer || sched_job_info(m->sched, j->id, &info) < 0 ||
        info.state != JOB_RUNNING || info.samples_done == j->journal.checkpoint_samples)
        return;
    size_t image_bytes =
        (size_t)j->scene.xres * (size_t)j->scene.yres * ((size_t)j->scene.nbuckets + 3) * 8;
    if (j->journal.bytes < image_bytes ||
        (j->journal.bytes < 4 * image_bytes &&
         now - j->journal.last_checkpoint < CHECKPOINT_INTERVAL_S))
        return;
    err_t err;
    struct checkpoint_writer *w = calloc(1, sizeof *w);
    const tilebuf_t *img = sched_job_image(m->sched, j->id);
    if (w) {
        w->round = j->sched.round;
        w->ntiles = info.ntiles;
        w->gen = j->journal.checkpoint + 1;
        w->samples = info.samples_done;
        w->bytes = j->journal.bytes;
        w->elapsed = persist_record(m, j, now).elapsed;
        persist_checkpoint_path(m, j->id, w->gen, w->path, sizeof w->path);
        w->next = malloc((size_t)info.ntiles * sizeof *w->next);
    }
    if (!w || !w->next || !img) {
        err_set(&err, "out of memory for a checkpoint");
    } else if (sched_job_next_pass(m->sched, j->id, w->next, info.ntiles) < 0) {
        err_set(&err, "the scheduler has no pass table for the job");
    } else if ((w->image = tilebuf_new_from(
                    tilebuf_x0(img), tilebuf_y0(img), tilebuf_width(img), tilebuf_height(img),
                    tilebuf_nbuckets(img), tilebuf_sums(img), tilebuf_xyz_sums(img),
                    tilebuf_counts(img), tilebuf_luminance_sums(img),
                    tilebuf_luminance_sq_sums(img), tilebuf_nonfinite(img), &err))) {
        atomic_init(&w->done, false);
        /* A thread of its own, not the pool's: it waits on the disk (base/pool.h). */
        if (pthread_create(&w->thread, NULL, checkpoint_thread, w) == 0) {
            j->journal.writer = w;
            return;
        }
        /* No thread: written here, as before. */
        checkpoint_thread(w);
        checkpoint_written(m, j, w, now);
        writer_free(w);
        return;
    }
    if (w)
        writer_free(w);
    persist_failed(m, j, &err);
    j->journal.bytes = 0;
    j->journal.last_checkpoint = now;
}

/* A restarted master or a refinement loads the store instead of tracing again. */
/* The most tiles a figures file may list: a 65536-pixel square image cut into 8-pixel tiles. */
#define FIGURES_MAX_TILES (1 << 26)

int persist_save_figures(master_t *m, const job_t *j, err_t *err)
{
    if (j->scene.xres < 1 || j->scene.yres < 1 || j->scene.spp < 1)
        return 0; /* its scene never loaded: nothing to show but its state */
    char dir[PATH_MAX], path[PATH_MAX + 32];
    if (spool_job_dir(m->spool, j->id, dir, sizeof dir, err) < 0)
        return -1;
    size_t ntiles =
        j->accuracy.tile_passes && j->accuracy.ntiles > 0 ? (size_t)j->accuracy.ntiles : 0;
    size_t size = 256 + 12 * ntiles, n = 0;
    char *text = malloc(size);
    if (!text)
        return err_set(err, "out of memory");
    strbuf_appendf(text, size, &n, "xres %d\nyres %d\nspp %d\nintegrator %s\ntile %d\n",
                   j->scene.xres, j->scene.yres, j->scene.spp,
                   j->scene.integrator ? j->scene.integrator : "?", j->sched.tile);
    if (j->sched.has_tasks)
        strbuf_appendf(text, size, &n, "tasks %u %u\n", j->sched.tasks_total, j->sched.tasks_done);
    if (ntiles) {
        strbuf_appendf(text, size, &n, "tile_passes %zu", ntiles);
        for (size_t i = 0; i < ntiles; i++)
            strbuf_appendf(text, size, &n, " %d", j->accuracy.tile_passes[i]);
        strbuf_appendf(text, size, &n, "\n");
    }
    snprintf(path, sizeof path, "%s/figures", dir);
    int rc = n < size
                 ? files_write_atomic(path, text, n, true, err)
                 : err_set(err, "the figures of job %llu do not fit", (unsigned long long)j->id);
    free(text);
    return rc;
}

int persist_load_figures(master_t *m, job_t *j, err_t *err)
{
    char dir[PATH_MAX], path[PATH_MAX + 32];
    if (spool_job_dir(m->spool, j->id, dir, sizeof dir, err) < 0)
        return -1;
    snprintf(path, sizeof path, "%s/figures", dir);
    FILE *f = fopen(path, "r");
    if (!f)
        return 0;
    int xres = 0, yres = 0, spp = 0, tile = 0, ntiles = -1;
    unsigned total = 0, done = 0;
    bool has_tasks = false;
    char integrator[32] = "?", key[32];
    int *passes = NULL, rc = 0;
    while (rc == 0 && fscanf(f, "%31s", key) == 1) {
        if (!strcmp(key, "xres"))
            rc = fscanf(f, "%d", &xres) == 1 ? 0 : -1;
        else if (!strcmp(key, "yres"))
            rc = fscanf(f, "%d", &yres) == 1 ? 0 : -1;
        else if (!strcmp(key, "spp"))
            rc = fscanf(f, "%d", &spp) == 1 ? 0 : -1;
        else if (!strcmp(key, "tile"))
            rc = fscanf(f, "%d", &tile) == 1 ? 0 : -1;
        else if (!strcmp(key, "integrator"))
            rc = fscanf(f, "%31s", integrator) == 1 ? 0 : -1;
        else if (!strcmp(key, "tasks"))
            rc = fscanf(f, "%u %u", &total, &done) == 2 && done <= total ? (has_tasks = true, 0)
                                                                         : -1;
        else if (!strcmp(key, "tile_passes") && !passes && fscanf(f, "%d", &ntiles) == 1 &&
                 ntiles > 0 && ntiles <= FIGURES_MAX_TILES &&
                 (passes = malloc((size_t)ntiles * sizeof *passes)))
            for (int i = 0; i < ntiles && rc == 0; i++)
                rc = fscanf(f, "%d", &passes[i]) == 1 && passes[i] >= 0 ? 0 : -1;
        else
            rc = -1;
    }
    fclose(f);
    if (rc < 0 || xres < 1 || yres < 1 || spp < 1 || xres > 1 << 20 || yres > 1 << 20 || tile < 1 ||
        tile > 1 << 20) {
        free(passes);
        return err_set(err, "%s does not read as a job's figures", path);
    }
    tilegrid_t grid = tilegrid_make(xres, yres, tile);
    if (passes && ntiles != tilegrid_count(&grid)) {
        free(passes);
        return err_set(err, "%s does not read as a job's figures", path);
    }
    j->scene.xres = xres;
    j->scene.yres = yres;
    j->scene.spp = spp;
    snprintf(j->scene.integrator_kept, sizeof j->scene.integrator_kept, "%s", integrator);
    j->scene.integrator = j->scene.integrator_kept;
    j->sched.tile = tile;
    j->sched.has_tasks = has_tasks;
    j->sched.tasks_total = total;
    j->sched.tasks_done = done;
    if (passes) {
        free(j->accuracy.tile_passes);
        j->accuracy.tile_passes = passes;
        j->accuracy.ntiles = ntiles;
    }
    return 0;
}

int persist_save_photons(master_t *m, job_t *j, err_t *err)
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
