#include "sched.h"

#include "adaptive.h"
#include "bisect.h"
#include "proto.h"
#include "tilegrid.h"

#include <float.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef enum { TASK_PENDING, TASK_RUNNING, TASK_DONE } task_state_t;

typedef struct task {
    task_state_t state;
    uint32_t attempt;
    int failures;
    uint64_t owner; /* worker holding it while RUNNING */
    uint64_t issued[2]; /* the last two workers it was issued to, newest first (0: none) */
    uint64_t avoid;     /* requeued by hand from this worker: not given back to it (0: none) */
    double deadline;
    tilebuf_t *result; /* done but not yet merged (an earlier pass of its tile is missing) */
} task_t;

typedef struct strike {
    uint64_t worker;
    int failures;
} strike_t;

typedef struct sched_job {
    uint64_t id;
    job_state_t state;
    int xres, yres, spp;
    tilegrid_t tiles;
    spectral_grid_t grid;
    int nbuckets; /* render_settings_buckets of the job's scene */
    int ntiles, npasses, passes_done;
    uint32_t *pass_begin; /* npasses + 1 bounds */
    task_t *tasks;        /* pass-major: task = pass * ntiles + tile */
    task_t *ptasks;       /* photon batches */
    uint32_t nphoton, photon_done, first_pending_photon;
    int *next_pass;       /* per tile: the pass to merge next */
    int *merged_in_pass;  /* per pass: tiles merged */
    int *done_in_pass;    /* per pass: tiles done (merged or held) */
    bool whole_passes;    /* merge a pass only once all its tiles are done (sched.h) */
    /* Adaptive sampling (sched_set_adaptive): the target its rule aims at, and per tile whether
     * it still runs; NULL for a job without it. A stopped tile's later tasks are done without a
     * result, its next_pass stays the pass it stopped at. */
    double adaptive_target;
    bool *active;
    bool *decided; /* adapt's copy of active, allocated with it: no allocation at a boundary */
    int tiles_active;
    uint32_t first_pending; /* no PENDING task before this index */
    uint32_t tasks_done;
    uint32_t running; /* tasks RUNNING, camera and photon: sched_job_info without a scan */
    uint64_t samples_done, samples_total;
    tilebuf_t *image;
    strike_t *strikes;
    size_t nstrikes;
    char error[512];
    /* Operations (sched.h, "Priorities, fair share, pause"). */
    int priority;
    bool paused;
    /* Its time paused while running (sched_job_paused_s): the pauses that ended, and when the
     * current one began (the caller's clock). */
    double paused_s, paused_at;
    uint32_t owner; /* index into sched.owners; its share is the sum of running over its jobs */
} sched_job_t;

typedef struct worker {
    uint64_t id;
    int slots, busy;
    int threads; /* tasks it runs at once; slots beyond them are prefetch (sched_worker_set_threads) */
    double last_seen;
    bool alive;
    uint64_t tasks_done, tasks_failed;
    uint64_t samples_done; /* camera samples of the results it returned first */
    uint32_t missed; /* deadlines missed since it last returned a task */
    uint32_t fail_streak; /* failures since it last returned a task */
    bool blocked;         /* no task of any job (sched_worker_block, or its fail_streak) */
} worker_t;

typedef struct owner {
    char name[SCHED_OWNER_MAX];
    uint32_t running; /* scratch of pick_job: tasks running over the owner's jobs */
} owner_t;

#define MAX_EVENTS 4096 /* undrained events kept; beyond, counted in events_dropped */

struct sched {
    sched_config_t cfg;
    sched_job_t **jobs;
    size_t njobs, cap_jobs;
    worker_t *workers;
    size_t nworkers, cap_workers;
    /* The live workers' idle threads (idle_of summed), kept as busy, threads and alive change:
     * prefetch_allowed asks it for every worker at every dispatch, and summing it there made a
     * turn of the loop quadratic in the workers. */
    uint64_t idle_threads;
    /* No running task's deadline is before this (the least issued since sched_tick last looked;
     * a task's deadline is set only when it is issued): a tick before it has no task to look at,
     * where scanning every task of every running job each turn of the master's loop cost it
     * the whole job's task table per turn. 0: look at the next tick. */
    double next_deadline;
    owner_t *owners; /* owners[0] is "" (no keys); never shrinks: one per key that submitted */
    size_t nowners, cap_owners;
    sched_event_t *events; /* since the last sched_events_take, oldest first */
    size_t nevents, cap_events;
    uint64_t events_dropped;
};

sched_config_t sched_config_default(void)
{
    return (sched_config_t){.task_deadline_s = 120.0, .worker_timeout_s = 5.0,
                            .max_task_failures = 4, .max_worker_job_failures = 2, .tile_size = 32,
                            .claim_start = 32, .max_worker_failures_in_row = 5};
}

sched_t *sched_new(const sched_config_t *cfg, err_t *err)
{
    sched_config_t c = cfg ? *cfg : sched_config_default();
    if (!(c.task_deadline_s > 0) || !(c.worker_timeout_s > 0) || c.max_task_failures < 1 ||
        c.max_worker_job_failures < 1 || c.tile_size < 1 || c.tile_size > 4096 ||
        c.claim_start < 0 || c.max_worker_failures_in_row < 0) {
        err_set(err, "scheduler settings out of range (deadline %g s, timeout %g s, tile %d)",
                c.task_deadline_s, c.worker_timeout_s, c.tile_size);
        return NULL;
    }
    sched_t *self = calloc(1, sizeof *self);
    if (!self) {
        err_set(err, "out of memory");
        return NULL;
    }
    self->cfg = c;
    return self;
}

static void sched_job_free(sched_job_t *j)
{
    if (!j)
        return;
    if (j->tasks)
        for (int i = 0; i < j->ntiles * j->npasses; i++)
            tilebuf_destroy(&j->tasks[i].result);
    free(j->tasks);
    free(j->ptasks);
    free(j->pass_begin);
    free(j->next_pass);
    free(j->merged_in_pass);
    free(j->done_in_pass);
    free(j->active);
    free(j->decided);
    free(j->strikes);
    tilebuf_destroy(&j->image);
    free(j);
}

void sched_destroy(sched_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    sched_t *self = *self_p;
    for (size_t i = 0; i < self->njobs; i++)
        sched_job_free(self->jobs[i]);
    free(self->jobs);
    free(self->workers);
    free(self->owners);
    free(self->events);
    free(self);
    *self_p = NULL;
}

static void fill_task(const struct sched_job *j, uint32_t i, sched_task_t *out);
static void check_job_done(struct sched_job *j, int *result);
static void stop_tile(struct sched *self, struct sched_job *j, int tile, int from_pass);
static void adapt(struct sched *self, struct sched_job *j);
static bool takes_tasks(const struct sched *self, const struct sched_job *j, uint64_t worker);

static sched_job_t *find_job(const sched_t *self, uint64_t id)
{
    for (size_t i = 0; i < self->njobs; i++)
        if (self->jobs[i]->id == id)
            return self->jobs[i];
    return NULL;
}

/* The first worker of id >= id in the table, which sched_worker_join keeps in id order: every
 * result, task and sign of life looks its worker up, and a linear search made a round of the
 * farm's workers quadratic in them. */
static uint64_t worker_key(const void *workers, size_t i)
{
    return ((const worker_t *)workers)[i].id;
}

static size_t worker_slot(const sched_t *self, uint64_t id)
{
    return bisect_lower(self->workers, self->nworkers, worker_key, id);
}

static worker_t *find_worker(const sched_t *self, uint64_t id)
{
    size_t i = worker_slot(self, id);
    return i < self->nworkers && self->workers[i].id == id ? &self->workers[i] : NULL;
}

/* Records what the caller should log (sched_events_take); beyond MAX_EVENTS undrained, only
 * counted, so that a caller that never drains cannot grow the scheduler without bound. */
static void emit(sched_t *self, sched_event_kind_t kind, uint64_t job, uint32_t task,
                 uint32_t attempt, uint64_t worker)
{
    if (self->nevents == self->cap_events) {
        size_t cap = self->cap_events ? 2 * self->cap_events : 64;
        sched_event_t *p = cap <= MAX_EVENTS ? realloc(self->events, cap * sizeof *p) : NULL;
        if (!p) {
            self->events_dropped++;
            return;
        }
        self->events = p;
        self->cap_events = cap;
    }
    self->events[self->nevents++] =
        (sched_event_t){.kind = kind, .job = job, .task = task, .attempt = attempt, .worker = worker};
}

size_t sched_events_take(sched_t *self, sched_event_t *out, size_t max, uint64_t *dropped)
{
    size_t n = self->nevents < max ? self->nevents : max;
    if (n > 0) {
        memcpy(out, self->events, n * sizeof *out);
        memmove(self->events, self->events + n, (self->nevents - n) * sizeof *self->events);
        self->nevents -= n;
    }
    if (dropped) {
        *dropped = self->events_dropped;
        self->events_dropped = 0;
    }
    return n;
}

static uint32_t ncamera(const sched_job_t *j)
{
    return (uint32_t)(j->ntiles * j->npasses);
}

/* The task of an id, camera or photon, or NULL for an id the job does not have. */
static task_t *task_of(sched_job_t *j, uint32_t id)
{
    if (id & SCHED_PHOTON_TASK) {
        uint32_t b = id & ~SCHED_PHOTON_TASK;
        return b < j->nphoton ? &j->ptasks[b] : NULL;
    }
    return id < ncamera(j) ? &j->tasks[id] : NULL;
}

int sched_add_job(sched_t *self, uint64_t id, int xres, int yres, int spp, spectral_grid_t grid,
                  int nbuckets, err_t *err)
{
    if (find_job(self, id))
        return err_set(err, "job %llu exists already", (unsigned long long)id);
    if (xres < 1 || yres < 1 || xres > 65536 || yres > 65536 || spp < 1 || spp > (1 << 24))
        return err_set(err, "job %llu: %dx%d pixels at %d spp is out of range", (unsigned long long)id,
                       xres, yres, spp);
    if (spectral_grid_validate(grid, err))
        return -1;
    if (nbuckets < grid.n || nbuckets % grid.n != 0 || nbuckets / grid.n > 4)
        return err_set(err, "job %llu: %d buckets per pixel is not 1 to 4 planes of the grid's %d",
                       (unsigned long long)id, nbuckets, grid.n);
    sched_job_t *j = calloc(1, sizeof *j);
    if (!j)
        return err_set(err, "out of memory");
    j->id = id;
    j->state = JOB_QUEUED;
    j->xres = xres;
    j->yres = yres;
    j->spp = spp;
    j->grid = grid;
    j->nbuckets = nbuckets;
    j->tiles = tilegrid_make(xres, yres, self->cfg.tile_size);
    j->ntiles = tilegrid_count(&j->tiles);
    j->npasses = passes_bounds(spp, NULL);
    j->pass_begin = malloc(((size_t)j->npasses + 1) * sizeof *j->pass_begin);
    j->tasks = calloc((size_t)j->ntiles * (size_t)j->npasses, sizeof *j->tasks);
    j->next_pass = calloc((size_t)j->ntiles, sizeof *j->next_pass);
    j->merged_in_pass = calloc((size_t)j->npasses, sizeof *j->merged_in_pass);
    j->done_in_pass = calloc((size_t)j->npasses, sizeof *j->done_in_pass);
    j->image = tilebuf_new(0, 0, xres, yres, nbuckets, err);
    if (!j->pass_begin || !j->tasks || !j->next_pass || !j->merged_in_pass || !j->done_in_pass ||
        !j->image) {
        sched_job_free(j);
        return err_set(err, "out of memory for job %llu (%dx%d, %d buckets)",
                       (unsigned long long)id, xres, yres, nbuckets);
    }
    passes_bounds(spp, j->pass_begin);
    j->samples_total = (uint64_t)xres * (uint64_t)yres * (uint64_t)spp;
    if (self->njobs == self->cap_jobs) {
        size_t cap = self->cap_jobs ? 2 * self->cap_jobs : 8;
        sched_job_t **p = realloc(self->jobs, cap * sizeof *p);
        if (!p) {
            sched_job_free(j);
            return err_set(err, "out of memory");
        }
        self->jobs = p;
        self->cap_jobs = cap;
    }
    self->jobs[self->njobs++] = j;
    return 0;
}

/* A worker's threads that run nothing (0 for a lost worker). */
static uint32_t idle_of(const worker_t *w)
{
    return w->alive && w->busy < w->threads ? (uint32_t)(w->threads - w->busy) : 0;
}

static void release_task(sched_t *self, sched_job_t *j, task_t *t)
{
    if (t->state != TASK_RUNNING)
        return;
    worker_t *w = find_worker(self, t->owner);
    if (w && w->busy > 0) {
        self->idle_threads -= idle_of(w);
        w->busy--;
        self->idle_threads += idle_of(w);
    }
    j->running--;
    t->state = TASK_PENDING;
    t->owner = 0;
}

static void requeue(sched_t *self, sched_job_t *j, uint32_t i)
{
    release_task(self, j, task_of(j, i));
    if (i & SCHED_PHOTON_TASK) {
        if ((i & ~SCHED_PHOTON_TASK) < j->first_pending_photon)
            j->first_pending_photon = i & ~SCHED_PHOTON_TASK;
    } else if (i < j->first_pending) {
        j->first_pending = i;
    }
}

/* Ends a job: running tasks are released (their workers' slots freed), held results freed. */
static void finish_job(sched_t *self, sched_job_t *j, job_state_t state)
{
    j->state = state;
    for (int i = 0; i < j->ntiles * j->npasses; i++) {
        release_task(self, j, &j->tasks[i]);
        tilebuf_destroy(&j->tasks[i].result);
    }
    for (uint32_t b = 0; b < j->nphoton; b++)
        release_task(self, j, &j->ptasks[b]);
}

static int grow_photon(sched_job_t *j, uint32_t n, err_t *err)
{
    if (n == 0 || n > SCHED_PHOTON_TASK - 1 - j->nphoton)
        return err_set(err, "job %llu: %u photon batches is out of range", (unsigned long long)j->id, n);
    task_t *p = realloc(j->ptasks, (size_t)(j->nphoton + n) * sizeof *p);
    if (!p)
        return err_set(err, "out of memory");
    memset(&p[j->nphoton], 0, (size_t)n * sizeof *p);
    j->ptasks = p;
    if (j->photon_done == j->nphoton)
        j->first_pending_photon = j->nphoton;
    j->nphoton += n;
    return 0;
}

int sched_add_photon_batches(sched_t *self, uint64_t id, uint32_t n, err_t *err)
{
    sched_job_t *j = find_job(self, id);
    if (!j)
        return err_set(err, "no job %llu", (unsigned long long)id);
    if (j->state != JOB_QUEUED || j->tasks_done > 0)
        return err_set(err, "job %llu has started: photon batches must come first", (unsigned long long)id);
    return grow_photon(j, n, err);
}

int sched_set_whole_passes(sched_t *self, uint64_t id, err_t *err)
{
    sched_job_t *j = find_job(self, id);
    if (!j)
        return err_set(err, "no job %llu", (unsigned long long)id);
    if ((j->state != JOB_QUEUED && j->state != JOB_RUNNING) || j->tasks_done > j->photon_done)
        return err_set(err, "job %llu has merged camera results already: whole passes must be "
                       "chosen before", (unsigned long long)id);
    j->whole_passes = true;
    return 0;
}

int sched_set_adaptive(sched_t *self, uint64_t id, double target_error, err_t *err)
{
    sched_job_t *j = find_job(self, id);
    if (!j)
        return err_set(err, "no job %llu", (unsigned long long)id);
    if (!j->whole_passes)
        return err_set(err, "job %llu merges tiles as they come: adaptive sampling decides at "
                       "whole-pass boundaries", (unsigned long long)id);
    if (!(target_error > 0 && target_error < 1))
        return err_set(err, "job %llu: adaptive sampling needs a target error in (0, 1), not %g",
                       (unsigned long long)id, target_error);
    if (j->tasks_done > j->photon_done)
        return err_set(err, "job %llu has merged camera results already: adaptive sampling must "
                       "be chosen before", (unsigned long long)id);
    if (!j->active && !(j->active = malloc((size_t)j->ntiles * sizeof *j->active)))
        return err_set(err, "out of memory");
    if (!j->decided && !(j->decided = malloc((size_t)j->ntiles * sizeof *j->decided))) {
        free(j->active);
        j->active = NULL;
        return err_set(err, "out of memory");
    }
    for (int t = 0; t < j->ntiles; t++)
        j->active[t] = true;
    j->tiles_active = j->ntiles;
    j->adaptive_target = target_error;
    return 0;
}

int sched_finish_job_at_pass(sched_t *self, uint64_t id, err_t *err)
{
    sched_job_t *j = find_job(self, id);
    if (!j)
        return err_set(err, "no job %llu", (unsigned long long)id);
    if (j->state != JOB_RUNNING)
        return err_set(err, "job %llu is %s: only a running job can end at a pass",
                       (unsigned long long)id, proto_job_state_name(j->state));
    if (!j->whole_passes)
        return err_set(err, "job %llu merges tiles as they come: only a whole-pass job can end "
                       "before its last pass", (unsigned long long)id);
    if (j->passes_done < 1)
        return err_set(err, "job %llu has no whole pass merged yet", (unsigned long long)id);
    finish_job(self, j, JOB_DONE);
    return 0;
}

int sched_restore_job(sched_t *self, uint64_t id, tilebuf_t **image, const int *next_pass,
                      uint32_t photons_done, err_t *err)
{
    tilebuf_t *img = image ? *image : NULL;
    if (image)
        *image = NULL;
    sched_job_t *j = find_job(self, id);
    int rc = 0;
    if (!j)
        rc = err_set(err, "no job %llu", (unsigned long long)id);
    else if (j->state != JOB_QUEUED || j->tasks_done > 0)
        rc = err_set(err, "job %llu has started: its progress cannot be restored", (unsigned long long)id);
    else if (photons_done > j->nphoton)
        rc = err_set(err, "job %llu: %u photon batches done of %u", (unsigned long long)id,
                     photons_done, j->nphoton);
    else if (img &&
             (tilebuf_x0(img) != 0 || tilebuf_y0(img) != 0 || tilebuf_width(img) != j->xres ||
              tilebuf_height(img) != j->yres || tilebuf_nbuckets(img) != j->nbuckets))
        rc = err_set(err, "job %llu: the restored image is not %dx%d with %d buckets",
                     (unsigned long long)id, j->xres, j->yres, j->nbuckets);
    /* A whole-pass job holds every tile at the same pass, but for the tiles adaptive sampling
     * stopped: those are at the pass they stopped at, below the others. */
    int top = 0;
    for (int t = 0; next_pass && t < j->ntiles; t++)
        top = next_pass[t] > top ? next_pass[t] : top;
    for (int t = 0; rc == 0 && next_pass && t < j->ntiles; t++)
        if (next_pass[t] < 0 || next_pass[t] > j->npasses ||
            (j->whole_passes && next_pass[t] != top && (!j->active || next_pass[t] < 1)))
            rc = err_set(err, "job %llu: tile %d restored at pass %d of %d%s", (unsigned long long)id,
                         t, next_pass[t], j->npasses, j->whole_passes ? " (not a whole pass)" : "");
    if (rc == 0 && next_pass && !img)
        rc = err_set(err, "job %llu: merged passes restored without their image", (unsigned long long)id);
    if (rc < 0) {
        tilebuf_destroy(&img);
        return -1;
    }
    if (img) {
        tilebuf_destroy(&j->image);
        j->image = img;
    }
    for (int t = 0; next_pass && t < j->ntiles; t++) {
        sched_task_t q;
        fill_task(j, (uint32_t)t, &q);
        for (int p = 0; p < next_pass[t]; p++) {
            j->tasks[(size_t)p * (size_t)j->ntiles + (size_t)t].state = TASK_DONE;
            j->tasks_done++;
            j->done_in_pass[p]++;
            j->merged_in_pass[p]++;
            j->samples_done += (uint64_t)q.w * (uint64_t)q.h * (j->pass_begin[p + 1] - j->pass_begin[p]);
        }
        j->next_pass[t] = next_pass[t];
    }
    /* The tiles adaptive sampling stopped before the boundary the checkpoint holds; those it
     * stopped at that boundary are still at it, and the decision, a function of the image and of
     * the tiles running, is made there again below: the same one. */
    for (int t = 0; next_pass && j->active && t < j->ntiles; t++)
        if (next_pass[t] < top)
            stop_tile(self, j, t, next_pass[t]);
    while (j->passes_done < j->npasses && j->merged_in_pass[j->passes_done] == j->ntiles)
        j->passes_done++;
    if (next_pass)
        adapt(self, j);
    for (uint32_t b = 0; b < photons_done; b++) {
        j->ptasks[b].state = TASK_DONE;
        j->tasks_done++;
        j->photon_done++;
    }
    j->state = JOB_RUNNING;
    int out = 0;
    check_job_done(j, &out);
    return out & SCHED_JOB_DONE;
}

int sched_job_next_pass(const sched_t *self, uint64_t id, int *out, int n)
{
    const sched_job_t *j = find_job(self, id);
    if (!j || n < j->ntiles)
        return -1;
    memcpy(out, j->next_pass, (size_t)j->ntiles * sizeof *out);
    return j->ntiles;
}

int sched_cancel_job(sched_t *self, uint64_t id, err_t *err)
{
    sched_job_t *j = find_job(self, id);
    if (!j)
        return err_set(err, "no job %llu", (unsigned long long)id);
    if (j->state == JOB_QUEUED || j->state == JOB_RUNNING)
        finish_job(self, j, JOB_CANCELLED);
    return 0;
}

void sched_fail_job(sched_t *self, uint64_t id, const char *message)
{
    sched_job_t *j = find_job(self, id);
    if (!j || (j->state != JOB_QUEUED && j->state != JOB_RUNNING))
        return;
    snprintf(j->error, sizeof j->error, "%s", message ? message : "failed");
    finish_job(self, j, JOB_FAILED);
}

int sched_remove_job(sched_t *self, uint64_t id, err_t *err)
{
    for (size_t i = 0; i < self->njobs; i++) {
        sched_job_t *j = self->jobs[i];
        if (j->id != id)
            continue;
        if (j->state == JOB_QUEUED || j->state == JOB_RUNNING)
            return err_set(err, "job %llu is still %s", (unsigned long long)id, proto_job_state_name(j->state));
        sched_job_free(j);
        memmove(&self->jobs[i], &self->jobs[i + 1], (self->njobs - i - 1) * sizeof *self->jobs);
        self->njobs--;
        return 0;
    }
    return err_set(err, "no job %llu", (unsigned long long)id);
}

int sched_worker_join(sched_t *self, uint64_t id, int slots, double now, err_t *err)
{
    if (slots < 1 || slots > 65536) /* a worker's threads (<= 4096) and its prefetch */
        return err_set(err, "worker %llu: %d task slots is out of range", (unsigned long long)id, slots);
    worker_t *w = find_worker(self, id);
    if (!w) {
        if (self->nworkers == self->cap_workers) {
            size_t cap = self->cap_workers ? 2 * self->cap_workers : 8;
            worker_t *p = realloc(self->workers, cap * sizeof *p);
            if (!p)
                return err_set(err, "out of memory");
            self->workers = p;
            self->cap_workers = cap;
        }
        size_t at = worker_slot(self, id);
        memmove(&self->workers[at + 1], &self->workers[at],
                (self->nworkers - at) * sizeof *self->workers);
        self->nworkers++;
        w = &self->workers[at];
        *w = (worker_t){.id = id};
    } else {
        /* A worker that joins again has lost whatever it was doing. */
        sched_worker_leave(self, id);
    }
    w->slots = slots;
    w->threads = slots;
    w->busy = 0;
    w->alive = true;
    w->last_seen = now;
    self->idle_threads += idle_of(w); /* it was lost or new: it counted 0 */
    return 0;
}

int sched_worker_set_threads(sched_t *self, uint64_t id, int threads, err_t *err)
{
    worker_t *w = find_worker(self, id);
    if (!w)
        return err_set(err, "no worker %llu", (unsigned long long)id);
    if (threads < 1 || threads > w->slots)
        return err_set(err, "worker %llu: %d threads for %d slots", (unsigned long long)id,
                       threads, w->slots);
    self->idle_threads -= idle_of(w);
    w->threads = threads;
    self->idle_threads += idle_of(w);
    return 0;
}

void sched_worker_seen(sched_t *self, uint64_t id, double now)
{
    worker_t *w = find_worker(self, id);
    if (w && w->alive)
        w->last_seen = now;
}

/* Every task the worker runs back to the queue, each with a SCHED_EV_REQUEUED_LOST event. */
static void requeue_worker_tasks(sched_t *self, uint64_t id)
{
    for (size_t k = 0; k < self->njobs; k++) {
        sched_job_t *j = self->jobs[k];
        for (uint32_t i = 0; i < (uint32_t)(j->ntiles * j->npasses); i++)
            if (j->tasks[i].state == TASK_RUNNING && j->tasks[i].owner == id) {
                requeue(self, j, i);
                emit(self, SCHED_EV_REQUEUED_LOST, j->id, i, j->tasks[i].attempt, id);
            }
        for (uint32_t b = 0; b < j->nphoton; b++)
            if (j->ptasks[b].state == TASK_RUNNING && j->ptasks[b].owner == id) {
                requeue(self, j, SCHED_PHOTON_TASK | b);
                emit(self, SCHED_EV_REQUEUED_LOST, j->id, SCHED_PHOTON_TASK | b,
                     j->ptasks[b].attempt, id);
            }
    }
}

void sched_worker_leave(sched_t *self, uint64_t id)
{
    worker_t *w = find_worker(self, id);
    if (!w || !w->alive)
        return;
    requeue_worker_tasks(self, id);
    self->idle_threads -= idle_of(w);
    w->alive = false;
    w->busy = 0;
}

static void strike(sched_t *self, worker_t *w, uint64_t job, uint32_t task, uint32_t attempt);

void sched_worker_dropped(sched_t *self, uint64_t id)
{
    worker_t *w = find_worker(self, id);
    if (!w || !w->alive)
        return;
    int held = w->busy;
    sched_worker_leave(self, id);
    if (held > 0) {
        /* Its connection dropped (a SIGKILL, a crash) with tasks it never returned: they count
         * as expired, so a key that keeps dying mid-task is put on probation when it comes back
         * and, in a row, blocked, as a peer that holds tasks until their deadline is (issue 26).
         * The standing stays on this record: a HELLO on a new connection takes it over
         * (sched_worker_take_over). */
        if (w->missed < UINT32_MAX)
            w->missed++;
        strike(self, w, 0, 0, 0);
    }
}

/* One more strike in the worker's row (a failed task, a refused result, a task that expired or
 * that it abandoned by joining again): at max_worker_failures_in_row it is blocked from every
 * job and what it runs goes back to the queue at once (it would not come back). job and task
 * name the last one, for the event (0: none). */
static void strike(sched_t *self, worker_t *w, uint64_t job, uint32_t task, uint32_t attempt)
{
    if (w->blocked || self->cfg.max_worker_failures_in_row <= 0 ||
        ++w->fail_streak < (uint32_t)self->cfg.max_worker_failures_in_row)
        return;
    w->blocked = true;
    emit(self, SCHED_EV_WORKER_BLOCKED, job, task, attempt, w->id);
    if (w->busy > 0)
        requeue_worker_tasks(self, w->id);
}

void sched_worker_strike(sched_t *self, uint64_t worker)
{
    worker_t *w = find_worker(self, worker);
    if (w)
        strike(self, w, 0, 0, 0);
}

int sched_worker_take_over(sched_t *self, uint64_t to, uint64_t from)
{
    worker_t *f = find_worker(self, from), *t = find_worker(self, to);
    if (!f || !t || f == t)
        return 0;
    int held = f->alive ? f->busy : 0;
    if (f->alive) {
        requeue_worker_tasks(self, from);
        self->idle_threads -= idle_of(f);
        f->alive = false;
        f->busy = 0;
    }
    /* t was found before requeue_worker_tasks, which moves no worker. */
    self->idle_threads -= idle_of(t);
    t->tasks_done = f->tasks_done;
    t->tasks_failed = f->tasks_failed;
    t->samples_done = f->samples_done;
    t->missed = f->missed;
    t->fail_streak = f->fail_streak;
    t->blocked = t->blocked || f->blocked;
    if (held > 0) {
        /* It joined again without returning what it held: as if those tasks had expired. */
        if (t->missed < UINT32_MAX)
            t->missed++;
        strike(self, t, 0, 0, 0);
    }
    self->idle_threads += idle_of(t);
    return held;
}

static bool blocked(const sched_t *self, const sched_job_t *j, uint64_t worker)
{
    for (size_t i = 0; i < j->nstrikes; i++)
        if (j->strikes[i].worker == worker)
            return j->strikes[i].failures >= self->cfg.max_worker_job_failures;
    return false;
}

static void fill_task(const sched_job_t *j, uint32_t i, sched_task_t *out)
{
    int pass = (int)(i / (uint32_t)j->ntiles), tile = (int)(i % (uint32_t)j->ntiles);
    int x0, y0, w, h;
    tilegrid_rect(&j->tiles, tile, &x0, &y0, &w, &h);
    *out = (sched_task_t){
        .job = j->id,
        .task = i,
        .attempt = j->tasks[i].attempt,
        .x0 = x0,
        .y0 = y0,
        .w = w,
        .h = h,
        .sample_begin = j->pass_begin[pass],
        .sample_end = j->pass_begin[pass + 1],
        .pass = pass,
        .kind = SCHED_CAMERA,
    };
}

static void issue(sched_t *self, worker_t *w, sched_job_t *j, task_t *t, double now)
{
    t->state = TASK_RUNNING;
    j->running++;
    t->owner = w->id;
    if (t->issued[0] != w->id) {
        t->issued[1] = t->issued[0];
        t->issued[0] = w->id;
    }
    t->attempt++;
    t->avoid = 0;
    t->deadline = now + self->cfg.task_deadline_s;
    if (t->deadline < self->next_deadline)
        self->next_deadline = t->deadline;
    self->idle_threads -= idle_of(w);
    w->busy++;
    self->idle_threads += idle_of(w);
    j->state = JOB_RUNNING;
}

/* Up to limit + 1 tasks the worker could be given now (photon batches of a job in its photon
 * phase, else camera tasks), counted without a scan: a task is pending, running or done, so a
 * phase's pending tasks are its total less those done and those running (in a job's photon
 * phase only batches run, in its camera phase only camera tasks). A scan from first_pending
 * passed every task the other workers hold, for every worker at every dispatch. */
static uint32_t count_issuable(const sched_t *self, uint64_t worker, uint32_t limit)
{
    uint64_t n = 0;
    for (size_t k = 0; k < self->njobs && n <= limit; k++) {
        const sched_job_t *j = self->jobs[k];
        if (!takes_tasks(self, j, worker))
            continue;
        /* Left to give in the job's phase, never below 0: running counts only this phase's
         * tasks today, but a wrapped subtraction would let every worker prefetch. */
        uint64_t left = j->photon_done < j->nphoton
                            ? (uint64_t)j->nphoton - j->photon_done
                            : (uint64_t)ncamera(j) - (j->tasks_done - j->photon_done);
        n += left > j->running ? left - j->running : 0;
    }
    return n > limit ? limit + 1 : (uint32_t)n;
}

/* A task beyond the worker's threads (a prefetch) only while there are more tasks to give than
 * other workers have idle threads: near the end of the work the last tasks go to threads that
 * would otherwise idle, not into one worker's queue (docs/performance.md, "Scaling"). */
static bool prefetch_allowed(const sched_t *self, const worker_t *w)
{
    uint64_t others = self->idle_threads - idle_of(w);
    uint32_t idle = others < UINT32_MAX ? (uint32_t)others : UINT32_MAX - 1;
    return count_issuable(self, w->id, idle) > idle;
}

/* How many tasks the worker may hold now (sched_config_t claim_start). */
static int worker_claim(const sched_t *self, const worker_t *w)
{
    if (w->missed > 0)
        return 1;
    int cap = w->slots;
    if (self->cfg.claim_start > 0) {
        uint64_t c = (uint64_t)self->cfg.claim_start + 2 * w->tasks_done;
        if (c < (uint64_t)cap)
            cap = (int)c;
    }
    return cap;
}

/* A worker on probation (its last task missed its deadline) is given work only when no worker
 * that answers has room for it, so a silent peer never takes a task an honest one could run. */
static bool others_have_room(const sched_t *self, const worker_t *w)
{
    for (size_t i = 0; i < self->nworkers; i++) {
        const worker_t *o = &self->workers[i];
        if (o != w && o->alive && o->missed == 0 && o->busy < worker_claim(self, o))
            return true;
    }
    return false;
}

/* The job's next task for the worker in its current phase (its photon batches, else its
 * camera tasks): the first pending one that was not requeued by hand from this worker; moves the
 * job's cursor past tasks that are not pending. UINT32_MAX when there is none. */
static uint32_t next_pending(sched_job_t *j, uint64_t worker)
{
    bool photons = j->photon_done < j->nphoton;
    task_t *tasks = photons ? j->ptasks : j->tasks;
    uint32_t n = photons ? j->nphoton : ncamera(j);
    uint32_t *cursor = photons ? &j->first_pending_photon : &j->first_pending;
    while (*cursor < n && tasks[*cursor].state != TASK_PENDING)
        (*cursor)++;
    for (uint32_t i = *cursor; i < n; i++)
        if (tasks[i].state == TASK_PENDING && tasks[i].avoid != worker)
            return photons ? SCHED_PHOTON_TASK | i : i;
    return UINT32_MAX;
}

/* Whether the worker may be given tasks of the job at all. */
static bool takes_tasks(const sched_t *self, const sched_job_t *j, uint64_t worker)
{
    return (j->state == JOB_QUEUED || j->state == JOB_RUNNING) && !j->paused &&
           !blocked(self, j, worker);
}

/* The one rule for which job's task goes next (sched.h, "Priorities and fair share"): of the
 * jobs the worker may take a task of now, the highest priority; among equal priorities, the
 * job whose owner has the fewest tasks running over all of its jobs, so that owners share the
 * workers evenly however many jobs each submitted; then the oldest job. Which worker renders a
 * task never changes its pixels, so this decides only when a job finishes, not what it makes. */
static sched_job_t *pick_job(sched_t *self, uint64_t worker)
{
    for (size_t o = 0; o < self->nowners; o++)
        self->owners[o].running = 0;
    for (size_t k = 0; k < self->njobs; k++)
        if (self->jobs[k]->owner < self->nowners)
            self->owners[self->jobs[k]->owner].running += self->jobs[k]->running;
    sched_job_t *best = NULL;
    uint32_t best_share = 0;
    for (size_t k = 0; k < self->njobs; k++) {
        sched_job_t *j = self->jobs[k];
        if (!takes_tasks(self, j, worker))
            continue;
        uint32_t share = j->owner < self->nowners ? self->owners[j->owner].running : 0;
        if (best && (j->priority < best->priority ||
                     (j->priority == best->priority && share >= best_share)))
            continue;
        if (next_pending(j, worker) == UINT32_MAX)
            continue;
        best = j;
        best_share = share;
    }
    return best;
}

int sched_next_task(sched_t *self, uint64_t worker, double now, sched_task_t *out)
{
    worker_t *w = find_worker(self, worker);
    if (!w || !w->alive || w->blocked || w->busy >= worker_claim(self, w))
        return 0;
    if (w->missed > 0 && others_have_room(self, w))
        return 0;
    if (w->busy >= w->threads && !prefetch_allowed(self, w))
        return 0;
    sched_job_t *j = pick_job(self, worker);
    if (!j)
        return 0;
    uint32_t i = next_pending(j, worker);
    issue(self, w, j, task_of(j, i), now);
    if (i & SCHED_PHOTON_TASK) {
        /* The photon phase: batches only; the camera tasks wait for the merged store. */
        uint32_t b = i & ~SCHED_PHOTON_TASK;
        *out = (sched_task_t){.job = j->id, .task = i, .attempt = j->ptasks[b].attempt,
                              .kind = SCHED_PHOTON, .batch = b};
    } else {
        fill_task(j, i, out);
    }
    return 1;
}

/* Adaptive sampling stops a tile at the boundary before pass from_pass: its tasks of that pass
 * on are done without a result (a running one is released, its worker's result will be a
 * duplicate; one done and held is dropped), counted merged, and the job's total shrinks by the
 * samples they would have added, so progress counts a stopped tile as done. */
static void stop_tile(sched_t *self, sched_job_t *j, int tile, int from_pass)
{
    if (!j->active || !j->active[tile])
        return;
    j->active[tile] = false;
    j->tiles_active--;
    int x0, y0, w, h;
    tilegrid_rect(&j->tiles, tile, &x0, &y0, &w, &h);
    for (int p = from_pass; p < j->npasses; p++) {
        task_t *t = &j->tasks[(size_t)p * (size_t)j->ntiles + (size_t)tile];
        if (t->state != TASK_DONE) {
            release_task(self, j, t);
            t->state = TASK_DONE;
            j->tasks_done++;
            j->done_in_pass[p]++;
        }
        tilebuf_destroy(&t->result);
        j->merged_in_pass[p]++;
        j->samples_total -= (uint64_t)w * (uint64_t)h * (j->pass_begin[p + 1] - j->pass_begin[p]);
    }
}

/* At the boundary of passes_done whole passes of an adaptive job: film/adaptive.h decides from
 * the image which running tiles stop here. */
static void adapt(sched_t *self, sched_job_t *j)
{
    if (!j->active || j->passes_done < 1 || j->passes_done >= j->npasses)
        return;
    error_estimate_t e = error_estimate_image(j->image);
    bool *was = j->decided;
    memcpy(was, j->active, (size_t)j->ntiles * sizeof *was);
    if (adaptive_decide(j->image, &j->tiles, j->adaptive_target,
                        (int)j->pass_begin[j->passes_done], &e, was) > 0)
        for (int t = 0; t < j->ntiles; t++)
            if (j->active[t] && !was[t])
                stop_tile(self, j, t, j->passes_done);
}

/* Merges what can be merged of one tile, in pass order. */
static int merge_tile(sched_job_t *j, int tile, int *result, err_t *err)
{
    while (j->next_pass[tile] < j->npasses) {
        int pass = j->next_pass[tile];
        task_t *t = &j->tasks[(size_t)pass * (size_t)j->ntiles + (size_t)tile];
        if (t->state != TASK_DONE || !t->result)
            break;
        if (tilebuf_merge(j->image, t->result, err))
            return -1;
        int w = tilebuf_width(t->result), h = tilebuf_height(t->result);
        j->samples_done += (uint64_t)w * (uint64_t)h * (j->pass_begin[pass + 1] - j->pass_begin[pass]);
        tilebuf_destroy(&t->result);
        j->next_pass[tile]++;
        if (++j->merged_in_pass[pass] == j->ntiles) {
            j->passes_done++;
            *result |= SCHED_PASS_DONE;
        }
    }
    return 0;
}

/* Whole-pass jobs: merges the next pass if every tile of it is done, all tiles at once (tiles
 * are disjoint, so each pixel still sums its passes in pass order: the bytes of merge_tile).
 * One pass per call, so that the caller sees every pass boundary. */
static int merge_whole_pass(sched_t *self, sched_job_t *j, int *result, err_t *err)
{
    int pass = j->passes_done;
    if (pass >= j->npasses || j->done_in_pass[pass] < j->ntiles)
        return 0;
    for (int tile = 0; tile < j->ntiles; tile++) {
        if (j->active && !j->active[tile])
            continue; /* stopped: counted merged when it stopped (stop_tile) */
        task_t *t = &j->tasks[(size_t)pass * (size_t)j->ntiles + (size_t)tile];
        if (!t->result || j->next_pass[tile] != pass)
            return err_set(err, "job %llu pass %d tile %d: result missing",
                           (unsigned long long)j->id, pass, tile);
        if (tilebuf_merge(j->image, t->result, err))
            return -1;
        int w = tilebuf_width(t->result), h = tilebuf_height(t->result);
        j->samples_done +=
            (uint64_t)w * (uint64_t)h * (j->pass_begin[pass + 1] - j->pass_begin[pass]);
        tilebuf_destroy(&t->result);
        j->next_pass[tile]++;
        j->merged_in_pass[pass]++;
    }
    j->passes_done++;
    *result |= SCHED_PASS_DONE;
    adapt(self, j);
    if (j->passes_done < j->npasses && j->done_in_pass[j->passes_done] == j->ntiles)
        *result |= SCHED_PASS_READY;
    return 0;
}

static void check_job_done(sched_job_t *j, int *result)
{
    if (j->passes_done == j->npasses && j->state == JOB_RUNNING) {
        j->state = JOB_DONE;
        *result |= SCHED_JOB_DONE;
    }
}

int sched_merge_next_pass(sched_t *self, uint64_t id, err_t *err)
{
    sched_job_t *j = find_job(self, id);
    if (!j)
        return err_set(err, "no job %llu", (unsigned long long)id);
    int out = 0;
    if (j->state != JOB_RUNNING || !j->whole_passes)
        return 0;
    if (merge_whole_pass(self, j, &out, err))
        return -1;
    check_job_done(j, &out);
    return out;
}

/* Whether worker may return task (issue 16: any peer's result for any task was merged, first
 * result wins): only a worker the task was issued to, the current holder or the one before it
 * (a late copy after a deadline or a lost worker's, which are the same bytes), with an attempt
 * it was given; the journal's replay (SCHED_JOURNAL) is the master's own. */
static bool may_return(const task_t *t, uint64_t worker, uint32_t attempt, err_t *err)
{
    if (worker == SCHED_JOURNAL)
        return true;
    if (t->issued[0] == 0) {
        err_set(err, "that task was never issued to any worker");
        return false;
    }
    if (worker != t->issued[0] && worker != t->issued[1]) {
        err_set(err, "that task was issued to worker %llu, not to this one",
                (unsigned long long)t->issued[0]);
        return false;
    }
    if (attempt == 0 || attempt > t->attempt) {
        err_set(err, "attempt %u of that task was never issued (the last is %u)", attempt,
                t->attempt);
        return false;
    }
    return true;
}

bool sched_may_return(const sched_t *self, uint64_t worker, uint64_t job, uint32_t task,
                      uint32_t attempt, err_t *err)
{
    sched_job_t *j = find_job(self, job);
    task_t *t = j ? task_of(j, task) : NULL;
    if (!t) {
        err_set(err, "job %llu has no task %u", (unsigned long long)job, task);
        return false;
    }
    return may_return(t, worker, attempt, err);
}

int sched_photon_done(sched_t *self, uint64_t worker, uint64_t job, uint32_t task, uint32_t attempt,
                      double now, err_t *err)
{
    sched_worker_seen(self, worker, now);
    sched_job_t *j = find_job(self, job);
    task_t *t = j && (task & SCHED_PHOTON_TASK) ? task_of(j, task) : NULL;
    if (!t)
        return err_set(err, "photon result for unknown job %llu task %u", (unsigned long long)job,
                       task & ~SCHED_PHOTON_TASK);
    if (!may_return(t, worker, attempt, err))
        return SCHED_REFUSED;
    worker_t *wa = find_worker(self, worker);
    if (wa)
        wa->missed = wa->fail_streak = 0; /* it answers: off probation, its streak broken */
    /* Batches are the same photons whatever the attempt: the first result wins. */
    if (j->state != JOB_RUNNING || t->state == TASK_DONE)
        return SCHED_DUPLICATE;
    release_task(self, j, t);
    t->state = TASK_DONE;
    j->tasks_done++;
    j->photon_done++;
    worker_t *w = find_worker(self, worker);
    if (w)
        w->tasks_done++;
    return SCHED_MERGED | (j->photon_done == j->nphoton ? SCHED_PHASE_DONE : 0);
}

int sched_task_done(sched_t *self, uint64_t worker, uint64_t job, uint32_t task, uint32_t attempt,
                    tilebuf_t **result, double now, err_t *err)
{
    tilebuf_t *r = *result;
    *result = NULL;
    sched_worker_seen(self, worker, now);
    sched_job_t *j = find_job(self, job);
    if (!j || task >= (uint32_t)(j->ntiles * j->npasses)) {
        tilebuf_destroy(&r);
        return err_set(err, "result for unknown job %llu task %u", (unsigned long long)job, task);
    }
    task_t *t = &j->tasks[task];
    if (!may_return(t, worker, attempt, err)) {
        tilebuf_destroy(&r);
        return SCHED_REFUSED;
    }
    worker_t *wa = find_worker(self, worker);
    if (wa)
        wa->missed = wa->fail_streak = 0; /* it answers: off probation, its streak broken */
    if (j->state != JOB_RUNNING || t->state == TASK_DONE) {
        /* Every attempt of a task gives the same bytes, so the first result wins. */
        tilebuf_destroy(&r);
        return SCHED_DUPLICATE;
    }
    sched_task_t expect;
    fill_task(j, task, &expect);
    if (!r || tilebuf_x0(r) != expect.x0 || tilebuf_y0(r) != expect.y0 ||
        tilebuf_width(r) != expect.w || tilebuf_height(r) != expect.h ||
        tilebuf_nbuckets(r) != j->nbuckets) {
        tilebuf_destroy(&r);
        return err_set(
            err,
            "job %llu task %u: the result does not cover tile %dx%d at (%d,%d) with %d buckets",
            (unsigned long long)job, task, expect.w, expect.h, expect.x0, expect.y0, j->nbuckets);
    }
    /* The holder's, or someone else's re-issued copy: no need to finish it. */
    release_task(self, j, t);
    t->state = TASK_DONE;
    t->result = r;
    j->tasks_done++;
    j->done_in_pass[task / (uint32_t)j->ntiles]++;
    worker_t *w = find_worker(self, worker);
    if (w) {
        w->tasks_done++;
        w->samples_done +=
            (uint64_t)expect.w * (uint64_t)expect.h * (expect.sample_end - expect.sample_begin);
    }
    int out = SCHED_MERGED;
    if (j->whole_passes ? merge_whole_pass(self, j, &out, err)
                        : merge_tile(j, (int)(task % (uint32_t)j->ntiles), &out, err))
        return -1;
    check_job_done(j, &out);
    return out;
}

void sched_task_failed(sched_t *self, uint64_t worker, uint64_t job, uint32_t task,
                       uint32_t attempt, const char *message)
{
    sched_job_t *j = find_job(self, job);
    worker_t *w = find_worker(self, worker);
    if (w)
        w->tasks_failed++;
    task_t *t = j ? task_of(j, task) : NULL;
    if (!t || j->state != JOB_RUNNING)
        return;
    err_t ignore;
    /* A failure of a task the worker was not given counts against nothing: a peer must not fail
     * another's job. */
    if (t->state == TASK_DONE || !may_return(t, worker, attempt, &ignore))
        return;
    if (t->state == TASK_RUNNING && t->owner == worker)
        requeue(self, j, task);
    t->failures++;
    size_t s = 0;
    while (s < j->nstrikes && j->strikes[s].worker != worker)
        s++;
    if (s == j->nstrikes) {
        strike_t *p = realloc(j->strikes, (j->nstrikes + 1) * sizeof *p);
        if (p) {
            j->strikes = p;
            j->strikes[j->nstrikes++] = (strike_t){worker, 0};
        }
    }
    if (s < j->nstrikes && ++j->strikes[s].failures == self->cfg.max_worker_job_failures)
        emit(self, SCHED_EV_WORKER_BLOCKED_JOB, j->id, task, attempt, worker);
    if (w)
        strike(self, w, j->id, task, attempt);
    if (t->failures >= self->cfg.max_task_failures) {
        if (task & SCHED_PHOTON_TASK)
            snprintf(j->error, sizeof j->error, "photon batch %u failed %d times; last error: %s",
                     task & ~SCHED_PHOTON_TASK, t->failures, message ? message : "(none)");
        else
            snprintf(j->error, sizeof j->error, "task %u failed %d times; last error: %s", task,
                     t->failures, message ? message : "(none)");
        finish_job(self, j, JOB_FAILED);
        emit(self, SCHED_EV_JOB_FAILED, j->id, task, attempt, worker);
    }
}

/* A task of the worker's missed its deadline: one task at a time until it returns one, and a
 * strike in its row (called after the task went back to the queue). */
static void missed_by(sched_t *self, uint64_t worker, uint64_t job, uint32_t task,
                      uint32_t attempt)
{
    worker_t *w = find_worker(self, worker);
    if (!w)
        return;
    if (w->missed < UINT32_MAX)
        w->missed++;
    strike(self, w, job, task, attempt);
}

int sched_tick(sched_t *self, double now)
{
    int requeued = 0;
    for (size_t i = 0; i < self->nworkers; i++) {
        worker_t *w = &self->workers[i];
        if (w->alive && now - w->last_seen > self->cfg.worker_timeout_s) {
            requeued += w->busy;
            sched_worker_leave(self, w->id);
        }
    }
    if (now <= self->next_deadline)
        return requeued;
    double next = DBL_MAX;
    for (size_t k = 0; k < self->njobs; k++) {
        sched_job_t *j = self->jobs[k];
        if (j->state != JOB_RUNNING)
            continue;
        for (uint32_t i = 0; i < (uint32_t)(j->ntiles * j->npasses); i++)
            if (j->tasks[i].state == TASK_RUNNING && j->tasks[i].deadline < now) {
                uint64_t owner = j->tasks[i].owner;
                uint32_t attempt = j->tasks[i].attempt;
                emit(self, SCHED_EV_REQUEUED_DEADLINE, j->id, i, attempt, owner);
                requeue(self, j, i);
                missed_by(self, owner, j->id, i, attempt);
                requeued++;
            } else if (j->tasks[i].state == TASK_RUNNING && j->tasks[i].deadline < next) {
                next = j->tasks[i].deadline;
            }
        for (uint32_t b = 0; b < j->nphoton; b++)
            if (j->ptasks[b].state == TASK_RUNNING && j->ptasks[b].deadline < now) {
                uint64_t owner = j->ptasks[b].owner;
                uint32_t attempt = j->ptasks[b].attempt;
                emit(self, SCHED_EV_REQUEUED_DEADLINE, j->id, SCHED_PHOTON_TASK | b, attempt,
                     owner);
                requeue(self, j, SCHED_PHOTON_TASK | b);
                missed_by(self, owner, j->id, SCHED_PHOTON_TASK | b, attempt);
                requeued++;
            } else if (j->ptasks[b].state == TASK_RUNNING && j->ptasks[b].deadline < next) {
                next = j->ptasks[b].deadline;
            }
    }
    self->next_deadline = next;
    return requeued;
}

int sched_job_info(const sched_t *self, uint64_t id, sched_job_info_t *out)
{
    const sched_job_t *j = find_job(self, id);
    if (!j)
        return -1;
    uint32_t running = j->running;
    *out = (sched_job_info_t){
        .id = j->id,
        .state = j->state,
        .xres = j->xres,
        .yres = j->yres,
        .spp = j->spp,
        .grid = j->grid,
        .nbuckets = j->nbuckets,
        .ntiles = j->ntiles,
        .npasses = j->npasses,
        .passes_done = j->passes_done,
        .spp_done = (int)j->pass_begin[j->passes_done],
        .whole_passes = j->whole_passes,
        .samples_done = j->samples_done,
        .samples_total = j->samples_total,
        .nonfinite = tilebuf_nonfinite(j->image),
        .tasks_total = (uint32_t)(j->ntiles * j->npasses) + j->nphoton,
        .tasks_done = j->tasks_done,
        .tasks_running = running,
        .photon_batches = j->nphoton,
        .photon_batches_done = j->photon_done,
        .priority = j->priority,
        .paused = j->paused,
        .adaptive = j->active != NULL,
        .tiles_active = j->active ? j->tiles_active : j->ntiles,
    };
    snprintf(out->error, sizeof out->error, "%s", j->error);
    return 0;
}

int sched_job_running(const sched_t *self, uint64_t id, sched_running_t *out, int max)
{
    const sched_job_t *j = find_job(self, id);
    if (!j)
        return -1;
    int n = 0;
    for (uint32_t b = 0; b < j->nphoton && n < max; b++)
        if (j->ptasks[b].state == TASK_RUNNING)
            out[n++] = (sched_running_t){
                .task = SCHED_PHOTON_TASK | b, .kind = SCHED_PHOTON, .tile = -1, .pass = -1,
                .batch = b, .attempt = j->ptasks[b].attempt, .worker = j->ptasks[b].owner,
                .issued = j->ptasks[b].deadline - self->cfg.task_deadline_s};
    for (uint32_t i = 0; i < ncamera(j) && n < max; i++)
        if (j->tasks[i].state == TASK_RUNNING) {
            int pass = (int)(i / (uint32_t)j->ntiles);
            out[n++] = (sched_running_t){
                .task = i, .kind = SCHED_CAMERA, .tile = (int)(i % (uint32_t)j->ntiles),
                .pass = pass, .sample_begin = j->pass_begin[pass],
                .sample_end = j->pass_begin[pass + 1], .attempt = j->tasks[i].attempt,
                .worker = j->tasks[i].owner,
                .issued = j->tasks[i].deadline - self->cfg.task_deadline_s};
        }
    return n;
}

const tilebuf_t *sched_job_image(const sched_t *self, uint64_t id)
{
    const sched_job_t *j = find_job(self, id);
    return j ? j->image : NULL;
}

size_t sched_jobs(const sched_t *self, uint64_t *ids, size_t max)
{
    for (size_t i = 0; i < self->njobs && i < max; i++)
        ids[i] = self->jobs[i]->id;
    return self->njobs;
}

size_t sched_workers(const sched_t *self, sched_worker_info_t *out, size_t max)
{
    for (size_t i = 0; i < self->nworkers && i < max; i++) {
        const worker_t *w = &self->workers[i];
        uint32_t nblocked = 0;
        for (size_t k = 0; k < self->njobs; k++)
            nblocked += (self->jobs[k]->state == JOB_QUEUED || self->jobs[k]->state == JOB_RUNNING) &&
                        blocked(self, self->jobs[k], w->id);
        out[i] = (sched_worker_info_t){.id = w->id, .slots = w->slots, .busy = w->busy,
                                       .tasks_done = w->tasks_done, .tasks_failed = w->tasks_failed,
                                       .samples_done = w->samples_done,
                                       .last_seen = w->last_seen, .alive = w->alive,
                                       .blocked = w->blocked, .fail_streak = w->fail_streak,
                                       .blocked_jobs = nblocked};
    }
    return self->nworkers;
}

/* ---------------------------------------------------------------- operations */

int sched_set_job_priority(sched_t *self, uint64_t id, int priority, err_t *err)
{
    sched_job_t *j = find_job(self, id);
    if (!j)
        return err_set(err, "no job %llu", (unsigned long long)id);
    if (priority < SCHED_PRIORITY_MIN || priority > SCHED_PRIORITY_MAX)
        return err_set(err, "priority %d is outside %d..%d", priority, SCHED_PRIORITY_MIN,
                       SCHED_PRIORITY_MAX);
    j->priority = priority;
    return 0;
}

int sched_set_job_owner(sched_t *self, uint64_t id, const char *owner, err_t *err)
{
    sched_job_t *j = find_job(self, id);
    if (!j)
        return err_set(err, "no job %llu", (unsigned long long)id);
    if (!owner)
        owner = "";
    if (strlen(owner) >= SCHED_OWNER_MAX)
        return err_set(err, "owner name '%.40s...' is longer than %d bytes", owner,
                       SCHED_OWNER_MAX - 1);
    size_t o = 0;
    while (o < self->nowners && strcmp(self->owners[o].name, owner) != 0)
        o++;
    if (o == self->nowners) {
        if (self->nowners == self->cap_owners) {
            size_t cap = self->cap_owners ? 2 * self->cap_owners : 8;
            owner_t *p = realloc(self->owners, cap * sizeof *p);
            if (!p)
                return err_set(err, "out of memory");
            self->owners = p;
            self->cap_owners = cap;
        }
        self->owners[o] = (owner_t){0};
        snprintf(self->owners[o].name, sizeof self->owners[o].name, "%s", owner);
        self->nowners++;
    }
    j->owner = (uint32_t)o;
    return 0;
}

int sched_pause_job(sched_t *self, uint64_t id, bool paused, double now, err_t *err)
{
    sched_job_t *j = find_job(self, id);
    if (!j)
        return err_set(err, "no job %llu", (unsigned long long)id);
    if (j->state != JOB_QUEUED && j->state != JOB_RUNNING)
        return err_set(err, "job %llu is %s: only a queued or running job can be %s",
                       (unsigned long long)id, proto_job_state_name(j->state),
                       paused ? "paused" : "resumed");
    if (paused && !j->paused)
        j->paused_at = now;
    else if (!paused && j->paused && j->state == JOB_RUNNING && now > j->paused_at)
        j->paused_s += now - j->paused_at;
    j->paused = paused;
    return 0;
}

/* A pause counts from when it began while the job runs at its end (or now): a job paused while
 * queued cannot start before it is resumed, so its pause ends before its time does; one the
 * master paused when it restored it from the journal (queued, then running at once) counts from
 * that pause, after the time the journal gave it. */
double sched_job_paused_s(const sched_t *self, uint64_t id, double now)
{
    const sched_job_t *j = find_job(self, id);
    if (!j)
        return 0;
    double s = j->paused_s;
    if (j->paused && j->state == JOB_RUNNING && now > j->paused_at)
        s += now - j->paused_at;
    return s;
}

int sched_requeue_task(sched_t *self, uint64_t id, uint32_t task, err_t *err)
{
    sched_job_t *j = find_job(self, id);
    if (!j)
        return err_set(err, "no job %llu", (unsigned long long)id);
    if (j->state != JOB_QUEUED && j->state != JOB_RUNNING)
        return err_set(err, "job %llu is %s: its tasks are no longer handed out",
                       (unsigned long long)id, proto_job_state_name(j->state));
    task_t *t = task_of(j, task);
    /* Tasks named as `logs` shows them: 12, or p3 for photon batch 3. */
    char label[PROTO_TASK_LABEL_MAX];
    proto_task_label(task, label);
    if (!t) {
        char photons[48] = "";
        if (j->nphoton)
            snprintf(photons, sizeof photons, ", photon batches p0..p%u", j->nphoton - 1);
        return err_set(err, "job %llu has no task %s (camera tasks 0..%u%s)",
                       (unsigned long long)id, label, ncamera(j) - 1, photons);
    }
    if (t->state == TASK_DONE)
        return err_set(err, "job %llu task %s is done: its result is merged (or held for its "
                            "pass), so rendering it again would add nothing",
                       (unsigned long long)id, label);
    if (t->state == TASK_PENDING)
        return err_set(err, "job %llu task %s is waiting in the queue already",
                       (unsigned long long)id, label);
    uint64_t holder = t->owner;
    requeue(self, j, task);
    /* By hand: the task starts its retries afresh (the operator saw why it was stuck), on
     * another worker than the one it was stuck on. */
    t->failures = 0;
    t->avoid = holder;
    emit(self, SCHED_EV_REQUEUED_BY_HAND, j->id, task, t->attempt, holder);
    return 0;
}

int sched_worker_block(sched_t *self, uint64_t worker, bool blocked_, err_t *err)
{
    worker_t *w = find_worker(self, worker);
    if (!w)
        return err_set(err, "no worker %llu", (unsigned long long)worker);
    w->blocked = blocked_;
    w->fail_streak = 0;
    if (!blocked_)
        /* Unblocked: its strikes against each job go too, so that it serves every job again. */
        for (size_t k = 0; k < self->njobs; k++) {
            sched_job_t *j = self->jobs[k];
            for (size_t i = 0; i < j->nstrikes; i++)
                if (j->strikes[i].worker == worker)
                    j->strikes[i].failures = 0;
        }
    return 0;
}
