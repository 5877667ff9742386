/* The farm end to end, as users run it: `prismfarm render` (a master and workers in one process) with 1 and 3 workers, and separate
 * master and worker processes on loopback TCP with a worker killed half-way, all giving
 * bit-identical EXR pixel data; plus the client commands against a live master. The TCP farm
 * runs with CURVE keys (docs/security.md), as a real one does. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#define CLI_RUN_TIMEOUT_MS 120000
#include "cli_run.h"
#include "farm_testutil.h"
#include "image_exr.h"

#include <dirent.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

static char DIR_[256];
static char MASTER_KEY[600], AUTHORIZED[600]; /* the master's --key and --authorized */

static int setup(void **state)
{
    (void)state;
    return testutil_mkdtemp(DIR_, sizeof DIR_, "farm") < 0 ||
                   testutil_farm_keys(DIR_, MASTER_KEY, AUTHORIZED, sizeof MASTER_KEY) < 0
               ? -1
               : 0;
}

static int teardown(void **state)
{
    (void)state;
    return testutil_rmtree(DIR_);
}

static const char *path_in(const char *name)
{
    static char buf[8][512];
    static int k;
    k = (k + 1) % 8;
    snprintf(buf[k], sizeof buf[k], "%s/%s", DIR_, name);
    return buf[k];
}

/* Entries in a folder other than . and ..; -1 if it cannot be read. */
static int count_entries(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return -1;
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)))
        n += strcmp(e->d_name, ".") && strcmp(e->d_name, "..");
    closedir(d);
    return n;
}

static void test_render_any_worker_count(void **state)
{
    (void)state;
    /* The in-process farm's temporary spool (the scene, the job's outputs, the worker's cache
     * with the extracted bundle) goes in $TMPDIR and is removed, with everything in it. */
    const char *tmp = path_in("tmp");
    assert_int_equal(mkdir(tmp, 0700), 0);
    assert_int_equal(setenv("TMPDIR", tmp, 1), 0);
    const run_t *r = run("render", "data/render/tiny.pbrt", "-o", path_in("one.exr"), "--workers", "1",
                         "--threads", "1", "--tile", "8", "--quiet", NULL);
    assert_int_equal(unsetenv("TMPDIR"), 0);
    if (r->status != 0)
        fail_msg("exit %d: %s", r->status, r->err);
    expect_in(r->out, "wrote ");
    if (count_entries(tmp) != 0)
        fail_msg("%d entries left in the render's TMPDIR %s: %s", count_entries(tmp), tmp, r->err);
    r = run("render", "data/render/tiny.pbrt", "-o", path_in("three.exr"), "--workers", "3", "--threads", "1",
            "--tile", "8", "--quiet", NULL);
    if (r->status != 0)
        fail_msg("exit %d: %s", r->status, r->err);
    testutil_assert_same_pixels(path_in("one.exr"), path_in("three.exr"));
    struct stat st;
    assert_int_equal(stat(path_in("three.png"), &st), 0);
}

/* Separate processes over TCP on loopback; one worker is killed with SIGKILL while it holds
 * tasks. Its tasks go back to the queue, and the result is the same bytes as with one worker. */
static void test_processes_and_a_killed_worker(void **state)
{
    (void)state;
    const char *spool = path_in("spool");
    pid_t master =
        testutil_spawn(path_in("master.log"), "master", "--workers", "tcp://127.0.0.1:*",
                       "--clients", "tcp://127.0.0.1:*", "--spool", spool, "--heartbeat", "200",
                       "--tile", "8", "--key", MASTER_KEY, "--authorized", AUTHORIZED, NULL);
    char wep[256], cep[256];
    testutil_read_endpoints(spool, wep, cep);
    pid_t w1 = testutil_spawn(path_in("w1.log"), "worker", "--connect", wep, "--threads", "1",
                              "--name", "w1", "--cache", path_in("c1"), NULL);
    pid_t w2 = testutil_spawn(path_in("w2.log"), "worker", "--connect", wep, "--threads", "1",
                              "--name", "w2", "--cache", path_in("c2"), NULL);

    /* A job large enough to be caught half-way. */
    const run_t *r = run("submit", "data/render/tiny.pbrt", "--master", cep, "--spp", "64", "--name", "big", NULL);
    if (r->status != 0)
        fail_msg("submit: exit %d: %s", r->status, r->err);
    assert_string_equal(r->out, "1\n");
    testutil_sleep_ms(300);
    testutil_stop(w2, SIGKILL);
    r = run("workers", "--master", cep, NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "w1");
    /* Wait for the job with the surviving worker. */
    for (int i = 0; i < 600; i++) {
        r = run("status", "1", "--master", cep, "--json", NULL);
        assert_int_equal(r->status, 0);
        if (strstr(r->out, "\"done\"") || strstr(r->out, "\"failed\""))
            break;
        testutil_sleep_ms(100);
    }
    expect_in(r->out, "\"state\": \"done\"");
    r = run("fetch", "1", "-o", path_in("killed.exr"), "--master", cep, NULL);
    if (r->status != 0)
        fail_msg("fetch: %s", r->err);
    /* The same job with a single worker from the start. */
    r = run("submit", "data/render/tiny.pbrt", "--master", cep, "--spp", "64", "--name", "again", "--wait", "-o",
            path_in("single.exr"), "--quiet", NULL);
    if (r->status != 0)
        fail_msg("submit --wait: exit %d: %s", r->status, r->err);
    testutil_assert_same_pixels(path_in("killed.exr"), path_in("single.exr"));
    /* And the same bytes as `prismfarm render` of the scene with the same seed and spp (another
     * tile size changes nothing: passes are per job, so each pixel sums the same samples in the
     * same order). */
    r = run("render", "data/render/tiny.pbrt", "--spp", "64", "-o", path_in("render.exr"), "--quiet", NULL);
    if (r->status != 0)
        fail_msg("render: exit %d: %s", r->status, r->err);
    testutil_assert_same_pixels(path_in("single.exr"), path_in("render.exr"));

    /* Errors a user sees: a broken scene, a job that does not exist. */
    r = run("submit", "data/render/broken.pbrt", "--master", cep, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "broken.pbrt:4:");
    r = run("fetch", "99", "-o", path_in("none.exr"), "--master", cep, NULL);
    assert_int_equal(r->status, 1);
    r = run("jobs", "--master", cep, NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "big");
    expect_in(r->out, "again");

    testutil_stop(w1, SIGTERM);
    testutil_stop(master, SIGTERM);
}

static void test_client_without_master(void **state)
{
    (void)state;
    const run_t *r = run("jobs", "--master", "tcp://127.0.0.1:9", "--timeout", "0.5", NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "is it running?");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_render_any_worker_count),
        cmocka_unit_test(test_processes_and_a_killed_worker),
        cmocka_unit_test(test_client_without_master),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
