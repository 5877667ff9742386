/* master_state: the master daemon's state, an internal header shared by the files of master/
 * that make the daemon (cli/ and tests/ use master.h). One thread owns it all: master_run's loop
 * (loop.c) hands each message to a handler (on_worker.c, on_client.c) and each turn's clock
 * work to peers.c, jobs.c and dispatch.c, and they change it in place; nothing here is locked
 * or copied. The helpers below are the few every file needs: a job's end and its running time,
 * the log, a string copy, a REFUSE. */
#ifndef PRISMFARM_MASTER_STATE_H
#define PRISMFARM_MASTER_STATE_H

#include "conn_guard.h"
#include "journal.h"
#include "loader.h"
#include "master.h"
#include "net.h"
#include "photon_phase.h"
#include "sched.h"
#include "spool.h"
#include "stopping.h"
#include "tasklog.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define POLL_MS 100      /* longest wait on the sockets: the stop flag's latency */
#define MAX_WAITERS 1024 /* STATUS long polls held at once; more are answered at once */

/* The wire's reasons for an early end are film/stopping.h's, value for value. */
_Static_assert((int)PROTO_STOP_NONE == (int)STOPPING_NONE &&
                   (int)PROTO_STOP_TARGET == (int)STOPPING_TARGET &&
                   (int)PROTO_STOP_TIME == (int)STOPPING_TIME,
               "proto_stop_t and stopping_why_t differ");

typedef struct mworker {
    uint64_t id;
    proto_peer_t peer;
    char *name;
    char key[72]; /* the name of its authorised key (the ZAP user id); "" without CURVE */
    int threads;
    bool alive;
    double last_seen;
    /* A task the scheduler issued whose TASK found the peer's queue full: sent before any
     * other. Only one, because dispatch stops at the first full queue. */
    bool has_unsent;
    sched_task_t unsent;
    /* Samples per second lately (/metrics, WORKERS): the samples of the results it returned
     * in the window that began at window_start, and the rate of the last full window. */
    struct {
        double window_start;
        uint64_t window_samples;
        double samples_per_s;
    } rate;
} mworker_t;

/* A job, in the master's list from its submission (or the journal) on. Its fields by concern:
 * what was submitted, what its scene says, its place in the scheduler, its outputs, its photon
 * phase, its accuracy and the journal's view of it. */
/* The polarisation pilot's figures of a submitted job (render/polar_pilot.h). */
typedef struct job_polar {
    int cause_file;           /* the scene asks for polarisation itself (no pilot) */
    int measured;             /* the pilot ran */
    double change, change_hi; /* its figure and bound */
    double target;            /* the error the bound was compared with */
} job_polar_t;

typedef struct job {
    uint64_t id;
    char *name;
    char stem[88]; /* file-name form of the name: outputs are <stem>.exr and <stem>.png */
    char hash[PROTO_HASH_HEX + 1];
    char *main; /* the bundle's main file, to load the scene again (a refinement, a restarted
                 * master) */
    proto_settings_t settings; /* its names point into setting_names */
    proto_setting_names_t setting_names;
    job_state_t state;
    char *error;
    /* Who may act on it (access.h): the submitting key's name, proto_peer_t.user; "" when
     * submitted without keys. */
    char owner[72];
    double submitted, started, finished; /* monotonic seconds; 0: not yet */
    /* The figures it takes from its loaded scene (job_take_scene). */
    struct {
        int xres, yres, spp;
        uint64_t seed;                       /* the scene's, after the settings' override */
        const char *integrator, *dispersion; /* what the loaded scene runs with */
        spectral_grid_t grid;
        int nbuckets; /* per pixel of its image and tiles: render_settings_buckets */
        /* A job that ended before a restart: its integrator as its figures kept it
         * (persist_load_figures; integrator then points here). */
        char integrator_kept[32];
    } scene;
    /* What the plan's polarisation pilot measured when the job was submitted (jobs.c job_new;
     * the decision itself is settings.polarized), for the master's log. */
    job_polar_t polar;
    /* Its place in the scheduler. */
    struct {
        bool known; /* false once finished: its image is on disk and the scheduler forgot it */
        int ntiles;
        /* Bumped by each refinement and carried in the upper 32 bits of every task id on the
         * wire, so a late result of an earlier round is told from the current one's. */
        uint32_t round;
        uint64_t samples_done, samples_total, nonfinite; /* kept when the scheduler forgets it */
        int tile; /* the tile size it was cut with (the master's --tile then) */
        /* Its tasks when the scheduler forgot it (has_tasks), for the dashboard's page. */
        bool has_tasks;
        uint32_t tasks_total, tasks_done;
    } sched;
    struct {
        bool preview;        /* jobs/<id>/preview.png exists */
        double last_preview; /* when it was written; 0: never */
        bool final;          /* jobs/<id>/<stem>.exr and .png exist */
        /* A done job whose outputs could not be written (a full disk): its image stays in the
         * scheduler and the write is tried again at retry_at (jobs_retry_outputs), so nothing
         * rendered is lost; why says what failed, for STATUS. */
        bool waiting;
        double retry_at;
        char why[600];
    } outputs;
    /* A job with a photon pass: its batches, their merge and the merged store (kept for
     * refinement after the job is done). The scheduler's batch b is the phase's batch
     * base + b: a refinement adds its batches to a fresh scheduler job. */
    struct {
        photon_phase_t *phase;
        bool enabled;     /* the scene has a photon pass (phase may be on disk, below) */
        uint64_t saved;   /* photons in jobs/<id>/photons.store when phase is NULL */
        uint32_t base;    /* the round's first batch */
        bool store_ready; /* the round's batches are merged: store names the merged store */
        char store[PROTO_HASH_HEX + 1]; /* its hash, in every camera task (STORE_REQUEST) */
    } photons;
    /* Accuracy of the current round: a record per merged pass (film/stopping.h: one merged pass
     * of a job and the error estimate after it; docs/farm.md, "Accuracy"), the spp of the passes
     * merged (kept when the scheduler forgets the job) and why it ended before its last pass. */
    struct {
        pass_record_t history[STOPPING_MAX_RECORDS];
        int nhistory;
        int spp_done;
        proto_stop_t stop;
        /* Adaptive sampling: each tile's passes merged when the job was done (the scheduler's
         * next_pass), for the dashboard's map once the scheduler forgot them; NULL without. */
        int *tile_passes;
        int ntiles;
    } accuracy;
    /* The journal's view (journal.h): what the round's photon store holds when its phase is
     * done, the photons this round added, the checkpoint file's generation, and the bytes of
     * results journaled since it (a new checkpoint once they outgrow the image). */
    struct {
        uint64_t round_photons, refine_photons;
        uint64_t checkpoint;
        size_t bytes;
        uint64_t checkpoint_samples; /* samples merged at the last checkpoint */
        double last_checkpoint;      /* when it was written (monotonic seconds; 0: none yet) */
        struct checkpoint_writer *writer; /* the checkpoint being written off the loop (persist.c) */
    } journal;
    /* Operations (ops.h): its priority and whether it is paused; the scheduler holds the same
     * (and the owner, for fair share) while it knows the job. */
    struct {
        int priority;
        bool paused;
        double paused_s; /* its time paused while running, kept when the scheduler forgets it */
    } ops;
    /* Frame sequences (docs/farm.md, "Frame sequences"). A sequence job (nframes > 0) is never
     * in the scheduler: its frames are, each a job of its own with the ids after the
     * sequence's (parent + 1 .. parent + nframes), sharing its bundle, each loading its own
     * main; the sequence's state and figures follow its frames' (jobs_sequence_refresh). */
    struct {
        uint64_t parent; /* a frame: its sequence's id; 0 otherwise */
        uint32_t frame;  /* a frame: its number */
        uint32_t nframes;
    } seq;
} job_t;

/* A client's STATUS with a wait: answered when its job is over or at the deadline. */
typedef struct waiter {
    proto_peer_t peer;
    uint64_t job;
    double deadline; /* monotonic seconds */
} waiter_t;

typedef struct submission submission_t; /* loop/submit.c */

typedef struct master {
    const master_opts_t *opts;
    void *ctx;       /* the ZeroMQ context: opts->zmq_ctx, or the master's own */
    struct zap *zap; /* the ZAP handler of a keyed master (zap.h); NULL without keys */
    int until_waiter; /* ms until the next long poll's deadline (on_client_answer_waiters) */
    proto_limits_t limits;
    int max_conns; /* open connections per endpoint (opts->max_conns or from the file limit) */
    sched_t *sched;
    spool_t *spool;
    journal_t *journal; /* NULL without opts->journal */
    net_t *wnet, *cnet;
    conn_guard_t *wguard, *cguard; /* their connection bounds (conn_guard.h) */
    /* Scenes loading off the loop (loader.h; submit.c's submissions), oldest first. */
    loader_t *loader;
    submission_t **loading;
    size_t nloading, caploading;
    mworker_t **workers;
    size_t nworkers, cap_workers;
    job_t **jobs; /* in id order */
    size_t njobs, cap_jobs;
    uint64_t last_job, last_worker;
    sched_worker_info_t *winfo; /* scratch for sched_workers */
    size_t cap_winfo;
    double heartbeat_s, last_heartbeat;
    waiter_t waiters[MAX_WAITERS];
    size_t nwaiters;
    tasklog_t *tasklog; /* the jobs' task logs (tasklog.h) */
    /* Workers blocked from every job, by name (so that a worker that reconnects stays
     * blocked), as the journal keeps them (ops.h). */
    struct {
        char **names;
        size_t n, cap;
    } blocked;
    /* The dashboard (--http, master/dash_view.h) and the log lines it shows; NULL without. */
    struct dash_view *dash;
    struct logbook *logbook;
} master_t;

/* Done, failed or cancelled: what a STATUS long poll waits for. */
static inline bool job_over(const job_t *j)
{
    return j->state == JOB_DONE || j->state == JOB_FAILED || j->state == JOB_CANCELLED;
}

/* The seconds the job has run, from its start to its end (or now) less the time it was paused
 * while running (sched_job_paused_s): what its time limit and pass records count, and what the
 * journal keeps for a restarted master. */
double job_elapsed(const master_t *m, const job_t *j, double now);

/* A line "master: ..." on stderr when opts->verbose. */
__attribute__((format(printf, 2, 3))) void master_log(const master_t *m, const char *fmt, ...);

/* A malloc'ed copy of s; NULL when out of memory. */
char *master_strdup(const char *s);

/* A message to a client; a failure is logged. */
void master_reply(master_t *m, const proto_peer_t *to, const proto_msg_t *msg);
/* ERROR {message} to a client. */
__attribute__((format(printf, 3, 4))) void master_reply_error(master_t *m, const proto_peer_t *to,
                                                              const char *fmt, ...);

/* REFUSE {reason} to a peer of net (nothing to a peer without a routing id); a failure is
 * logged. */
void master_refuse(master_t *m, net_t *net, const proto_peer_t *to, const char *reason);

#endif
