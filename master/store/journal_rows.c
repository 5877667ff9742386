/* journal_rows: the journal's rows of jobs (submission, state, round, control), blocked
 * workers, the checkpoint each job names and its passes' accuracy records. */
#include "journal_db.h"


#include "clock.h"
#include "files.h"
#include "sha256.h"
#include "tilebuf.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <sqlite3.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>
void journal_job_clear(journal_job_t *j)
{
    if (!j)
        return;
    free(j->name);
    free(j->hash);
    free(j->main);
    free(j->error);
    j->name = j->hash = j->main = j->error = NULL;
}

static int bind_text_or_null(sqlite3_stmt *st, int i, const char *s)
{
    return s ? sqlite3_bind_text(st, i, s, -1, SQLITE_TRANSIENT) : sqlite3_bind_null(st, i);
}

int journal_add_job(journal_t *self, const journal_job_t *j, err_t *err)
{
    return journal_add_jobs(self, j, 1, err);
}

/* Each setting bound to its column (JDB_SETTING_COLUMNS) at *i, then the next. */
#define BIND_INT(field) sqlite3_bind_int64(st, i++, j->settings.field);
#define BIND_LLONG(field) sqlite3_bind_int64(st, i++, j->settings.field);
#define BIND_DOUBLE(field) sqlite3_bind_double(st, i++, j->settings.field);
#define BIND_NAME(field) bind_text_or_null(st, i++, j->settings.field);
#define BIND_SETTING(field, kind, ...) BIND_##kind(field)

static int insert_job(journal_t *self, const journal_job_t *j, err_t *err)
{
    sqlite3_stmt *st;
    if (jdb_prepare(self,
                    "INSERT OR REPLACE INTO jobs(id, name, hash, main, " JDB_SETTING_COLUMNS
                    "state, round_photons, samples_total, owner, priority, paused, parent, frame, "
                    "nframes) VALUES(?, ?, ?, ?, " JDB_SETTING_PLACES "?, ?, ?, ?, ?, ?, ?, ?, ?)",
                    &st, err) < 0)
        return -1;
    double t0 = clock_now_s();
    int i = 1;
    sqlite3_bind_int64(st, i++, (sqlite3_int64)j->id);
    sqlite3_bind_text(st, i++, j->name, -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st, i++, j->hash, -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st, i++, j->main, -1, SQLITE_TRANSIENT);
    JOB_SETTINGS(BIND_SETTING)
    sqlite3_bind_int(st, i++, j->state);
    sqlite3_bind_int64(st, i++, (sqlite3_int64)j->round_photons);
    sqlite3_bind_int64(st, i++, (sqlite3_int64)j->samples_total);
    sqlite3_bind_text(st, i++, j->owner, -1, SQLITE_TRANSIENT);
    sqlite3_bind_int(st, i++, j->priority);
    sqlite3_bind_int(st, i++, j->paused);
    sqlite3_bind_int64(st, i++, (sqlite3_int64)j->parent);
    sqlite3_bind_int64(st, i++, (sqlite3_int64)j->frame);
    sqlite3_bind_int64(st, i++, (sqlite3_int64)j->nframes);
    int rc = jdb_step_done(self, st, "adding a job", err);
    jdb_count_write(self, t0);
    return rc;
}

/* A write outside jdb_begin()/jdb_commit() (one statement, committed as it runs) first commits the
 * turn's open transaction: otherwise it would land inside it, and a master that died before
 * journal_turn_end would lose a change it had already answered for (journal.h: committed when
 * the function returns). */
int jdb_single_write(journal_t *self, err_t *err)
{
    return jdb_turn_flush(self, err);
}

int journal_add_jobs(journal_t *self, const journal_job_t *jobs, size_t n, err_t *err)
{
    if (n == 1)
        return jdb_single_write(self, err) < 0 ? -1 : insert_job(self, jobs, err);
    if (jdb_begin(self, err) < 0)
        return -1;
    int rc = 0;
    for (size_t i = 0; i < n && rc == 0; i++)
        rc = insert_job(self, &jobs[i], err);
    return jdb_commit(self, rc, err);
}

int journal_set_control(journal_t *self, uint64_t job, int priority, bool paused, err_t *err)
{
    sqlite3_stmt *st;
    if (jdb_single_write(self, err) < 0 || jdb_prepare(self, "UPDATE jobs SET priority=?2, paused=?3 WHERE id=?1", &st, err) < 0)
        return -1;
    double t0 = clock_now_s();
    sqlite3_bind_int64(st, 1, (sqlite3_int64)job);
    sqlite3_bind_int(st, 2, priority);
    sqlite3_bind_int(st, 3, paused);
    int rc = jdb_step_done(self, st, "setting a job's priority and pause", err);
    jdb_count_write(self, t0);
    if (rc == 0 && sqlite3_changes(self->db) == 0)
        return err_set(err, "journal %s: no job %llu", self->path, (unsigned long long)job);
    return rc;
}

int journal_set_blocked(journal_t *self, const char *worker, const char *reason, err_t *err)
{
    sqlite3_stmt *st;
    if (jdb_single_write(self, err) < 0 || jdb_prepare(self,
                reason ? "INSERT OR REPLACE INTO blocked(name, reason) VALUES(?1, ?2)"
                       : "DELETE FROM blocked WHERE name=?1",
                &st, err) < 0)
        return -1;
    double t0 = clock_now_s();
    sqlite3_bind_text(st, 1, worker, -1, SQLITE_TRANSIENT);
    if (reason)
        sqlite3_bind_text(st, 2, reason, -1, SQLITE_TRANSIENT);
    int rc = jdb_step_done(self, st, reason ? "blocking a worker" : "unblocking a worker", err);
    jdb_count_write(self, t0);
    return rc;
}

int journal_blocked(journal_t *self, journal_blocked_fn fn, void *user, err_t *err)
{
    sqlite3_stmt *st;
    if (jdb_prepare(self, "SELECT name, reason FROM blocked ORDER BY name", &st, err) < 0)
        return -1;
    int rc;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
        const char *name = (const char *)sqlite3_column_text(st, 0);
        const char *reason = (const char *)sqlite3_column_text(st, 1);
        if (name)
            fn(user, name, reason ? reason : "");
    }
    sqlite3_finalize(st);
    return rc == SQLITE_DONE ? 0 : jdb_error(self, err, "reading the blocked workers");
}

int journal_set_state(journal_t *self, const journal_job_t *j, err_t *err)
{
    bool over = j->state >= 2; /* JOB_DONE, JOB_FAILED, JOB_CANCELLED (sched.h) */
    if (jdb_begin(self, err) < 0)
        return -1;
    sqlite3_stmt *st;
    int rc = jdb_prepare(self,
                     "UPDATE jobs SET state=?2, error=?3, stop=?4, outputs=?5, samples_done=?6, "
                     "samples_total=?7, nonfinite=?8, spp_done=?9, elapsed=?10, "
                     "checkpoint=CASE WHEN ?11 THEN 0 ELSE checkpoint END WHERE id=?1",
                     &st, err);
    if (rc == 0) {
        sqlite3_bind_int64(st, 1, (sqlite3_int64)j->id);
        sqlite3_bind_int(st, 2, j->state);
        bind_text_or_null(st, 3, j->error);
        sqlite3_bind_int(st, 4, j->stop);
        sqlite3_bind_int(st, 5, j->outputs);
        sqlite3_bind_int64(st, 6, (sqlite3_int64)j->samples_done);
        sqlite3_bind_int64(st, 7, (sqlite3_int64)j->samples_total);
        sqlite3_bind_int64(st, 8, (sqlite3_int64)j->nonfinite);
        sqlite3_bind_int(st, 9, j->spp_done);
        sqlite3_bind_double(st, 10, j->elapsed);
        sqlite3_bind_int(st, 11, over);
        rc = jdb_step_done(self, st, "setting a job's state", err);
    }
    if (rc == 0 && over) {
        rc = jdb_prepare(self, "DELETE FROM results WHERE job=?1", &st, err);
        if (rc == 0) {
            sqlite3_bind_int64(st, 1, (sqlite3_int64)j->id);
            rc = jdb_step_done(self, st, "dropping a finished job's results", err);
        }
    }
    if (jdb_commit(self, rc, err) < 0)
        return -1;
    if (over)
        journal_prune(self, j->id);
    return 0;
}

int journal_set_round(journal_t *self, const journal_job_t *j, err_t *err)
{
    if (jdb_begin(self, err) < 0)
        return -1;
    sqlite3_stmt *st;
    int rc = jdb_prepare(self,
                     "UPDATE jobs SET state=0, error=NULL, round=?2, photon_base=?3, "
                     "round_photons=?4, refine_photons=?5, checkpoint=0, elapsed=0, stop=0, "
                     "samples_done=0, spp_done=0 WHERE id=?1",
                     &st, err);
    if (rc == 0) {
        sqlite3_bind_int64(st, 1, (sqlite3_int64)j->id);
        sqlite3_bind_int64(st, 2, j->round);
        sqlite3_bind_int64(st, 3, j->photon_base);
        sqlite3_bind_int64(st, 4, (sqlite3_int64)j->round_photons);
        sqlite3_bind_int64(st, 5, (sqlite3_int64)j->refine_photons);
        rc = jdb_step_done(self, st, "starting a round", err);
    }
    if (rc == 0 && (rc = jdb_prepare(self, "DELETE FROM passes WHERE job=?1", &st, err)) == 0) {
        sqlite3_bind_int64(st, 1, (sqlite3_int64)j->id);
        rc = jdb_step_done(self, st, "dropping a round's passes", err);
    }
    if (rc == 0 && (rc = jdb_prepare(self, "DELETE FROM results WHERE job=?1", &st, err)) == 0) {
        sqlite3_bind_int64(st, 1, (sqlite3_int64)j->id);
        rc = jdb_step_done(self, st, "dropping a round's results", err);
    }
    if (jdb_commit(self, rc, err) < 0)
        return -1;
    journal_prune(self, j->id);
    return 0;
}

int journal_set_photons_saved(journal_t *self, uint64_t job, uint64_t photons, err_t *err)
{
    if (jdb_begin(self, err) < 0)
        return -1;
    sqlite3_stmt *st;
    int rc = jdb_prepare(self, "UPDATE jobs SET photons_saved=?2 WHERE id=?1", &st, err);
    if (rc == 0) {
        sqlite3_bind_int64(st, 1, (sqlite3_int64)job);
        sqlite3_bind_int64(st, 2, (sqlite3_int64)photons);
        rc = jdb_step_done(self, st, "recording the photon store", err);
    }
    if (rc == 0 && (rc = jdb_prepare(self, "DELETE FROM results WHERE job=?1 AND kind=1", &st, err)) == 0) {
        sqlite3_bind_int64(st, 1, (sqlite3_int64)job);
        rc = jdb_step_done(self, st, "dropping merged photon batches", err);
    }
    if (jdb_commit(self, rc, err) < 0)
        return -1;
    journal_prune(self, job);
    return 0;
}

static char *col_dup(sqlite3_stmt *st, int i)
{
    const unsigned char *s = sqlite3_column_text(st, i);
    return s ? strdup((const char *)s) : NULL;
}

/* Each setting read from its column (JDB_SETTING_COLUMNS) at col, then the next; a name into the
 * record's setting_names. */
#define READ_INT(field) j->settings.field = sqlite3_column_int(st, col++);
#define READ_LLONG(field) j->settings.field = sqlite3_column_int64(st, col++);
#define READ_DOUBLE(field) j->settings.field = sqlite3_column_double(st, col++);
#define READ_NAME(field)                                                                           \
    if ((s = sqlite3_column_text(st, col++))) {                                                    \
        snprintf(j->setting_names.field, sizeof j->setting_names.field, "%s", (const char *)s);    \
        j->settings.field = j->setting_names.field;                                                \
    }
#define READ_SETTING(field, kind, ...) READ_##kind(field)

int journal_jobs(journal_t *self, journal_job_t **jobs, size_t *n, err_t *err)
{
    *jobs = NULL;
    *n = 0;
    sqlite3_stmt *st;
    if (jdb_prepare(self,
                    "SELECT id, name, hash, main, " JDB_SETTING_COLUMNS
                    "state, error, round, photon_base, photons_saved, round_photons, "
                    "refine_photons, checkpoint, elapsed, stop, outputs, samples_done, "
                    "samples_total, nonfinite, spp_done, owner, priority, paused, parent, frame, "
                    "nframes FROM jobs ORDER BY id",
                    &st, err) < 0)
        return -1;
    size_t cap = 0;
    int rc;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
        if (*n == cap) {
            size_t c = cap ? 2 * cap : 16;
            journal_job_t *p = realloc(*jobs, c * sizeof *p);
            if (!p) {
                rc = SQLITE_NOMEM;
                break;
            }
            *jobs = p;
            cap = c;
        }
        journal_job_t *j = &(*jobs)[*n];
        memset(j, 0, sizeof *j);
        (*n)++;
        j->id = (uint64_t)sqlite3_column_int64(st, 0);
        j->name = col_dup(st, 1);
        j->hash = col_dup(st, 2);
        j->main = col_dup(st, 3);
        int col = 4;
        const unsigned char *s;
        JOB_SETTINGS(READ_SETTING)
        j->state = sqlite3_column_int(st, col++);
        j->error = col_dup(st, col++);
        j->round = (uint32_t)sqlite3_column_int64(st, col++);
        j->photon_base = (uint32_t)sqlite3_column_int64(st, col++);
        j->photons_saved = (uint64_t)sqlite3_column_int64(st, col++);
        j->round_photons = (uint64_t)sqlite3_column_int64(st, col++);
        j->refine_photons = (uint64_t)sqlite3_column_int64(st, col++);
        j->checkpoint = (uint64_t)sqlite3_column_int64(st, col++);
        j->elapsed = sqlite3_column_double(st, col++);
        j->stop = sqlite3_column_int(st, col++);
        j->outputs = sqlite3_column_int(st, col++) != 0;
        j->samples_done = (uint64_t)sqlite3_column_int64(st, col++);
        j->samples_total = (uint64_t)sqlite3_column_int64(st, col++);
        j->nonfinite = (uint64_t)sqlite3_column_int64(st, col++);
        j->spp_done = sqlite3_column_int(st, col++);
        if ((s = sqlite3_column_text(st, col++)))
            snprintf(j->owner, sizeof j->owner, "%s", (const char *)s);
        j->priority = sqlite3_column_int(st, col++);
        j->paused = sqlite3_column_int(st, col++) != 0;
        j->parent = (uint64_t)sqlite3_column_int64(st, col++);
        j->frame = (uint32_t)sqlite3_column_int64(st, col++);
        j->nframes = (uint32_t)sqlite3_column_int64(st, col++);
        if (!j->name || !j->hash || !j->main || j->state < 0 || j->state > 4) {
            rc = SQLITE_CORRUPT;
            break;
        }
    }
    sqlite3_finalize(st);
    if (rc != SQLITE_DONE) {
        for (size_t i = 0; i < *n; i++)
            journal_job_clear(&(*jobs)[i]);
        free(*jobs);
        *jobs = NULL;
        *n = 0;
        return err_set(err, "journal %s: reading the jobs: %s", self->path,
                       rc == SQLITE_NOMEM     ? "out of memory"
                       : rc == SQLITE_CORRUPT ? "a job row without its name, scene or state"
                                              : sqlite3_errmsg(self->db));
    }
    return 0;
}


int journal_set_checkpoint(journal_t *self, uint64_t job, uint32_t round, uint64_t gen,
                           const int *next_pass, int ntiles, double elapsed, err_t *err)
{
    /* This commit drops results the checkpoint holds: synced to disk before it returns (an fsync
     * at most every few seconds), so that a power cut cannot bring them back without it. (The
     * turn's results first: the setting cannot change inside a transaction.) */
    if (jdb_turn_flush(self, err) < 0 || jdb_exec(self, "PRAGMA synchronous=FULL", err) < 0)
        return -1;
    err_t ignore;
    if (jdb_begin(self, err) < 0) {
        (void)jdb_exec(self, "PRAGMA synchronous=NORMAL", &ignore);
        return -1;
    }
    sqlite3_stmt *st;
    int rc = jdb_prepare(self, "UPDATE jobs SET checkpoint=?2, elapsed=?3 WHERE id=?1", &st, err);
    if (rc == 0) {
        sqlite3_bind_int64(st, 1, (sqlite3_int64)job);
        sqlite3_bind_int64(st, 2, (sqlite3_int64)gen);
        sqlite3_bind_double(st, 3, elapsed);
        rc = jdb_step_done(self, st, "recording a checkpoint", err);
    }
    if (rc == 0)
        rc = jdb_drop_checkpointed(self, job, round, next_pass, ntiles, err);
    rc = jdb_commit(self, rc, err);
    (void)jdb_exec(self, "PRAGMA synchronous=NORMAL", &ignore);
    if (rc < 0)
        return -1;
    journal_prune(self, job);
    return 0;
}

int journal_add_pass(journal_t *self, uint64_t job, uint32_t round, const journal_pass_t *p,
                     err_t *err)
{
    if (jdb_begin(self, err) < 0)
        return -1;
    sqlite3_stmt *st;
    int rc = jdb_prepare(self,
                     "INSERT OR REPLACE INTO passes(job, round, pass, spp, elapsed, valid, "
                     "rel_error) VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7)",
                     &st, err);
    if (rc == 0) {
        sqlite3_bind_int64(st, 1, (sqlite3_int64)job);
        sqlite3_bind_int64(st, 2, round);
        sqlite3_bind_int(st, 3, p->pass);
        sqlite3_bind_int(st, 4, p->spp);
        sqlite3_bind_double(st, 5, p->elapsed);
        sqlite3_bind_int(st, 6, p->valid);
        sqlite3_bind_double(st, 7, p->rel_error);
        rc = jdb_step_done(self, st, "adding a pass record", err);
    }
    if (rc == 0 && (rc = jdb_prepare(self, "UPDATE jobs SET elapsed=?2 WHERE id=?1", &st, err)) == 0) {
        sqlite3_bind_int64(st, 1, (sqlite3_int64)job);
        sqlite3_bind_double(st, 2, p->elapsed);
        rc = jdb_step_done(self, st, "recording the elapsed time", err);
    }
    return jdb_commit(self, rc, err);
}

int journal_passes(journal_t *self, uint64_t job, uint32_t round, journal_pass_t *out, int max,
                   err_t *err)
{
    sqlite3_stmt *st;
    if (jdb_prepare(self,
                "SELECT pass, spp, elapsed, valid, rel_error FROM passes WHERE job=?1 AND "
                "round=?2 ORDER BY pass",
                &st, err) < 0)
        return -1;
    sqlite3_bind_int64(st, 1, (sqlite3_int64)job);
    sqlite3_bind_int64(st, 2, round);
    int n = 0, rc;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW && n < max)
        out[n++] = (journal_pass_t){.pass = sqlite3_column_int(st, 0),
                                    .spp = sqlite3_column_int(st, 1),
                                    .elapsed = sqlite3_column_double(st, 2),
                                    .valid = sqlite3_column_int(st, 3) != 0,
                                    .rel_error = sqlite3_column_double(st, 4)};
    if (rc != SQLITE_DONE && rc != SQLITE_ROW) {
        jdb_error(self, err, "reading pass records");
        n = -1;
    }
    sqlite3_finalize(st);
    return n;
}

/* ---------------------------------------------------------------- blobs */

/* A reader over a blob that fails (and stays failed) on any short read. */
