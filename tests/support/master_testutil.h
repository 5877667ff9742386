/* master_testutil: what the farm tests that drive master_run in a thread of their own share
 * (test_master, test_ops, test_dashboard_http): the master on inproc:// or tcp://127.0.0.1 with
 * ports the system chooses, started again on the same spool when a test restarts it; clients
 * (one request, its reply); and fake workers that say HELLO, heartbeat while they wait, render a
 * TASK of data/render/tiny.pbrt with render_tile as a real worker does and send its RESULT.
 * Every wait is bounded by the test's deadline (test_wait.h) and fails the test when it passes.
 * Header-only (each test is its own executable); include after cmocka.h. */
#ifndef PRISMFARM_MASTER_TESTUTIL_H
#define PRISMFARM_MASTER_TESTUTIL_H

#include "clock.h"
#include "farm_testutil.h"
#include "master.h"
#include "net.h"
#include "render.h"
#include "scene_load.h"
#include "settings.h"
#include "test_wait.h"

#include <pthread.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zmq.h>

#define TESTUTIL_MAX_OPEN 8 /* fake workers' sockets tracked per master */

typedef struct testutil_master {
    void *ctx;
    char spool[64];
    master_opts_t opts;
    volatile sig_atomic_t stop;
    pthread_t thread;
    bool running;
    pthread_mutex_t lock;
    pthread_cond_t cond;
    int ready, rc;
    char err[512];
    char bind_wep[64], bind_cep[64]; /* what opts binds */
    char wep[256], cep[256];         /* as bound (the ready callback) */
    uint8_t *scene_bytes;            /* data/render/tiny.pbrt */
    size_t scene_size;
    /* Fake workers' sockets still open: closed by testutil_master_destroy when a failed
     * assertion left them (zmq_ctx_term waits for every socket). */
    net_t *open[TESTUTIL_MAX_OPEN];
} testutil_master_t;

static inline void testutil_master_on_ready(void *user, const char *wep, const char *cep)
{
    testutil_master_t *f = user;
    pthread_mutex_lock(&f->lock);
    snprintf(f->wep, sizeof f->wep, "%s", wep);
    snprintf(f->cep, sizeof f->cep, "%s", cep);
    f->ready = 1;
    pthread_cond_broadcast(&f->cond);
    pthread_mutex_unlock(&f->lock);
}

static inline void *testutil_master_thread(void *arg)
{
    testutil_master_t *f = arg;
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

/* A master not started yet, on a fresh spool named after name, inproc:// (tcp false) or
 * tcp://127.0.0.1:* in plain text; master_opts_default() but for the endpoints, spool, context,
 * stop flag, heartbeat_ms, a worker timeout of the test's deadline (a test that does not lose a
 * worker on purpose never has one lost, however slowly the machine runs it), verbose with
 * PRISMFARM_TEST_VERBOSE. The test sets more of opts, then testutil_master_start. NULL (said on
 * stderr) on failure. */
static inline testutil_master_t *testutil_master_new(const char *name, bool tcp, int heartbeat_ms)
{
    static int counter;
    testutil_master_t *f = calloc(1, sizeof *f);
    if (!f)
        return NULL;
    f->scene_bytes = (uint8_t *)testutil_slurp("data/render/tiny.pbrt", &f->scene_size);
    if (!f->scene_bytes) {
        fprintf(stderr, "cannot read data/render/tiny.pbrt: run from tests/ (ctest does)\n");
        free(f);
        return NULL;
    }
    f->ctx = zmq_ctx_new();
    if (!f->ctx || testutil_mkdtemp(f->spool, sizeof f->spool, name) < 0) {
        fprintf(stderr, "cannot make a zmq context and a spool for %s\n", name);
        if (f->ctx)
            zmq_ctx_term(f->ctx);
        free(f->scene_bytes);
        free(f);
        return NULL;
    }
    counter++;
    if (tcp) {
        snprintf(f->bind_wep, sizeof f->bind_wep, "tcp://127.0.0.1:*");
        snprintf(f->bind_cep, sizeof f->bind_cep, "tcp://127.0.0.1:*");
    } else {
        snprintf(f->bind_wep, sizeof f->bind_wep, "inproc://%s-workers-%d", name, counter);
        snprintf(f->bind_cep, sizeof f->bind_cep, "inproc://%s-clients-%d", name, counter);
    }
    f->opts = master_opts_default();
    f->opts.worker_endpoint = f->bind_wep;
    f->opts.client_endpoint = f->bind_cep;
    f->opts.insecure = tcp; /* plain text on the loopback; test_curve covers the keys */
    f->opts.spool_dir = f->spool;
    f->opts.zmq_ctx = f->ctx;
    f->opts.stop = &f->stop;
    f->opts.heartbeat_ms = heartbeat_ms;
    f->opts.sched.worker_timeout_s = test_wait_s();
    f->opts.verbose = getenv("PRISMFARM_TEST_VERBOSE") != NULL;
    f->opts.ready = testutil_master_on_ready;
    f->opts.user = f;
    pthread_mutex_init(&f->lock, NULL);
    pthread_cond_init(&f->cond, NULL);
    return f;
}

/* Starts (or, after testutil_master_stop, restarts) the master and waits until it listens;
 * -1 (master_run's error on stderr) when it could not start. */
static inline int testutil_master_start(testutil_master_t *f)
{
    f->stop = 0;
    f->ready = 0;
    f->rc = 0;
    if (pthread_create(&f->thread, NULL, testutil_master_thread, f) != 0)
        return -1;
    f->running = true;
    pthread_mutex_lock(&f->lock);
    while (!f->ready)
        pthread_cond_wait(&f->cond, &f->lock);
    pthread_mutex_unlock(&f->lock);
    if (f->ready < 0) {
        fprintf(stderr, "master_run: %s\n", f->err);
        return -1;
    }
    return 0;
}

/* Stops the master; returns master_run's status. */
static inline int testutil_master_stop(testutil_master_t *f)
{
    if (!f->running)
        return f->rc;
    f->stop = 1;
    pthread_join(f->thread, NULL);
    f->running = false;
    return f->rc;
}

/* Stops the master, closes the sockets left open, removes the spool; returns 0 when the master
 * ended well and the spool is gone (a teardown's status). */
static inline int testutil_master_destroy(testutil_master_t **f_p)
{
    testutil_master_t *f = *f_p;
    if (!f)
        return 0;
    int rc = testutil_master_stop(f);
    for (int i = 0; i < TESTUTIL_MAX_OPEN; i++)
        net_destroy(&f->open[i]);
    zmq_ctx_term(f->ctx);
    if (testutil_rmtree(f->spool) != 0)
        rc = -1;
    pthread_mutex_destroy(&f->lock);
    pthread_cond_destroy(&f->cond);
    free(f->scene_bytes);
    free(f);
    *f_p = NULL;
    return rc;
}

/* ------------------------------------------------------------------------------------------ */
/* Clients. */

static inline net_t *testutil_connect(testutil_master_t *f, const char *endpoint)
{
    err_t err;
    net_t *n = net_new(f->ctx, NET_DEALER, NULL, &err);
    if (!n || net_connect(n, endpoint, &err))
        fail_msg("connect %s: %s", endpoint, err.msg);
    return n;
}

static inline void testutil_send(net_t *n, const proto_msg_t *m)
{
    err_t err;
    if (net_send(n, NULL, m, &err))
        fail_msg("send %s: %s", proto_type_name(m->type), err.msg);
}

/* The next message other than HEARTBEAT and PROGRESS (a scene still loading) within
 * timeout_ms; fails the test otherwise. */
static inline void testutil_recv(net_t *n, proto_msg_t *m, int timeout_ms)
{
    double end = clock_now_s() + timeout_ms / 1000.0;
    while (clock_now_s() < end) {
        err_t err;
        int r = net_recv(n, NULL, m, 20, &err);
        if (r == PROTO_EAGAIN)
            continue;
        if (r)
            fail_msg("recv: %s", err.msg);
        if (m->type != PROTO_HEARTBEAT && m->type != PROTO_PROGRESS)
            return;
        proto_msg_free(m);
    }
    fail_msg("no message within %d ms", timeout_ms);
}

/* The next message, which must be of this type, within the test's deadline. */
static inline void testutil_expect(net_t *n, proto_type_t type, proto_msg_t *m)
{
    testutil_recv(n, m, test_wait_ms());
    if (m->type != type)
        fail_msg("expected %s, got %s (%s)", proto_type_name(type), proto_type_name(m->type),
                 m->type == PROTO_ERROR    ? m->error.message
                 : m->type == PROTO_REFUSE ? m->refuse.reason
                                           : "");
}

/* One client request and its reply, on a connection of its own. */
static inline void testutil_call(testutil_master_t *f, const proto_msg_t *req, proto_msg_t *reply)
{
    net_t *c = testutil_connect(f, f->cep);
    testutil_send(c, req);
    testutil_recv(c, reply, test_wait_ms());
    net_destroy(&c);
}

/* SUBMITs data/render/tiny.pbrt at spp with priority; returns the job's id. */
static inline uint64_t testutil_submit_tiny(testutil_master_t *f, int spp, int priority)
{
    proto_bundle_file_t file = {.path = "tiny.pbrt", .data = f->scene_bytes, .size = f->scene_size};
    proto_msg_t req = {.type = PROTO_SUBMIT,
                       .submit = {.name = "tiny.pbrt",
                                  .settings = {.spp = spp, .seed = -1},
                                  .bundle = {.main = "tiny.pbrt", .files = &file, .nfiles = 1},
                                  .priority = priority}};
    proto_msg_t r;
    testutil_call(f, &req, &r);
    if (r.type != PROTO_SUBMITTED)
        fail_msg("SUBMIT answered %s: %s", proto_type_name(r.type),
                 r.type == PROTO_ERROR ? r.error.message : "");
    uint64_t id = r.submitted.job;
    proto_msg_free(&r);
    return id;
}

/* The job's STATUS entry (its strings cleared); its error into error[size] when error is not
 * NULL. */
static inline proto_job_info_t testutil_status(testutil_master_t *f, uint64_t job, char *error,
                                               size_t size)
{
    proto_msg_t req = {.type = PROTO_STATUS, .status = {.job = job}}, r;
    testutil_call(f, &req, &r);
    if (r.type != PROTO_STATUS_REPLY || r.status_reply.njobs != 1)
        fail_msg("STATUS answered %s", proto_type_name(r.type));
    proto_job_info_t info = r.status_reply.jobs[0];
    if (error)
        snprintf(error, size, "%s", info.error ? info.error : "");
    info.name = NULL;
    info.error = NULL;
    proto_msg_free(&r);
    return info;
}

static inline void testutil_wait_state(testutil_master_t *f, uint64_t job, job_state_t state)
{
    double end = clock_now_s() + test_wait_s();
    while (clock_now_s() < end) {
        if (testutil_status(f, job, NULL, 0).state == state)
            return;
        testutil_sleep_ms(10);
    }
    fail_msg("job %llu never became %s", (unsigned long long)job, proto_job_state_name(state));
}

/* ------------------------------------------------------------------------------------------ */
/* Fake workers. */

typedef struct testutil_worker {
    testutil_master_t *f;
    net_t *net;
    uint64_t id;
    double last_sent;
    scene_t *scene;        /* tiny.pbrt with the first task's settings */
    proto_msg_t queue[64]; /* tasks received, not yet answered (the test's to fill) */
    int nqueue;
} testutil_worker_t;

static inline void testutil_worker_send(testutil_worker_t *w, const proto_msg_t *m)
{
    testutil_send(w->net, m);
    w->last_sent = clock_now_s();
}

/* Connects, says HELLO with name and threads and reads the WELCOME (with the master's
 * heartbeat interval): w->id is its worker id. */
static inline void testutil_worker_hello(testutil_master_t *f, testutil_worker_t *w,
                                         const char *name, int threads)
{
    memset(w, 0, sizeof *w);
    w->f = f;
    w->net = testutil_connect(f, f->wep);
    for (int i = 0; i < TESTUTIL_MAX_OPEN; i++)
        if (!f->open[i]) {
            f->open[i] = w->net;
            break;
        }
    proto_msg_t hello = {.type = PROTO_HELLO,
                         .hello = {.name = name, .threads = threads, .software = "test"}};
    testutil_worker_send(w, &hello);
    proto_msg_t m;
    testutil_expect(w->net, PROTO_WELCOME, &m);
    assert_int_equal(m.welcome.heartbeat_ms, f->opts.heartbeat_ms);
    w->id = m.welcome.worker_id;
    proto_msg_free(&m);
}

static inline void testutil_worker_close(testutil_worker_t *w)
{
    for (int i = 0; i < w->nqueue; i++)
        proto_msg_free(&w->queue[i]);
    w->nqueue = 0;
    scene_destroy(&w->scene);
    for (int i = 0; w->f && i < TESTUTIL_MAX_OPEN; i++)
        if (w->f->open[i] == w->net)
            w->f->open[i] = NULL;
    net_destroy(&w->net);
}

/* The next message other than HEARTBEAT within timeout_ms, heartbeating meanwhile like a live
 * worker; 0, or -1 when none came. */
static inline int testutil_worker_recv(testutil_worker_t *w, proto_msg_t *m, int timeout_ms)
{
    double end = clock_now_s() + timeout_ms / 1000.0;
    while (clock_now_s() < end) {
        if (clock_now_s() - w->last_sent > w->f->opts.heartbeat_ms / 1000.0) {
            proto_msg_t hb = {.type = PROTO_HEARTBEAT};
            testutil_worker_send(w, &hb);
        }
        err_t err;
        int r = net_recv(w->net, NULL, m, 20, &err);
        if (r == PROTO_EAGAIN)
            continue;
        if (r)
            fail_msg("worker recv: %s", err.msg);
        if (m->type != PROTO_HEARTBEAT)
            return 0;
        proto_msg_free(m);
    }
    return -1;
}

/* Renders a TASK as a real worker does: render_tile with the task's settings, the sums rounded
 * before sending (tilebuf.h). */
static inline tilebuf_t *testutil_worker_render(testutil_worker_t *w, const proto_msg_t *t)
{
    err_t err;
    if (!w->scene) {
        scene_overrides_t ov = settings_to_overrides(&t->task.settings);
        w->scene = scene_load_file("data/render/tiny.pbrt", &ov, &err);
        if (!w->scene)
            fail_msg("%s", err.msg);
    }
    const proto_tile_t *r = &t->task.tile;
    tilebuf_t *tb = tilebuf_new(r->x0, r->y0, r->w, r->h, w->scene->settings.grid.n, &err);
    assert_non_null(tb);
    if (render_tile(w->scene, NULL, r->x0, r->y0, r->w, r->h, r->sample_begin, r->sample_end, tb,
                    NULL, &err))
        fail_msg("render_tile: %s", err.msg);
    tilebuf_round_sums(tb);
    return tb;
}

/* The RESULT of task t with tile tb and stats. */
static inline void testutil_worker_result(testutil_worker_t *w, const proto_msg_t *t,
                                          const tilebuf_t *tb, proto_task_stats_t stats)
{
    proto_msg_t out = {.type = PROTO_RESULT};
    out.result.job = t->task.job;
    out.result.task = t->task.task;
    out.result.attempt = t->task.attempt;
    out.result.kind = PROTO_KIND_CAMERA_TILE;
    out.result.tile = (proto_tile_result_t){.rect = t->task.tile,
                                            .nbuckets = tilebuf_nbuckets(tb),
                                            .sums = tilebuf_sums(tb),
                                            .xyz = tilebuf_xyz_sums(tb),
                                            .counts = tilebuf_counts(tb),
                                            .lum = tilebuf_luminance_sums(tb),
                                            .lum_sq = tilebuf_luminance_sq_sums(tb),
                                            .nonfinite = tilebuf_nonfinite(tb)};
    out.result.stats = stats;
    testutil_worker_send(w, &out);
}

#endif
