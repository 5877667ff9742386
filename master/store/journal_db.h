/* journal_db: what the journal's files share (store/journal.h is the module's one public
 * header): the journal's struct -- the SQLite database, its prepared statements, the open result
 * segments, the turn's transaction -- and the database helpers. journal.c opens, migrates, checks
 * and closes the database; journal_rows.c keeps the rows (jobs, their control, blocked workers,
 * checkpoints named, passes); journal_segments.c the results (rows naming bytes in segment
 * files); journal_blobs.c the bytes' formats (tile and photon results, checkpoint files). */
#ifndef PRISMFARM_JOURNAL_DB_H
#define PRISMFARM_JOURNAL_DB_H

#include "journal.h"

#include <limits.h>
#include <sqlite3.h>
#include <stdbool.h>

/* Bumped whenever a table or a blob changes meaning: a master never reads a journal it does
 * not understand. 4: tile blobs carry their sums' width, float32 sums when they fit. 5: tile
 * blobs and checkpoints carry the pixels' XYZ sums after the bucket sums (new magics, so that a
 * blob or checkpoint of version 4 found in a version-5 spool is refused by name). 6: jobs have
 * an owner (the submitting key's name, issue 16); a version-5 journal is migrated in place (its
 * jobs get the owner "", which only an admin may act on when the master has keys). 7: jobs carry
 * their priority and pause (docs/farm.md, "Operating a farm") and the blocked workers have a
 * table; a version-6 journal is migrated in place (migrate_6_to_7), a version-5 one through 6.
 * 8: frame sequences (docs/farm.md, "Frame sequences"): a job has its sequence (parent), its
 * frame number and, for a sequence, its count of frames; a version-7 journal is migrated in place
 * (migrate_7_to_8: its jobs are single scenes), older ones through 7. 9: a result's blob is
 * the RESULT message as received (journal.h); a version-8 journal is only marked 9, since its
 * blobs still read (journal_blob_is_v8). 10: a column per job setting, each from
 * proto/job_settings.h (adaptive sampling had been the sign of target_error: a version-9
 * journal gets the column, its negative targets made the flag; migrate_settings). A new
 * setting bumps the version too: migrate_settings gives an older spool the missing columns,
 * each filled with its setting's KEEP, which is how that spool's jobs ran. 11: `polarized`,
 * the plan's decision on polarised transport (render/polar_pilot.h), kept so that a restarted
 * master does not decide again; a version-10 spool's jobs get 0, the file's, as they ran. */
#define JOURNAL_VERSION 11

/* The segment a job's results are appended to (journal.h): open until the job's next prune. */
typedef struct segment {
    uint64_t job;
    uint32_t seg;
    int fd;
    uint64_t size;
} segment_t;

struct journal {
    sqlite3 *db;
    char path[PATH_MAX]; /* the database */
    char
        dir[PATH_MAX - 128]; /* the folder holding it and results/: room left for the names in it */
    sqlite3_stmt *add_result; /* prepared once: the master journals every result it receives */
    segment_t *segs;          /* one per job being appended to */
    size_t nsegs, capsegs;
    journal_stats_t stats;
    double t_begin; /* when the open transaction began */
    /* Between journal_turn_begin and journal_turn_end the results go into one transaction,
     * opened by the turn's first result (turn_open) and committed before any other write. */
    bool in_turn, turn_open;
    double t_turn; /* when the turn's transaction began */
};

/* The jobs table's column per job setting (proto/job_settings.h), named as the field: its
 * type and the default an older spool's rows get (JDB_SETTING_DDL: " spp INTEGER NOT NULL
 * DEFAULT 0,"), the column names and placeholders of an INSERT or SELECT (JDB_SETTING_COLUMNS:
 * "spp, xres, ..., ", JDB_SETTING_PLACES: "?, ?, ..., "). */
#define JDB_SQL_INT(keep) " INTEGER NOT NULL DEFAULT " #keep
#define JDB_SQL_LLONG(keep) " INTEGER NOT NULL DEFAULT " #keep
#define JDB_SQL_DOUBLE(keep) " REAL NOT NULL DEFAULT " #keep
#define JDB_SQL_NAME(keep) " TEXT"
#define JDB_SETTING_DDL(field, kind, keep, ...) " " #field JDB_SQL_##kind(keep) ","
#define JDB_SETTING_COLUMN(field, ...) #field ", "
#define JDB_SETTING_PLACE(field, ...) "?, "
#define JDB_SETTING_COLUMNS JOB_SETTINGS(JDB_SETTING_COLUMN)
#define JDB_SETTING_PLACES JOB_SETTINGS(JDB_SETTING_PLACE)

/* An SQLite error of the journal's database, with what was being done. Returns -1. */
int jdb_error(journal_t *self, err_t *err, const char *what);
int jdb_exec(journal_t *self, const char *sql, err_t *err);
int jdb_prepare(journal_t *self, const char *sql, sqlite3_stmt **st, err_t *err);
/* Runs a statement that returns no rows; finalises it. */
int jdb_step_done(journal_t *self, sqlite3_stmt *st, const char *what, err_t *err);
/* Commits the turn's results so far (journal_turn_begin): before any other write. */
int jdb_turn_flush(journal_t *self, err_t *err);
/* BEGIN IMMEDIATE after the turn's results; jdb_commit commits (rc 0) or rolls back (rc < 0). */
int jdb_begin(journal_t *self, err_t *err);
int jdb_commit(journal_t *self, int rc, err_t *err);
/* A write's time since t0 (journal_stats). */
void jdb_count_write(journal_t *self, double t0);
/* A write of its own, after the turn's results (journal_rows.c). */
int jdb_single_write(journal_t *self, err_t *err);
/* Drops the results a new checkpoint holds (journal_segments.c). */
int jdb_drop_checkpointed(journal_t *self, uint64_t job, uint32_t round, const int *next_pass,
                          int ntiles, err_t *err);

#endif
