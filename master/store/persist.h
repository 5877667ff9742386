/* persist: what the master writes so that a restart loses nothing (docs/reliability.md): a job's
 * record and state in the journal (journal.h), its checkpoints (jobs/<id>/checkpoint-<gen>.bin,
 * named here and nowhere else) and its merged photon store (jobs/<id>/photons.store). Every
 * function does nothing without a journal except the photon store, which a refinement needs
 * too. A journal that cannot be written does not stop the farm: the job goes on and the log
 * says what a restart would lose. */
#ifndef PRISMFARM_PERSIST_H
#define PRISMFARM_PERSIST_H

#include "master_state.h"

/* The job as journal.h keeps it (its elapsed time is job_elapsed's: pauses not counted); the
 * strings point into j. */
journal_job_t persist_record(const master_t *m, const job_t *j, double now);

/* jobs/<job>/checkpoint-<gen>.bin of the spool, in buf. */
void persist_checkpoint_path(const master_t *m, uint64_t job, uint64_t gen, char *buf, size_t size);
/* Removes jobs/<id>/checkpoint-*.bin other than generation keep (0: all). */
void persist_remove_stale_checkpoints(master_t *m, uint64_t id, uint64_t keep);

/* Logs a journal failure and what a restart would lose by it. */
void persist_failed(const master_t *m, const job_t *j, const err_t *err);

/* The job's state in the journal; a job that is over leaves no checkpoint behind. */
void persist_state(master_t *m, job_t *j, double now);

/* A new checkpoint of a running job once the results journaled since the last one outgrow
 * its image (and not too often); nothing otherwise, nor while one is being written. The file is
 * written by a thread from a copy of the image; persist_checkpoints_collect journals it. */
void persist_maybe_checkpoint(master_t *m, job_t *j, double now);
/* Journals the checkpoints whose files are written (each turn of the loop). */
void persist_checkpoints_collect(master_t *m, double now);
/* Waits for the job's checkpoint being written, if any, and forgets it (its file removed): the
 * master stops (a job that ended leaves it to persist_checkpoints_collect). */
void persist_checkpoint_drop(master_t *m, job_t *j);

/* The merged photon store on disk as jobs/<id>/photons.store (atomically), and in the journal
 * when there is one (jobs.c's job_restore_photons reads it back). */
int persist_save_photons(master_t *m, job_t *j, err_t *err);

/* A job over (done, failed or cancelled) keeps what the scheduler forgets and a restarted master
 * could only learn by loading its scene again -- its size, spp, integrator, tile size, task
 * counts and an adaptive job's passes per tile -- in jobs/<id>/figures (text, "key value"
 * lines), so that its dashboard page reads the same after a restart (docs/dashboard.md). */
int persist_save_figures(master_t *m, const job_t *j, err_t *err);
/* Reads them back into a job restored from the journal. 0 with nothing changed when there is no
 * file (a job that ended before its scene was known, or before figures were kept); -1 with err
 * for a file that does not read as figures (nothing changed then either). */
int persist_load_figures(master_t *m, job_t *j, err_t *err);

#endif
