/* The master's dashboard over a real HTTP connection (docs/dashboard.md): master_run with
 * --http on 127.0.0.1 and a port the system chooses, a fake worker and a client over inproc://,
 * and plain sockets speaking HTTP/1.1 to the port. A job's tasks and its worker show in the
 * API; a cancel without a token is refused and the job runs on; with the administrator's token
 * the job is cancelled, the worker is told to drop it and no task of it runs. The port's bounds
 * hold, and the master keeps serving while they are tried: a header larger than a connection's
 * memory, a body larger than DASH_MAX_BODY, a garbage request line, more idle connections than
 * DASH_MAX_PER_ADDRESS, and a request left half sent (the loop is never blocked by it). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>
#include <zmq.h>

#include "clock.h"
#include "curve.h"
#include "dash_server.h"
#include "farm_testutil.h"
#include "master.h"
#include "net.h"
#include "test_wait.h"

#define HEARTBEAT_MS 100

typedef struct fx {
    void *ctx;
    char spool[64];
    char token[CURVE_TOKEN_CHARS + 1];
    char token_file[4096];
    master_opts_t opts;
    volatile sig_atomic_t stop;
    pthread_t thread;
    pthread_mutex_t lock;
    pthread_cond_t cond;
    int ready, rc;
    char err[512];
    char wep[256], cep[256];
    int port;
    uint8_t *scene;
    size_t scene_size;
} fx_t;

static void on_ready(void *user, const char *wep, const char *cep)
{
    fx_t *f = user;
    pthread_mutex_lock(&f->lock);
    snprintf(f->wep, sizeof f->wep, "%s", wep);
    snprintf(f->cep, sizeof f->cep, "%s", cep);
    f->ready = 1;
    pthread_cond_broadcast(&f->cond);
    pthread_mutex_unlock(&f->lock);
}

static void *run_master(void *arg)
{
    fx_t *f = arg;
    err_t err;
    f->rc = master_run(&f->opts, &err);
    if (f->rc)
        snprintf(f->err, sizeof f->err, "%s", err.msg);
    pthread_mutex_lock(&f->lock);
    f->ready = f->ready ? f->ready : -1;
    pthread_cond_broadcast(&f->cond);
    pthread_mutex_unlock(&f->lock);
    return NULL;
}

static int setup(void **state)
{
    fx_t *f = calloc(1, sizeof *f);
    f->scene = (uint8_t *)testutil_slurp("data/render/tiny.pbrt", &f->scene_size);
    if (!f->scene || testutil_mkdtemp(f->spool, sizeof f->spool, "dashboard") < 0)
        return -1;
    /* The administrator's token, as prismfarm keygen writes it. */
    curve_pair_t pair;
    curve_paths_t paths;
    err_t err;
    if (curve_generate(&pair, &err) < 0 || curve_token_generate(f->token) < 0 ||
        curve_write(&pair, f->token, f->spool, "ops", false, &paths, &err) < 0)
        return -1;
    snprintf(f->token_file, sizeof f->token_file, "%s", paths.token);
    f->ctx = zmq_ctx_new();
    static int counter;
    counter++;
    static char wep[64], cep[64];
    snprintf(wep, sizeof wep, "inproc://dash-test-workers-%d", counter);
    snprintf(cep, sizeof cep, "inproc://dash-test-clients-%d", counter);
    f->opts = master_opts_default();
    f->opts.worker_endpoint = wep;
    f->opts.client_endpoint = cep;
    f->opts.spool_dir = f->spool;
    f->opts.zmq_ctx = f->ctx;
    f->opts.stop = &f->stop;
    f->opts.heartbeat_ms = HEARTBEAT_MS;
    f->opts.sched.tile_size = 8;
    f->opts.sched.worker_timeout_s = test_wait_s();
    f->opts.journal = 0;
    f->opts.task_prefetch = 0;
    f->opts.http = "127.0.0.1:0";
    f->opts.http_token_file = f->token_file;
    f->opts.verbose = getenv("PRISMFARM_TEST_VERBOSE") != NULL;
    f->opts.ready = on_ready;
    f->opts.user = f;
    pthread_mutex_init(&f->lock, NULL);
    pthread_cond_init(&f->cond, NULL);
    pthread_create(&f->thread, NULL, run_master, f);
    pthread_mutex_lock(&f->lock);
    while (!f->ready)
        pthread_cond_wait(&f->cond, &f->lock);
    pthread_mutex_unlock(&f->lock);
    if (f->ready < 0) {
        fprintf(stderr, "master_run: %s\n", f->err);
        return -1;
    }
    /* The port as bound, from the endpoints file (written before the ready call). */
    char path[128];
    snprintf(path, sizeof path, "%s/endpoints", f->spool);
    char *text = testutil_slurp(path, NULL);
    const char *h = text ? strstr(text, "http http://127.0.0.1:") : NULL;
    if (!h) {
        fprintf(stderr, "no http line in %s\n", path);
        free(text);
        return -1;
    }
    f->port = atoi(h + strlen("http http://127.0.0.1:"));
    free(text);
    *state = f;
    return 0;
}

static int teardown(void **state)
{
    fx_t *f = *state;
    f->stop = 1;
    pthread_join(f->thread, NULL);
    int rc = f->rc;
    zmq_ctx_term(f->ctx);
    if (testutil_rmtree(f->spool) != 0)
        rc = -1;
    free(f->scene);
    free(f);
    return rc;
}

/* ---------------------------------------------------------------- HTTP by hand */

static int http_connect(fx_t *f)
{
    int s = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in a = {.sin_family = AF_INET, .sin_port = htons((uint16_t)f->port)};
    inet_pton(AF_INET, "127.0.0.1", &a.sin_addr);
    if (s < 0 || connect(s, (struct sockaddr *)&a, sizeof a) != 0)
        fail_msg("cannot connect to the dashboard on port %d", f->port);
    return s;
}

static void send_all(int s, const char *data, size_t n)
{
    while (n > 0) {
        ssize_t w = send(s, data, n, MSG_NOSIGNAL);
        if (w <= 0)
            return; /* the server may close on us: what the caller checks */
        data += w;
        n -= (size_t)w;
    }
}

/* Everything the server sends until it closes (or out is full), within the test's deadline;
 * returns the HTTP status, 0 when it closed without one. */
static int read_answer(int s, char *out, size_t size)
{
    size_t len = 0;
    double end = clock_now_s() + test_wait_s();
    while (len + 1 < size && clock_now_s() < end) {
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
    if (sscanf(out, "HTTP/1.1 %d", &status) != 1)
        status = 0;
    return status;
}

/* One request on its own connection (farm_testutil.h); returns the status, the answer in out. */
static int request(fx_t *f, const char *method, const char *path, const char *auth,
                   const char *body, char *out, size_t size)
{
    return testutil_http(f->port, method, path, auth, body, out, size);
}

/* ---------------------------------------------------------------- the farm side */

static net_t *connect_to(fx_t *f, const char *endpoint)
{
    err_t err;
    net_t *n = net_new(f->ctx, NET_DEALER, NULL, &err);
    if (!n || net_connect(n, endpoint, &err))
        fail_msg("connect %s: %s", endpoint, err.msg);
    return n;
}

/* The next message other than HEARTBEAT (and PROGRESS, a scene still loading) within the
 * deadline, heartbeating meanwhile. */
static void recv_msg(net_t *n, proto_msg_t *m, bool heartbeat)
{
    double end = clock_now_s() + test_wait_s(), last = 0;
    while (clock_now_s() < end) {
        err_t err;
        if (heartbeat && clock_now_s() - last > HEARTBEAT_MS / 1000.0) {
            proto_msg_t hb = {.type = PROTO_HEARTBEAT};
            (void)net_send(n, NULL, &hb, &err);
            last = clock_now_s();
        }
        int r = net_recv(n, NULL, m, 20, &err);
        if (r == PROTO_EAGAIN)
            continue;
        if (r)
            fail_msg("recv: %s", err.msg);
        if (m->type != PROTO_HEARTBEAT && m->type != PROTO_PROGRESS)
            return;
        proto_msg_free(m);
    }
    fail_msg("no message within the deadline");
}

static void call(fx_t *f, const proto_msg_t *req, proto_msg_t *reply)
{
    net_t *c = connect_to(f, f->cep);
    err_t err;
    if (net_send(c, NULL, req, &err))
        fail_msg("send: %s", err.msg);
    recv_msg(c, reply, false);
    net_destroy(&c);
}

static uint64_t submit_tiny(fx_t *f)
{
    proto_bundle_file_t file = {.path = "tiny.pbrt", .data = f->scene, .size = f->scene_size};
    proto_msg_t req = {.type = PROTO_SUBMIT,
                       .submit = {.name = "tiny",
                                  .settings = {.spp = 4, .seed = -1},
                                  .bundle = {.main = "tiny.pbrt", .files = &file, .nfiles = 1}}};
    proto_msg_t r;
    call(f, &req, &r);
    if (r.type != PROTO_SUBMITTED)
        fail_msg("SUBMIT answered %s", proto_type_name(r.type));
    uint64_t id = r.submitted.job;
    proto_msg_free(&r);
    return id;
}

static proto_job_state_t state_of(fx_t *f, uint64_t job)
{
    proto_msg_t req = {.type = PROTO_STATUS, .status = {.job = job}}, r;
    call(f, &req, &r);
    assert_int_equal(r.type, PROTO_STATUS_REPLY);
    proto_job_state_t s = r.status_reply.jobs[0].state;
    proto_msg_free(&r);
    return s;
}

/* ---------------------------------------------------------------- tests */

static void test_cancel_over_http(void **state)
{
    fx_t *f = *state;
    static char out[1 << 16];
    uint64_t job = submit_tiny(f);
    net_t *w = connect_to(f, f->wep);
    proto_msg_t hello = {.type = PROTO_HELLO,
                         .hello = {.name = "fake-host", .threads = 2, .software = "test"}};
    err_t err;
    assert_int_equal(net_send(w, NULL, &hello, &err), 0);
    proto_msg_t m;
    recv_msg(w, &m, true);
    assert_int_equal(m.type, PROTO_WELCOME);
    proto_msg_free(&m);
    recv_msg(w, &m, true); /* two tasks, kept unanswered: the job stays running */
    assert_int_equal(m.type, PROTO_TASK);
    proto_msg_free(&m);
    recv_msg(w, &m, true);
    assert_int_equal(m.type, PROTO_TASK);
    proto_msg_free(&m);

    assert_int_equal(request(f, "GET", "/api/jobs", NULL, NULL, out, sizeof out), 200);
    assert_non_null(strstr(out, "\"name\":\"tiny\""));
    assert_non_null(strstr(out, "\"state\":\"running\""));
    char path[64];
    snprintf(path, sizeof path, "/api/jobs/%llu/tasks", (unsigned long long)job);
    assert_int_equal(request(f, "GET", path, NULL, NULL, out, sizeof out), 200);
    assert_int_equal(testutil_count_in(out, "\"worker_name\":\"fake-host\""), 2);
    assert_int_equal(request(f, "GET", "/api/workers", NULL, NULL, out, sizeof out), 200);
    assert_non_null(strstr(out, "\"state\":\"busy\""));

    /* Pause and resume go through the master's operations (ops.h), as the clients' ACT. */
    snprintf(path, sizeof path, "/api/jobs/%llu/pause", (unsigned long long)job);
    assert_int_equal(request(f, "POST", path, f->token, "", out, sizeof out), 200);
    assert_int_equal(state_of(f, job), PROTO_JOB_PAUSED);
    assert_int_equal(request(f, "GET", "/api/jobs", NULL, NULL, out, sizeof out), 200);
    assert_non_null(strstr(out, "\"paused\":true"));
    snprintf(path, sizeof path, "/api/jobs/%llu/resume", (unsigned long long)job);
    assert_int_equal(request(f, "POST", path, f->token, "", out, sizeof out), 200);
    assert_int_equal(state_of(f, job), PROTO_JOB_RUNNING);

    snprintf(path, sizeof path, "/api/jobs/%llu/cancel", (unsigned long long)job);
    assert_int_equal(request(f, "POST", path, NULL, "", out, sizeof out), 401);
    assert_non_null(strstr(out, "WWW-Authenticate: Bearer"));
    char wrong[CURVE_TOKEN_CHARS + 1];
    memcpy(wrong, f->token, sizeof wrong);
    wrong[0] = wrong[0] == '0' ? '1' : '0';
    assert_int_equal(request(f, "POST", path, wrong, "", out, sizeof out), 401);
    assert_int_equal(state_of(f, job), PROTO_JOB_RUNNING);

    assert_int_equal(request(f, "POST", path, f->token, "", out, sizeof out), 200);
    assert_non_null(strstr(out, "\"action\":\"cancel\""));
    assert_int_equal(state_of(f, job), PROTO_JOB_CANCELLED);
    recv_msg(w, &m, true);
    assert_int_equal(m.type, PROTO_CANCEL);
    assert_true(m.cancel.job == job);
    proto_msg_free(&m);
    snprintf(path, sizeof path, "/api/jobs/%llu/tasks", (unsigned long long)job);
    assert_int_equal(request(f, "GET", path, NULL, NULL, out, sizeof out), 200);
    assert_non_null(strstr(out, "\"tasks\":[]"));
    assert_non_null(strstr(out, "\"state\":\"cancelled\""));
    /* The job's log says who cancelled it. */
    snprintf(path, sizeof path, "/api/jobs/%llu/log", (unsigned long long)job);
    assert_int_equal(request(f, "GET", path, NULL, NULL, out, sizeof out), 200);
    assert_non_null(strstr(out, "cancel from the dashboard by 'ops' (admin)"));
    /* Cancelling again is refused with the reason. */
    snprintf(path, sizeof path, "/api/jobs/%llu/cancel", (unsigned long long)job);
    assert_int_equal(request(f, "POST", path, f->token, "", out, sizeof out), 409);
    /* A job that is over cannot be paused: refused with the reason. */
    snprintf(path, sizeof path, "/api/jobs/%llu/pause", (unsigned long long)job);
    assert_int_equal(request(f, "POST", path, f->token, "", out, sizeof out), 409);
    assert_non_null(strstr(out, "only a queued or running job"));
    net_destroy(&w);
}

static void test_bounds(void **state)
{
    fx_t *f = *state;
    static char out[1 << 16];
    /* A half-sent request does not hold the loop: other requests and the farm's own clients
     * are answered while it waits. */
    int stalled = http_connect(f);
    send_all(stalled, "GET /api/jobs HTTP/1.1\r\nHost: 12", 32);
    assert_int_equal(request(f, "GET", "/api/jobs", NULL, NULL, out, sizeof out), 200);
    proto_msg_t req = {.type = PROTO_JOBS}, r;
    call(f, &req, &r);
    assert_int_equal(r.type, PROTO_JOBS_REPLY);
    proto_msg_free(&r);

    /* A header beyond the connection's memory. */
    size_t big = 2 * DASH_CONNECTION_MEMORY;
    char *head = malloc(big + 200);
    int n = snprintf(head, 200, "GET /api/jobs HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Big: ");
    memset(head + n, 'x', big);
    memcpy(head + n + big, "\r\n\r\n", 5);
    int s = http_connect(f);
    send_all(s, head, strlen(head));
    int status = read_answer(s, out, sizeof out);
    close(s);
    free(head);
    assert_true(status == 0 || (status >= 400 && status < 500));

    /* A body beyond DASH_MAX_BODY. */
    char *body = malloc(DASH_MAX_BODY * 4 + 1);
    memset(body, ' ', DASH_MAX_BODY * 4);
    body[DASH_MAX_BODY * 4] = 0;
    assert_int_equal(request(f, "POST", "/api/jobs/1/priority", f->token, body, out, sizeof out),
                     413);
    free(body);

    /* A request line that is not one. */
    s = http_connect(f);
    send_all(s, "\x01\x02 garbage\r\n\r\n", 14);
    status = read_answer(s, out, sizeof out);
    close(s);
    assert_true(status == 0 || status == 400);

    /* More idle connections than one address may hold: the ones beyond are closed, and the
     * port serves again once they are gone. */
    int conns[DASH_MAX_PER_ADDRESS + 8];
    int count = (int)(sizeof conns / sizeof *conns);
    for (int i = 0; i < count; i++)
        conns[i] = http_connect(f);
    /* A connection beyond the limit is closed by the server: readable, with EOF. Waited for
     * until enough are, within the test's deadline. */
    bool closed[DASH_MAX_PER_ADDRESS + 8] = {0};
    int refused = 0;
    double until = clock_now_s() + test_wait_s();
    while (refused < count - DASH_MAX_PER_ADDRESS && clock_now_s() < until) {
        struct pollfd p[DASH_MAX_PER_ADDRESS + 8];
        for (int i = 0; i < count; i++)
            p[i] = (struct pollfd){.fd = closed[i] ? -1 : conns[i], .events = POLLIN};
        if (poll(p, (nfds_t)count, 50) <= 0)
            continue;
        for (int i = 0; i < count; i++) {
            char c;
            if (!closed[i] && (p[i].revents & (POLLIN | POLLHUP)) &&
                recv(conns[i], &c, 1, MSG_DONTWAIT) <= 0) {
                closed[i] = true;
                refused++;
            }
        }
    }
    for (int i = 0; i < count; i++)
        close(conns[i]);
    close(stalled);
    assert_true(refused >= count - DASH_MAX_PER_ADDRESS);
    double end = clock_now_s() + test_wait_s();
    while (request(f, "GET", "/api/jobs", NULL, NULL, out, sizeof out) != 200 &&
           clock_now_s() < end)
        testutil_sleep_ms(50);
    assert_int_equal(request(f, "GET", "/api/jobs", NULL, NULL, out, sizeof out), 200);
}

/* The address rules of the option: a port alone is 127.0.0.1; another host's address needs
 * http_public. */
static void test_http_option(void **state)
{
    (void)state;
    dash_server_config_t c;
    err_t err;
    assert_int_equal(dash_server_parse_address("8080", &c, &err), 0);
    assert_string_equal(c.address, "127.0.0.1");
    assert_int_equal(c.port, 8080);
    assert_int_equal(dash_server_parse_address("localhost:0", &c, &err), 0);
    assert_true(dash_server_loopback(&c));
    assert_int_equal(dash_server_parse_address("0.0.0.0:80", &c, &err), 0);
    assert_false(dash_server_loopback(&c));
    const char *bad[] = {"", ":", "80000", "host:80", "1.2.3:80", "1.2.3.4:-1", "1.2.3.4:8a"};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++)
        assert_int_equal(dash_server_parse_address(bad[i], &c, &err), -1);
    master_opts_t o = master_opts_default();
    o.http = "0.0.0.0:8080";
    assert_int_equal(master_check_http(&o, &err), -1);
    assert_non_null(strstr(err.msg, "--http-public"));
    o.http_public = 1;
    assert_int_equal(master_check_http(&o, &err), 0);
    o.http = NULL;
    o.http_token_file = "x.token";
    assert_int_equal(master_check_http(&o, &err), -1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_cancel_over_http, setup, teardown),
        cmocka_unit_test_setup_teardown(test_bounds, setup, teardown),
        cmocka_unit_test(test_http_option),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
