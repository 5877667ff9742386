/* journal: the database opened (created, or migrated from an older version), checked and
 * closed, and the helpers the journal's files share (journal_db.h). */
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


int jdb_error(journal_t *self, err_t *err, const char *what)
{
    return err_set(err, "journal %s: %s: %s", self->path, what, sqlite3_errmsg(self->db));
}

int jdb_exec(journal_t *self, const char *sql, err_t *err)
{
    char *msg = NULL;
    if (sqlite3_exec(self->db, sql, NULL, NULL, &msg) != SQLITE_OK) {
        err_set(err, "journal %s: %s", self->path, msg ? msg : sqlite3_errmsg(self->db));
        sqlite3_free(msg);
        return -1;
    }
    return 0;
}

int jdb_prepare(journal_t *self, const char *sql, sqlite3_stmt **st, err_t *err)
{
    if (sqlite3_prepare_v2(self->db, sql, -1, st, NULL) != SQLITE_OK)
        return jdb_error(self, err, "prepare");
    return 0;
}

/* Runs a statement that returns no rows; finalises it. */
int jdb_step_done(journal_t *self, sqlite3_stmt *st, const char *what, err_t *err)
{
    int rc = sqlite3_step(st);
    int out = rc == SQLITE_DONE ? 0 : jdb_error(self, err, what);
    sqlite3_finalize(st);
    return out;
}

/* Commits the turn's results so far (journal_turn_begin): before any other write, so that every
 * change but a result is still committed when its function returns, after the results that
 * came before it. */
int jdb_turn_flush(journal_t *self, err_t *err)
{
    if (!self->turn_open)
        return 0;
    self->turn_open = false;
    /* SQLite rolls a transaction back by itself on some errors (a full disk, an I/O error). */
    if (sqlite3_get_autocommit(self->db))
        return err_set(err, "journal %s: a write error rolled back the results since the turn "
                            "began", self->path);
    int rc = jdb_exec(self, "COMMIT", err);
    self->stats.writes++;
    self->stats.seconds += clock_now_s() - self->t_turn;
    if (rc < 0) {
        err_t ignore;
        (void)jdb_exec(self, "ROLLBACK", &ignore);
    }
    return rc;
}

int jdb_begin(journal_t *self, err_t *err)
{
    if (jdb_turn_flush(self, err) < 0)
        return -1;
    self->t_begin = clock_now_s();
    return jdb_exec(self, "BEGIN IMMEDIATE", err);
}

/* A write's time since t0 (journal_stats). */
void jdb_count_write(journal_t *self, double t0)
{
    self->stats.writes++;
    self->stats.seconds += clock_now_s() - t0;
}

int jdb_commit(journal_t *self, int rc, err_t *err)
{
    if (rc < 0) {
        err_t ignore;
        (void)jdb_exec(self, "ROLLBACK", &ignore);
        return -1;
    }
    rc = jdb_exec(self, "COMMIT", err);
    jdb_count_write(self, self->t_begin);
    return rc;
}


journal_stats_t journal_stats(const journal_t *self)
{
    return self->stats;
}

/* clang-format off */
static const char *SCHEMA =
    "CREATE TABLE IF NOT EXISTS meta(key TEXT PRIMARY KEY, value INTEGER NOT NULL);"
    "CREATE TABLE IF NOT EXISTS jobs("
    " id INTEGER PRIMARY KEY, name TEXT NOT NULL, hash TEXT NOT NULL, main TEXT NOT NULL,"
    JOB_SETTINGS(JDB_SETTING_DDL)
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
/* clang-format on */

/* Version 6 to 7: the jobs' priority and pause columns (the blocked table came with SCHEMA).
 * One transaction: a master killed half-way leaves version 6, migrated again next time. */
static int migrate_6_to_7(journal_t *self, err_t *err)
{
    if (jdb_begin(self, err) < 0)
        return -1;
    int rc = jdb_exec(self,
                  "ALTER TABLE jobs ADD COLUMN priority INTEGER NOT NULL DEFAULT 0;"
                  "ALTER TABLE jobs ADD COLUMN paused INTEGER NOT NULL DEFAULT 0;"
                  "UPDATE meta SET value=7 WHERE key='version';",
                  err);
    return jdb_commit(self, rc, err);
}

/* Version 7 to 8: the frame columns; every job of a version-7 journal is a single scene (0 in
 * each). One transaction, as migrate_6_to_7. */
static int migrate_7_to_8(journal_t *self, err_t *err)
{
    if (jdb_begin(self, err) < 0)
        return -1;
    int rc = jdb_exec(self,
                  "ALTER TABLE jobs ADD COLUMN parent INTEGER NOT NULL DEFAULT 0;"
                  "ALTER TABLE jobs ADD COLUMN frame INTEGER NOT NULL DEFAULT 0;"
                  "ALTER TABLE jobs ADD COLUMN nframes INTEGER NOT NULL DEFAULT 0;"
                  "UPDATE meta SET value=8 WHERE key='version';",
                  err);
    return jdb_commit(self, rc, err);
}

static int migrate_8_to_9(journal_t *self, err_t *err)
{
    return jdb_exec(self, "UPDATE meta SET value=9 WHERE key='version'", err);
}

/* Whether the jobs table has the column: 1, 0, or -1 with err. */
static int has_column(journal_t *self, const char *column, err_t *err)
{
    sqlite3_stmt *st;
    if (jdb_prepare(self, "SELECT COUNT(*) FROM pragma_table_info('jobs') WHERE name=?1", &st,
                    err) < 0)
        return -1;
    sqlite3_bind_text(st, 1, column, -1, SQLITE_STATIC);
    int rc = sqlite3_step(st), n = rc == SQLITE_ROW ? sqlite3_column_int(st, 0) : -1;
    sqlite3_finalize(st);
    return n < 0 ? jdb_error(self, err, "reading the jobs table's columns") : n > 0;
}

/* A journal of version 9 (or one migrated to it) up to this version: the column of each job
 * setting it lacks (proto/job_settings.h; JDB_SETTING_DDL gives the setting's KEEP as the
 * default), and adaptive sampling, which version 9 kept as a negative target_error, becomes its
 * column. One transaction, as migrate_6_to_7. */
static int migrate_settings(journal_t *self, long long version, err_t *err)
{
    static const struct {
        const char *name, *ddl;
    } columns[] = {
#define SETTING_COLUMN(field, ...) {#field, JDB_SETTING_DDL(field, __VA_ARGS__)},
        JOB_SETTINGS(SETTING_COLUMN)
#undef SETTING_COLUMN
    };
    if (jdb_begin(self, err) < 0)
        return -1;
    int rc = 0;
    for (size_t i = 0; i < sizeof columns / sizeof columns[0] && rc == 0; i++) {
        int has = has_column(self, columns[i].name, err);
        if (has < 0) {
            rc = -1;
        } else if (!has) {
            /* The DDL ends with the comma it has in SCHEMA. */
            char sql[256];
            snprintf(sql, sizeof sql, "ALTER TABLE jobs ADD COLUMN%.*s",
                     (int)strlen(columns[i].ddl) - 1, columns[i].ddl);
            rc = jdb_exec(self, sql, err);
        }
    }
    if (rc == 0 && version <= 9)
        rc = jdb_exec(self,
                      "UPDATE jobs SET adaptive=1, target_error=-target_error "
                      "WHERE target_error < 0",
                      err);
    if (rc == 0) {
        char sql[96];
        snprintf(sql, sizeof sql, "UPDATE meta SET value=%d WHERE key='version'", JOURNAL_VERSION);
        rc = jdb_exec(self, sql, err);
    }
    return jdb_commit(self, rc, err);
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
    if (jdb_exec(self, "PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL; PRAGMA foreign_keys=OFF",
             err) < 0 ||
        jdb_exec(self, SCHEMA, err) < 0) {
        journal_close(&self);
        return NULL;
    }
    sqlite3_stmt *st;
    if (jdb_prepare(self, "SELECT value FROM meta WHERE key='version'", &st, err) < 0) {
        journal_close(&self);
        return NULL;
    }
    int rc = sqlite3_step(st);
    long long version = rc == SQLITE_ROW ? sqlite3_column_int64(st, 0) : -1;
    sqlite3_finalize(st);
    if (rc != SQLITE_ROW && rc != SQLITE_DONE) {
        jdb_error(self, err, "reading its version");
        journal_close(&self);
        return NULL;
    }
    if (version < 0) {
        char sql[96];
        snprintf(sql, sizeof sql, "INSERT INTO meta(key, value) VALUES('version', %d)",
                 JOURNAL_VERSION);
        if (jdb_exec(self, sql, err) < 0) {
            journal_close(&self);
            return NULL;
        }
    } else if (version == 5) {
        /* Version 6 only adds the owner column: the rest of a version-5 spool reads as it is. */
        if (jdb_exec(self,
                     "BEGIN IMMEDIATE; ALTER TABLE jobs ADD COLUMN owner TEXT NOT NULL DEFAULT '';"
                     " UPDATE meta SET value=6 WHERE key='version'; COMMIT",
                     err) < 0 ||
            migrate_6_to_7(self, err) < 0 || migrate_7_to_8(self, err) < 0 ||
            migrate_8_to_9(self, err) < 0) {
            err_t ignore;
            (void)jdb_exec(self, "ROLLBACK", &ignore);
            err_prefix(err, "migrating from version 5: ");
            journal_close(&self);
            return NULL;
        }
    }
    if (version == 6 && (migrate_6_to_7(self, err) < 0 || migrate_7_to_8(self, err) < 0 ||
                         migrate_8_to_9(self, err) < 0)) {
        err_prefix(err, "journal %s: migrating version 6 to 9: ", path);
        journal_close(&self);
        return NULL;
    } else if (version == 7 && (migrate_7_to_8(self, err) < 0 || migrate_8_to_9(self, err) < 0)) {
        err_prefix(err, "journal %s: migrating version 7 to 9: ", path);
        journal_close(&self);
        return NULL;
    } else if (version == 8 && migrate_8_to_9(self, err) < 0) {
        err_prefix(err, "journal %s: migrating version 8 to 9: ", path);
        journal_close(&self);
        return NULL;
    } else if (version >= 0 && (version < 5 || version > JOURNAL_VERSION)) {
        err_set(err, "journal %s: version %lld, this master reads version %d (move the spool "
                     "aside or use a matching prismfarm)",
                path, version, JOURNAL_VERSION);
        journal_close(&self);
        return NULL;
    }
    if (version >= 5 && version < JOURNAL_VERSION && migrate_settings(self, version, err) < 0) {
        err_prefix(err, "journal %s: migrating version %lld to %d: ", path, version,
                   JOURNAL_VERSION);
        journal_close(&self);
        return NULL;
    }
    return self;
}

int journal_check(journal_t *self, char *report, size_t size, err_t *err)
{
    sqlite3_stmt *st;
    report[0] = 0;
    if (jdb_prepare(self, "PRAGMA quick_check(8)", &st, err) < 0)
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
    (void)jdb_turn_flush(self, &ignore);
    for (size_t i = 0; i < self->nsegs; i++)
        (void)close(self->segs[i].fd);
    free(self->segs);
    sqlite3_finalize(self->add_result); /* a no-op for NULL */
    if (self->db)
        (void)sqlite3_close(self->db);
    free(self);
    *self_p = NULL;
}

int journal_checkpoint_wal(journal_t *self, err_t *err)
{
    if (jdb_turn_flush(self, err) < 0)
        return -1;
    double t0 = clock_now_s();
    int nlog = 0, ncopied = 0;
    int rc = sqlite3_wal_checkpoint_v2(self->db, NULL, SQLITE_CHECKPOINT_PASSIVE, &nlog, &ncopied);
    self->stats.checkpoints++;
    self->stats.checkpoint_seconds += clock_now_s() - t0;
    if (rc != SQLITE_OK)
        return jdb_error(self, err, "checkpointing the WAL");
    if (nlog > 0 && ncopied < nlog)
        return err_set(err,
                       "journal %s: %d of the WAL's %d frames copied into the database (another "
                       "process reads it)",
                       self->path, ncopied, nlog);
    return 0;
}
