/* The farm across hosts: network namespaces on one bridge (tests/support/netns-hosts.sh) stand in for a
 * master host (10.77.0.1), two worker hosts (.2, .3) and a client host (.4), each with its own
 * network stack. A job submitted from the client host completes with pixel data identical to
 * `prismfarm render` of the same scene and seed; deploy/start-workers.sh, through an ssh
 * stand-in that enters a namespace, starts, reports and stops workers idempotently; and its
 * argument handling is checked with --dry-run. The farm runs with CURVE keys (docs/security.md),
 * as across real hosts. The namespace tests need root and iproute2 and skip without them
 * (PRISMFARM_REQUIRE_NETNS=1 turns the skip into a failure, for CI). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "cli_run.h"
#include "farm_testutil.h"
#include "image_exr.h"

#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#define MASTER_WORKERS_EP "tcp://10.77.0.1:5555"
#define MASTER_CLIENTS_EP "tcp://10.77.0.1:5556"
#define MAX_SPAWNED 8

/* The scene and its settings, for the farm and for the reference render alike. tiny.pbrt is
 * 24x16 pixels; with 8-pixel tiles and 16 samples per pixel the master cuts 3 x 2 tiles times
 * the passes [0,1), [1,2), [2,4), [4,8), [8,16) (docs/farm.md): 30 camera tasks. */
#define SCENE "data/render/tiny.pbrt"
#define SPP "16"
#define TILE "8"
#define N_TASKS 30

static char PREFIX[64]; /* namespaces are PREFIX-m, -a, -b, -c and the switch PREFIX-sw */
static bool HOSTS_CREATED;
static pid_t SPAWNED[MAX_SPAWNED];
static int N_SPAWNED;

static const char *bin(void)
{
    const char *b = getenv("PRISMFARM_BIN");
    if (!b)
        fail_msg("PRISMFARM_BIN is not set (run the test through ctest)");
    return b;
}

/* A path or a namespace name, by value: no buffer is shared between calls. Use .s inside the
 * expression that built it, or keep the struct. */
typedef struct text {
    char s[512];
} text_t;

static text_t path_in(const char *name)
{
    text_t t;
    snprintf(t.s, sizeof t.s, "%s/%s", testutil_scratch_dir(), name);
    return t;
}

static text_t source_path(const char *rel)
{
    const char *src = getenv("PRISMFARM_SOURCE_DIR");
    if (!src)
        fail_msg("PRISMFARM_SOURCE_DIR is not set (run the test through ctest)");
    text_t t;
    snprintf(t.s, sizeof t.s, "%s/%s", src, rel);
    return t;
}

static text_t ns(const char *host)
{
    text_t t;
    snprintf(t.s, sizeof t.s, "%s-%s", PREFIX, host);
    return t;
}

/* The child's side of run_argv and spawn_argv: stdin from /dev/null, stdout and stderr to log. */
static void exec_logged(const char *log, const char *const *argv)
{
    int in = open("/dev/null", O_RDONLY);
    int out = open(log, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (in < 0 || out < 0 || dup2(in, STDIN_FILENO) < 0 || dup2(out, STDOUT_FILENO) < 0 ||
        dup2(out, STDERR_FILENO) < 0)
        _exit(126);
    close(in);
    close(out);
    execvp(argv[0], (char *const *)argv);
    _exit(127);
}

/* Runs argv (NULL-terminated) with its output in log and returns its exit status; a command
 * still running after timeout_ms, or the deadline of a wait (test_wait.h) if that is longer, is
 * killed and fails the test. */
static int run_argv(const char *log, int timeout_ms, const char *const *argv)
{
    if (timeout_ms < test_wait_ms())
        timeout_ms = test_wait_ms();
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0)
        exec_logged(log, argv);
    for (int waited = 0;; waited += 10) {
        int st;
        pid_t got = waitpid(pid, &st, WNOHANG);
        if (got == pid)
            return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
        if (got < 0 && errno != EINTR)
            fail_msg("waitpid(%s): %s", argv[0], strerror(errno));
        if (waited >= timeout_ms) {
            kill(pid, SIGKILL);
            waitpid(pid, &st, 0);
            testutil_fail_quoting(log, "'%s %s' did not finish within %d ms; its output:", argv[0],
                                  argv[1] ? argv[1] : "", timeout_ms);
        }
        testutil_sleep_ms(10);
    }
}
#define RUN(log, timeout_ms, ...)                                                                  \
    run_argv((log), (timeout_ms), (const char *const[]){__VA_ARGS__, NULL})

/* Starts argv in the background with its output in log; teardown ends it. */
static pid_t spawn_argv(const char *log, const char *const *argv)
{
    assert_true(N_SPAWNED < MAX_SPAWNED);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0)
        exec_logged(log, argv);
    SPAWNED[N_SPAWNED++] = pid;
    return pid;
}
#define SPAWN(log, ...) spawn_argv((log), (const char *const[]){__VA_ARGS__, NULL})

static void expect_status(int status, int want, const char *what, const char *log)
{
    if (status != want)
        testutil_fail_quoting(log, "%s: exit status %d, expected %d; its output:", what, status,
                              want);
}

/* In the JSON array of `prismfarm workers --json` (flat objects), the integer field of the
 * k-th worker (from 0) with this name, or -1 when there is no such worker; its state goes to
 * state[32] when state is not NULL. A worker that fell silent under load and said HELLO again
 * is listed twice: lost under its old id, and in service under a new one. */
static long worker_field(const char *json, const char *name, int k, const char *field,
                         char *state)
{
    char key[600];
    snprintf(key, sizeof key, "\"name\": \"%s\"", name);
    const char *at = strstr(json, key);
    for (int i = 0; at && i < k; i++)
        at = strstr(at + 1, key);
    if (!at)
        return -1;
    const char *begin = at;
    while (begin > json && *begin != '{')
        begin--;
    const char *end = strchr(at, '}');
    if (!end)
        return -1;
    if (state) {
        const char *s = strstr(begin, "\"state\": \"");
        state[0] = '\0';
        if (s && s < end)
            sscanf(s + strlen("\"state\": \""), "%31[a-z]", state);
    }
    snprintf(key, sizeof key, "\"%s\": ", field);
    const char *f = strstr(begin, key);
    long v;
    if (!f || f > end || sscanf(f + strlen(key), "%ld", &v) != 1)
        return -1;
    return v;
}

static bool worker_alive(const char *json, const char *name)
{
    char state[32];
    for (int k = 0; worker_field(json, name, k, "tasks_done", state) >= 0; k++)
        if (strcmp(state, "idle") == 0 || strcmp(state, "busy") == 0)
            return true;
    return false;
}

/* The tasks the workers of this name returned, under every id the master gave them. */
static long worker_tasks_done(const char *json, const char *name)
{
    long sum = 0, v;
    for (int k = 0; (v = worker_field(json, name, k, "tasks_done", NULL)) >= 0; k++)
        sum += v;
    return sum;
}

/* Entries of `workers --json` named neither a nor b. */
static int other_names(const char *json, const char *a, const char *b)
{
    int n = 0;
    for (const char *p = strstr(json, "\"name\": \""); p; p = strstr(p + 1, "\"name\": \"")) {
        const char *v = p + strlen("\"name\": \"");
        size_t len = strcspn(v, "\"");
        bool is_a = len == strlen(a) && !strncmp(v, a, len);
        bool is_b = len == strlen(b) && !strncmp(v, b, len);
        n += !is_a && !is_b;
    }
    return n;
}

/* Asks the master, from the client host, for its workers until every name is there and alive
 * (idle or busy); returns the JSON (the caller frees it). */
static char *wait_for_workers(const char *name1, const char *name2)
{
    const text_t log = path_in("workers.json");
    for (double until = testutil_now_s() + test_wait_s(); testutil_now_s() < until;) {
        int st = RUN(log.s, 10000, "ip", "netns", "exec", ns("c").s, bin(), "workers", "--master",
                     MASTER_CLIENTS_EP, "--json", "--timeout", "1");
        char *json = testutil_slurp(log.s, NULL);
        if (st == 0 && json && worker_alive(json, name1) && worker_alive(json, name2))
            return json;
        free(json);
        testutil_sleep_ms(100);
    }
    print_error("last answer of `workers`:\n");
    testutil_print_file(log.s);
    testutil_fail_quoting(path_in("master.log").s,
                          "workers '%s' and '%s' did not both join the master within %.0f s; "
                          "master log:",
                          name1, name2, test_wait_s());
    return NULL;
}

static void assert_same_pixels(const char *a, const char *b)
{
    testutil_assert_same_pixels(a, b);
    image_exr_t *x = image_exr_read(a, NULL);
    assert_non_null(x);
    assert_int_equal(image_exr_width(x), 24);
    assert_int_equal(image_exr_height(x), 16);
    assert_int_equal(image_exr_n_spectral(x), 8);
    image_exr_destroy(&x);
}

/* Skips the test when namespaces cannot be made here (not root, no iproute2, a container that
 * forbids them), unless PRISMFARM_REQUIRE_NETNS=1; then builds the four hosts. */
static void hosts_up(void)
{
    const char *require = getenv("PRISMFARM_REQUIRE_NETNS");
    bool required = require && strcmp(require, "1") == 0;
    const text_t script = source_path("tests/support/netns-hosts.sh");
    const text_t log = path_in("netns.log");
    if (geteuid() != 0) {
        if (required)
            fail_msg("PRISMFARM_REQUIRE_NETNS=1 but not root: network namespaces need root");
        print_message("[  SKIP    ] network namespaces need root (CI runs this test as root)\n");
        skip();
    }
    /* Namespaces left by an earlier run that was killed before its teardown. */
    if (RUN(log.s, 20000, "bash", script.s, "reap", "pfnet") != 0)
        testutil_fail_quoting(log.s, "netns-hosts.sh reap:");
    if (RUN(log.s, 20000, "bash", script.s, "check", PREFIX) != 0) {
        if (required)
            testutil_fail_quoting(log.s, "PRISMFARM_REQUIRE_NETNS=1 but:");
        char *why = testutil_slurp(log.s, NULL);
        print_message("[  SKIP    ] network namespaces unavailable here: %s", why ? why : "");
        free(why);
        skip();
    }
    HOSTS_CREATED = true;
    int st = RUN(log.s, 20000, "bash", script.s, "up", PREFIX, "m=10.77.0.1/24", "a=10.77.0.2/24",
                 "b=10.77.0.3/24", "c=10.77.0.4/24");
    expect_status(st, 0, "netns-hosts.sh up", log.s);
}

static int group_setup(void **state)
{
    snprintf(PREFIX, sizeof PREFIX, "pfnet-%ld", (long)getpid());
    /* The namespaces share the file system: every "host" reads its keys from the scratch
     * folder's keys/, and workers and clients find theirs in PRISMFARM_KEY and
     * PRISMFARM_MASTER_KEY. */
    return testutil_scratch_keys_setup(state);
}

/* Ends what the test started (SIGTERM, then SIGKILL after 3 s) and deletes the namespaces,
 * whatever state a failed test left. */
static int hosts_teardown(void **state)
{
    (void)state;
    for (int i = 0; i < N_SPAWNED; i++)
        kill(SPAWNED[i], SIGTERM);
    for (int i = 0; i < N_SPAWNED; i++) {
        int st;
        int waited = 0;
        while (waitpid(SPAWNED[i], &st, WNOHANG) == 0 && waited < 3000) {
            testutil_sleep_ms(10);
            waited += 10;
        }
        if (waited >= 3000) {
            kill(SPAWNED[i], SIGKILL);
            waitpid(SPAWNED[i], &st, 0);
        }
    }
    N_SPAWNED = 0;
    int rc = 0;
    if (HOSTS_CREATED) {
        char cmd[1024];
        /* netns-hosts.sh down also kills what start-workers.sh left running in the hosts. */
        snprintf(cmd, sizeof cmd,
                 "bash '%s/tests/support/netns-hosts.sh' down '%s' >'%s/down.log' 2>&1",
                 getenv("PRISMFARM_SOURCE_DIR"), PREFIX, testutil_scratch_dir());
        rc = system(cmd) == 0 ? 0 : -1;
        if (rc != 0)
            fprintf(stderr, "teardown: could not delete the namespaces %s-*\n", PREFIX);
        HOSTS_CREATED = false;
    }
    return rc;
}

/* Starts the master on the master host, on its own address, and waits for its endpoints. */
static void start_master(const char *spool)
{
    SPAWN(path_in("master.log").s, "ip", "netns", "exec", ns("m").s, bin(), "master", "--workers",
          MASTER_WORKERS_EP, "--clients", MASTER_CLIENTS_EP, "--spool", spool, "--tile", TILE,
          "--key", testutil_master_key(), "--authorized", testutil_authorized());
    char wep[256], cep[256];
    testutil_read_endpoints(spool, wep, cep, path_in("master.log").s);
}

/* The in-process render the farm's results must match, made once for the tests that need it. */
static void render_reference(void)
{
    static bool done;
    if (done)
        return;
    const text_t log = path_in("ref.log");
    int st = RUN(log.s, 60000, bin(), "render", SCENE, "-o", path_in("ref.exr").s, "--spp", SPP,
                 "--tile", TILE, "--quiet");
    expect_status(st, 0, "prismfarm render", log.s);
    done = true;
}

static void submit_and_wait(const char *out)
{
    const text_t log = path_in("submit.log");
    int st = RUN(log.s, 60000, "ip", "netns", "exec", ns("c").s, bin(), "submit", SCENE, "--master",
                 MASTER_CLIENTS_EP, "--spp", SPP, "--wait", "-o", out, "--quiet");
    if (st != 0) {
        print_error("submit's output:\n");
        testutil_print_file(log.s);
        testutil_fail_quoting(path_in("master.log").s,
                              "submit --wait from the client host: exit %d; master log:", st);
    }
}

/* A master host, two worker hosts and a client host: the job crosses the bridge both ways and
 * comes back bit-identical to the in-process render. */
static void test_job_across_hosts(void **state)
{
    (void)state;
    hosts_up();
    render_reference();
    start_master(path_in("spool").s);
    SPAWN(path_in("worker-a.log").s, "ip", "netns", "exec", ns("a").s, bin(), "worker", "--connect",
          MASTER_WORKERS_EP, "--threads", "1", "--name", "host-a", "--cache", path_in("cache-a").s);
    SPAWN(path_in("worker-b.log").s, "ip", "netns", "exec", ns("b").s, bin(), "worker", "--connect",
          MASTER_WORKERS_EP, "--threads", "1", "--name", "host-b", "--cache", path_in("cache-b").s);
    free(wait_for_workers("host-a", "host-b"));

    /* The client host has its own network stack: the master is not on its loopback. */
    const text_t log = path_in("loopback.log");
    int st = RUN(log.s, 10000, "ip", "netns", "exec", ns("c").s, bin(), "jobs", "--master",
                 "tcp://127.0.0.1:5556", "--timeout", "0.5");
    expect_status(st, 1, "prismfarm jobs via the client host's loopback", log.s);

    submit_and_wait(path_in("farm.exr").s);
    assert_same_pixels(path_in("ref.exr").s, path_in("farm.exr").s);

    /* Both worker hosts rendered: each was given a task when the job started (one slot each),
     * and together they returned at least the job's 30 tasks (more if one was re-issued). */
    char *json = wait_for_workers("host-a", "host-b");
    long done_a = worker_tasks_done(json, "host-a");
    long done_b = worker_tasks_done(json, "host-b");
    free(json);
    print_message("tasks done: host-a %ld, host-b %ld\n", done_a, done_b);
    assert_true(done_a >= 1);
    assert_true(done_b >= 1);
    assert_true(done_a + done_b >= N_TASKS);
}

/* Reads the pid in "HOST: started (pid N" from start-workers.sh's output. */
static pid_t started_pid(const char *out, const char *host)
{
    char key[600];
    snprintf(key, sizeof key, "%s: started (pid ", host);
    const char *at = strstr(out, key);
    long pid;
    if (!at || sscanf(at + strlen(key), "%ld", &pid) != 1 || pid <= 1)
        fail_msg("no '%s' in:\n%s", key, out);
    return (pid_t)pid;
}

/* True once pid has exited: no such process, or a zombie (orphans of start-workers.sh are not
 * our children, and an init that does not reap them leaves zombies). */
static bool process_gone(pid_t pid)
{
    if (kill(pid, 0) != 0)
        return errno == ESRCH;
    char path[64];
    snprintf(path, sizeof path, "/proc/%ld/stat", (long)pid);
    FILE *f = fopen(path, "r");
    if (!f)
        return true;
    char line[512];
    bool zombie = false;
    if (fgets(line, sizeof line, f)) {
        const char *paren = strrchr(line, ')'); /* the command name may hold spaces and ')' */
        zombie = paren && paren[1] == ' ' && paren[2] == 'Z';
    }
    fclose(f);
    return zombie;
}

/* Runs deploy/start-workers.sh ACTION on the two worker hosts, through the ssh stand-in. */
static int start_workers(const char *action, const char *log)
{
    char ssh[600];
    snprintf(ssh, sizeof ssh, "bash %s ssh", source_path("tests/support/netns-hosts.sh").s);
    return RUN(log, 30000, "bash", source_path("deploy/start-workers.sh").s, "--ssh", ssh,
               "--launcher", "nohup", "--bin", bin(), "--master", "10.77.0.1", "--threads", "1",
               "--key", getenv("PRISMFARM_KEY"), "--master-key", getenv("PRISMFARM_MASTER_KEY"),
               action, ns("a").s, ns("b").s);
}

/* deploy/start-workers.sh with an ssh that enters a namespace instead of a host: start is
 * idempotent, status reports, a job completes on the workers it started, stop ends them. */
static void test_start_workers_over_ssh(void **state)
{
    (void)state;
    hosts_up();
    render_reference();
    start_master(path_in("spool-ssh").s);
    if (setenv("NETNS_HOSTS_HOME", path_in("homes").s, 1) != 0)
        fail_msg("setenv: %s", strerror(errno));
    const text_t host_a = ns("a"), host_b = ns("b");
    const text_t log = path_in("start.log");

    int st = start_workers("start", log.s);
    expect_status(st, 0, "start-workers.sh start", log.s);
    char *out = testutil_slurp(log.s, NULL);
    assert_non_null(out);
    pid_t pid_a = started_pid(out, host_a.s);
    pid_t pid_b = started_pid(out, host_b.s);
    free(out);
    free(wait_for_workers(host_a.s, host_b.s));

    st = start_workers("start", log.s);
    expect_status(st, 0, "start-workers.sh start, again", log.s);
    assert_int_equal(testutil_file_count(log.s, ": already running (pid "), 2);
    /* Still one worker per host: no third name has joined. */
    char *json = wait_for_workers(host_a.s, host_b.s);
    int others = other_names(json, host_a.s, host_b.s);
    if (others != 0)
        print_error("%s\n", json);
    free(json);
    if (others != 0)
        fail_msg("a worker other than %s and %s joined (the list above)", host_a.s, host_b.s);

    st = start_workers("status", log.s);
    expect_status(st, 0, "start-workers.sh status", log.s);
    assert_int_equal(testutil_file_count(log.s, ": running (pid "), 2);

    submit_and_wait(path_in("ssh.exr").s);
    assert_same_pixels(path_in("ref.exr").s, path_in("ssh.exr").s);

    st = start_workers("stop", log.s);
    expect_status(st, 0, "start-workers.sh stop", log.s);
    assert_int_equal(testutil_file_count(log.s, ": stopped (pid "), 2);
    testutil_expect_file_has(log.s, "SIGTERM)"); /* they stopped when asked, within 10 s */
    assert_true(process_gone(pid_a));
    assert_true(process_gone(pid_b));

    st = start_workers("status", log.s);
    expect_status(st, 3, "start-workers.sh status after stop", log.s);
    assert_int_equal(testutil_file_count(log.s, ": not running"), 2);
    st = start_workers("stop", log.s);
    expect_status(st, 0, "start-workers.sh stop, again", log.s);
    assert_int_equal(testutil_file_count(log.s, ": not running"), 2);
}

/* The commands --dry-run prints, and the refusals of bad arguments (no root, no ssh needed). */
static void test_start_workers_arguments(void **state)
{
    (void)state;
    const text_t script = source_path("deploy/start-workers.sh");
    const text_t log = path_in("dry.log");

    /* A repeated host is contacted once; user@host names the worker after the host; the key
     * paths (on the hosts) are handed over as given. */
    int st = RUN(log.s, 10000, "bash", script.s, "--dry-run", "start", "--master", "m1", "-t", "4",
                 "-k", "keys/w.key", "--master-key", "/etc/pf/master.pub", "h1", "user@h2", "h1");
    expect_status(st, 0, "dry-run start", log.s);
    char *out = testutil_slurp(log.s, NULL);
    assert_non_null(out);
    expect_in(out, "\nssh -o BatchMode=yes -o ConnectTimeout=10 h1 sh -s -- 'start' "
                   "'tcp://m1:5555' 'm1-5555' '4' "
                   "'prismfarm' 'h1' '' 'auto' 'keys/w.key' '/etc/pf/master.pub' ''\n");
    expect_in(out, "\nssh -o BatchMode=yes -o ConnectTimeout=10 user@h2 sh -s -- 'start' "
                   "'tcp://m1:5555' 'm1-5555' "
                   "'4' 'prismfarm' 'h2' '' 'auto' 'keys/w.key' '/etc/pf/master.pub' ''\n");
    assert_int_equal(testutil_count_in(out, " sh -s -- "), 2);
    free(out);
    st = RUN(log.s, 10000, "bash", script.s, "-n", "start", "-m", "m1", "--insecure", "h1");
    expect_status(st, 0, "dry-run start --insecure", log.s);
    testutil_expect_file_has(log.s,
                             " h1 sh -s -- 'start' 'tcp://m1:5555' 'm1-5555' '' 'prismfarm' 'h1' "
                             "'' 'auto' '' '' 'insecure'\n");

    /* A hosts file (comments, blank lines, a per-host thread count), hosts on the command line
     * after it, a full endpoint, another ssh. */
    testutil_write_text(path_in("hosts").s, "# render nodes\nr1 8   # the big one\n\n   r2\n",
                        0644);
    st = RUN(log.s, 10000, "bash", script.s, "-n", "--hosts", path_in("hosts").s, "--master",
             "tcp://10.0.0.9:7000", "--ssh", "ssh -p 2222", "--cache", "/scratch/pf", "stop", "r3");
    expect_status(st, 0, "dry-run stop with a hosts file", log.s);
    out = testutil_slurp(log.s, NULL);
    assert_non_null(out);
    expect_in(out, "\nssh -p 2222 r1 sh -s -- 'stop' 'tcp://10.0.0.9:7000' '10.0.0.9-7000' '8' "
                   "'prismfarm' 'r1' "
                   "'/scratch/pf' 'auto' '' '' ''\n");
    expect_in(out, "\nssh -p 2222 r2 sh -s -- 'stop' 'tcp://10.0.0.9:7000' '10.0.0.9-7000' '' "
                   "'prismfarm' 'r2' ");
    expect_in(out, "\nssh -p 2222 r3 sh -s -- 'stop' ");
    assert_true(strstr(out, " r1 ") < strstr(out, " r2 ") &&
                strstr(out, " r2 ") < strstr(out, " r3 "));
    free(out);

    /* Bad arguments: exit status 2 and a message naming what is wrong; nothing is contacted. */
    static const struct {
        const char *args[10];
        const char *message;
    } bad[] = {
        {{"-n", NULL}, "expected an action"},
        {{"-n", "launch", "-m", "m", "h", NULL}, "got 'launch'"},
        {{"-n", "start", "h", NULL}, "--master is required"},
        {{"-n", "start", "-m", "m", NULL}, "no hosts"},
        {{"-n", "start", "-m", "m", "h;reboot", NULL}, "'h;reboot' is not a host name"},
        {{"-n", "start", "-m", "m", "--", "-oProxyCommand=x", NULL}, "is not a host name"},
        {{"-n", "start", "-m", "m", "-t", "0", NULL},
         "--threads expects an integer in 1..1024, got '0'"},
        {{"-n", "start", "-m", "m", "--launcher", "cron", NULL},
         "--launcher expects auto, systemd or nohup"},
        {{"-n", "start", "-m", "m a", "h", NULL}, "does not give an endpoint"},
        {{"-n", "start", "-m", "m", "--frobnicate", NULL}, "unknown option '--frobnicate'"},
        {{"-n", "start", "-m", "m", "h", NULL}, "start needs --key FILE and --master-key FILE"},
        {{"-n", "start", "-m", "m", "-k", "w.key", "h", NULL}, "or --insecure"},
        {{"-n", "start", "-m", "m", "--insecure", "-k", "w.key", "h", NULL},
         "--insecure and --key/--master-key exclude each other"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        const char *argv[14] = {"bash", script.s};
        int n = 2;
        for (int k = 0; k < 10 && bad[i].args[k]; k++)
            argv[n++] = bad[i].args[k];
        argv[n] = NULL;
        st = run_argv(log.s, 10000, argv);
        expect_status(st, 2, bad[i].message, log.s);
        testutil_expect_file_has(log.s, bad[i].message);
        assert_false(testutil_file_has(log.s, " sh -s -- "));
    }
    testutil_write_text(path_in("hosts").s, "r1\nr2 8 extra\n", 0644);
    st = RUN(log.s, 10000, "bash", script.s, "-n", "start", "-m", "m", "--hosts",
             path_in("hosts").s);
    expect_status(st, 2, "a hosts file line with three words", log.s);
    testutil_expect_file_has(log.s, "hosts:2: expected HOST [THREADS]");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_start_workers_arguments),
        cmocka_unit_test_teardown(test_job_across_hosts, hosts_teardown),
        cmocka_unit_test_teardown(test_start_workers_over_ssh, hosts_teardown),
    };
    return cmocka_run_group_tests(tests, group_setup, testutil_scratch_teardown);
}
