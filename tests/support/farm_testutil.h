/* farm_testutil: helpers shared by the tests that run prismfarm processes (with the scratch
 * folder and file helpers of files_testutil.h): CURVE keys, sleeping and the clock, waiting for a
 * log line, starting `prismfarm master` / `worker` child processes, stopping them within a
 * deadline, killing those a failed test left, reading the endpoints a master chose, and comparing
 * two EXRs' pixel data byte for byte. Header-only (each test is its own executable); include after
 * cmocka.h. */
#ifndef PRISMFARM_FARM_TESTUTIL_H
#define PRISMFARM_FARM_TESTUTIL_H

#include "clock.h"
#include "files_testutil.h"
#include "image_exr.h"
#include "test_wait.h"

#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

/* The farm's CURVE keys for a test (docs/security.md), made with `$PRISMFARM_BIN keygen`:
 * DIR/keys/master.key and .pub, DIR/keys/farm.key and .pub (shared by the test's workers and
 * clients) and the master's authorised folder DIR/authorized holding farm.pub. PRISMFARM_KEY and
 * PRISMFARM_MASTER_KEY are then set, so every worker and client the test starts uses them;
 * master_key and authorized (size bytes each) get the master's --key and --authorized. */
static inline int testutil_farm_keys(const char *dir, char *master_key, char *authorized,
                                     size_t size)
{
    const char *bin = getenv("PRISMFARM_BIN");
    char cmd[2400], farm_key[600], master_pub[600];
    if (!bin)
        return -1;
    snprintf(cmd, sizeof cmd,
             "'%s' keygen master --dir '%s/keys' >/dev/null && '%s' keygen farm --dir '%s/keys' "
             ">/dev/null && mkdir -p '%s/authorized' && cp '%s/keys/farm.pub' '%s/authorized/'",
             bin, dir, bin, dir, dir, dir, dir);
    if (system(cmd) != 0)
        return -1;
    snprintf(master_key, size, "%s/keys/master.key", dir);
    snprintf(authorized, size, "%s/authorized", dir);
    snprintf(farm_key, sizeof farm_key, "%s/keys/farm.key", dir);
    snprintf(master_pub, sizeof master_pub, "%s/keys/master.pub", dir);
    return setenv("PRISMFARM_KEY", farm_key, 1) == 0 &&
                   setenv("PRISMFARM_MASTER_KEY", master_pub, 1) == 0
               ? 0
               : -1;
}

/* The master's --key and --authorized made by testutil_scratch_keys_setup ("" before). */
static inline char *testutil_keys_buf(int which)
{
    static char keys[2][600];
    return keys[which];
}

static inline const char *testutil_master_key(void)
{
    return testutil_keys_buf(0);
}

static inline const char *testutil_authorized(void)
{
    return testutil_keys_buf(1);
}

/* The scratch folder (files_testutil.h) with the farm's keys in it (testutil_farm_keys), as a
 * cmocka setup; returns 0 or -1. */
static inline int testutil_scratch_keys_setup(void **state)
{
    return testutil_scratch_setup(state) < 0 ||
                   testutil_farm_keys(testutil_scratch_dir(), testutil_keys_buf(0),
                                      testutil_keys_buf(1), 600) < 0
               ? -1
               : 0;
}

/* The clock and sleep of base/clock.h, under the names the farm tests use. */
static inline void testutil_sleep_ms(int ms)
{
    clock_sleep_s(ms / 1000.0);
}

static inline double testutil_now_s(void)
{
    return clock_now_s();
}

/* Waits until the file at path holds needle (a log line the process writes when the event
 * happens), up to the deadline of a wait (test_wait.h); fails the test otherwise, quoting the
 * file. */
static inline void testutil_wait_file_has(const char *path, const char *needle)
{
    for (double until = testutil_now_s() + test_wait_s(); !testutil_file_has(path, needle);
         testutil_sleep_ms(10))
        if (testutil_now_s() > until)
            testutil_fail_quoting(path, "no '%s' in %s after %.0f s:", needle, path, test_wait_s());
}

/* The children the test started (testutil_spawn, or its own fork handed to
 * testutil_track_child) and has not reaped, so that a failing test leaves none running:
 * testutil_kill_children, a cmocka teardown, kills and reaps them. */
#define TESTUTIL_MAX_CHILDREN 64
static inline pid_t *testutil_children(void)
{
    static pid_t kids[TESTUTIL_MAX_CHILDREN];
    return kids;
}

/* Adds pid to the children testutil_kill_children ends; fails the test when they are full. */
static inline void testutil_track_child(pid_t pid)
{
    pid_t *kids = testutil_children();
    for (int i = 0; i < TESTUTIL_MAX_CHILDREN; i++)
        if (kids[i] <= 0) {
            kids[i] = pid;
            return;
        }
    fail_msg("more than %d child processes at once", TESTUTIL_MAX_CHILDREN);
}

/* Takes pid off that list: the test reaped it itself (its pid may be reused). */
static inline void testutil_forget_child(pid_t pid)
{
    pid_t *kids = testutil_children();
    for (int i = 0; i < TESTUTIL_MAX_CHILDREN; i++)
        if (kids[i] == pid)
            kids[i] = 0;
}

/* Kills (SIGKILL) and reaps every child still on the list: a cmocka teardown; returns 0. */
static inline int testutil_kill_children(void **state)
{
    (void)state;
    pid_t *kids = testutil_children();
    for (int i = 0; i < TESTUTIL_MAX_CHILDREN; i++)
        if (kids[i] > 0) {
            if (kill(kids[i], SIGKILL) == 0)
                (void)waitpid(kids[i], NULL, 0);
            kids[i] = 0;
        }
    return 0;
}

/* Starts `$PRISMFARM_BIN ARGS...` in the background (args: NULL-terminated, at most
 * TESTUTIL_MAX_ARGS) with its stderr to log and its stdout to /dev/null, so that no child holds
 * the test's own output open (ctest reads it until every writer is gone); returns its pid, or
 * -1 when PRISMFARM_BIN is not set or fork fails. The child goes on the list of
 * testutil_kill_children, and dies with the test should ctest's timeout end the test before its
 * teardown. A child that cannot arrange that, open its log or run the executable exits 125, 126
 * or 127. */
#define TESTUTIL_MAX_ARGS 48
static inline pid_t testutil_spawn_argv(const char *log, const char *const *args)
{
    const char *bin = getenv("PRISMFARM_BIN");
    if (!bin)
        return -1;
    char *argv[TESTUTIL_MAX_ARGS + 2];
    int argc = 0;
    argv[argc++] = (char *)bin;
    for (int i = 0; args[i] && i < TESTUTIL_MAX_ARGS; i++)
        argv[argc++] = (char *)args[i];
    argv[argc] = NULL;
    pid_t pid = fork();
    if (pid == 0) {
        if (prctl(PR_SET_PDEATHSIG, SIGKILL) != 0)
            _exit(125);
        if (!freopen(log, "w", stderr) || !freopen("/dev/null", "w", stdout))
            _exit(126);
        execv(bin, argv);
        _exit(127);
    }
    if (pid > 0)
        testutil_track_child(pid);
    return pid;
}

/* testutil_spawn_argv with the arguments listed; fails the test if the process cannot start. */
static inline pid_t testutil_spawn(const char *log, const char *arg, ...)
{
    const char *args[TESTUTIL_MAX_ARGS + 1];
    int n = 0;
    va_list ap;
    va_start(ap, arg);
    for (const char *a = arg; a && n < TESTUTIL_MAX_ARGS; a = va_arg(ap, const char *))
        args[n++] = a;
    va_end(ap);
    args[n] = NULL;
    pid_t pid = testutil_spawn_argv(log, args);
    if (pid < 0)
        fail_msg("cannot start prismfarm %s (is PRISMFARM_BIN set?)", arg);
    return pid;
}

/* `prismfarm master` on the endpoints wep and cep ("tcp://127.0.0.1:*": ports the system
 * chooses) with its spool and the CURVE keys of testutil_scratch_keys_setup, its stderr to log,
 * and the options opts (NULL-terminated, at most TESTUTIL_MAX_ARGS - 10) after; returns its pid
 * (testutil_read_endpoints gives the endpoints it bound). Fails the test if it cannot start. */
static inline pid_t testutil_start_master_argv(const char *log, const char *spool, const char *wep,
                                               const char *cep, const char *const *opts)
{
    const char *args[TESTUTIL_MAX_ARGS + 1] = {"master",
                                               "--workers",
                                               wep,
                                               "--clients",
                                               cep,
                                               "--spool",
                                               spool,
                                               "--key",
                                               testutil_master_key(),
                                               "--authorized",
                                               testutil_authorized()};
    int n = 11;
    for (int i = 0; opts && opts[i] && n < TESTUTIL_MAX_ARGS; i++)
        args[n++] = opts[i];
    args[n] = NULL;
    pid_t pid = testutil_spawn_argv(log, args);
    if (pid < 0)
        fail_msg("cannot start prismfarm master (is PRISMFARM_BIN set?)");
    return pid;
}

/* testutil_start_master_argv with the options listed (NULL-terminated; NULL alone for none). */
static inline pid_t testutil_start_master(const char *log, const char *spool, const char *wep,
                                          const char *cep, ...)
{
    const char *opts[TESTUTIL_MAX_ARGS + 1];
    int n = 0;
    va_list ap;
    va_start(ap, cep);
    for (const char *a = va_arg(ap, const char *); a && n < TESTUTIL_MAX_ARGS;
         a = va_arg(ap, const char *))
        opts[n++] = a;
    va_end(ap);
    opts[n] = NULL;
    return testutil_start_master_argv(log, spool, wep, cep, opts);
}

/* `prismfarm worker` of one thread named name, with its bundle cache, serving the master at wep
 * (its CURVE keys from PRISMFARM_KEY and PRISMFARM_MASTER_KEY, testutil_farm_keys), its stderr to
 * log; returns its pid. */
static inline pid_t testutil_start_worker(const char *log, const char *wep, const char *name,
                                          const char *cache)
{
    return testutil_spawn(log, "worker", "--connect", wep, "--threads", "1", "--name", name,
                          "--cache", cache, NULL);
}

/* Sends sig to the child pid (0: none, to wait for it to end by itself) and reaps it within the
 * deadline of a wait (test_wait.h); returns its wait status. A child still running then is
 * killed and fails the test (a daemon that ignores SIGTERM fails it rather than hangs it), as
 * does a pid that cannot be signalled (not a child, or one already reaped). */
static inline int testutil_stop(pid_t pid, int sig)
{
    testutil_forget_child(pid);
    if (pid <= 0 || kill(pid, sig) != 0)
        fail_msg("cannot signal process %ld: %s", (long)pid, strerror(errno));
    int st;
    for (double until = testutil_now_s() + test_wait_s();; testutil_sleep_ms(10)) {
        pid_t got = waitpid(pid, &st, WNOHANG);
        if (got == pid)
            return st;
        if (got < 0 && errno != EINTR)
            fail_msg("waitpid(%ld): %s", (long)pid, strerror(errno));
        if (testutil_now_s() > until) {
            kill(pid, SIGKILL);
            waitpid(pid, &st, 0);
            fail_msg("process %ld did not end within %.0f s of signal %d", (long)pid, test_wait_s(),
                     sig);
        }
    }
}

/* Reads "workers EP" and "clients EP" (workers and clients: 256 bytes each) from the endpoints
 * file a master writes into its spool once its sockets are bound; fails the test if the file is
 * not there within the deadline of a wait (test_wait.h; a master starts in milliseconds),
 * quoting the master's log unless log is NULL. */
static inline void testutil_read_endpoints(const char *spool, char *workers, char *clients,
                                           const char *log)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/endpoints", spool);
    double deadline = testutil_now_s() + test_wait_s();
    do {
        FILE *f = fopen(path, "r");
        if (f) {
            int got = fscanf(f, "workers %255s clients %255s", workers, clients);
            fclose(f);
            if (got == 2)
                return;
        }
        testutil_sleep_ms(25);
    } while (testutil_now_s() < deadline);
    if (log)
        testutil_fail_quoting(log, "the master did not write %s within %.0f s; its log:", path,
                              test_wait_s());
    fail_msg("the master did not write %s within %.0f s", path, test_wait_s());
}

/* Waits until something accepts TCP connections at endpoint ("tcp://HOST:PORT"), within the
 * test deadline: a restarted master on a fixed port listens a moment after it starts, and
 * `submit` and `fetch` report a refused connection at once (docs/security.md). */
static inline void testutil_wait_listening(const char *endpoint)
{
    const char *hp = strncmp(endpoint, "tcp://", 6) == 0 ? endpoint + 6 : endpoint;
    const char *colon = strrchr(hp, ':');
    if (!colon)
        fail_msg("testutil_wait_listening: no port in %s", endpoint);
    char host[256];
    snprintf(host, sizeof host, "%.*s", (int)(colon - hp), hp);
    struct sockaddr_in a;
    memset(&a, 0, sizeof a);
    a.sin_family = AF_INET;
    a.sin_port = htons((uint16_t)atoi(colon + 1));
    if (inet_pton(AF_INET, host, &a.sin_addr) != 1)
        fail_msg("testutil_wait_listening: %s is not an IPv4 address", host);
    double deadline = testutil_now_s() + test_wait_s();
    do {
        int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
        int ok = fd >= 0 && connect(fd, (const struct sockaddr *)&a, sizeof a) == 0;
        if (fd >= 0)
            close(fd);
        if (ok)
            return;
        testutil_sleep_ms(25);
    } while (testutil_now_s() < deadline);
    fail_msg("nothing listened at %s within %.0f s", endpoint, test_wait_s());
}

/* An EXR's "prismfarm" record (film/jobinfo.h), copied (free it): the test fails when the
 * file cannot be read or has no record. */
static inline char *testutil_exr_info(const char *exr)
{
    err_t err;
    image_exr_t *img = image_exr_read(exr, &err);
    if (!img)
        fail_msg("%s", err.msg);
    const char *info = image_exr_attribute(img, "prismfarm");
    assert_non_null(info);
    char *copy = strdup(info);
    assert_non_null(copy);
    image_exr_destroy(&img);
    return copy;
}

/* Reads EXRs a and b into *x and *y (the caller destroys both) and returns their pixel count:
 * the test fails when either cannot be read or their sizes or spectral channels differ. */
static inline size_t testutil_exr_pair(const char *a, const char *b, image_exr_t **x,
                                       image_exr_t **y)
{
    err_t err;
    *x = image_exr_read(a, &err);
    if (!*x)
        fail_msg("%s", err.msg);
    *y = image_exr_read(b, &err);
    if (!*y)
        fail_msg("%s", err.msg);
    const int w = image_exr_width(*x), h = image_exr_height(*x);
    assert_int_equal(w, image_exr_width(*y));
    assert_int_equal(h, image_exr_height(*y));
    assert_int_equal(image_exr_n_spectral(*x), image_exr_n_spectral(*y));
    return (size_t)w * h;
}

/* Both EXRs have the same size and spectral channels and byte-identical spectral and RGB
 * pixel data. Two paths to the same file fail: the comparison would prove nothing (a path held
 * too long in testutil_scratch's rotating buffers shows that way). */
static inline void testutil_assert_same_pixels(const char *a, const char *b)
{
    struct stat sa, sb;
    if (!strcmp(a, b) || (stat(a, &sa) == 0 && stat(b, &sb) == 0 && sa.st_dev == sb.st_dev &&
                          sa.st_ino == sb.st_ino))
        fail_msg("%s and %s are the same file: nothing to compare", a, b);
    image_exr_t *x, *y;
    const size_t px = testutil_exr_pair(a, b, &x, &y), nv = px * image_exr_n_spectral(x);
    assert_memory_equal(image_exr_spectral(x), image_exr_spectral(y), nv * sizeof(float));
    assert_memory_equal(image_exr_rgb(x), image_exr_rgb(y), px * 3 * sizeof(float));
    /* A Stokes output's S1-S3 layers too (Film "bool stokes"): both have them or neither. */
    for (int k = 1; k <= 3; k++) {
        const float *sx = image_exr_stokes(x, k), *sy = image_exr_stokes(y, k);
        assert_true(!sx == !sy);
        if (sx)
            assert_memory_equal(sx, sy, nv * sizeof(float));
    }
    image_exr_destroy(&x);
    image_exr_destroy(&y);
}

/* Whether two EXRs of the same size and spectral channels (the test fails otherwise, or when
 * either cannot be read) differ anywhere in their spectral pixels: what makes a comparison of
 * renders that should agree prove something. */
static inline int testutil_pixels_differ(const char *a, const char *b)
{
    image_exr_t *x, *y;
    const size_t nv = testutil_exr_pair(a, b, &x, &y) * image_exr_n_spectral(x);
    const int differ = memcmp(image_exr_spectral(x), image_exr_spectral(y), nv * sizeof(float));
    image_exr_destroy(&x);
    image_exr_destroy(&y);
    return differ != 0;
}

/* ------------------------------------------------------------------------------------------ */
/* The master's dashboard (docs/dashboard.md) over plain HTTP/1.1. */

/* The dashboard's port from SPOOL/endpoints' "http http://127.0.0.1:PORT/" line, waited for
 * within the test's deadline; fails the test without one. */
static inline int testutil_http_port(const char *spool)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/endpoints", spool);
    double deadline = testutil_now_s() + test_wait_s();
    do {
        FILE *f = fopen(path, "r");
        char line[600];
        while (f && fgets(line, sizeof line, f)) {
            int port;
            if (sscanf(line, "http http://127.0.0.1:%d/", &port) == 1) {
                fclose(f);
                return port;
            }
        }
        if (f)
            fclose(f);
        testutil_sleep_ms(20);
    } while (testutil_now_s() < deadline);
    fail_msg("no http line in %s", path);
    return -1;
}

/* A TCP connection to 127.0.0.1:port; fails the test without one. */
static inline int testutil_http_connect(int port)
{
    int s = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = htons((uint16_t)port)};
    inet_pton(AF_INET, "127.0.0.1", &a.sin_addr);
    if (s < 0 || connect(s, (struct sockaddr *)&a, sizeof a) != 0)
        fail_msg("cannot connect to the dashboard on port %d", port);
    return s;
}

/* The n bytes, or as many as the server takes before it closes on us (what the caller
 * checks). */
static inline void testutil_http_send(int s, const char *data, size_t n)
{
    while (n > 0) {
        ssize_t w = send(s, data, n, MSG_NOSIGNAL);
        if (w <= 0)
            return;
        data += w;
        n -= (size_t)w;
    }
}

/* Everything the server sends until it closes (or out is full), within the test's deadline;
 * returns the HTTP status, 0 when it closed without one. */
static inline int testutil_http_read(int s, char *out, size_t size)
{
    size_t len = 0;
    double deadline = testutil_now_s() + test_wait_s();
    while (len + 1 < size && testutil_now_s() < deadline) {
        struct pollfd p = {.fd = s, .events = POLLIN};
        if (poll(&p, 1, 100) <= 0)
            continue;
        ssize_t r = recv(s, out + len, size - 1 - len, 0);
        if (r <= 0)
            break;
        len += (size_t)r;
    }
    out[len] = 0;
    int status = 0;
    return sscanf(out, "HTTP/1.1 %d", &status) == 1 ? status : 0;
}

/* One request to 127.0.0.1:port on its own connection, with "Authorization: Bearer token"
 * when token is not NULL; the whole answer (status line, headers, body) into out. Returns the
 * status, 0 when the server closed without one. */
static inline int testutil_http(int port, const char *method, const char *path,
                                const char *token, const char *body, char *out, size_t size)
{
    char head[1024];
    snprintf(head, sizeof head,
             "%s %s HTTP/1.1\r\nHost: 127.0.0.1:%d\r\nConnection: close\r\n%s%s%s"
             "Content-Length: %zu\r\n\r\n",
             method, path, port, token ? "Authorization: Bearer " : "", token ? token : "",
             token ? "\r\n" : "", body ? strlen(body) : 0);
    int s = testutil_http_connect(port);
    testutil_http_send(s, head, strlen(head));
    if (body)
        testutil_http_send(s, body, strlen(body));
    int status = testutil_http_read(s, out, size);
    close(s);
    return status;
}

#endif
