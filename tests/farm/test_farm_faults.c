/* The farm's faults, as users meet them, with separate master, worker and client processes on
 * loopback TCP: a worker started before its master, a master killed (SIGKILL) and restarted on
 * the same endpoints and spool while workers wait, a client killed during `submit --wait`, and a
 * running job cancelled. Each job that completes is checked pixel for pixel against
 * `prismfarm render` of the same scene and settings (docs/farm.md: the image bytes do not depend
 * on who rendered what), so "completes" means "completes with the right image". The farm runs
 * with CURVE keys (docs/security.md), so a restarted master must take its workers back through
 * the handshake too. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#define CLI_RUN_TIMEOUT_MS 60000
#include "cli_run.h"
#include "farm_testutil.h"
#include "image_exr.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <time.h>

/* A job that completes: tiny.pbrt (24x16) at 256 spp, 0.1 s on one core (Release), 0.2 s under
 * ASan. A job that must still be running when the test acts on it: 2^20 spp, about 1000 times
 * longer than anything here waits, so no race decides the outcome. */
#define SCENE "data/render/tiny.pbrt"
#define SPP_DONE "256"
#define SPP_FOREVER "1048576"
/* The master's heartbeat; workers take it from WELCOME, and the master loses a worker silent
 * for 3 of them. The default 1 s, not less: on loaded cores under a sanitizer a live worker
 * can be silent for half a second, and one lost then misses the CANCEL the test waits for. */
#define HEARTBEAT_MS "1000"
#define TILE "8"

static int REF_MADE;

static int file_exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

static void wait_file(const char *path)
{
    double timeout_s = test_wait_s();
    for (double t0 = testutil_now_s(); testutil_now_s() - t0 < timeout_s; testutil_sleep_ms(10))
        if (file_exists(path))
            return;
    fail_msg("%s did not appear within %.0f s", path, timeout_s);
}

/* A loopback port nobody listens on right now (the kernel's choice for port 0). */
static int free_port(void)
{
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    assert_true(fd >= 0);
    struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = 0};
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    assert_int_equal(bind(fd, (struct sockaddr *)&a, sizeof a), 0);
    socklen_t len = sizeof a;
    assert_int_equal(getsockname(fd, (struct sockaddr *)&a, &len), 0);
    close(fd);
    return ntohs(a.sin_port);
}

static pid_t start_master(const char *log, const char *spool, const char *wep, const char *cep)
{
    return testutil_start_master(log, spool, wep, cep, "--heartbeat", HEARTBEAT_MS, "--tile", TILE,
                                 NULL);
}

/* `prismfarm status JOB --json`'s state, polled until it is one of want ("done|failed") or the
 * deadline of a wait (test_wait.h); returns the last state seen (want NULL: the first). */
static const char *job_state(const char *cep, const char *job, const char *want)
{
    double timeout_s = test_wait_s();
    static char state[32];
    double t0 = testutil_now_s();
    for (;;) {
        const run_t *r = run("status", job, "--master", cep, "--json", NULL);
        if (r->status != 0)
            fail_msg("status %s: exit %d: %s", job, r->status, r->err);
        const char *s = strstr(r->out, "\"state\": \"");
        assert_non_null(s);
        s += strlen("\"state\": \"");
        size_t n = strcspn(s, "\"");
        snprintf(state, sizeof state, "%.*s", (int)(n < 31 ? n : 31), s);
        if (!want || strstr(want, state) || testutil_now_s() - t0 > timeout_s)
            return state;
        testutil_sleep_ms(50);
    }
}

/* The job id in `submit --json` output ({"job": N, ...}). */
static unsigned long long json_job(const char *out)
{
    const char *s = strstr(out, "\"job\": ");
    if (!s)
        fail_msg("no job id in: %s", out);
    return strtoull(s + strlen("\"job\": "), NULL, 10);
}

/* The reference image: the same scene and settings through `prismfarm render` (the farm's code
 * in one process), made once. */
static const char *reference(void)
{
    const char *ref = testutil_scratch("reference.exr");
    if (!REF_MADE) {
        const run_t *r = run("render", SCENE, "--spp", SPP_DONE, "--workers", "1", "--threads",
                             "1", "--tile", TILE, "-o", ref, "--quiet", NULL);
        if (r->status != 0)
            fail_msg("reference render: exit %d: %s", r->status, r->err);
        REF_MADE = 1;
    }
    return ref;
}

static void assert_same_pixels(const char *a, const char *b)
{
    testutil_assert_same_pixels(a, b);
    err_t err;
    image_exr_t *x = image_exr_read(a, &err);
    if (!x)
        fail_msg("%s", err.msg);
    assert_int_equal(image_exr_width(x), 24);
    assert_int_equal(image_exr_height(x), 16);
    /* Every sample of every pixel arrived: 24 x 16 pixels x 256 spp = 98304. */
    const char *info = image_exr_attribute(x, "prismfarm");
    assert_non_null(info);
    if (!strstr(info, "samples=98304;"))
        fail_msg("%s: expected samples=98304 in '%s'", a, info);
    image_exr_destroy(&x);
}

/* A worker started before its master: it gives up on the silent endpoint after 3 heartbeats
 * (3 s before any WELCOME), backs off, tries again, and serves the master that came up
 * meanwhile. The master is only started once the worker's log shows it gave up, so the job
 * completes through the worker's own retry, not through ZeroMQ's reconnection of the first
 * socket. */
static void test_worker_before_master(void **state)
{
    (void)state;
    const char *ref = reference();
    char wep[64];
    snprintf(wep, sizeof wep, "tcp://127.0.0.1:%d", free_port());
    const char *wlog = testutil_scratch("early-worker.log"),
               *spool = testutil_scratch("early-spool");
    pid_t w = testutil_start_worker(wlog, wep, "early", testutil_scratch("early-cache"));
    testutil_wait_file_has(wlog, "the master is silent");
    pid_t master =
        start_master(testutil_scratch("early-master.log"), spool, wep, "tcp://127.0.0.1:*");
    char wbound[256], cep[256];
    testutil_read_endpoints(spool, wbound, cep, testutil_scratch("early-master.log"));
    assert_string_equal(wbound, wep);
    const run_t *r = run("submit", SCENE, "--master", cep, "--spp", SPP_DONE, "--wait", "-o",
                         testutil_scratch("early.exr"), "--quiet", NULL);
    if (r->status != 0)
        testutil_fail_quoting(wlog, "submit --wait: exit %d: %s\nworker log:", r->status, r->err);
    assert_same_pixels(testutil_scratch("early.exr"), ref);
    assert_true(testutil_file_has(testutil_scratch("early-master.log"), "'early' joined"));
    testutil_stop(w, SIGTERM);
    testutil_stop(master, SIGTERM);
}

/* A master killed with SIGKILL while two workers render a job, restarted on the same endpoints
 * and spool. The workers notice and come back by themselves; a job submitted to the new master
 * completes with the right pixels, gets an id past those of the earlier run's outputs, and the
 * earlier run's outputs are left byte for byte as they were. The job that was running is
 * resumed from the journal (test_journal covers its pixels) and can be cancelled. */
static void test_master_restarted(void **state)
{
    (void)state;
    const char *ref = reference();
    const char *spool = testutil_scratch("restart-spool");
    const char *mlog1 = testutil_scratch("restart-master1.log"),
               *mlog2 = testutil_scratch("restart-master2.log");
    pid_t master = start_master(mlog1, spool, "tcp://127.0.0.1:*", "tcp://127.0.0.1:*");
    char wep[256], cep[256];
    testutil_read_endpoints(spool, wep, cep, mlog1);
    pid_t w1 = testutil_start_worker(testutil_scratch("restart-w1.log"), wep, "w1",
                                     testutil_scratch("restart-c1"));
    pid_t w2 = testutil_start_worker(testutil_scratch("restart-w2.log"), wep, "w2",
                                     testutil_scratch("restart-c2"));

    const run_t *r = run("submit", SCENE, "--master", cep, "--spp", SPP_DONE, "--wait", "-o",
                         testutil_scratch("restart-first.exr"), "--quiet", NULL);
    if (r->status != 0)
        fail_msg("submit --wait: exit %d: %s", r->status, r->err);
    expect_in(r->out, "job 1 done");
    char first_exr[600];
    snprintf(first_exr, sizeof first_exr, "%s/jobs/1/tiny.exr", spool);
    size_t first_size;
    char *first_bytes = testutil_slurp(first_exr, &first_size);
    assert_non_null(first_bytes);
    assert_true(first_size > 0);

    /* A job that is running when the master dies: both workers hold its tasks. */
    r = run("submit", SCENE, "--master", cep, "--spp", SPP_FOREVER, "--name", "long", NULL);
    assert_int_equal(r->status, 0);
    assert_string_equal(r->out, "2\n");
    char preview[600];
    snprintf(preview, sizeof preview, "%s/jobs/2/preview.png", spool);
    wait_file(preview);
    testutil_stop(master, SIGKILL);

    master = start_master(mlog2, spool, wep, cep);
    /* Both workers say HELLO to the new master without being restarted: "joined" (not "joined
     * again") because the new master never knew them. */
    testutil_wait_file_has(mlog2, "'w1' joined");
    testutil_wait_file_has(mlog2, "'w2' joined");
    testutil_wait_file_has(mlog2, "job 2 'long' resumed");
    r = run("cancel", "2", "--master", cep, NULL);
    if (r->status != 0)
        fail_msg("cancel of the resumed job: exit %d: %s", r->status, r->err);
    r = run("submit", SCENE, "--master", cep, "--spp", SPP_DONE, "--wait", "--json", "-o",
            testutil_scratch("restart-second.exr"), "--quiet", NULL);
    if (r->status != 0)
        testutil_fail_quoting(
            mlog2, "submit --wait to the new master: exit %d: %s\nmaster log:", r->status, r->err);
    unsigned long long id = json_job(r->out);
    /* Jobs 1 and 2 have folders in the spool: the new master must count past them. */
    if (id <= 2)
        fail_msg("the restarted master gave job id %llu, which the earlier run used", id);
    assert_same_pixels(testutil_scratch("restart-second.exr"), ref);
    size_t size_now;
    char *bytes_now = testutil_slurp(first_exr, &size_now);
    assert_non_null(bytes_now);
    assert_int_equal(size_now, first_size);
    assert_memory_equal(bytes_now, first_bytes, first_size);
    free(bytes_now);
    free(first_bytes);
    testutil_stop(w1, SIGTERM);
    testutil_stop(w2, SIGTERM);
    testutil_stop(master, SIGTERM);
}

/* The id a killed master gave a job that was only queued (no output folder yet) must not be
 * handed out again by its successor: a client following that id (submit --wait, status,
 * fetch) would otherwise be shown another job. No workers are needed. */
static void test_restart_does_not_reuse_queued_job_id(void **state)
{
    (void)state;
    const char *spool = testutil_scratch("ids-spool");
    pid_t master = start_master(testutil_scratch("ids-master1.log"), spool, "tcp://127.0.0.1:*",
                                "tcp://127.0.0.1:*");
    char wep[256], cep[256];
    testutil_read_endpoints(spool, wep, cep, testutil_scratch("ids-master1.log"));
    const run_t *r = run("submit", SCENE, "--master", cep, "--spp", SPP_DONE, NULL);
    assert_int_equal(r->status, 0);
    assert_string_equal(r->out, "1\n");
    testutil_stop(master, SIGKILL);
    master = start_master(testutil_scratch("ids-master2.log"), spool, wep, cep);
    testutil_wait_listening(cep); /* submit reports a refused connection at once */
    r = run("submit", SCENE, "--master", cep, "--spp", SPP_DONE, NULL);
    assert_int_equal(r->status, 0);
    unsigned long long id = strtoull(r->out, NULL, 10);
    testutil_stop(master, SIGTERM);
    /* The killed master's queued job 1 left its folder in the spool: its id is not reused. */
    assert_true(id >= 2);
}

/* A client killed (SIGKILL) while `submit --wait` follows its job: the job is the master's, not
 * the client's; it completes, and `prismfarm fetch` gets it. The job is held queued (no worker
 * yet) until the client is dead, so the client certainly dies mid-wait. */
static void test_client_killed_during_wait(void **state)
{
    (void)state;
    const char *ref = reference();
    const char *spool = testutil_scratch("client-spool"), *clog = testutil_scratch("client.log");
    pid_t master = start_master(testutil_scratch("client-master.log"), spool, "tcp://127.0.0.1:*",
                                "tcp://127.0.0.1:*");
    char wep[256], cep[256];
    testutil_read_endpoints(spool, wep, cep, testutil_scratch("client-master.log"));
    pid_t client = testutil_spawn(clog, "submit", SCENE, "--master", cep, "--spp", SPP_DONE,
                                  "--wait", "-o", testutil_scratch("client-never.exr"), NULL);
    /* Its --wait loop has had an answer to a STATUS long poll (its progress line) and asks
     * again: it dies mid-wait. */
    testutil_wait_file_has(clog, "job:   0.0%");
    testutil_stop(client, SIGKILL);
    assert_string_equal(job_state(cep, "1", NULL), "queued");

    pid_t w = testutil_start_worker(testutil_scratch("client-w.log"), wep, "w",
                                    testutil_scratch("client-cache"));
    const char *s = job_state(cep, "1", "done|failed|cancelled");
    assert_string_equal(s, "done");
    const run_t *r =
        run("fetch", "1", "-o", testutil_scratch("client-fetched.exr"), "--master", cep, NULL);
    if (r->status != 0)
        fail_msg("fetch: exit %d: %s", r->status, r->err);
    assert_false(file_exists(testutil_scratch("client-never.exr")));
    assert_same_pixels(testutil_scratch("client-fetched.exr"), ref);
    testutil_stop(w, SIGTERM);
    testutil_stop(master, SIGTERM);
}

/* `prismfarm cancel` on a running job: its status says cancelled (and stays so), it has no EXR
 * to fetch, the workers stop rendering it (each says so once it holds none of the job's tasks,
 * and the master lists them idle), and the next job completes with the right pixels. */
static void test_cancel_running_job(void **state)
{
    (void)state;
    const char *ref = reference();
    const char *spool = testutil_scratch("cancel-spool");
    const char *wlog1 = testutil_scratch("cancel-w1.log"),
               *wlog2 = testutil_scratch("cancel-w2.log");
    pid_t master = start_master(testutil_scratch("cancel-master.log"), spool, "tcp://127.0.0.1:*",
                                "tcp://127.0.0.1:*");
    char wep[256], cep[256];
    testutil_read_endpoints(spool, wep, cep, testutil_scratch("cancel-master.log"));
    pid_t w1 = testutil_start_worker(wlog1, wep, "w1", testutil_scratch("cancel-c1"));
    pid_t w2 = testutil_start_worker(wlog2, wep, "w2", testutil_scratch("cancel-c2"));

    const run_t *r = run("submit", SCENE, "--master", cep, "--spp", SPP_FOREVER, "--name", "long",
                         NULL);
    assert_int_equal(r->status, 0);
    assert_string_equal(r->out, "1\n");
    /* Running, with a first pass merged. */
    char preview[600];
    snprintf(preview, sizeof preview, "%s/jobs/1/preview.png", spool);
    wait_file(preview);
    assert_string_equal(job_state(cep, "1", NULL), "running");

    r = run("cancel", "1", "--master", cep, "--json", NULL);
    if (r->status != 0)
        fail_msg("cancel: exit %d: %s", r->status, r->err);
    expect_in(r->out, "\"state\": \"cancelled\"");
    assert_string_equal(job_state(cep, "1", NULL), "cancelled");
    testutil_wait_file_has(wlog1, "job 1 cancelled");
    testutil_wait_file_has(wlog2, "job 1 cancelled");
    /* Stopped, as the workers see it: the tasks queued at the cancel were dropped, a task in
     * flight finished and was dropped unsent, and none of the job's tasks is left to run. */
    testutil_wait_file_has(wlog1, "job 1: all its tasks stopped");
    testutil_wait_file_has(wlog2, "job 1: all its tasks stopped");

    /* Idle as the master sees them. */
    double t0 = testutil_now_s();
    for (;;) {
        r = run("workers", "--master", cep, "--json", NULL);
        assert_int_equal(r->status, 0);
        int idle = 0;
        for (const char *p = r->out; (p = strstr(p, "\"state\": \"idle\"")); p++)
            idle++;
        if (idle == 2)
            break;
        if (testutil_now_s() - t0 > test_wait_s())
            fail_msg("workers not idle %.0f s after the cancel:\n%s", test_wait_s(), r->out);
        testutil_sleep_ms(50);
    }

    r = run("submit", SCENE, "--master", cep, "--spp", SPP_DONE, "--wait", "--json", "-o",
            testutil_scratch("cancel-next.exr"), "--quiet", NULL);
    if (r->status != 0)
        fail_msg("submit --wait after the cancel: exit %d: %s", r->status, r->err);
    assert_int_equal(json_job(r->out), 2);
    assert_same_pixels(testutil_scratch("cancel-next.exr"), ref);
    assert_string_equal(job_state(cep, "1", NULL), "cancelled");
    r = run("fetch", "1", "-o", testutil_scratch("cancel-none.exr"), "--master", cep, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "cancelled");
    testutil_stop(w1, SIGTERM);
    testutil_stop(w2, SIGTERM);
    testutil_stop(master, SIGTERM);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_worker_before_master, testutil_kill_children),
        cmocka_unit_test_teardown(test_master_restarted, testutil_kill_children),
        cmocka_unit_test_teardown(test_restart_does_not_reuse_queued_job_id,
                                  testutil_kill_children),
        cmocka_unit_test_teardown(test_client_killed_during_wait, testutil_kill_children),
        cmocka_unit_test_teardown(test_cancel_running_job, testutil_kill_children),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_keys_setup, testutil_scratch_teardown);
}
