/* jobs: a job's life in the master, from its scene to its outputs. The master's list (m->jobs,
 * in id order) holds every job it knows, over or not; a job is in the scheduler (sched.known)
 * from job_schedule until job_refresh sees it over, writes its outputs through film (the
 * spectral EXR with its job info, and the PNG), tells the workers to drop its tasks and has
 * the scheduler forget it, keeping only the figures STATUS reports. A job's scene is loaded
 * confined to its bundle's folder, so no message can show a client a file of the master's
 * host. */
#ifndef PRISMFARM_JOBS_H
#define PRISMFARM_JOBS_H

#include "master_state.h"

/* The job with this id; NULL if none. */
job_t *jobs_find(const master_t *m, uint64_t id);
/* Appends a job to the list (its id above every other's); -1 when out of memory. */
int jobs_append(master_t *m, job_t *j);

/* What job_new does with the setting `polarized` when it is not given (SCENE_POLARIZED_FILE). */
typedef enum job_polar_mode {
    /* Left as given: a resumed job (the journal keeps the decision). */
    JOB_POLAR_KEEP,
    /* A submitted job: the plan decides once here (polar_pilot_decide). */
    JOB_POLAR_DECIDE,
    /* A frame of a sequence: its part of the sequence's decision in j->polar (polar_seq_frame
     * without the pilot), the setting left to the caller, who decides for every frame at once
     * (polar_seq.h). */
    JOB_POLAR_FRAME,
    /* The same, with the pilot (polar_seq_pilots chose the frame). */
    JOB_POLAR_FRAME_PILOT,
} job_polar_mode_t;

/* A job made from its scene, dir/main loaded with the settings and confined to dir, within
 * budget (budget.h; NULL: none), on threads threads (0: all cores; the scene is the same
 * whatever the number) -- or taken from shelf when it holds the scene of that hash and settings
 * (NULL: no shelf); a photon job gets a fresh photon phase. With polar JOB_POLAR_DECIDE (a
 * submission, never a resumed job: the journal keeps the decision) and the setting `polarized`
 * not given, the plan decides polarised transport once here (render/polar_pilot.h
 * polar_pilot_decide, its pilot against the job's target error) and the job's settings carry
 * the decision to every worker; a sequence's frames are decided together by the caller
 * (JOB_POLAR_FRAME*). Not yet scheduled (job_schedule). Touches nothing of the master's, so
 * several may run at once. NULL with err. */
job_t *job_new(uint64_t id, const char *name, const char *hash, const char *main,
               const proto_settings_t *set, const char *dir, const scene_budget_t *budget,
               scene_shelf_t *shelf, int threads, job_polar_mode_t polar, err_t *err);
/* A job of the journal as the master lists it without rendering it: one that is over, or one
 * that cannot be resumed. NULL when out of memory. */
job_t *job_from_record(const journal_job_t *r);
/* Frees *self_p (its photon phase, strings and tile record) and sets it to NULL; NULL is
 * fine. */
void job_destroy(job_t **self_p);

/* A frame sequence's own job (docs/farm.md, "Frame sequences"): queued, nframes frames, never
 * in the scheduler; main is its first frame's. Its id is set by the caller. NULL when out of
 * memory. */
job_t *job_new_sequence(const char *name, const char *hash, const char *main,
                         const proto_settings_t *set, uint32_t nframes);
/* Frame k (0-based, in submission order) of a sequence: the job with id seq->id + 1 + k; NULL
 * when it is not listed. */
job_t *jobs_frame(const master_t *m, const job_t *seq, uint32_t k);
/* The sequence's state from its frames' (called by job_refresh when a frame's state changes):
 * logged and journaled when it changes. */
void jobs_sequence_refresh(master_t *m, job_t *seq, double now);
/* The photon pass of a finished job back from disk: its scene loaded again from the spool (as
 * at submission, confined to the bundle's folder) and its merged store from photons.store. */
int job_restore_photons(master_t *m, job_t *j, err_t *err);

void job_set_error(job_t *j, const char *msg);

/* The job's stopping rule (film/stopping.h), from its settings. */
stopping_rule_t job_stopping_rule(const job_t *j);

/* Adds a new job to the scheduler, with photon_batches batches before its camera phase and
 * whole passes when it may end early, and to the master's list. */
int job_schedule(master_t *m, job_t *j, uint32_t photon_batches, err_t *err);
/* How the job's passes are merged, from its settings: whole passes when it may end early, and
 * adaptive sampling when it has a target error and asks for it (film/adaptive.h).
 * After sched_add_job, before any camera result (job_schedule; a refinement's new round). */
int jobs_apply_stopping(master_t *m, const job_t *j, err_t *err);
/* Pushes the job's owner, priority and pause (j->ops) into the scheduler, after sched_add_job
 * (job_schedule does it; a refinement's new round too). */
int jobs_apply_ops(master_t *m, const job_t *j, err_t *err);
/* Takes a job back out of the master's list and the scheduler, and frees it. */
void job_unschedule(master_t *m, job_t *j);

/* The job's image as the scheduler holds it: final, jobs/<id>/<stem>.exr and .png; else the
 * progressive jobs/<id>/preview.png. */
int job_write_image(master_t *m, job_t *j, bool final, err_t *err);

/* Follows the scheduler's state of a job: logs the change and, once the job is over, writes
 * its outputs (done), tells the workers to drop its tasks (failed, cancelled) and frees its
 * image in the scheduler, keeping only the figures STATUS reports. */
void job_refresh(master_t *m, job_t *j, double now);

/* The job's state as clients see it: a queued or running job that is paused shows "paused". */
job_state_t jobs_wire_state(const job_t *j);
/* How often a finished job's outputs are tried again after a write failed (a full disk). */
#define JOB_OUTPUT_RETRY_S 5.0

/* Tries again the outputs of the done jobs waiting for space (outputs.waiting) whose time has
 * come. Call it every turn. */
void jobs_retry_outputs(master_t *m, double now);

/* A cancel of a job waiting to write its outputs: it ends cancelled and its image is
 * dropped. */
void job_give_up_outputs(master_t *m, job_t *j, double now);

/* Cancels a job (a client's CANCEL, the dashboard's action; a sequence: each of its frames): the scheduler ends it, and
 * job_refresh tells the workers to drop its tasks; a job waiting to write its outputs gives
 * them up (job_give_up_outputs). Nothing for a job that is over. */
void job_cancel(master_t *m, job_t *j, double now);

/* Ends every running job past its time limit that has a whole pass (docs/farm.md,
 * "Accuracy"). */
void jobs_enforce_time_limits(master_t *m, double now);

#endif
