/* journal_testutil: what the tests of the master's journal across restarts share (test_journal,
 * test_journal_damage): the journal read while a master writes it (a number an SQL query
 * answers, a wait until queries answer), a `prismfarm master` process on a spool in the tests'
 * settings, the uninterrupted render to compare with, and the end of job 1 under a restarted
 * master checked against it. Header-only; include after cmocka.h, cli_run.h (with the test's
 * CLI_RUN_TIMEOUT_MS) and farm_testutil.h. */
#ifndef PRISMFARM_JOURNAL_TESTUTIL_H
#define PRISMFARM_JOURNAL_TESTUTIL_H

#include "cli_run.h"
#include "farm_testutil.h"

#include <sqlite3.h>
#include <stdarg.h>
#include <string.h>
#include <sys/stat.h>

#define TESTUTIL_JOURNAL_TILE "8"
#define TESTUTIL_JOURNAL_HEARTBEAT "200"

/* A number the journal of spool answers to sql (a COUNT or a column), or -1 when it cannot be
 * read yet. */
static inline long long testutil_journal_query(const char *spool, const char *sql)
{
    char path[600];
    snprintf(path, sizeof path, "%s/journal.db", spool);
    sqlite3 *db = NULL;
    long long v = -1;
    if (sqlite3_open_v2(path, &db, SQLITE_OPEN_READONLY, NULL) == SQLITE_OK) {
        sqlite3_busy_timeout(db, test_wait_ms());
        sqlite3_stmt *st;
        if (sqlite3_prepare_v2(db, sql, -1, &st, NULL) == SQLITE_OK) {
            if (sqlite3_step(st) == SQLITE_ROW)
                v = sqlite3_column_int64(st, 0);
            sqlite3_finalize(st);
        }
    }
    sqlite3_close(db);
    return v;
}

/* Waits until every sql of the NULL-terminated list answers at least 1; fails the test, naming
 * what, after timeout_s. */
static inline void testutil_wait_journal(const char *spool, double timeout_s, const char *what,
                                         ...)
{
    double deadline = testutil_now_s() + timeout_s;
    for (;;) {
        va_list ap;
        va_start(ap, what);
        int all = 1;
        for (const char *sql = va_arg(ap, const char *); sql; sql = va_arg(ap, const char *))
            all &= testutil_journal_query(spool, sql) >= 1;
        va_end(ap);
        if (all)
            return;
        if (testutil_now_s() > deadline)
            fail_msg("the journal did not show %s within %.0f s", what, timeout_s);
        testutil_sleep_ms(20);
    }
}

/* `prismfarm master` on spool, in plain text, with the tests' tile size and heartbeat. */
static inline pid_t testutil_journal_master(const char *log, const char *spool, const char *wep,
                                            const char *cep)
{
    return testutil_spawn(log, "master", "--workers", wep, "--clients", cep, "--spool", spool,
                          "--heartbeat", TESTUTIL_JOURNAL_HEARTBEAT, "--tile",
                          TESTUTIL_JOURNAL_TILE, "--insecure", NULL);
}

/* `prismfarm worker` of one thread called name, in plain text. */
static inline pid_t testutil_journal_worker(const char *log, const char *wep, const char *name)
{
    return testutil_spawn(log, "worker", "--connect", wep, "--threads", "1", "--name", name,
                          "--insecure", NULL);
}

/* The uninterrupted render of scene at spp (an in-process farm of one worker, in the tests'
 * tiles), in the scratch folder as name; made once per test run. */
static inline const char *testutil_journal_reference(const char *scene, const char *spp,
                                                     const char *name)
{
    const char *ref = testutil_scratch(name);
    struct stat st;
    if (stat(ref, &st) == 0)
        return ref;
    const run_t *r = run("render", scene, "--spp", spp, "--workers", "1", "--threads", "2",
                         "--tile", TESTUTIL_JOURNAL_TILE, "-o", ref, "--quiet", NULL);
    if (r->status != 0)
        fail_msg("reference render of %s: exit %d: %s", scene, r->status, r->err);
    return ref;
}

/* Follows job 1 to its end with a fresh client (`status --wait`), which must say done (else the
 * test fails quoting the master's log mlog), fetches it as out and compares it with ref. */
static inline void testutil_journal_finish(const char *cep, const char *ref, const char *out,
                                           const char *mlog)
{
    const run_t *r = run("status", "1", "--wait", "--quiet", "--master", cep, "--insecure", NULL);
    if (r->status != 0 || !strstr(r->out, " done "))
        testutil_fail_quoting(mlog, "status 1 --wait: exit %d: %s\n%s\nmaster log:", r->status,
                              r->err, r->out);
    r = run("fetch", "1", "-o", out, "--master", cep, "--insecure", NULL);
    if (r->status != 0)
        fail_msg("fetch 1: exit %d: %s", r->status, r->err);
    testutil_assert_same_pixels(out, ref);
}

#endif
