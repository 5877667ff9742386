/* A full disk at the end of a job (issue 16, item 1: nothing already rendered is lost). The
 * master's spool is a small tmpfs in a private mount namespace; the test fills it through
 * /proc/PID/root while the job is queued, then lets a worker render it: the outputs cannot be
 * written, so the master keeps the image, shows the job running with the reason, and tries
 * again every 5 s; once the filler is deleted the outputs are written and they are the pixels
 * of `prismfarm render`. Needs root (a mount namespace the test can reach into); skipped with
 * the reason otherwise. */
#define _GNU_SOURCE

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#define CLI_RUN_TIMEOUT_MS 120000
#include "cli_run.h"
#include "diskfull_testutil.h"
#include "farm_testutil.h"

#include <sys/prctl.h>
#include <sys/stat.h>

/* Fills the file system holding dir until a write fails with ENOSPC. */
static void fill(const char *path)
{
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    assert_true(fd >= 0);
    static char block[4096];
    memset(block, 0xab, sizeof block);
    for (;;) {
        ssize_t n = write(fd, block, sizeof block);
        if (n < 0) {
            assert_int_equal(errno, ENOSPC);
            break;
        }
        if (n == 0)
            break;
    }
    close(fd);
}

static void test_full_spool_waits(void **state)
{
    (void)state;
    if (getuid() != 0)
        skip(); /* reaching into the master's mount namespace needs root */
    char fs[600], spool[700], mlog[700];
    snprintf(fs, sizeof fs, "%s", testutil_scratch("spoolfs"));
    assert_int_equal(mkdir(fs, 0755), 0);
    snprintf(spool, sizeof spool, "%s/spool", fs);
    snprintf(mlog, sizeof mlog, "%s", testutil_scratch("space-master.log"));
    int gate[2];
    assert_int_equal(pipe(gate), 0);
    pid_t master = fork();
    assert_true(master >= 0);
    if (master == 0) {
        char why[1024] = "";
        prctl(PR_SET_PDEATHSIG, SIGKILL);
        int rc = diskfull_mount_tmpfs(fs, 2048, why, sizeof why);
        char status = rc == 0 ? 'y' : 'n';
        (void)!write(gate[1], &status, 1);
        if (rc != 0) {
            fprintf(stderr, "%s\n", why);
            _exit(DISKFULL_SKIP);
        }
        if (!freopen(mlog, "w", stderr) || !freopen("/dev/null", "w", stdout))
            _exit(126);
        execl(getenv("PRISMFARM_BIN"), getenv("PRISMFARM_BIN"), "master", "--workers",
              "tcp://127.0.0.1:*", "--clients", "tcp://127.0.0.1:*", "--spool", spool,
              "--no-journal", "--heartbeat", "200", "--tile", "8", "--key",
              testutil_master_key(), "--authorized", testutil_authorized(), (char *)NULL);
        _exit(127);
    }
    testutil_track_child(master);
    char status = 0;
    assert_int_equal(read(gate[0], &status, 1), 1);
    close(gate[0]);
    close(gate[1]);
    if (status != 'y') {
        testutil_stop(master, SIGKILL);
        print_message("no tmpfs in a mount namespace here: skipped\n");
        skip();
    }
    /* The spool as the master sees it. */
    char inside[800];
    snprintf(inside, sizeof inside, "/proc/%ld/root%s", (long)master, spool);
    char wep[256], cep[256];
    testutil_read_endpoints(inside, wep, cep, mlog);
    /* A client follows the job (submit --wait): it must say once why the job waits at 100 %. */
    const char *wlog = testutil_scratch("space-wait.log");
    pid_t waiter = testutil_spawn(wlog, "submit", "data/render/tiny.pbrt", "--master", cep, "--spp",
                                  "16", "--wait", "-o", testutil_scratch("space-wait.exr"), NULL);
    testutil_wait_file_has(wlog, "job:   0.0%"); /* submitted, and followed */
    char filler[900];
    snprintf(filler, sizeof filler, "%s/filler", inside);
    fill(filler);
    pid_t worker =
        testutil_start_worker(testutil_scratch("space-w.log"), wep, "w1", testutil_scratch("c1"));
    testutil_wait_file_has(mlog, "rendered; waiting to write its outputs (tried again every 5 s)");
    testutil_wait_file_has(wlog, "prismfarm: job 1: rendered; waiting to write its outputs");
    const run_t *r = run("jobs", "--master", cep, "--json", NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "\"running\"");
    expect_in(r->out, "waiting to write its outputs");
    expect_in(r->out, "No space left on device");
    /* Space again: the next try writes the image that was kept. */
    assert_int_equal(unlink(filler), 0);
    testutil_wait_file_has(mlog, "its outputs are written at last");
    testutil_wait_file_has(mlog, "job 1 'tiny' done");
    /* The follower saw the job wait for several polls, and said why once; then it got the
     * outputs. */
    int st = testutil_stop(waiter, 0);
    if (!WIFEXITED(st) || WEXITSTATUS(st) != 0)
        testutil_fail_quoting(wlog, "submit --wait: status %d:", st);
    if (testutil_file_count(wlog, "waiting to write its outputs") != 1)
        testutil_fail_quoting(wlog, "expected the reason once in %s:", wlog);
    testutil_expect_file_has(wlog, "No space left on device");
    r = run("fetch", "1", "-o", testutil_scratch("space.exr"), "--master", cep, NULL);
    if (r->status != 0)
        testutil_fail_quoting(mlog, "fetch: %s\nmaster log:", r->err);
    r = run("render", "data/render/tiny.pbrt", "--spp", "16", "-o",
            testutil_scratch("space-ref.exr"), "--quiet", NULL);
    assert_int_equal(r->status, 0);
    testutil_assert_same_pixels(testutil_scratch("space.exr"), testutil_scratch("space-ref.exr"));
    testutil_assert_same_pixels(testutil_scratch("space-wait.exr"),
                                testutil_scratch("space-ref.exr"));
    testutil_stop(worker, SIGTERM);
    testutil_stop(master, SIGTERM);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_full_spool_waits, testutil_kill_children),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_keys_setup, testutil_scratch_teardown);
}
