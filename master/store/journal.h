/* journal: what the master must not forget when it dies (docs/reliability.md). An SQLite
 * database in the spool folder holds every job (its submission, state and round), a row for
 * each result it has received since the job's last checkpoint (the result's bytes are appended
 * to a segment file beside the database, results/<job>/<seg>.log, and the row names the
 * segment, offset, size and CRC-32: large blobs in SQLite cost the master three times the CPU,
 * and a file per result cost it a fifth of its time in creating, renaming and removing them), and
 * the accuracy record of each merged pass; checkpoint files hold a job's merged image and which
 * passes of each tile it contains. A master restarted on the same spool reads it back and
 * resumes each unfinished job where the journal leaves it, with the same pixels as a run that
 * never stopped, since the results it replays and the ones still to come are merged in the
 * same fixed order.
 *
 * Every change is one transaction, committed before the function returns (WAL, synchronous
 * NORMAL): a master killed at any moment (SIGKILL) loses nothing it journaled; a power cut may
 * lose the last few transactions, never the database's consistency. The exception is results
 * between journal_turn_begin and journal_turn_end (a turn of the master's loop): they share one
 * transaction, committed at the turn's end or before any other change, so a killed master loses
 * at most the results of the turn it died in -- tasks that are then rendered again. A result's bytes are written
 * before its row is committed, but not fsync'ed: after a power cut they may be missing, short or
 * other bytes (the CRC tells), and are then skipped (the task is rendered again). A segment is
 * appended to by one master only (a restarted one starts a new segment) and is closed at the
 * job's next prune, so that it can be removed once no row names it. A checkpoint file is
 * written (fsync'ed, renamed) before the transaction that names it. */
#ifndef PRISMFARM_JOURNAL_H
#define PRISMFARM_JOURNAL_H

#include "err.h"
#include "proto.h"
#include "tilebuf.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef struct journal journal_t;

/* A job as the journal keeps it. Strings are copies owned by the record (journal_job_clear). */
typedef struct journal_job {
    uint64_t id;
    char *name, *hash, *main; /* the client's name, the bundle's hash and main file */
    proto_settings_t settings; /* its names point into setting_names */
    proto_setting_names_t setting_names;
    job_state_t state;
    char *error; /* NULL unless failed */
    uint32_t round;          /* refinements so far (task ids carry it) */
    uint32_t photon_base;    /* the round's first batch in the photon phase */
    uint64_t photons_saved;  /* photons in jobs/<id>/photons.store (0: none) */
    uint64_t round_photons;  /* photons the store holds once this round's photon phase is done */
    uint64_t refine_photons; /* photons this round added (0 for round 0) */
    uint64_t checkpoint;     /* generation of jobs/<id>/checkpoint-<gen>.bin (0: none) */
    double elapsed;          /* seconds the round had run at its last journaled event */
    int stop;                /* proto_stop_t of a job ended early */
    bool outputs;            /* its final EXR and PNG exist */
    uint64_t samples_done, samples_total, nonfinite;
    int spp_done;
    char owner[72]; /* the submitting key's name (proto_peer_t.user); "" without keys */
    int priority; /* sched.h's; written by journal_add_job and journal_set_control */
    bool paused;
    /* Frame sequences (docs/farm.md): a frame's sequence job (0: none) and its frame number; a
     * sequence job's count of frames, whose jobs are the ids after its own (0: a single scene). */
    uint64_t parent;
    uint32_t frame;
    uint32_t nframes;
} journal_job_t;

void journal_job_clear(journal_job_t *j);

/* One merged pass's accuracy record (film/stopping.h's pass_record_t). */
typedef struct journal_pass {
    int pass, spp;
    double elapsed;
    bool valid;
    double rel_error;
} journal_pass_t;

/* Opens (creating if missing) the journal in folder dir: dir/journal.db and dir/results/<job>/
 * (the segments).
 * A file that is not a journal of this version is an error naming it, never silently
 * replaced. */
journal_t *journal_open(const char *dir, err_t *err);
void journal_close(journal_t **self_p);
/* SQLite's PRAGMA quick_check: 0 when the database is sound, else the number of problems found
 * with the first few in report; -1 with err when it cannot run. */
int journal_check(journal_t *self, char *report, size_t size, err_t *err);

/* A submitted job (state queued). */
int journal_add_job(journal_t *self, const journal_job_t *job, err_t *err);
/* Several submitted jobs in one transaction (a frame sequence and its frames): all or none. */
int journal_add_jobs(journal_t *self, const journal_job_t *jobs, size_t n, err_t *err);
/* Copies every commit in the write-ahead log (journal.db-wal) into journal.db and syncs it
 * (SQLite's passive checkpoint), so that what was committed survives a deleted or garbled WAL
 * -- an operator tidying up, a backup that copies journal.db alone (issue 26, finding 6). The
 * master calls it after journaling a submission, before the client hears SUBMITTED: an
 * acknowledged job is in journal.db itself. Results and later changes may still be in the WAL
 * only; losing them costs renders, not jobs. -1 with err when SQLite cannot, or when a reader
 * (an operator's sqlite3) kept some frames from being copied. */
int journal_checkpoint_wal(journal_t *self, err_t *err);
/* The job's state, error, figures, stop rule and outputs flag. A job that is over (done,
 * failed, cancelled) loses its results and checkpoint reference in the same transaction; the
 * caller then removes the checkpoint file. */
int journal_set_state(journal_t *self, const journal_job_t *job, err_t *err);
/* A new round (a refinement): round, photon_base, round_photons, refine_photons, state queued;
 * the earlier round's pass records are dropped. */
int journal_set_round(journal_t *self, const journal_job_t *job, err_t *err);
/* The merged photon store of the job is in jobs/<id>/photons.store with photons photons: the
 * round's photon batch results are dropped. */
int journal_set_photons_saved(journal_t *self, uint64_t job, uint64_t photons, err_t *err);

/* The job's priority and pause (docs/farm.md, "Operating a farm"): a paused job stays paused
 * through a restart. */
int journal_set_control(journal_t *self, uint64_t job, int priority, bool paused, err_t *err);

/* A worker (by name) blocked from every job, with why (reason NULL: unblocked, its row
 * removed). */
int journal_set_blocked(journal_t *self, const char *worker, const char *reason, err_t *err);
typedef void (*journal_blocked_fn)(void *user, const char *worker, const char *reason);
/* Each blocked worker, by name. */
int journal_blocked(journal_t *self, journal_blocked_fn fn, void *user, err_t *err);

/* One transaction for the results journaled until journal_turn_end (journal.h, above), instead
 * of a commit each: a loop turn that reads many results commits them once. journal_turn_end
 * returns -1 with err when that commit fails (the turn's results are then not journaled). */
void journal_turn_begin(journal_t *self);
int journal_turn_end(journal_t *self, err_t *err);

/* What the journal's writes cost (for /metrics): transactions and results written, and the
 * seconds they took, since journal_open. */
typedef struct journal_stats {
    uint64_t writes;
    double seconds;
    uint64_t checkpoints;      /* journal_checkpoint_wal calls */
    double checkpoint_seconds; /* their time (included in neither of the above) */
} journal_stats_t;
journal_stats_t journal_stats(const journal_t *self);

/* Every job, in id order, into a malloc'ed array (free each with journal_job_clear, then the
 * array). */
int journal_jobs(journal_t *self, journal_job_t **jobs, size_t *n, err_t *err);

/* A task's result, as received: kind 0 a camera tile (tile, pass), 1 a photon batch (tile =
 * batch, pass = -1); data is the RESULT message's bytes as the worker sent them (the blobs
 * below), appended to the job's open segment before the row is committed. A result journaled again (the same task: the same bytes) keeps its one row. */
int journal_add_result(journal_t *self, uint64_t job, uint32_t round, uint32_t task, int kind,
                       int tile, int pass, const void *data, size_t size, err_t *err);

typedef int (*journal_result_fn)(void *user, uint32_t task, int kind, const void *data,
                                 size_t size, err_t *err);
/* The round's journaled results in merge order (photon batches by batch, then camera tiles by
 * pass and tile); stops at the first callback that returns -1. A result whose bytes are missing,
 * short or fail their CRC is skipped and counted in *lost. */
int journal_results(journal_t *self, uint64_t job, uint32_t round, journal_result_fn fn,
                    void *user, size_t *lost, err_t *err);
/* Closes the job's open segment (the next result starts another) and removes the files of its
 * results folder that no row names (segments whose rows were all dropped, files left by a
 * killed master); with no rows left, the folder too. */
void journal_prune(journal_t *self, uint64_t job);

/* A checkpoint of generation gen is written: the job names it, its elapsed time is recorded,
 * and the camera results now in it (tile t's passes below next_pass[t]) are dropped. */
int journal_set_checkpoint(journal_t *self, uint64_t job, uint32_t round, uint64_t gen,
                           const int *next_pass, int ntiles, double elapsed, err_t *err);

/* A merged pass's record (replacing one of the same pass), with the round's elapsed time. */
int journal_add_pass(journal_t *self, uint64_t job, uint32_t round, const journal_pass_t *p,
                     err_t *err);
/* The round's pass records in order, up to max; returns how many (or -1 with err). */
int journal_passes(journal_t *self, uint64_t job, uint32_t round, journal_pass_t *out, int max,
                   err_t *err);

/* Blobs. Since version 9 a result's blob is the RESULT message as the worker sent it (proto/),
 * which resume.c decodes and checks again. Masters of version 8 wrote the formats below, which a
 * spool they left may still hold; resume.c tells them apart by their magic (a message begins
 * with a msgpack map). */
bool journal_blob_is_v8(const void *data, size_t size);
/* A version-8 camera tile: its rectangle, samples and the tilebuf's arrays in this host's byte
 * order (the journal never leaves the master's host; a header marks the order and a blob of
 * another is refused). The packing half is for tests that write a version-8 spool. */
int journal_pack_tile(const proto_tile_result_t *r, uint8_t **data, size_t *size, err_t *err);
/* Back into a tilebuf and its sample range; the arrays are checked as a wire result is. */
tilebuf_t *journal_unpack_tile(const void *data, size_t size, uint32_t *sample_begin,
                               uint32_t *sample_end, err_t *err);
int journal_pack_photons(const proto_photon_result_t *r, uint8_t **data, size_t *size, err_t *err);
/* r's data points into data. */
int journal_unpack_photons(const void *data, size_t size, proto_photon_result_t *r, err_t *err);

/* A checkpoint file: the job's image and next_pass[ntiles] of its round, with the SHA-256 of its
 * bytes after them, written atomically (fsync'ed) at path. */
int journal_write_checkpoint(const char *path, uint32_t round, const tilebuf_t *image,
                             const int *next_pass, int ntiles, err_t *err);
/* Reads one back; the image must be xres x yres with nbuckets and ntiles entries, of the round.
 * A file whose checksum fails (a flipped bit, bytes appended or cut off), of another size,
 * round or format, is an error naming it and the reason, never an image. */
int journal_read_checkpoint(const char *path, uint32_t round, int xres, int yres, int nbuckets,
                            int ntiles, tilebuf_t **image, int *next_pass, err_t *err);

#endif
