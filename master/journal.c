#include "journal.h"

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
 * (migrate_7_to_8: its jobs are single scenes), older ones through 7. */
#define JOURNAL_VERSION 8

#define TILE_MAGIC 0x58544650u  /* "PFTX" in this host's order: a blob of another is refused */
#define PHOT_MAGIC 0x48504650u  /* "PFPH" */
#define CKPT_MAGIC 0x53434650u  /* "PFCS": a checkpoint with its round and SHA-256 */
/* Version 5's first checkpoints, without a checksum: recognised only to say so (the job then
 * falls back to an older checkpoint or renders those passes again). */
#define CKPT_MAGIC_NOSUM 0x58434650u /* "PFCX" */
/* Version 4's, without XYZ sums: recognised only to say so. */
#define TILE_MAGIC_V4 0x4b544650u /* "PFTK" */
#define CKPT_MAGIC_V4 0x4b434650u /* "PFCK" */
#define MAX_IMAGE_SIDE 65536
#define MAX_BUCKETS 1024

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
    char dir[PATH_MAX - 128]; /* the folder holding it and results/: room left for the names in it */
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

static int db_error(journal_t *self, err_t *err, const char *what)
{
    return err_set(err, "journal %s: %s: %s", self->path, what, sqlite3_errmsg(self->db));
}

static int exec(journal_t *self, const char *sql, err_t *err)
{
    char *msg = NULL;
    if (sqlite3_exec(self->db, sql, NULL, NULL, &msg) != SQLITE_OK) {
        err_set(err, "journal %s: %s", self->path, msg ? msg : sqlite3_errmsg(self->db));
        sqlite3_free(msg);
        return -1;
    }
    return 0;
}

static int prepare(journal_t *self, const char *sql, sqlite3_stmt **st, err_t *err)
{
    if (sqlite3_prepare_v2(self->db, sql, -1, st, NULL) != SQLITE_OK)
        return db_error(self, err, "prepare");
    return 0;
}

/* Runs a statement that returns no rows; finalises it. */
static int step_done(journal_t *self, sqlite3_stmt *st, const char *what, err_t *err)
{
    int rc = sqlite3_step(st);
    int out = rc == SQLITE_DONE ? 0 : db_error(self, err, what);
    sqlite3_finalize(st);
    return out;
}

/* Commits the turn's results so far (journal_turn_begin): before any other write, so that every
 * change but a result is still committed when its function returns, after the results that
 * came before it. */
static int turn_flush(journal_t *self, err_t *err)
{
    if (!self->turn_open)
        return 0;
    self->turn_open = false;
    /* SQLite rolls a transaction back by itself on some errors (a full disk, an I/O error). */
    if (sqlite3_get_autocommit(self->db))
        return err_set(err, "journal %s: a write error rolled back the results since the turn "
                            "began", self->path);
    int rc = exec(self, "COMMIT", err);
    self->stats.writes++;
    self->stats.seconds += clock_now_s() - self->t_turn;
    if (rc < 0) {
        err_t ignore;
        (void)exec(self, "ROLLBACK", &ignore);
    }
    return rc;
}

static int begin(journal_t *self, err_t *err)
{
    if (turn_flush(self, err) < 0)
        return -1;
    self->t_begin = clock_now_s();
    return exec(self, "BEGIN IMMEDIATE", err);
}

/* A write's time since t0 (journal_stats). */
static void count_write(journal_t *self, double t0)
{
    self->stats.writes++;
    self->stats.seconds += clock_now_s() - t0;
}

static int commit(journal_t *self, int rc, err_t *err)
{
    if (rc < 0) {
        err_t ignore;
        (void)exec(self, "ROLLBACK", &ignore);
        return -1;
    }
    rc = exec(self, "COMMIT", err);
    count_write(self, self->t_begin);
    return rc;
}

journal_stats_t journal_stats(const journal_t *self)
{
    return self->stats;
}

static const char *SCHEMA =
    "CREATE TABLE IF NOT EXISTS meta(key TEXT PRIMARY KEY, value INTEGER NOT NULL);"
    "CREATE TABLE IF NOT EXISTS jobs("
    " id INTEGER PRIMARY KEY, name TEXT NOT NULL, hash TEXT NOT NULL, main TEXT NOT NULL,"
    " spp INTEGER NOT NULL, xres INTEGER NOT NULL, yres INTEGER NOT NULL, seed INTEGER NOT NULL,"
    " integrator TEXT, dispersion TEXT, target_error REAL NOT NULL, time_limit REAL NOT NULL,"
    " state INTEGER NOT NULL, error TEXT, round INTEGER NOT NULL DEFAULT 0,"
    " photon_base INTEGER NOT NULL DEFAULT 0, photons_saved INTEGER NOT NULL DEFAULT 0,"
    " round_photons INTEGER NOT NULL DEFAULT 0, refine_photons INTEGER NOT NULL DEFAULT 0,"
    " checkpoint INTEGER NOT NULL DEFAULT 0, elapsed REAL NOT NULL DEFAULT 0,"
    " stop INTEGER NOT NULL DEFAULT 0, outputs INTEGER NOT NULL DEFAULT 0,"
    " samples_done INTEGER NOT NULL DEFAULT 0, samples_total INTEGER NOT NULL DEFAULT 0,"
    " nonfinite INTEGER NOT NULL DEFAULT 0, spp_done INTEGER NOT NULL DEFAULT 0,"
    " owner TEXT NOT NULL DEFAULT '',"
    " priority INTEGER NOT NULL DEFAULT 0, paused INTEGER NOT NULL DEFAULT 0,"
    " parent INTEGER NOT NULL DEFAULT 0, frame INTEGER NOT NULL DEFAULT 0,"
    " nframes INTEGER NOT NULL DEFAULT 0);"
    "CREATE TABLE IF NOT EXISTS blocked(name TEXT PRIMARY KEY, reason TEXT NOT NULL);"
    "CREATE TABLE IF NOT EXISTS results("
    " job INTEGER NOT NULL, round INTEGER NOT NULL, task INTEGER NOT NULL, kind INTEGER NOT NULL,"
    " tile INTEGER NOT NULL, pass INTEGER NOT NULL, size INTEGER NOT NULL,"
    " seg INTEGER NOT NULL, offset INTEGER NOT NULL, crc INTEGER NOT NULL,"
    " PRIMARY KEY(job, round, task));"
    "CREATE TABLE IF NOT EXISTS passes("
    " job INTEGER NOT NULL, round INTEGER NOT NULL, pass INTEGER NOT NULL, spp INTEGER NOT NULL,"
    " elapsed REAL NOT NULL, valid INTEGER NOT NULL, rel_error REAL NOT NULL,"
    " PRIMARY KEY(job, round, pass));";

/* Version 6 to 7: the jobs' priority and pause columns (the blocked table came with SCHEMA).
 * One transaction: a master killed half-way leaves version 6, migrated again next time. */
static int migrate_6_to_7(journal_t *self, err_t *err)
{
    if (begin(self, err) < 0)
        return -1;
    int rc = exec(self,
                  "ALTER TABLE jobs ADD COLUMN priority INTEGER NOT NULL DEFAULT 0;"
                  "ALTER TABLE jobs ADD COLUMN paused INTEGER NOT NULL DEFAULT 0;"
                  "UPDATE meta SET value=7 WHERE key='version';",
                  err);
    return commit(self, rc, err);
}

/* Version 7 to 8: the frame columns; every job of a version-7 journal is a single scene (0 in
 * each). One transaction, as migrate_6_to_7. */
static int migrate_7_to_8(journal_t *self, err_t *err)
{
    if (begin(self, err) < 0)
        return -1;
    int rc = exec(self,
                  "ALTER TABLE jobs ADD COLUMN parent INTEGER NOT NULL DEFAULT 0;"
                  "ALTER TABLE jobs ADD COLUMN frame INTEGER NOT NULL DEFAULT 0;"
                  "ALTER TABLE jobs ADD COLUMN nframes INTEGER NOT NULL DEFAULT 0;"
                  "UPDATE meta SET value=8 WHERE key='version';",
                  err);
    return commit(self, rc, err);
}

journal_t *journal_open(const char *dir, err_t *err)
{
    journal_t *self = calloc(1, sizeof *self);
    if (!self) {
        err_set(err, "journal: out of memory");
        return NULL;
    }
    if (strlen(dir) >= sizeof self->dir) {
        err_set(err, "journal: folder name too long: '%s'", dir);
        free(self);
        return NULL;
    }
    snprintf(self->dir, sizeof self->dir, "%s", dir);
    snprintf(self->path, sizeof self->path, "%s/journal.db", dir);
    const char *path = self->path;
    char results[PATH_MAX + 16];
    snprintf(results, sizeof results, "%s/results", dir);
    if ((mkdir(dir, 0755) < 0 && errno != EEXIST) || (mkdir(results, 0755) < 0 && errno != EEXIST)) {
        err_set(err, "journal: cannot create '%s': %s", results, strerror(errno));
        free(self);
        return NULL;
    }
    if (sqlite3_open_v2(path, &self->db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, NULL) !=
        SQLITE_OK) {
        err_set(err, "journal %s: cannot open: %s", path,
                self->db ? sqlite3_errmsg(self->db) : "out of memory");
        journal_close(&self);
        return NULL;
    }
    /* WAL with NORMAL sync: a commit is in the log before it returns, so a killed process
     * loses nothing; only an operating-system crash can lose the last commits (sqlite.org,
     * "Write-Ahead Logging"). The busy timeout covers a second process reading it (sqlite3). */
    sqlite3_busy_timeout(self->db, 5000);
    if (exec(self, "PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL; PRAGMA foreign_keys=OFF",
             err) < 0 ||
        exec(self, SCHEMA, err) < 0) {
        journal_close(&self);
        return NULL;
    }
    sqlite3_stmt *st;
    if (prepare(self, "SELECT value FROM meta WHERE key='version'", &st, err) < 0) {
        journal_close(&self);
        return NULL;
    }
    int rc = sqlite3_step(st);
    long long version = rc == SQLITE_ROW ? sqlite3_column_int64(st, 0) : -1;
    sqlite3_finalize(st);
    if (rc != SQLITE_ROW && rc != SQLITE_DONE) {
        db_error(self, err, "reading its version");
        journal_close(&self);
        return NULL;
    }
    if (version < 0) {
        char sql[96];
        snprintf(sql, sizeof sql, "INSERT INTO meta(key, value) VALUES('version', %d)",
                 JOURNAL_VERSION);
        if (exec(self, sql, err) < 0) {
            journal_close(&self);
            return NULL;
        }
    } else if (version == 5) {
        /* Version 6 only adds the owner column: the rest of a version-5 spool reads as it is. */
        if (exec(self,
                 "BEGIN IMMEDIATE; ALTER TABLE jobs ADD COLUMN owner TEXT NOT NULL DEFAULT '';"
                 " UPDATE meta SET value=6 WHERE key='version'; COMMIT",
                 err) < 0 ||
            migrate_6_to_7(self, err) < 0 || migrate_7_to_8(self, err) < 0) {
            err_t ignore;
            (void)exec(self, "ROLLBACK", &ignore);
            err_prefix(err, "migrating from version 5: ");
            journal_close(&self);
            return NULL;
        }
    }
    if (version == 6 && (migrate_6_to_7(self, err) < 0 || migrate_7_to_8(self, err) < 0)) {
        err_prefix(err, "journal %s: migrating version 6 to 8: ", path);
        journal_close(&self);
        return NULL;
    } else if (version == 7 && migrate_7_to_8(self, err) < 0) {
        err_prefix(err, "journal %s: migrating version 7 to 8: ", path);
        journal_close(&self);
        return NULL;
    } else if (version >= 0 && version != 5 && version != 6 && version != 7 &&
               version != JOURNAL_VERSION) {
        err_set(err, "journal %s: version %lld, this master reads version %d (move the spool "
                     "aside or use a matching prismfarm)",
                path, version, JOURNAL_VERSION);
        journal_close(&self);
        return NULL;
    }
    return self;
}

int journal_check(journal_t *self, char *report, size_t size, err_t *err)
{
    sqlite3_stmt *st;
    report[0] = 0;
    if (prepare(self, "PRAGMA quick_check(8)", &st, err) < 0)
        return -1;
    int rc, problems = 0;
    size_t k = 0;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
        const char *line = (const char *)sqlite3_column_text(st, 0);
        if (!line || !strcmp(line, "ok"))
            continue;
        problems++;
        int w = snprintf(report + k, size - k, "%s%s", k ? "; " : "", line);
        if (w > 0)
            k = (size_t)w < size - k ? k + (size_t)w : size - 1;
    }
    sqlite3_finalize(st);
    if (rc != SQLITE_DONE && problems == 0) {
        snprintf(report, size, "%s", sqlite3_errmsg(self->db));
        problems = 1;
    }
    return problems;
}

void journal_close(journal_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    journal_t *self = *self_p;
    err_t ignore;
    (void)turn_flush(self, &ignore);
    for (size_t i = 0; i < self->nsegs; i++)
        (void)close(self->segs[i].fd);
    free(self->segs);
    sqlite3_finalize(self->add_result); /* a no-op for NULL */
    if (self->db)
        (void)sqlite3_close(self->db);
    free(self);
    *self_p = NULL;
}

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

static int insert_job(journal_t *self, const journal_job_t *j, err_t *err)
{
    sqlite3_stmt *st;
    if (prepare(self,
                "INSERT OR REPLACE INTO jobs(id, name, hash, main, spp, xres, yres, seed, "
                "integrator, dispersion, target_error, time_limit, state, round_photons, "
                "samples_total, owner, priority, paused, parent, frame, nframes) VALUES(?1, ?2, "
                "?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17, ?18, ?19, "
                "?20, ?21)",
                &st, err) < 0)
        return -1;
    double t0 = clock_now_s();
    sqlite3_bind_int64(st, 1, (sqlite3_int64)j->id);
    sqlite3_bind_text(st, 2, j->name, -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st, 3, j->hash, -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(st, 4, j->main, -1, SQLITE_TRANSIENT);
    sqlite3_bind_int(st, 5, j->settings.spp);
    sqlite3_bind_int(st, 6, j->settings.xres);
    sqlite3_bind_int(st, 7, j->settings.yres);
    sqlite3_bind_int64(st, 8, j->settings.seed);
    bind_text_or_null(st, 9, j->settings.integrator);
    bind_text_or_null(st, 10, j->settings.dispersion);
    /* A job with adaptive sampling keeps its target negated: the column's sign is the setting,
     * so the schema (and the version) stay as they were, and a journal of a master before
     * adaptive sampling reads as without it, which is how its jobs ran. */
    sqlite3_bind_double(st, 11, j->settings.adaptive ? -j->settings.target_error
                                                     : j->settings.target_error);
    sqlite3_bind_double(st, 12, j->settings.time_limit);
    sqlite3_bind_int(st, 13, j->state);
    sqlite3_bind_int64(st, 14, (sqlite3_int64)j->round_photons);
    sqlite3_bind_int64(st, 15, (sqlite3_int64)j->samples_total);
    sqlite3_bind_text(st, 16, j->owner, -1, SQLITE_TRANSIENT);
    sqlite3_bind_int(st, 17, j->priority);
    sqlite3_bind_int(st, 18, j->paused);
    sqlite3_bind_int64(st, 19, (sqlite3_int64)j->parent);
    sqlite3_bind_int64(st, 20, (sqlite3_int64)j->frame);
    sqlite3_bind_int64(st, 21, (sqlite3_int64)j->nframes);
    int rc = step_done(self, st, "adding a job", err);
    count_write(self, t0);
    return rc;
}

/* A write outside begin()/commit() (one statement, committed as it runs) first commits the
 * turn's open transaction: otherwise it would land inside it, and a master that died before
 * journal_turn_end would lose a change it had already answered for (journal.h: committed when
 * the function returns). */
static int single_write(journal_t *self, err_t *err)
{
    return turn_flush(self, err);
}

int journal_add_jobs(journal_t *self, const journal_job_t *jobs, size_t n, err_t *err)
{
    if (n == 1)
        return single_write(self, err) < 0 ? -1 : insert_job(self, jobs, err);
    if (begin(self, err) < 0)
        return -1;
    int rc = 0;
    for (size_t i = 0; i < n && rc == 0; i++)
        rc = insert_job(self, &jobs[i], err);
    return commit(self, rc, err);
}

int journal_set_control(journal_t *self, uint64_t job, int priority, bool paused, err_t *err)
{
    sqlite3_stmt *st;
    if (single_write(self, err) < 0 || prepare(self, "UPDATE jobs SET priority=?2, paused=?3 WHERE id=?1", &st, err) < 0)
        return -1;
    double t0 = clock_now_s();
    sqlite3_bind_int64(st, 1, (sqlite3_int64)job);
    sqlite3_bind_int(st, 2, priority);
    sqlite3_bind_int(st, 3, paused);
    int rc = step_done(self, st, "setting a job's priority and pause", err);
    count_write(self, t0);
    if (rc == 0 && sqlite3_changes(self->db) == 0)
        return err_set(err, "journal %s: no job %llu", self->path, (unsigned long long)job);
    return rc;
}

int journal_set_blocked(journal_t *self, const char *worker, const char *reason, err_t *err)
{
    sqlite3_stmt *st;
    if (single_write(self, err) < 0 || prepare(self,
                reason ? "INSERT OR REPLACE INTO blocked(name, reason) VALUES(?1, ?2)"
                       : "DELETE FROM blocked WHERE name=?1",
                &st, err) < 0)
        return -1;
    double t0 = clock_now_s();
    sqlite3_bind_text(st, 1, worker, -1, SQLITE_TRANSIENT);
    if (reason)
        sqlite3_bind_text(st, 2, reason, -1, SQLITE_TRANSIENT);
    int rc = step_done(self, st, reason ? "blocking a worker" : "unblocking a worker", err);
    count_write(self, t0);
    return rc;
}

int journal_blocked(journal_t *self, journal_blocked_fn fn, void *user, err_t *err)
{
    sqlite3_stmt *st;
    if (prepare(self, "SELECT name, reason FROM blocked ORDER BY name", &st, err) < 0)
        return -1;
    int rc;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
        const char *name = (const char *)sqlite3_column_text(st, 0);
        const char *reason = (const char *)sqlite3_column_text(st, 1);
        if (name)
            fn(user, name, reason ? reason : "");
    }
    sqlite3_finalize(st);
    return rc == SQLITE_DONE ? 0 : db_error(self, err, "reading the blocked workers");
}

int journal_set_state(journal_t *self, const journal_job_t *j, err_t *err)
{
    bool over = j->state >= 2; /* JOB_DONE, JOB_FAILED, JOB_CANCELLED (sched.h) */
    if (begin(self, err) < 0)
        return -1;
    sqlite3_stmt *st;
    int rc = prepare(self,
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
        rc = step_done(self, st, "setting a job's state", err);
    }
    if (rc == 0 && over) {
        rc = prepare(self, "DELETE FROM results WHERE job=?1", &st, err);
        if (rc == 0) {
            sqlite3_bind_int64(st, 1, (sqlite3_int64)j->id);
            rc = step_done(self, st, "dropping a finished job's results", err);
        }
    }
    if (commit(self, rc, err) < 0)
        return -1;
    if (over)
        journal_prune(self, j->id);
    return 0;
}

int journal_set_round(journal_t *self, const journal_job_t *j, err_t *err)
{
    if (begin(self, err) < 0)
        return -1;
    sqlite3_stmt *st;
    int rc = prepare(self,
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
        rc = step_done(self, st, "starting a round", err);
    }
    if (rc == 0 && (rc = prepare(self, "DELETE FROM passes WHERE job=?1", &st, err)) == 0) {
        sqlite3_bind_int64(st, 1, (sqlite3_int64)j->id);
        rc = step_done(self, st, "dropping a round's passes", err);
    }
    if (rc == 0 && (rc = prepare(self, "DELETE FROM results WHERE job=?1", &st, err)) == 0) {
        sqlite3_bind_int64(st, 1, (sqlite3_int64)j->id);
        rc = step_done(self, st, "dropping a round's results", err);
    }
    if (commit(self, rc, err) < 0)
        return -1;
    journal_prune(self, j->id);
    return 0;
}

int journal_set_photons_saved(journal_t *self, uint64_t job, uint64_t photons, err_t *err)
{
    if (begin(self, err) < 0)
        return -1;
    sqlite3_stmt *st;
    int rc = prepare(self, "UPDATE jobs SET photons_saved=?2 WHERE id=?1", &st, err);
    if (rc == 0) {
        sqlite3_bind_int64(st, 1, (sqlite3_int64)job);
        sqlite3_bind_int64(st, 2, (sqlite3_int64)photons);
        rc = step_done(self, st, "recording the photon store", err);
    }
    if (rc == 0 && (rc = prepare(self, "DELETE FROM results WHERE job=?1 AND kind=1", &st, err)) == 0) {
        sqlite3_bind_int64(st, 1, (sqlite3_int64)job);
        rc = step_done(self, st, "dropping merged photon batches", err);
    }
    if (commit(self, rc, err) < 0)
        return -1;
    journal_prune(self, job);
    return 0;
}

static char *col_dup(sqlite3_stmt *st, int i)
{
    const unsigned char *s = sqlite3_column_text(st, i);
    return s ? strdup((const char *)s) : NULL;
}

int journal_jobs(journal_t *self, journal_job_t **jobs, size_t *n, err_t *err)
{
    *jobs = NULL;
    *n = 0;
    sqlite3_stmt *st;
    if (prepare(self,
                "SELECT id, name, hash, main, spp, xres, yres, seed, integrator, dispersion, "
                "target_error, time_limit, state, error, round, photon_base, photons_saved, "
                "round_photons, refine_photons, checkpoint, elapsed, stop, outputs, "
                "samples_done, samples_total, nonfinite, spp_done, owner, priority, paused, "
                "parent, frame, nframes FROM jobs ORDER BY id",
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
        j->settings.spp = sqlite3_column_int(st, 4);
        j->settings.xres = sqlite3_column_int(st, 5);
        j->settings.yres = sqlite3_column_int(st, 6);
        j->settings.seed = sqlite3_column_int64(st, 7);
        const unsigned char *s = sqlite3_column_text(st, 8);
        if (s) {
            snprintf(j->integrator, sizeof j->integrator, "%s", (const char *)s);
            j->settings.integrator = j->integrator;
        }
        if ((s = sqlite3_column_text(st, 9))) {
            snprintf(j->dispersion, sizeof j->dispersion, "%s", (const char *)s);
            j->settings.dispersion = j->dispersion;
        }
        j->settings.target_error = sqlite3_column_double(st, 10);
        j->settings.adaptive = j->settings.target_error < 0; /* insert_job */
        if (j->settings.adaptive)
            j->settings.target_error = -j->settings.target_error;
        j->settings.time_limit = sqlite3_column_double(st, 11);
        j->state = sqlite3_column_int(st, 12);
        j->error = col_dup(st, 13);
        j->round = (uint32_t)sqlite3_column_int64(st, 14);
        j->photon_base = (uint32_t)sqlite3_column_int64(st, 15);
        j->photons_saved = (uint64_t)sqlite3_column_int64(st, 16);
        j->round_photons = (uint64_t)sqlite3_column_int64(st, 17);
        j->refine_photons = (uint64_t)sqlite3_column_int64(st, 18);
        j->checkpoint = (uint64_t)sqlite3_column_int64(st, 19);
        j->elapsed = sqlite3_column_double(st, 20);
        j->stop = sqlite3_column_int(st, 21);
        j->outputs = sqlite3_column_int(st, 22) != 0;
        j->samples_done = (uint64_t)sqlite3_column_int64(st, 23);
        j->samples_total = (uint64_t)sqlite3_column_int64(st, 24);
        j->nonfinite = (uint64_t)sqlite3_column_int64(st, 25);
        j->spp_done = sqlite3_column_int(st, 26);
        if ((s = sqlite3_column_text(st, 27)))
            snprintf(j->owner, sizeof j->owner, "%s", (const char *)s);
        j->priority = sqlite3_column_int(st, 28);
        j->paused = sqlite3_column_int(st, 29) != 0;
        j->parent = (uint64_t)sqlite3_column_int64(st, 30);
        j->frame = (uint32_t)sqlite3_column_int64(st, 31);
        j->nframes = (uint32_t)sqlite3_column_int64(st, 32);
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

static void result_dir(const journal_t *self, uint64_t job, char *buf, size_t size)
{
    snprintf(buf, size, "%s/results/%llu", self->dir, (unsigned long long)job);
}

static void segment_path(const journal_t *self, uint64_t job, uint32_t seg, char *buf,
                         size_t size)
{
    snprintf(buf, size, "%s/results/%llu/%u.log", self->dir, (unsigned long long)job, seg);
}

/* "<seg>.log" -> seg; false for any other name. */
static bool segment_name(const char *name, uint32_t *seg)
{
    unsigned v;
    int used = 0;
    if (sscanf(name, "%u.log%n", &v, &used) != 1 || used == 0 || name[used] != 0)
        return false;
    *seg = v;
    return true;
}

static segment_t *segment_find(journal_t *self, uint64_t job)
{
    for (size_t i = 0; i < self->nsegs; i++)
        if (self->segs[i].job == job)
            return &self->segs[i];
    return NULL;
}

static void segment_close(journal_t *self, uint64_t job)
{
    segment_t *g = segment_find(self, job);
    if (!g)
        return;
    (void)close(g->fd);
    *g = self->segs[--self->nsegs];
}

/* The job's open segment, or a new one numbered past every segment its rows or its folder
 * name: a restarted master never appends to a file a killed one may have left half written. */
static segment_t *segment_open(journal_t *self, uint64_t job, err_t *err)
{
    segment_t *g = segment_find(self, job);
    if (g)
        return g;
    char dir[PATH_MAX];
    result_dir(self, job, dir, sizeof dir);
    if (mkdir(dir, 0755) < 0 && errno != EEXIST) {
        err_set(err, "journal: cannot create '%s': %s", dir, strerror(errno));
        return NULL;
    }
    uint32_t next = 1, seg;
    sqlite3_stmt *st;
    if (prepare(self, "SELECT MAX(seg) FROM results WHERE job=?1", &st, err) < 0)
        return NULL;
    sqlite3_bind_int64(st, 1, (sqlite3_int64)job);
    if (sqlite3_step(st) == SQLITE_ROW && sqlite3_column_type(st, 0) != SQLITE_NULL)
        next = (uint32_t)sqlite3_column_int64(st, 0) + 1;
    sqlite3_finalize(st);
    DIR *d = opendir(dir);
    if (!d) {
        err_set(err, "journal: cannot read '%s': %s", dir, strerror(errno));
        return NULL;
    }
    struct dirent *e;
    while ((e = readdir(d)))
        if (segment_name(e->d_name, &seg) && seg >= next)
            next = seg + 1;
    (void)closedir(d);
    if (self->nsegs == self->capsegs) {
        size_t c = self->capsegs ? 2 * self->capsegs : 4;
        segment_t *p = realloc(self->segs, c * sizeof *p);
        if (!p) {
            err_set(err, "journal: out of memory");
            return NULL;
        }
        self->segs = p;
        self->capsegs = c;
    }
    char path[PATH_MAX + 64];
    segment_path(self, job, next, path, sizeof path);
    int fd = open(path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd < 0) {
        err_set(err, "journal: cannot create '%s': %s", path, strerror(errno));
        return NULL;
    }
    g = &self->segs[self->nsegs++];
    *g = (segment_t){.job = job, .seg = next, .fd = fd, .size = 0};
    return g;
}

static uint32_t blob_crc(const void *data, size_t size)
{
    uLong c = crc32(0L, Z_NULL, 0);
    const Bytef *p = data;
    while (size > 0) { /* crc32 takes a uInt length */
        uInt n = size > (1u << 30) ? (1u << 30) : (uInt)size;
        c = crc32(c, p, n);
        p += n;
        size -= n;
    }
    return (uint32_t)c;
}

static int add_result(journal_t *self, uint64_t job, uint32_t round, uint32_t task, int kind,
                      int tile, int pass, const void *data, size_t size, err_t *err);

int journal_add_result(journal_t *self, uint64_t job, uint32_t round, uint32_t task, int kind,
                       int tile, int pass, const void *data, size_t size, err_t *err)
{
    double t0 = clock_now_s();
    if (self->in_turn && !self->turn_open) {
        if (exec(self, "BEGIN IMMEDIATE", err) < 0)
            return -1;
        self->turn_open = true;
        self->t_turn = t0;
    }
    int rc = add_result(self, job, round, task, kind, tile, pass, data, size, err);
    if (!self->turn_open)
        count_write(self, t0); /* a turn's results count as its one commit */
    return rc;
}

void journal_turn_begin(journal_t *self)
{
    self->in_turn = true;
}

int journal_turn_end(journal_t *self, err_t *err)
{
    self->in_turn = false;
    return turn_flush(self, err);
}

static int add_result(journal_t *self, uint64_t job, uint32_t round, uint32_t task, int kind,
                      int tile, int pass, const void *data, size_t size, err_t *err)
{
    segment_t *g = segment_open(self, job, err);
    if (!g)
        return -1;
    const uint8_t *p = data;
    uint64_t offset = g->size;
    for (size_t done = 0; done < size;) {
        ssize_t n = pwrite(g->fd, p + done, size - done, (off_t)(offset + done));
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0) {
            char path[PATH_MAX + 64];
            segment_path(self, job, g->seg, path, sizeof path);
            err_set(err, "journal: cannot write to '%s': %s", path, n < 0 ? strerror(errno) : "no progress");
            segment_close(self, job); /* its tail is unknown: the next result starts another */
            return -1;
        }
        done += (size_t)n;
    }
    g->size += size;
    if (!self->add_result &&
        prepare(self,
                "INSERT OR IGNORE INTO results(job, round, task, kind, tile, pass, size, seg, "
                "offset, crc) VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10)",
                &self->add_result, err) < 0)
        return -1;
    sqlite3_stmt *st = self->add_result;
    sqlite3_bind_int64(st, 1, (sqlite3_int64)job);
    sqlite3_bind_int64(st, 2, round);
    sqlite3_bind_int64(st, 3, task);
    sqlite3_bind_int(st, 4, kind);
    sqlite3_bind_int(st, 5, tile);
    sqlite3_bind_int(st, 6, pass);
    sqlite3_bind_int64(st, 7, (sqlite3_int64)size);
    sqlite3_bind_int64(st, 8, g->seg);
    sqlite3_bind_int64(st, 9, (sqlite3_int64)offset);
    sqlite3_bind_int64(st, 10, blob_crc(data, size));
    int rc = sqlite3_step(st) == SQLITE_DONE ? 0 : db_error(self, err, "adding a result");
    sqlite3_reset(st);
    return rc;
}

/* A blob of the segment open in *fd (segment *open_seg), opening seg first when it differs.
 * NULL when the file is missing, short, or the bytes are not the ones journaled. */
static uint8_t *read_blob(const journal_t *self, uint64_t job, uint32_t seg, uint64_t offset,
                          size_t size, uint32_t crc, int *fd, uint32_t *open_seg)
{
    if (*fd < 0 || *open_seg != seg) {
        if (*fd >= 0)
            (void)close(*fd);
        char path[PATH_MAX + 64];
        segment_path(self, job, seg, path, sizeof path);
        *fd = open(path, O_RDONLY | O_CLOEXEC);
        *open_seg = seg;
        if (*fd < 0)
            return NULL;
    }
    uint8_t *data = malloc(size ? size : 1);
    if (!data)
        return NULL;
    for (size_t done = 0; done < size;) {
        ssize_t n = pread(*fd, data + done, size - done, (off_t)(offset + done));
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0) {
            free(data);
            return NULL;
        }
        done += (size_t)n;
    }
    if (blob_crc(data, size) != crc) {
        free(data);
        return NULL;
    }
    return data;
}

int journal_results(journal_t *self, uint64_t job, uint32_t round, journal_result_fn fn,
                    void *user, size_t *lost, err_t *err)
{
    *lost = 0;
    sqlite3_stmt *st;
    if (prepare(self,
                "SELECT task, kind, size, seg, offset, crc FROM results WHERE job=?1 AND "
                "round=?2 ORDER BY kind DESC, pass, tile",
                &st, err) < 0)
        return -1;
    sqlite3_bind_int64(st, 1, (sqlite3_int64)job);
    sqlite3_bind_int64(st, 2, round);
    int rc, out = 0, fd = -1;
    uint32_t open_seg = 0;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
        uint32_t task = (uint32_t)sqlite3_column_int64(st, 0);
        size_t size = (size_t)sqlite3_column_int64(st, 2);
        uint8_t *data = read_blob(self, job, (uint32_t)sqlite3_column_int64(st, 3),
                                  (uint64_t)sqlite3_column_int64(st, 4), size,
                                  (uint32_t)sqlite3_column_int64(st, 5), &fd, &open_seg);
        if (!data) {
            (*lost)++;
            continue;
        }
        int r = fn(user, task, sqlite3_column_int(st, 1), data, size, err);
        free(data);
        if (r < 0) {
            out = -1;
            break;
        }
    }
    if (fd >= 0)
        (void)close(fd);
    if (out == 0 && rc != SQLITE_DONE)
        out = db_error(self, err, "reading results");
    sqlite3_finalize(st);
    return out;
}

void journal_prune(journal_t *self, uint64_t job)
{
    /* The next result starts a segment of its own, so that this one can go once the rows in
     * it are dropped (a checkpoint, the job's end). */
    segment_close(self, job);
    char dir[PATH_MAX];
    result_dir(self, job, dir, sizeof dir);
    DIR *d = opendir(dir);
    if (!d)
        return;
    /* The segments the job's rows name: a handful (one per checkpoint interval). */
    uint32_t used[64];
    size_t n = 0;
    bool listed = false;
    sqlite3_stmt *st;
    err_t ignore;
    if (prepare(self, "SELECT DISTINCT seg FROM results WHERE job=?1", &st, &ignore) == 0) {
        sqlite3_bind_int64(st, 1, (sqlite3_int64)job);
        int rc;
        while ((rc = sqlite3_step(st)) == SQLITE_ROW && n < sizeof used / sizeof *used)
            used[n++] = (uint32_t)sqlite3_column_int64(st, 0);
        /* More segments than the list holds: keep every file rather than guess. */
        listed = rc == SQLITE_DONE;
        sqlite3_finalize(st);
    }
    /* Without the list (a database error) nothing is removed. */
    if (listed) {
        struct dirent *e;
        while ((e = readdir(d))) {
            uint32_t seg;
            if (e->d_name[0] == '.')
                continue;
            bool keep = false;
            if (segment_name(e->d_name, &seg))
                for (size_t i = 0; i < n && !keep; i++)
                    keep = used[i] == seg;
            if (keep)
                continue;
            char path[PATH_MAX + 300];
            snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
            (void)unlink(path);
        }
    }
    (void)closedir(d);
    if (listed && n == 0)
        (void)rmdir(dir);
}

/* Drops the round's camera rows that the checkpoint holds (tile t's passes below
 * next_pass[t]), inside the caller's transaction. One scan of the round's rows, then a delete by
 * rowid for each: a DELETE per tile would walk every row of the round once per tile (the primary
 * key orders by task, not tile), seconds of the master's loop for a job of 10 000 tiles
 * (docs/performance.md, "The master at scale"). The rowids are gathered first and the scan
 * finished before any row goes, so the deletions never run under an open cursor of the table. */
static int drop_checkpointed(journal_t *self, uint64_t job, uint32_t round, const int *next_pass,
                             int ntiles, err_t *err)
{
    sqlite3_stmt *st;
    if (prepare(self, "SELECT rowid, tile, pass FROM results WHERE job=?1 AND round=?2 AND kind=0",
                &st, err) < 0)
        return -1;
    sqlite3_bind_int64(st, 1, (sqlite3_int64)job);
    sqlite3_bind_int64(st, 2, round);
    sqlite3_int64 *ids = NULL;
    size_t n = 0, cap = 0;
    int rc = 0, step = SQLITE_DONE;
    while (rc == 0 && (step = sqlite3_step(st)) == SQLITE_ROW) {
        int tile = sqlite3_column_int(st, 1), pass = sqlite3_column_int(st, 2);
        if (tile < 0 || tile >= ntiles || pass >= next_pass[tile])
            continue;
        if (n == cap) {
            size_t c = cap ? 2 * cap : 1024;
            sqlite3_int64 *p = realloc(ids, c * sizeof *p);
            if (!p) {
                rc = err_set(err, "journal: out of memory dropping checkpointed results");
                break;
            }
            ids = p;
            cap = c;
        }
        ids[n++] = sqlite3_column_int64(st, 0);
    }
    if (rc == 0 && step != SQLITE_DONE)
        rc = db_error(self, err, "reading the results a checkpoint holds");
    sqlite3_finalize(st);
    sqlite3_stmt *del = NULL;
    if (rc == 0 && n > 0)
        rc = prepare(self, "DELETE FROM results WHERE rowid=?1", &del, err);
    for (size_t i = 0; rc == 0 && i < n; i++) {
        sqlite3_bind_int64(del, 1, ids[i]);
        if (sqlite3_step(del) != SQLITE_DONE)
            rc = db_error(self, err, "dropping checkpointed results");
        sqlite3_reset(del);
    }
    sqlite3_finalize(del); /* a no-op for NULL */
    free(ids);
    return rc;
}

int journal_set_checkpoint(journal_t *self, uint64_t job, uint32_t round, uint64_t gen,
                           const int *next_pass, int ntiles, double elapsed, err_t *err)
{
    /* This commit drops results the checkpoint holds: synced to disk before it returns (an fsync
     * at most every few seconds), so that a power cut cannot bring them back without it. (The
     * turn's results first: the setting cannot change inside a transaction.) */
    if (turn_flush(self, err) < 0 || exec(self, "PRAGMA synchronous=FULL", err) < 0)
        return -1;
    err_t ignore;
    if (begin(self, err) < 0) {
        (void)exec(self, "PRAGMA synchronous=NORMAL", &ignore);
        return -1;
    }
    sqlite3_stmt *st;
    int rc = prepare(self, "UPDATE jobs SET checkpoint=?2, elapsed=?3 WHERE id=?1", &st, err);
    if (rc == 0) {
        sqlite3_bind_int64(st, 1, (sqlite3_int64)job);
        sqlite3_bind_int64(st, 2, (sqlite3_int64)gen);
        sqlite3_bind_double(st, 3, elapsed);
        rc = step_done(self, st, "recording a checkpoint", err);
    }
    if (rc == 0)
        rc = drop_checkpointed(self, job, round, next_pass, ntiles, err);
    rc = commit(self, rc, err);
    (void)exec(self, "PRAGMA synchronous=NORMAL", &ignore);
    if (rc < 0)
        return -1;
    journal_prune(self, job);
    return 0;
}

int journal_add_pass(journal_t *self, uint64_t job, uint32_t round, const journal_pass_t *p,
                     err_t *err)
{
    if (begin(self, err) < 0)
        return -1;
    sqlite3_stmt *st;
    int rc = prepare(self,
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
        rc = step_done(self, st, "adding a pass record", err);
    }
    if (rc == 0 && (rc = prepare(self, "UPDATE jobs SET elapsed=?2 WHERE id=?1", &st, err)) == 0) {
        sqlite3_bind_int64(st, 1, (sqlite3_int64)job);
        sqlite3_bind_double(st, 2, p->elapsed);
        rc = step_done(self, st, "recording the elapsed time", err);
    }
    return commit(self, rc, err);
}

int journal_passes(journal_t *self, uint64_t job, uint32_t round, journal_pass_t *out, int max,
                   err_t *err)
{
    sqlite3_stmt *st;
    if (prepare(self,
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
        db_error(self, err, "reading pass records");
        n = -1;
    }
    sqlite3_finalize(st);
    return n;
}

/* ---------------------------------------------------------------- blobs */

/* A reader over a blob that fails (and stays failed) on any short read. */
typedef struct reader {
    const uint8_t *p;
    size_t left;
    bool bad;
} reader_t;

static void rd(reader_t *r, void *out, size_t n)
{
    if (r->bad || r->left < n) {
        r->bad = true;
        memset(out, 0, n);
        return;
    }
    memcpy(out, r->p, n);
    r->p += n;
    r->left -= n;
}

static uint32_t rd_u32(reader_t *r)
{
    uint32_t v;
    rd(r, &v, sizeof v);
    return v;
}

static uint64_t rd_u64(reader_t *r)
{
    uint64_t v;
    rd(r, &v, sizeof v);
    return v;
}

static uint8_t *wr(uint8_t *p, const void *src, size_t n)
{
    memcpy(p, src, n);
    return p + n;
}

static uint8_t *wr_u32(uint8_t *p, uint32_t v)
{
    return wr(p, &v, sizeof v);
}

static uint8_t *wr_u64(uint8_t *p, uint64_t v)
{
    return wr(p, &v, sizeof v);
}

/* Sum values per pixel: nb bucket sums, then the X, Y, Z sums. */
static size_t sum_channels(int nb)
{
    return (size_t)nb + TILEBUF_XYZ;
}

/* Bytes of a tile's arrays: bucket sums [h][w][nb], XYZ sums [h][w][3] and counts, lum, lum_sq
 * [h][w], 8 bytes each. */
static size_t tile_array_bytes(int w, int h, int nb)
{
    return (size_t)w * (size_t)h * (sum_channels(nb) + 3) * 8;
}

static bool tile_dims_ok(int x0, int y0, int w, int h, int nb)
{
    return x0 >= 0 && y0 >= 0 && w > 0 && h > 0 && w <= MAX_IMAGE_SIDE && h <= MAX_IMAGE_SIDE &&
           x0 <= MAX_IMAGE_SIDE - w && y0 <= MAX_IMAGE_SIDE - h && nb > 0 && nb <= MAX_BUCKETS;
}

static uint8_t *pack_arrays(uint8_t *p, size_t px, int nb, const double *sums, const double *xyz,
                            const uint64_t *counts, const double *lum, const double *lum_sq)
{
    p = wr(p, sums, px * (size_t)nb * sizeof *sums);
    p = wr(p, xyz, px * TILEBUF_XYZ * sizeof *xyz);
    p = wr(p, counts, px * sizeof *counts);
    p = wr(p, lum, px * sizeof *lum);
    return wr(p, lum_sq, px * sizeof *lum_sq);
}

/* The arrays at r's position for a w x h tile of nb buckets, checked and copied into a
 * tilebuf (tilebuf_new_from refuses non-finite sums). */
static tilebuf_t *unpack_arrays(reader_t *r, int x0, int y0, int w, int h, int nb,
                                uint64_t nonfinite, err_t *err)
{
    size_t px = (size_t)w * (size_t)h, need = tile_array_bytes(w, h, nb);
    if (r->bad || r->left < need) {
        err_set(err, "a journal blob of %dx%d pixels and %d buckets is cut short", w, h, nb);
        return NULL;
    }
    /* The blob's bytes need not be aligned for doubles: copy them out first. */
    uint8_t *copy = malloc(need);
    if (!copy) {
        err_set(err, "out of memory for a %dx%d journal tile", w, h);
        return NULL;
    }
    rd(r, copy, need);
    const size_t nc = sum_channels(nb);
    const double *sums = (const double *)copy;
    const double *xyz = (const double *)(copy + px * (size_t)nb * 8);
    const uint64_t *counts = (const uint64_t *)(copy + px * nc * 8);
    const double *lum = (const double *)(copy + px * (nc + 1) * 8);
    const double *lum_sq = (const double *)(copy + px * (nc + 2) * 8);
    tilebuf_t *tb =
        tilebuf_new_from(x0, y0, w, h, nb, sums, xyz, counts, lum, lum_sq, nonfinite, err);
    free(copy);
    return tb;
}

/* A tile blob: magic, x0, y0, w, h, nb, sb, se, the sums' width in bits (32 or 64), nonfinite,
 * then bucket sums [h][w][nb] and XYZ sums [h][w][3] at that width and counts, lum, lum_sq
 * [h][w] at 8 bytes. Float32 sums are kept whenever every sum is a float value (tilebuf.h), as
 * on the wire: half the writes, and the same doubles back. */
int journal_pack_tile(const proto_tile_result_t *t, uint8_t **data, size_t *size, err_t *err)
{
    const proto_tile_t *q = &t->rect;
    if (!tile_dims_ok(q->x0, q->y0, q->w, q->h, t->nbuckets))
        return err_set(err, "journal: tile %dx%d at (%d,%d) with %d buckets is out of range", q->w,
                       q->h, q->x0, q->y0, t->nbuckets);
    size_t px = (size_t)q->w * (size_t)q->h, nbs = px * (size_t)t->nbuckets,
           ns = px * sum_channels(t->nbuckets);
    /* A decoded float32 result was checked by the decoder; anything else is checked here. */
    bool narrow = t->sums_bits == 32;
    if (!narrow) {
        size_t i = 0;
        while (i < ns && tilebuf_is_float_value(i < nbs ? t->sums[i] : t->xyz[i - nbs]))
            i++;
        narrow = i == ns;
    }
    size_t n = 4 + 8 * 4 + 8 + tile_array_bytes(q->w, q->h, t->nbuckets) - (narrow ? ns * 4 : 0);
    uint8_t *buf = malloc(n), *p = buf;
    if (!buf)
        return err_set(err, "journal: out of memory for a %zu-byte tile", n);
    p = wr_u32(p, TILE_MAGIC);
    p = wr_u32(p, (uint32_t)q->x0);
    p = wr_u32(p, (uint32_t)q->y0);
    p = wr_u32(p, (uint32_t)q->w);
    p = wr_u32(p, (uint32_t)q->h);
    p = wr_u32(p, (uint32_t)t->nbuckets);
    p = wr_u32(p, q->sample_begin);
    p = wr_u32(p, q->sample_end);
    p = wr_u32(p, narrow ? 32 : 64);
    p = wr_u64(p, t->nonfinite);
    if (narrow) {
        for (size_t i = 0; i < ns; i++) {
            float f = (float)(i < nbs ? t->sums[i] : t->xyz[i - nbs]); /* exact: a float value */
            p = wr(p, &f, sizeof f);
        }
        p = wr(p, t->counts, px * sizeof *t->counts);
        p = wr(p, t->lum, px * sizeof *t->lum);
        p = wr(p, t->lum_sq, px * sizeof *t->lum_sq);
    } else {
        p = pack_arrays(p, px, t->nbuckets, t->sums, t->xyz, t->counts, t->lum, t->lum_sq);
    }
    *data = buf;
    *size = (size_t)(p - buf);
    return 0;
}

/* A blob's float32 sums widened into a float64 copy of its arrays, read as unpack_arrays reads
 * a float64 blob. */
static tilebuf_t *unpack_narrow(reader_t *r, int x0, int y0, int w, int h, int nb,
                                uint64_t nonfinite, err_t *err)
{
    size_t ns = (size_t)w * (size_t)h * sum_channels(nb), wide = tile_array_bytes(w, h, nb);
    if (r->bad || r->left < wide - ns * 4) {
        err_set(err, "a journal blob of %dx%d pixels and %d buckets is cut short", w, h, nb);
        return NULL;
    }
    uint8_t *copy = malloc(wide);
    if (!copy) {
        err_set(err, "out of memory for a %dx%d journal tile", w, h);
        return NULL;
    }
    for (size_t i = 0; i < ns; i++) {
        float f;
        rd(r, &f, sizeof f);
        double d = f;
        memcpy(copy + 8 * i, &d, sizeof d);
    }
    rd(r, copy + 8 * ns, wide - 8 * ns);
    reader_t whole = {.p = copy, .left = wide};
    tilebuf_t *tb = unpack_arrays(&whole, x0, y0, w, h, nb, nonfinite, err);
    free(copy);
    return tb;
}

tilebuf_t *journal_unpack_tile(const void *data, size_t size, uint32_t *sample_begin,
                               uint32_t *sample_end, err_t *err)
{
    reader_t r = {.p = data, .left = size};
    uint32_t magic = rd_u32(&r);
    int x0 = (int)rd_u32(&r), y0 = (int)rd_u32(&r), w = (int)rd_u32(&r), h = (int)rd_u32(&r),
        nb = (int)rd_u32(&r);
    *sample_begin = rd_u32(&r);
    *sample_end = rd_u32(&r);
    uint32_t bits = rd_u32(&r);
    uint64_t nonfinite = rd_u64(&r);
    if (!r.bad && magic == TILE_MAGIC_V4) {
        err_set(err, "a journal tile blob of version 4 (no XYZ sums): this master reads version %d",
                JOURNAL_VERSION);
        return NULL;
    }
    if (r.bad || magic != TILE_MAGIC || !tile_dims_ok(x0, y0, w, h, nb) ||
        (bits != 32 && bits != 64)) {
        err_set(err, "a journal tile blob of %zu bytes has no valid header", size);
        return NULL;
    }
    tilebuf_t *tb = bits == 32 ? unpack_narrow(&r, x0, y0, w, h, nb, nonfinite, err)
                               : unpack_arrays(&r, x0, y0, w, h, nb, nonfinite, err);
    if (tb && r.left != 0) {
        tilebuf_destroy(&tb);
        err_set(err, "a journal tile blob has %zu bytes past its arrays", r.left);
    }
    return tb;
}

int journal_pack_photons(const proto_photon_result_t *r, uint8_t **data, size_t *size, err_t *err)
{
    size_t n = 4 + 4 * 8 + r->size;
    uint8_t *buf = malloc(n), *p = buf;
    if (!buf)
        return err_set(err, "journal: out of memory for a %zu-byte photon batch", n);
    p = wr_u32(p, PHOT_MAGIC);
    p = wr_u64(p, r->range.first);
    p = wr_u64(p, r->range.end);
    p = wr_u64(p, r->emitted);
    p = wr_u64(p, r->nonfinite);
    if (r->size)
        p = wr(p, r->data, r->size);
    *data = buf;
    *size = (size_t)(p - buf);
    return 0;
}

int journal_unpack_photons(const void *data, size_t size, proto_photon_result_t *out, err_t *err)
{
    reader_t r = {.p = data, .left = size};
    uint32_t magic = rd_u32(&r);
    memset(out, 0, sizeof *out);
    out->range.first = rd_u64(&r);
    out->range.end = rd_u64(&r);
    out->emitted = rd_u64(&r);
    out->nonfinite = rd_u64(&r);
    if (r.bad || magic != PHOT_MAGIC || out->range.end < out->range.first)
        return err_set(err, "a journal photon blob of %zu bytes has no valid header", size);
    out->data = r.p;
    out->size = r.left;
    return 0;
}

/* A checkpoint: magic, x0, y0, w, h, nb, ntiles, round, nonfinite, the image's arrays, the pass
 * table, then the SHA-256 of every byte before it (issue 16: a flipped bit in a checkpoint whose
 * size was right went into a finished image). */
#define CKPT_HEADER (8 * 4 + 8)
int journal_write_checkpoint(const char *path, uint32_t round, const tilebuf_t *image,
                             const int *next_pass, int ntiles, err_t *err)
{
    int x0 = tilebuf_x0(image), y0 = tilebuf_y0(image), w = tilebuf_width(image),
        h = tilebuf_height(image), nb = tilebuf_nbuckets(image);
    size_t n = CKPT_HEADER + tile_array_bytes(w, h, nb) + (size_t)ntiles * 4 + SHA256_DIGEST_BYTES;
    uint8_t *buf = malloc(n), *p = buf;
    if (!buf)
        return err_set(err, "journal: out of memory for a %zu-byte checkpoint", n);
    p = wr_u32(p, CKPT_MAGIC);
    p = wr_u32(p, (uint32_t)x0);
    p = wr_u32(p, (uint32_t)y0);
    p = wr_u32(p, (uint32_t)w);
    p = wr_u32(p, (uint32_t)h);
    p = wr_u32(p, (uint32_t)nb);
    p = wr_u32(p, (uint32_t)ntiles);
    p = wr_u32(p, round);
    p = wr_u64(p, tilebuf_nonfinite(image));
    p = pack_arrays(p, (size_t)w * (size_t)h, nb, tilebuf_sums(image), tilebuf_xyz_sums(image),
                    tilebuf_counts(image), tilebuf_luminance_sums(image),
                    tilebuf_luminance_sq_sums(image));
    for (int t = 0; t < ntiles; t++)
        p = wr_u32(p, (uint32_t)next_pass[t]);
    sha256_t h256;
    sha256_init(&h256);
    sha256_update(&h256, buf, (size_t)(p - buf));
    sha256_final(&h256, p);
    p += SHA256_DIGEST_BYTES;
    int rc = files_write_atomic(path, buf, (size_t)(p - buf), true, err);
    free(buf);
    return rc;
}

int journal_read_checkpoint(const char *path, uint32_t round, int xres, int yres, int nbuckets,
                            int ntiles, tilebuf_t **image, int *next_pass, err_t *err)
{
    *image = NULL;
    uint8_t *data;
    size_t size;
    size_t want = CKPT_HEADER + tile_array_bytes(xres, yres, nbuckets) + (size_t)ntiles * 4 +
                  SHA256_DIGEST_BYTES;
    /* One byte more than it should hold, so that bytes past its end are told from a right
     * size. */
    if (files_read(path, want + 1, &data, &size, err) < 0)
        return err_prefix(err, "checkpoint: ");
    reader_t r = {.p = data, .left = size};
    uint32_t magic = rd_u32(&r);
    int x0 = (int)rd_u32(&r), y0 = (int)rd_u32(&r), w = (int)rd_u32(&r), h = (int)rd_u32(&r),
        nb = (int)rd_u32(&r), nt = (int)rd_u32(&r);
    uint32_t rnd = rd_u32(&r);
    uint64_t nonfinite = rd_u64(&r);
    uint8_t digest[SHA256_DIGEST_BYTES];
    int rc = 0;
    if (!r.bad && magic == CKPT_MAGIC_V4) {
        rc = err_set(err, "checkpoint %s is of journal version 4, without the XYZ sums the RGB "
                          "layers now come from: it cannot be resumed by this master (version %d)",
                     path, JOURNAL_VERSION);
    } else if (!r.bad && magic == CKPT_MAGIC_NOSUM) {
        rc = err_set(err, "checkpoint %s carries no checksum (written by an older master): not "
                          "trusted",
                     path);
    } else if (r.bad || magic != CKPT_MAGIC) {
        rc = err_set(err, "checkpoint %s has no valid header", path);
    } else if (size != want) {
        rc = err_set(err, "checkpoint %s has %s bytes than a %dx%d image of %d buckets and %d "
                          "tiles needs (%zu)",
                     path, size > want ? "more" : "fewer", xres, yres, nbuckets, ntiles, want);
    }
    if (rc == 0) {
        sha256_t h256;
        sha256_init(&h256);
        sha256_update(&h256, data, size - SHA256_DIGEST_BYTES);
        sha256_final(&h256, digest);
        if (memcmp(digest, data + size - SHA256_DIGEST_BYTES, SHA256_DIGEST_BYTES) != 0)
            rc = err_set(err, "checkpoint %s fails its SHA-256 checksum (damaged on disk)", path);
        else if (x0 != 0 || y0 != 0 || w != xres || h != yres || nb != nbuckets || nt != ntiles)
            rc = err_set(err, "checkpoint %s is not a %dx%d image of %d buckets and %d tiles",
                         path, xres, yres, nbuckets, ntiles);
        else if (rnd != round)
            rc = err_set(err, "checkpoint %s is of round %u, the job is at round %u", path, rnd,
                         round);
    }
    if (rc == 0) {
        r.left -= SHA256_DIGEST_BYTES;
        if (!(*image = unpack_arrays(&r, 0, 0, w, h, nb, nonfinite, err))) {
            rc = err_prefix(err, "checkpoint %s: ", path);
        } else {
            for (int t = 0; t < ntiles; t++)
                next_pass[t] = (int)rd_u32(&r);
            if (r.bad || r.left != 0) {
                tilebuf_destroy(image);
                rc = err_set(err, "checkpoint %s: its pass table is %s", path,
                             r.bad ? "cut short" : "followed by extra bytes");
            }
        }
    }
    free(data);
    return rc;
}
