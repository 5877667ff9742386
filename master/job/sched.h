/* sched: the master's bookkeeping for render jobs, without sockets or clocks. A job is split
 * into camera tasks: tiles (pixel rectangles) times progressive passes (sample ranges 0-1, 1-2,
 * 2-4, 4-8, ... up to the job's spp). A job with a photon pass runs its photon batches first,
 * as a phase of their own: no camera task is given out before every batch is done (the
 * camera tasks gather from the merged store; the master merges the batches, photon_phase.h). Workers ask for tasks; results are merged into the job's
 * spectral image per tile in pass order, so the image bytes do not depend on which worker ran
 * what or when results arrived; a job that may end early merges whole passes only and can be
 * ended at any pass boundary (sched_set_whole_passes). Lost workers, missed deadlines and
 * repeated failures are handled here: tasks go back to the queue, workers get blocked for a
 * job, jobs fail with the error text. Time is passed in by the caller (seconds, monotonic), so tests can drive it.
 *
 * Priorities and fair share (docs/farm.md, "Operating a farm"): one function (pick_job in
 * sched.c) decides whose task goes next -- the highest priority first; among equal priorities
 * the owner with the fewest tasks running over all its jobs; then the oldest job. A paused job
 * gives no new task (those running finish and are merged). A worker whose row of strikes -- a
 * task failed, a task past its deadline, tasks abandoned by joining again, a result refused
 * (sched_worker_strike) -- reaches max_worker_failures_in_row without a task returned, of any
 * jobs, is blocked from every job (its tasks back in the queue at once) until
 * sched_worker_block lifts it; one that fails max_worker_job_failures tasks of one job is
 * blocked from that job only. What the caller should log (re-issues, blocks, a job failed by
 * its retry limit) is queued as events (sched_events_take). Scheduling never changes pixels. */
#ifndef PRISMFARM_SCHED_H
#define PRISMFARM_SCHED_H

#include "err.h"
#include "passes.h"
#include "proto.h"
#include "spectral_grid.h"
#include "tilebuf.h"

#include <stdbool.h>
#include <stdint.h>

typedef struct sched sched_t;

typedef struct sched_config {
    double task_deadline_s;       /* a task not back by then is issued again (default 120) */
    double worker_timeout_s;      /* a worker silent this long is dead (default 5) */
    int max_task_failures;        /* a task failing this often fails its job (default 4) */
    int max_worker_job_failures;  /* a worker failing this often is blocked for the job (2) */
    /* Tasks a worker may hold before it has returned any; each task it returns lets it hold
     * two more, up to its slots (default 32; 0: its slots from the start). A worker whose task
     * missed its deadline is on probation until it returns one: it holds one task at a time,
     * and only when no worker that answers has room. So a peer that claims thousands of
     * threads and never answers holds a few tasks for one deadline, not a job. */
    int claim_start;
    int tile_size;                /* default 32 */
    /* A worker with this many strikes in a row -- tasks failed or past their deadline, tasks
     * abandoned by joining again, results refused (any jobs; a returned task breaks the row) --
     * is blocked from every job until unblocked (default 5; 0: never). */
    int max_worker_failures_in_row;
} sched_config_t;

sched_config_t sched_config_default(void);

/* A job's state is the protocol's job_state_t (proto.h), the one enum of the master, the
 * journal, the wire and the dashboard; the scheduler uses JOB_QUEUED .. JOB_CANCELLED and keeps
 * a pause as a flag (JOB_PAUSED is how the wire shows a paused job that is not over). */

/* Task ids of photon batches: SCHED_PHOTON_TASK | batch; camera tasks are pass * ntiles + tile
 * and stay below it. */
#define SCHED_PHOTON_TASK 0x80000000u

typedef enum sched_kind { SCHED_CAMERA, SCHED_PHOTON } sched_kind_t;

typedef struct sched_task {
    uint64_t job;
    uint32_t task;    /* camera: pass * ntiles + tile; photon: SCHED_PHOTON_TASK | batch */
    uint32_t attempt; /* increases each time the task is issued again */
    sched_kind_t kind;
    uint32_t batch;   /* photon: the batch's index */
    int x0, y0, w, h; /* camera */
    uint32_t sample_begin, sample_end;
    int pass;
} sched_task_t;

typedef struct sched_job_info {
    uint64_t id;
    job_state_t state;
    int xres, yres, spp;
    spectral_grid_t grid;
    int nbuckets; /* per pixel of the image and of every tile (sched_add_job) */
    int ntiles, npasses, passes_done;
    int spp_done;      /* samples per pixel of the passes done: bound passes_done of the cut */
    bool whole_passes; /* sched_set_whole_passes was called */
    uint64_t samples_done, samples_total;
    uint64_t nonfinite;
    uint32_t tasks_total, tasks_done, tasks_running; /* photon batches included */
    uint32_t photon_batches, photon_batches_done;
    int priority; /* sched_set_job_priority; 0 by default */
    bool paused;
    bool adaptive;    /* sched_set_adaptive was called */
    int tiles_active; /* tiles still running (all of them but those adaptive sampling stopped) */
    char error[512];
} sched_job_info_t;

#define SCHED_PRIORITY_MIN (-1000)
#define SCHED_PRIORITY_MAX 1000
#define SCHED_OWNER_MAX 72 /* bytes of an owner's name with its NUL: a key's name (proto_peer_t) */

sched_t *sched_new(const sched_config_t *cfg, err_t *err);
void sched_destroy(sched_t **self_p);

/* A new job of xres x yres pixels, spp samples each, with the given spectral grid and nbuckets
 * buckets per pixel in its image and every tile result (render_settings_buckets: grid.n, or
 * 4 grid.n for a Stokes output; a multiple of grid.n): priority 0,
 * owner "", not paused. Among jobs of equal priority and owner, the oldest runs first. */
int sched_add_job(sched_t *self, uint64_t job, int xres, int yres, int spp, spectral_grid_t grid,
                  int nbuckets, err_t *err);
/* Adds photon batches to a job that has not started (0..n-1 after any it has): its camera
 * tasks wait until every batch is done. */
int sched_add_photon_batches(sched_t *self, uint64_t job, uint32_t n, err_t *err);
/* Whole passes for a job that may end early (a target error, a time limit; docs/farm.md,
 * "Accuracy"): its image only ever holds whole passes -- results are kept until every tile of
 * their pass is done, then the pass is merged at once -- so that at each pass boundary the image
 * is exactly the passes merged so far (every pixel at the same spp), and
 * sched_finish_job_at_pass can end the job there. The cost is memory: up to a pass of results held (a full image's worth of tiles) while
 * a straggler finishes. Only before any camera result of the job arrived. */
int sched_set_whole_passes(sched_t *self, uint64_t job, err_t *err);
/* Adaptive sampling for a whole-pass job (film/adaptive.h, docs/rendering.md): at each pass
 * boundary, from the image merged so far, the rule stops the tiles that reached their share of
 * target_error; a stopped tile's later tasks are done without being rendered (those already
 * handed out are released, their results ignored as duplicates), its samples leave
 * samples_total, and a pass is whole once the running tiles' results are in. The decisions
 * depend only on the merged image, so the bytes are the same whoever rendered what;
 * sched_job_next_pass keeps the pass each stopped tile stopped at, which is all a checkpoint
 * needs (sched_restore_job makes the last boundary's decision again). Only before any camera
 * result of the job arrived, after sched_set_whole_passes. */
int sched_set_adaptive(sched_t *self, uint64_t job, double target_error, err_t *err);
/* A whole-pass job merges one pass per call; when a result completes a pass whose next pass is
 * complete too, the mask has SCHED_PASS_READY, and this merges the next one, with the same mask
 * bits as sched_task_done (SCHED_PASS_DONE, SCHED_JOB_DONE, SCHED_PASS_READY). Returns 0 when
 * no whole pass is waiting, -1 with err for an unknown job. */
int sched_merge_next_pass(sched_t *self, uint64_t job, err_t *err);
/* Ends a running whole-pass job as done with the passes merged so far (at least one): its
 * image stays (every pixel at spp_done samples), running tasks are released and held results
 * freed, as for a cancel; the caller tells the workers to drop the job's tasks. */
int sched_finish_job_at_pass(sched_t *self, uint64_t job, err_t *err);
/* A job's progress brought back from the master's journal (journal.h), before any task of it
 * is issued: *image (the job's size and buckets; taken, also on failure) replaces its image,
 * tile t's passes below next_pass[t] count as merged into it (for a whole-pass job every tile
 * at the same pass, but for an adaptive job's tiles below it, which stopped there), and photon batches [0, photons_done) as done. The job is running from here
 * on; returns SCHED_JOB_DONE when that is every pass, else 0, or -1 with err. */
int sched_restore_job(sched_t *self, uint64_t job, tilebuf_t **image, const int *next_pass,
                      uint32_t photons_done, err_t *err);
/* Per tile the pass it merges next (what a checkpoint of the image holds) into out[0..ntiles);
 * returns ntiles, or -1 for an unknown job or n < ntiles. */
int sched_job_next_pass(const sched_t *self, uint64_t job, int *out, int n);
int sched_cancel_job(sched_t *self, uint64_t job, err_t *err);
/* Ends a job as failed with message (the master could not finish what its tasks gave). */
void sched_fail_job(sched_t *self, uint64_t job, const char *message);
/* Forgets a finished, failed or cancelled job and frees its image. */
int sched_remove_job(sched_t *self, uint64_t job, err_t *err);

/* Workers are known by an id of the caller's choosing. slots: tasks it may hold at once. */
int sched_worker_join(sched_t *self, uint64_t worker, int slots, double now, err_t *err);
/* Of its slots, the tasks the worker runs at once (default: all of them); the others are
 * prefetch, filled only while more tasks wait than the other workers have idle threads, so
 * that the last tasks of the work are not queued behind a busy worker while another idles. */
int sched_worker_set_threads(sched_t *self, uint64_t worker, int threads, err_t *err);
/* Any message from the worker counts as a sign of life. */
void sched_worker_seen(sched_t *self, uint64_t worker, double now);
/* The worker is gone: its tasks go back to the queue. */
void sched_worker_leave(sched_t *self, uint64_t worker);
/* The worker's connection dropped (killed, crashed: not merely silent, which a loaded machine
 * can be): it leaves, and if it held tasks they count as expired -- probation and one more
 * strike in its row, which a later connection of the same worker takes over
 * (sched_worker_take_over) -- so a worker that keeps dying mid-task gets blocked. */
void sched_worker_dropped(sched_t *self, uint64_t worker);
/* Worker `to` is worker `from` again (the same key and name said HELLO on a new connection):
 * from is gone at once (its tasks back in the queue, whatever their deadline) and to takes over
 * its standing -- the tasks it returned (its claim, sched_config_t claim_start), its probation,
 * its strikes in a row and a block -- so none of them restarts with a connection. When from
 * still held tasks, to starts on probation with one more strike (abandoned tasks count as
 * expired), as it does when from's connection had dropped holding tasks (sched_worker_dropped
 * struck it then). Returns the tasks from held. */
int sched_worker_take_over(sched_t *self, uint64_t to, uint64_t from);
/* A strike in the worker's row that is not a task's failure (a result refused as not its own,
 * stale or malformed): max_worker_failures_in_row of them, with failed and expired tasks, and no
 * task returned in between, block it from every job (SCHED_EV_WORKER_BLOCKED, its tasks back
 * in the queue). */
void sched_worker_strike(sched_t *self, uint64_t worker);

/* Gives the worker its next task if it has a free slot and there is work it is not blocked
 * from. Returns 1 with *out filled, 0 when there is nothing for it. */
int sched_next_task(sched_t *self, uint64_t worker, double now, sched_task_t *out);

typedef enum sched_result {
    SCHED_MERGED = 1,        /* the result was new and is (or will be) in the image */
    SCHED_DUPLICATE = 2,     /* the task was already done: result ignored */
    SCHED_PASS_DONE = 4,     /* one or more whole passes are now merged: time for a preview */
    SCHED_JOB_DONE = 8,      /* every pass is merged */
    SCHED_PHASE_DONE = 16,   /* every photon batch is done: the camera phase may start */
    SCHED_PASS_READY = 32,   /* whole-pass job: the next pass is complete too and waits for
                              * sched_merge_next_pass */
    SCHED_REFUSED = 64,      /* the task was not issued to that worker (or not that attempt):
                              * the result is dropped, err says why, nothing else changes */
} sched_result_t;

/* The worker id of results the master replays from its own journal: accepted for any task. */
#define SCHED_JOURNAL 0

/* A finished task. Only a worker the task was issued to (its holder, or the one before it after a
 * re-issue) with an attempt it was given may return it, else SCHED_REFUSED with err. The result
 * must cover exactly the task's tile with the job's buckets; the
 * scheduler takes ownership of *result (and nulls it) whatever happens. Returns a mask of
 * sched_result_t, or -1 with err for a result that does not match its task. */
int sched_task_done(sched_t *self, uint64_t worker, uint64_t job, uint32_t task, uint32_t attempt,
                    tilebuf_t **result, double now, err_t *err);
/* A photon batch the master has merged (or kept for merging) successfully. Returns a mask of
 * sched_result_t (SCHED_MERGED, SCHED_DUPLICATE, SCHED_PHASE_DONE), or -1 with err for a task
 * that is not a photon batch of the job. */
/* Whether the worker may return attempt of task (as sched_task_done checks it), err says why
 * not: for a result checked before it is handed to the scheduler (a photon batch is merged into
 * the photon phase first). */
bool sched_may_return(const sched_t *self, uint64_t worker, uint64_t job, uint32_t task,
                      uint32_t attempt, err_t *err);
int sched_photon_done(sched_t *self, uint64_t worker, uint64_t job, uint32_t task, uint32_t attempt,
                      double now, err_t *err);
/* A task the worker could not do (camera or photon); message is kept as the job's error if it
 * fails. */
void sched_task_failed(sched_t *self, uint64_t worker, uint64_t job, uint32_t task,
                       uint32_t attempt, const char *message);

/* Deadlines and dead workers. Returns the number of tasks put back in the queue. */
int sched_tick(sched_t *self, double now);

int sched_job_info(const sched_t *self, uint64_t job, sched_job_info_t *out);
/* A running task of a job, for listings (the master's dashboard). */
typedef struct sched_running {
    uint32_t task;
    sched_kind_t kind;
    int tile, pass; /* camera; -1 for a photon batch */
    uint32_t batch; /* photon */
    uint32_t sample_begin, sample_end;
    uint32_t attempt;
    uint64_t worker; /* who holds it */
    double issued;   /* when it was issued last (the caller's clock) */
} sched_running_t;
/* Up to max running tasks of a job, photon batches first then camera tasks in task order;
 * returns how many, or -1 for an unknown job. */
int sched_job_running(const sched_t *self, uint64_t job, sched_running_t *out, int max);

/* The job's merged image (all passes merged so far); NULL for an unknown job. */
const tilebuf_t *sched_job_image(const sched_t *self, uint64_t job);
/* Jobs in order, for listings: fills up to max ids, returns the number of jobs. */
size_t sched_jobs(const sched_t *self, uint64_t *ids, size_t max);

typedef struct sched_worker_info {
    uint64_t id;
    int slots, busy;
    uint64_t tasks_done, tasks_failed;
    uint64_t samples_done; /* camera samples of the results it returned first */
    double last_seen;
    bool alive;
    bool blocked;          /* from every job (sched_worker_block, or failures in a row) */
    uint32_t fail_streak;  /* failures since it last returned a task */
    uint32_t blocked_jobs; /* unfinished jobs it is blocked from by its failures of them */
} sched_worker_info_t;
size_t sched_workers(const sched_t *self, sched_worker_info_t *out, size_t max);

/* Operations on a job, for the master's client requests and dashboard actions. */
/* Higher runs first; SCHED_PRIORITY_MIN..MAX. */
int sched_set_job_priority(sched_t *self, uint64_t job, int priority, err_t *err);
/* Who the job belongs to for fair share (a key's name; "" without keys). */
int sched_set_job_owner(sched_t *self, uint64_t job, const char *owner, err_t *err);
/* A paused job gives no task; the running ones finish and are merged. Only a queued or running
 * job. now (the caller's clock) starts or ends the pause's time (sched_job_paused_s). */
int sched_pause_job(sched_t *self, uint64_t job, bool paused, double now, err_t *err);
/* The seconds the job has been paused while running, up to now: what its time limit must not
 * count (a paused job's clock stops: docs/farm.md, "Operating a farm"). 0 for an unknown job. */
double sched_job_paused_s(const sched_t *self, uint64_t job, double now);
/* A running task back to the queue by hand (stuck on a worker): issued again with a new attempt
 * to any worker but the one it was stuck on (whose result, the same bytes, is still accepted)
 * and its failures forgotten. A pending or done task is an error saying so. */
int sched_requeue_task(sched_t *self, uint64_t job, uint32_t task, err_t *err);
/* Blocks or unblocks a worker from every job; unblocking also forgets its failures of each job
 * (so it serves the jobs it was blocked from) and its failures in a row. */
int sched_worker_block(sched_t *self, uint64_t worker, bool blocked, err_t *err);

typedef enum sched_event_kind {
    SCHED_EV_REQUEUED_DEADLINE, /* the task missed its deadline on worker: back to the queue */
    SCHED_EV_REQUEUED_LOST,     /* worker was lost (or joined again) holding the task */
    SCHED_EV_REQUEUED_BY_HAND,  /* sched_requeue_task; worker held it */
    SCHED_EV_WORKER_BLOCKED_JOB, /* worker failed the job's tasks max_worker_job_failures times */
    SCHED_EV_WORKER_BLOCKED,     /* max_worker_failures_in_row strikes in a row (job 0: the last
                                  * was not a task's: sched_worker_strike, a take-over) */
    SCHED_EV_JOB_FAILED,         /* the task failed max_task_failures times: the job failed */
} sched_event_kind_t;

typedef struct sched_event {
    sched_event_kind_t kind;
    uint64_t job;
    uint32_t task, attempt; /* the attempt the event concerns */
    uint64_t worker;
} sched_event_t;

/* Moves up to max events, oldest first, into out; returns how many. *dropped (may be NULL) gets
 * the events lost since the last call because more than 4096 waited. */
size_t sched_events_take(sched_t *self, sched_event_t *out, size_t max, uint64_t *dropped);


#endif
