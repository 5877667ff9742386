/* The command line's outputs and inputs as issue 16 found them: outputs are written only as
 * regular files into folders that exist (checked before anything is rendered or fetched, a FIFO
 * or device at the name survives), a FIFO given as a scene or Included by one is refused at once
 * instead of hanging the parse, and a client told about a master that cannot be there (a bad
 * port, a host that does not resolve, a refused connection) says so at once. Each command runs
 * under cli_run's deadline: a hang is killed and fails the test. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "cli_run.h"
#include "farm_testutil.h"
#include "files_testutil.h"

#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>

static void assert_fifo(const char *path)
{
    struct stat st;
    assert_int_equal(lstat(path, &st), 0);
    if (!S_ISFIFO(st.st_mode))
        fail_msg("%s is no longer a FIFO (mode %o)", path, (unsigned)st.st_mode);
}

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + ts.tv_nsec / 1e9;
}

/* -o at a FIFO: refused before the render (exit 2, the message says what it is), the FIFO is
 * left as it was; the same for the PNG beside it, and for fetch and submit --wait. */
static void test_output_fifo_refused(void **state)
{
    (void)state;
    const char *fifo = testutil_scratch("out.exr");
    assert_int_equal(mkfifo(fifo, 0644), 0);
    const run_t *r = run("render", "data/render/tiny.pbrt", "-o", fifo, "--quiet", NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, fifo);
    expect_in(r->err, "is a FIFO");
    expect_in(r->err, "regular files");
    assert_fifo(fifo);
    r = run("render", "data/render/tiny.pbrt", "-o", fifo, "--direct", "--quiet", NULL);
    assert_int_equal(r->status, 2);
    assert_fifo(fifo);

    const char *png_fifo = testutil_scratch("p.png");
    assert_int_equal(mkfifo(png_fifo, 0644), 0);
    r = run("render", "data/render/tiny.pbrt", "-o", testutil_scratch("p.exr"), "--quiet", NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "p.png' is a FIFO");
    assert_fifo(png_fifo);
    struct stat st;
    assert_int_not_equal(stat(testutil_scratch("p.exr"), &st), 0);

    /* Checked before the master is asked anything: no master needed. */
    r = run("fetch", "1", "-o", fifo, "--master", "tcp://127.0.0.1:1", "--insecure", NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "is a FIFO");
    assert_fifo(fifo);
    r = run("submit", "data/render/tiny.pbrt", "--wait", "-o", fifo, "--master",
            "tcp://127.0.0.1:1", "--insecure", NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "is a FIFO");
    assert_fifo(fifo);
}

/* -o into a folder that does not exist: refused, naming the folder, and nothing is created. */
static void test_output_folder_missing(void **state)
{
    (void)state;
    const char *dir = testutil_scratch("no/such");
    char out[600];
    snprintf(out, sizeof out, "%s/o.exr", dir);
    const run_t *r = run("render", "data/render/tiny.pbrt", "-o", out, "--quiet", NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, dir);
    expect_in(r->err, "does not exist");
    struct stat st;
    assert_int_not_equal(stat(testutil_scratch("no"), &st), 0);
}

/* A scene that is a FIFO, or Includes one, is refused at once: nobody will ever write into the
 * FIFO, so a parse that opened it blocking would wait for ever (cli_run kills it and fails). */
static void test_fifo_scene_refused(void **state)
{
    (void)state;
    const char *fifo = testutil_scratch("fifo.pbrt");
    assert_int_equal(mkfifo(fifo, 0644), 0);
    const char *scene = testutil_scratch("includes_fifo.pbrt");
    FILE *f = fopen(scene, "w");
    assert_non_null(f);
    fprintf(f, "Camera \"perspective\"\nFilm \"spectral\" \"integer xresolution\" [ 8 ] "
               "\"integer yresolution\" [ 8 ]\nWorldBegin\nInclude \"fifo.pbrt\"\n");
    fclose(f);
    double t0 = now_s();
    const run_t *r = run("render", scene, "-o", testutil_scratch("i.exr"), "--quiet", NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "fifo.pbrt");
    expect_in(r->err, "a FIFO, not a regular file");
    r = run("render", fifo, "-o", testutil_scratch("i.exr"), "--quiet", NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "a FIFO, not a regular file");
    /* The bundle builder reads every file before it connects: no master needed. */
    r = run("submit", scene, "--master", "tcp://127.0.0.1:1", "--insecure", NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "a FIFO, not a regular file");
    print_message("three FIFO refusals in %.2f s\n", now_s() - t0);
    assert_fifo(fifo);
}

/* A command started in the background (its stderr to a log in the scratch folder), to wait on
 * with the others: the commands below wait on the clock (their --timeout), so they wait side by
 * side, not one after another. */
typedef struct bg {
    pid_t pid;
    char log[600];
} bg_t;

static bg_t bg_start(const char *name, const char *const *args)
{
    bg_t b;
    snprintf(b.log, sizeof b.log, "%s", testutil_scratch(name));
    b.pid = testutil_spawn_argv(b.log, args);
    if (b.pid < 0)
        fail_msg("cannot start prismfarm %s (is PRISMFARM_BIN set?)", args[0]);
    return b;
}

/* Waits for the command to end (within the deadline of a wait) and returns its exit status and
 * its stderr (free it); a command killed by a signal fails the test. */
static int bg_finish(const bg_t *b, char **err)
{
    int st = testutil_stop(b->pid, 0); /* signal 0: only waits for its exit */
    if (!WIFEXITED(st))
        testutil_fail_quoting(b->log, "prismfarm did not exit (wait status %d); its stderr:", st);
    *err = testutil_slurp(b->log, NULL);
    assert_non_null(*err);
    return WEXITSTATUS(st);
}

/* A master that cannot be there is named: a bad port or host at once, one that does not listen
 * after the command's --timeout (at most 10 s, not the call's 60 s), saying at once why it waits.
 * The commands that wait for port 1 run side by side (each its own process and deadline). */
static void test_client_endpoint_errors(void **state)
{
    (void)state;
    /* Port 1 on loopback: nothing listens there (tcpmux is not run on a build machine). Every
     * command waits for a master that does not listen yet up to its --timeout (a master starting
     * or restarting refuses for a moment), says so at once, then gives up with one message. */
    static const char *const submit_args[] = {"submit",     "data/render/tiny.pbrt",
                                              "--master",   "tcp://127.0.0.1:1",
                                              "--insecure", "--timeout",
                                              "3",          NULL};
    char fetch_out[600];
    snprintf(fetch_out, sizeof fetch_out, "%s", testutil_scratch("f.exr"));
    const char *const fetch_args[] = {
        "fetch",      "1",         "-o",  fetch_out, "--master", "tcp://127.0.0.1:1",
        "--insecure", "--timeout", "0.5", NULL};
    /* refine without --timeout: the default wait, which ends too. */
    static const char *const refine_args[] = {
        "refine", "1", "--photons", "1000", "--master", "tcp://127.0.0.1:1", "--insecure", NULL};
    /* One rule for every command that needs its master now: the queries and the operations
     * say the same (jobs waited 10 s and said "no answer", submit refused at once). */
    static const char *const cmds[][2] = {{"jobs", NULL},  {"workers", NULL}, {"status", "1"},
                                          {"cancel", "1"}, {"pause", "1"},    {"logs", "1"},
                                          {"resume", "1"}};
    enum { NCMDS = sizeof cmds / sizeof cmds[0] };
    bg_t refine = bg_start("refine.log", refine_args);
    bg_t submit = bg_start("submit.log", submit_args);
    bg_t fetch = bg_start("fetch.log", fetch_args);
    bg_t query[NCMDS];
    for (size_t i = 0; i < NCMDS; i++) {
        const char *args[8];
        int n = 0;
        args[n++] = cmds[i][0];
        if (cmds[i][1])
            args[n++] = cmds[i][1];
        const char *const tail[] = {"--master", "tcp://127.0.0.1:1", "--insecure", "--timeout",
                                    "0.5"};
        for (int k = 0; k < 5; k++)
            args[n++] = tail[k];
        args[n] = NULL;
        char log[64];
        snprintf(log, sizeof log, "query%zu.log", i);
        query[i] = bg_start(log, args);
    }

    const run_t *r = run("submit", "data/render/tiny.pbrt", "--master", "tcp://127.0.0.1:99999",
                         "--insecure", NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "port '99999': expected a number in 1..65535");
    r = run("jobs", "--master", "tcp://no-such-host.invalid:5556", "--insecure", NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "cannot resolve the host 'no-such-host.invalid'");

    char *err;
    assert_int_equal(bg_finish(&submit, &err), 1);
    expect_in(err, "prismfarm submit: nothing listens at tcp://127.0.0.1:1 yet: waiting up to 3 s");
    expect_in(err, "refused the connection");
    expect_in(err, "waited 3 s");
    free(err);
    assert_int_equal(bg_finish(&fetch, &err), 1);
    expect_in(err, "refused the connection");
    free(err);
    for (size_t i = 0; i < NCMDS; i++) {
        int status = bg_finish(&query[i], &err);
        if (status != 1 || !strstr(err, "refused the connection") ||
            !strstr(err, "nothing listens at tcp://127.0.0.1:1 yet"))
            fail_msg("%s: exit %d: %s", cmds[i][0], status, err);
        free(err);
    }
    assert_int_equal(bg_finish(&refine, &err), 1);
    expect_in(err, "refused the connection");
    free(err);
}

/* Options the issue found taken: a non-finite exposure, an authorised folder that does not
 * exist (docs/security.md: exit 2). */
static void test_bad_values_refused(void **state)
{
    (void)state;
    const char *exr = testutil_scratch("nan.exr");
    const run_t *r = run("render", "data/render/tiny.pbrt", "--exposure", "nan", "-o", exr, NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "--exposure expects stops in -30..30, got 'nan'");
    r = run("render", "data/render/tiny.pbrt", "--exposure", "inf", "-o", exr, NULL);
    assert_int_equal(r->status, 2);
    struct stat st;
    assert_int_not_equal(stat(exr, &st), 0);
    r = run("master", "--authorized", "/nonexistent", "--spool", testutil_scratch("m-spool"), NULL);
    assert_int_equal(r->status, 2);
    r = run("master", "--insecure", "--authorized", "/nonexistent", "--spool",
            testutil_scratch("m-spool"), NULL);
    assert_int_equal(r->status, 2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_output_fifo_refused),
        cmocka_unit_test(test_output_folder_missing),
        cmocka_unit_test(test_fifo_scene_refused),
        cmocka_unit_test_teardown(test_client_endpoint_errors, testutil_kill_children),
        cmocka_unit_test(test_bad_values_refused),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_setup, testutil_scratch_teardown);
}
