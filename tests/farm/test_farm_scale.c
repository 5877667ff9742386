/* The master against many simulated workers (docs/performance.md, "The master at scale"), the
 * small CI form of bench/farm_scale.sh: one `prismfarm master` on loopback TCP and the
 * benchmark's simulator (bench/farm_sim.c, FARM_SIM_BIN) with 20 workers on a job of 200 tiles
 * (160x80 pixels in 8x8 tiles, 4 spp: 600 tasks), while 10 % of the workers disconnect at
 * seeded points of the job's progress -- one drops its connection with the tasks it holds, one
 * goes silent past the master's timeout and then sends its held results late. The job must
 * complete with every task answered and every pass of every pixel merged exactly once (the
 * simulator's EXR check: a pass merged twice or never changes a pixel's mean). No timing is
 * asserted: every wait ends at its event or at the deadline of test_wait.h. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "farm_testutil.h"

#define N_WORKERS "20"
#define RES "160x80"
#define TILE "8"
#define SPP "4"
#define TASKS 600 /* 20 x 10 tiles, passes [0,1) [1,2) [2,4) */

static int teardown(void **state)
{
    testutil_kill_children(state);
    return testutil_scratch_teardown(state);
}

/* The value of key in the simulator's "key=value ..." line; fails the test when it is absent. */
static const char *field(const char *line, const char *key, char *buf, size_t size)
{
    char pat[64];
    snprintf(pat, sizeof pat, " %s=", key);
    char padded[4096];
    snprintf(padded, sizeof padded, " %s", line);
    const char *p = strstr(padded, pat);
    if (!p)
        fail_msg("no '%s' in the simulator's report: %s", key, line);
    p += strlen(pat);
    size_t n = strcspn(p, " \n");
    snprintf(buf, size, "%.*s", (int)(n < size ? n : size - 1), p);
    return buf;
}

/* Runs the simulator against the master's endpoints with its report to out and its log to log;
 * returns its exit status. */
static int run_sim(const char *wep, const char *cep, const char *out, const char *log, pid_t master)
{
    const char *sim = getenv("FARM_SIM_BIN");
    if (!sim)
        fail_msg("FARM_SIM_BIN is not set (tests/CMakeLists.txt sets it to bench_farm_sim)");
    char timeout[32], mpid[32];
    snprintf(timeout, sizeof timeout, "%.0f", test_wait_s());
    snprintf(mpid, sizeof mpid, "%ld", (long)master);
    const char *scene = testutil_source_path("bench/farm_scale.pbrt");
    pid_t pid = fork();
    if (pid == 0) {
        if (prctl(PR_SET_PDEATHSIG, SIGKILL) != 0 || !freopen(out, "w", stdout) ||
            !freopen(log, "w", stderr))
            _exit(126);
        execl(sim, sim, "--workers", wep, "--clients", cep, "--scene", scene, "--res", RES, "--spp",
              SPP, "--buckets", "16", "--tile", TILE, "--n", N_WORKERS, "--hold-ms", "20",
              "--disconnect", "0.1", "--seed", "17", "--master-pid", mpid, "--timeout", timeout,
              (char *)NULL);
        _exit(127);
    }
    assert_true(pid > 0);
    testutil_track_child(pid);
    /* The simulator ends by itself (its own --timeout is the deadline of a wait). */
    return testutil_stop(pid, 0);
}

static void test_no_task_lost_or_merged_twice(void **state)
{
    (void)state;
    char spool[600], mlog[600], out[600], slog[600], wep[256], cep[256];
    snprintf(spool, sizeof spool, "%s", testutil_scratch("spool"));
    snprintf(mlog, sizeof mlog, "%s", testutil_scratch("master.log"));
    snprintf(out, sizeof out, "%s", testutil_scratch("sim.out"));
    snprintf(slog, sizeof slog, "%s", testutil_scratch("sim.log"));
    pid_t master =
        testutil_spawn(mlog, "master", "--workers", "tcp://127.0.0.1:*", "--clients",
                       "tcp://127.0.0.1:*", "--insecure", "--tile", TILE, "--spool", spool, NULL);
    testutil_read_endpoints(spool, wep, cep, mlog);

    int st = run_sim(wep, cep, out, slog, master);
    /* Copied to the stack: a failed assertion leaves the test without freeing anything. */
    char line[4096] = "";
    char *text = testutil_slurp(out, NULL);
    if (text)
        snprintf(line, sizeof line, "%s", text);
    free(text);
    if (!WIFEXITED(st) || WEXITSTATUS(st) != 0 || !line[0]) {
        testutil_print_file(slog);
        testutil_print_file(mlog);
        fail_msg("the simulator failed (status %d): %s", st, line[0] ? line : "(no report)");
    }
    char v[128];
    assert_string_equal(field(line, "done", v, sizeof v), "yes");
    assert_int_equal(strtoll(field(line, "tasks", v, sizeof v), NULL, 10), TASKS);
    /* Every task answered at least once, some twice (re-issued after a disconnection) ... */
    assert_int_equal(strtoll(field(line, "answered_distinct", v, sizeof v), NULL, 10), TASKS);
    assert_int_equal(strtoll(field(line, "lost", v, sizeof v), NULL, 10), 0);
    /* ... and merged once: every pixel the same spectrum, the EXR's samples the image's. */
    assert_int_equal(strtoll(field(line, "pixels_bad", v, sizeof v), NULL, 10), 0);
    /* The two disconnections of the plan happened (they follow the job's progress, not time). */
    assert_int_equal(strtoll(field(line, "disconnects", v, sizeof v), NULL, 10), 2);
    assert_true(strtoll(field(line, "results_sent", v, sizeof v), NULL, 10) >= TASKS);
    print_message("%s", line);

    int ms = testutil_stop(master, SIGTERM);
    assert_true(WIFEXITED(ms) && WEXITSTATUS(ms) == 0);
    assert_true(testutil_file_has(mlog, "job 1 'farm_sim' done"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_no_task_lost_or_merged_twice, testutil_scratch_setup,
                                        teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
