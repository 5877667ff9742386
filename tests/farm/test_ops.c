/* Operating a farm (docs/farm.md): a master in a thread on inproc:// driven by fake workers and
 * clients. A paused job's worker finishes its task and gets no more, the job stays paused through
 * a restart of the master and finishes after a resume; a higher priority takes the workers
 * first; a stuck task requeued by hand goes to another worker; a worker that fails tasks in a
 * row is blocked (shown by WORKERS, kept through a restart, by name) until unblocked; the task
 * log tells all of it and survives the restart; METRICS answers Prometheus text. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zmq.h>

#include "clock.h"
#include "farm_testutil.h"
#include "master.h"
#include "net.h"
#include "render.h"
#include "scene_load.h"
#include "settings.h"
#include "test_wait.h"

#define TILE 8
#define SPP 4
#define NTASKS 18 /* tiny.pbrt: 24 x 16 pixels, 8-pixel tiles, 3 passes */
#define HEARTBEAT_MS 100

typedef struct fx {
    void *ctx;
    char spool[64];
    master_opts_t opts;
    volatile sig_atomic_t stop;
    pthread_t thread;
    int rc;
    char err[512];
    pthread_mutex_t lock;
    pthread_cond_t cond;
    int ready;
    char wep[64], cep[64];
    uint8_t *scene_bytes;
    size_t scene_size;
    /* The fake workers' sockets still open: closed by teardown when a failed assertion left
     * them (zmq_ctx_term waits for every socket). */
    net_t *open[8];
} fx_t;

static void on_ready(void *user, const char *wep, const char *cep)
{
    (void)wep;
    (void)cep;
    fx_t *f = user;
    pthread_mutex_lock(&f->lock);
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

/* (Re)starts the master on f's spool and endpoints. */
static void master_start(fx_t *f)
{
    f->stop = 0;
    f->ready = 0;
    pthread_create(&f->thread, NULL, run_master, f);
    pthread_mutex_lock(&f->lock);
    while (!f->ready)
        pthread_cond_wait(&f->cond, &f->lock);
    pthread_mutex_unlock(&f->lock);
    if (f->ready < 0)
        fail_msg("master_run: %s", f->err);
}

static void master_stop(fx_t *f)
{
    f->stop = 1;
    pthread_join(f->thread, NULL);
    assert_int_equal(f->rc, 0);
}

static int setup(void **state)
{
    static int counter;
    fx_t *f = calloc(1, sizeof *f);
    f->scene_bytes = (uint8_t *)testutil_slurp("data/render/tiny.pbrt", &f->scene_size);
    if (!f->scene_bytes) {
        fprintf(stderr, "cannot read data/render/tiny.pbrt: run from tests/ (ctest does)\n");
        free(f);
        return -1;
    }
    f->ctx = zmq_ctx_new();
    if (!f->ctx || testutil_mkdtemp(f->spool, sizeof f->spool, "ops") < 0)
        return -1;
    counter++;
    snprintf(f->wep, sizeof f->wep, "inproc://ops-workers-%d", counter);
    snprintf(f->cep, sizeof f->cep, "inproc://ops-clients-%d", counter);
    f->opts = master_opts_default();
    f->opts.worker_endpoint = f->wep;
    f->opts.client_endpoint = f->cep;
    f->opts.spool_dir = f->spool;
    f->opts.zmq_ctx = f->ctx;
    f->opts.stop = &f->stop;
    f->opts.heartbeat_ms = HEARTBEAT_MS;
    f->opts.sched.tile_size = TILE;
    f->opts.sched.worker_timeout_s = test_wait_s();
    f->opts.sched.max_worker_job_failures = 10;
    f->opts.sched.max_worker_failures_in_row = 2;
    f->opts.task_prefetch = 0;
    f->opts.preview_interval_s = 30;
    f->opts.verbose = getenv("PRISMFARM_TEST_VERBOSE") != NULL;
    f->opts.ready = on_ready;
    f->opts.user = f;
    pthread_mutex_init(&f->lock, NULL);
    pthread_cond_init(&f->cond, NULL);
    master_start(f);
    *state = f;
    return 0;
}

static int teardown(void **state)
{
    fx_t *f = *state;
    f->stop = 1;
    pthread_join(f->thread, NULL);
    int rc = f->rc;
    for (int i = 0; i < 8; i++)
        net_destroy(&f->open[i]);
    zmq_ctx_term(f->ctx);
    if (testutil_rmtree(f->spool) != 0)
        rc = -1;
    free(f->scene_bytes);
    free(f);
    return rc;
}

/* ---------------------------------------------------------------- clients */

static net_t *connect_to(fx_t *f, const char *endpoint)
{
    err_t err;
    net_t *n = net_new(f->ctx, NET_DEALER, NULL, &err);
    if (!n || net_connect(n, endpoint, &err))
        fail_msg("connect %s: %s", endpoint, err.msg);
    return n;
}

static void send_msg(net_t *n, const proto_msg_t *m)
{
    err_t err;
    if (net_send(n, NULL, m, &err))
        fail_msg("send %s: %s", proto_type_name(m->type), err.msg);
}

static void recv_msg(net_t *n, proto_msg_t *m, int timeout_ms)
{
    double end = clock_now_s() + timeout_ms / 1000.0;
    while (clock_now_s() < end) {
        err_t err;
        int r = net_recv(n, NULL, m, 20, &err);
        if (r == PROTO_EAGAIN)
            continue;
        if (r)
            fail_msg("recv: %s", err.msg);
        /* A PROGRESS precedes the answer to a SUBMIT (the scene is loading), as a client's
         * wait for the answer goes on past it (client_rpc.h). */
        if (m->type != PROTO_HEARTBEAT && m->type != PROTO_PROGRESS)
            return;
        proto_msg_free(m);
    }
    fail_msg("no message within %d ms", timeout_ms);
}

static void call(fx_t *f, const proto_msg_t *req, proto_msg_t *reply)
{
    net_t *c = connect_to(f, f->cep);
    send_msg(c, req);
    recv_msg(c, reply, test_wait_ms());
    net_destroy(&c);
}

static uint64_t submit_tiny(fx_t *f, int priority)
{
    proto_bundle_file_t file = {.path = "tiny.pbrt", .data = f->scene_bytes, .size = f->scene_size};
    proto_msg_t req = {.type = PROTO_SUBMIT,
                       .submit = {.name = "tiny.pbrt",
                                  .settings = {.spp = SPP, .seed = -1},
                                  .bundle = {.main = "tiny.pbrt", .files = &file, .nfiles = 1},
                                  .priority = priority}};
    proto_msg_t r;
    call(f, &req, &r);
    if (r.type != PROTO_SUBMITTED)
        fail_msg("SUBMIT answered %s: %s", proto_type_name(r.type),
                 r.type == PROTO_ERROR ? r.error.message : "");
    uint64_t id = r.submitted.job;
    proto_msg_free(&r);
    return id;
}

static proto_job_info_t status_of(fx_t *f, uint64_t job)
{
    proto_msg_t req = {.type = PROTO_STATUS, .status = {.job = job}}, r;
    call(f, &req, &r);
    if (r.type != PROTO_STATUS_REPLY || r.status_reply.njobs != 1)
        fail_msg("STATUS answered %s", proto_type_name(r.type));
    proto_job_info_t info = r.status_reply.jobs[0];
    info.name = info.error = NULL;
    proto_msg_free(&r);
    return info;
}

/* An ACT; returns the reply's type, the error's text in *error. */
static proto_type_t act(fx_t *f, proto_act_t what, uint64_t job, uint32_t task, int prio,
                        const char *worker, char *error, size_t size)
{
    proto_msg_t req = {.type = PROTO_ACT,
                       .act = {.act = what, .job = job, .task = task, .priority = prio,
                               .worker = worker}},
                r;
    call(f, &req, &r);
    proto_type_t type = r.type;
    if (error)
        snprintf(error, size, "%s", type == PROTO_ERROR ? r.error.message : "");
    proto_msg_free(&r);
    return type;
}

static void act_ok(fx_t *f, proto_act_t what, uint64_t job, uint32_t task, int prio,
                   const char *worker)
{
    char error[600];
    proto_type_t t = act(f, what, job, task, prio, worker, error, sizeof error);
    if (t == PROTO_ERROR)
        fail_msg("%s: %s", proto_act_name(what), error);
}

/* The text of a LOGS (task < 0: all) or METRICS reply, malloc'ed. */
static char *fetch_text(fx_t *f, proto_type_t type, uint64_t job, long long task)
{
    proto_msg_t req = {.type = type}, r;
    if (type == PROTO_LOGS) {
        req.logs.job = job;
        req.logs.has_task = task >= 0;
        req.logs.task = task >= 0 ? (uint32_t)task : 0;
    }
    call(f, &req, &r);
    if (r.type != PROTO_FILE)
        fail_msg("%s answered %s: %s", proto_type_name(type), proto_type_name(r.type),
                 r.type == PROTO_ERROR ? r.error.message : "");
    char *text = malloc(r.file.size + 1);
    memcpy(text, r.file.data, r.file.size);
    text[r.file.size] = 0;
    proto_msg_free(&r);
    return text;
}

static void expect_in(const char *text, const char *needle)
{
    if (!strstr(text, needle))
        fail_msg("'%s' not in:\n%s", needle, text);
}

/* The WORKERS entry of the worker of this id. */
static proto_worker_info_t worker_info(fx_t *f, uint64_t id)
{
    proto_msg_t req = {.type = PROTO_WORKERS}, r;
    call(f, &req, &r);
    assert_int_equal(r.type, PROTO_WORKERS_REPLY);
    proto_worker_info_t out = {0};
    bool found = false;
    for (size_t i = 0; i < r.workers_reply.nworkers; i++)
        if (r.workers_reply.workers[i].id == id) {
            out = r.workers_reply.workers[i];
            found = true;
        }
    out.name = NULL;
    proto_msg_free(&r);
    if (!found)
        fail_msg("no worker %llu in WORKERS", (unsigned long long)id);
    return out;
}

/* ---------------------------------------------------------------- a fake worker */

typedef struct fake_worker {
    fx_t *f;
    net_t *net;
    uint64_t id;
    double last_sent;
    scene_t *scene;
} fake_worker_t;

static void fw_send(fake_worker_t *w, const proto_msg_t *m)
{
    send_msg(w->net, m);
    w->last_sent = clock_now_s();
}

static void fw_hello(fx_t *f, fake_worker_t *w, const char *name)
{
    memset(w, 0, sizeof *w);
    w->f = f;
    w->net = connect_to(f, f->wep);
    for (int i = 0; i < 8; i++)
        if (!f->open[i]) {
            f->open[i] = w->net;
            break;
        }
    proto_msg_t hello = {.type = PROTO_HELLO,
                         .hello = {.name = name, .threads = 1, .software = "test"}};
    fw_send(w, &hello);
    proto_msg_t m;
    recv_msg(w->net, &m, test_wait_ms());
    assert_int_equal(m.type, PROTO_WELCOME);
    w->id = m.welcome.worker_id;
    proto_msg_free(&m);
}

static void fw_close(fake_worker_t *w)
{
    scene_destroy(&w->scene);
    for (int i = 0; i < 8; i++)
        if (w->f->open[i] == w->net)
            w->f->open[i] = NULL;
    net_destroy(&w->net);
}

/* The next message other than HEARTBEAT within timeout_ms, heartbeating meanwhile; -1 when
 * none came. */
static int fw_recv(fake_worker_t *w, proto_msg_t *m, int timeout_ms)
{
    double end = clock_now_s() + timeout_ms / 1000.0;
    while (clock_now_s() < end) {
        if (clock_now_s() - w->last_sent > HEARTBEAT_MS / 1000.0) {
            proto_msg_t hb = {.type = PROTO_HEARTBEAT};
            fw_send(w, &hb);
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

static void fw_task(fake_worker_t *w, proto_msg_t *m)
{
    if (fw_recv(w, m, test_wait_ms()) < 0)
        fail_msg("worker %llu: no TASK", (unsigned long long)w->id);
    if (m->type != PROTO_TASK)
        fail_msg("worker %llu: expected a TASK, got %s", (unsigned long long)w->id,
                 proto_type_name(m->type));
}

/* Renders the task and returns its result. */
static void fw_finish(fake_worker_t *w, const proto_msg_t *t)
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
    out.result.stats = (proto_task_stats_t){.samples = (uint64_t)r->w * (uint64_t)r->h *
                                                       (r->sample_end - r->sample_begin),
                                            .elapsed = 0.01};
    fw_send(w, &out);
    tilebuf_destroy(&tb);
}

static void fw_fail(fake_worker_t *w, const proto_msg_t *t, const char *why)
{
    proto_msg_t fail = {.type = PROTO_TASK_FAILED,
                        .task_failed = {.job = t->task.job, .task = t->task.task,
                                        .attempt = t->task.attempt, .error = why}};
    fw_send(w, &fail);
}

static void wait_state(fx_t *f, uint64_t job, proto_job_state_t state)
{
    double end = clock_now_s() + test_wait_s();
    while (clock_now_s() < end) {
        if (status_of(f, job).state == state)
            return;
        testutil_sleep_ms(10);
    }
    fail_msg("job %llu never became %s", (unsigned long long)job, proto_job_state_name(state));
}

/* ---------------------------------------------------------------- tests */

static void test_pause_survives_restart(void **state)
{
    fx_t *f = *state;
    uint64_t job = submit_tiny(f, 0);
    fake_worker_t w;
    fw_hello(f, &w, "node1");
    proto_msg_t held, m;
    fw_task(&w, &held);
    act_ok(f, PROTO_ACT_PAUSE, job, 0, 0, NULL);
    assert_int_equal(status_of(f, job).state, PROTO_JOB_PAUSED);
    char error[600];
    assert_int_equal(act(f, PROTO_ACT_PAUSE, job, 0, 0, NULL, error, sizeof error), PROTO_ERROR);
    expect_in(error, "paused already");
    /* The held task finishes and is merged; no other task follows while paused (the master
     * would send it at once: one heartbeat interval of silence is ten loop turns). */
    fw_finish(&w, &held);
    proto_msg_free(&held);
    double end = clock_now_s() + test_wait_s();
    while (status_of(f, job).samples_done == 0 && clock_now_s() < end)
        testutil_sleep_ms(10);
    assert_true(status_of(f, job).samples_done > 0);
    assert_int_equal(fw_recv(&w, &m, 5 * HEARTBEAT_MS), -1);
    fw_close(&w);

    /* Paused through a restart, and its log kept. */
    master_stop(f);
    master_start(f);
    assert_int_equal(status_of(f, job).state, PROTO_JOB_PAUSED);
    char *log = fetch_text(f, PROTO_LOGS, job, -1);
    expect_in(log, "assigned to worker");
    expect_in(log, "job paused by (no key)");
    expect_in(log, "merged");
    expect_in(log, "job resumed by a restarted master");
    free(log);
    fw_hello(f, &w, "node1");
    assert_int_equal(fw_recv(&w, &m, 5 * HEARTBEAT_MS), -1);
    act_ok(f, PROTO_ACT_RESUME, job, 0, 0, NULL);
    for (int i = 1; i < NTASKS; i++) {
        fw_task(&w, &m);
        assert_true(m.task.job == job);
        fw_finish(&w, &m);
        proto_msg_free(&m);
    }
    wait_state(f, job, PROTO_JOB_DONE);
    log = fetch_text(f, PROTO_LOGS, job, -1);
    expect_in(log, "job resumed by (no key)");
    expect_in(log, "job done at 4 of 4 spp");
    free(log);
    assert_int_equal(act(f, PROTO_ACT_PAUSE, job, 0, 0, NULL, error, sizeof error), PROTO_ERROR);
    expect_in(error, "only a queued or running job");
    fw_close(&w);
}

static void test_priority_and_requeue(void **state)
{
    fx_t *f = *state;
    uint64_t low = submit_tiny(f, 0);
    uint64_t high = submit_tiny(f, 0);
    act_ok(f, PROTO_ACT_PRIORITY, high, 0, 7, NULL);
    assert_int_equal(status_of(f, high).priority, 7);
    fake_worker_t a, b;
    fw_hello(f, &a, "stuck");
    proto_msg_t stuck, m;
    fw_task(&a, &stuck);
    assert_true(stuck.task.job == high); /* submitted later, but of higher priority */
    uint32_t task = (uint32_t)(stuck.task.task & UINT32_MAX);
    /* Its worker never answers: requeued by hand, to the next worker that asks. */
    act_ok(f, PROTO_ACT_REQUEUE, high, task, 0, NULL);
    char error[600];
    assert_int_equal(act(f, PROTO_ACT_REQUEUE, high, NTASKS - 1, 0, NULL, error, sizeof error),
                     PROTO_ERROR);
    expect_in(error, "waiting in the queue");
    /* Its slot is free again, but the requeued task is not given back to it. */
    fw_task(&a, &m);
    assert_true((uint32_t)(m.task.task & UINT32_MAX) != task);
    proto_msg_free(&m);
    fw_hello(f, &b, "helper");
    fw_task(&b, &m);
    assert_true(m.task.job == high);
    assert_true((uint32_t)(m.task.task & UINT32_MAX) == task);
    assert_true(m.task.attempt == stuck.task.attempt + 1);
    fw_finish(&b, &m);
    proto_msg_free(&m);
    char *log = fetch_text(f, PROTO_LOGS, high, task);
    expect_in(log, "requeued by (no key)");
    expect_in(log, "taken back from worker");
    expect_in(log, "assigned to worker");
    expect_in(log, "'helper'");
    /* Only that task's lines. */
    char other[32];
    snprintf(other, sizeof other, "task %u ", task + 1);
    assert_null(strstr(log, other));
    free(log);
    log = fetch_text(f, PROTO_LOGS, high, -1);
    expect_in(log, "job priority 0 -> 7 by (no key)");
    free(log);
    assert_int_equal(act(f, PROTO_ACT_PRIORITY, 99, 0, 1, NULL, error, sizeof error), PROTO_ERROR);
    expect_in(error, "no job 99");
    (void)low;
    proto_msg_free(&stuck);
    fw_close(&a);
    fw_close(&b);
}

static void test_blocklist(void **state)
{
    fx_t *f = *state;
    uint64_t job = submit_tiny(f, 0);
    fake_worker_t w;
    fw_hello(f, &w, "flaky");
    proto_msg_t m;
    /* Two failures in a row (the fixture's max_worker_failures_in_row) block it. */
    for (int i = 0; i < 2; i++) {
        fw_task(&w, &m);
        fw_fail(&w, &m, "out of memory\nat tile start");
        proto_msg_free(&m);
    }
    double end = clock_now_s() + test_wait_s();
    while (worker_info(f, w.id).state != PROTO_WORKER_BLOCKED && clock_now_s() < end)
        testutil_sleep_ms(10);
    proto_worker_info_t wi = worker_info(f, w.id);
    assert_int_equal(wi.state, PROTO_WORKER_BLOCKED);
    assert_int_equal(wi.tasks_failed, 2);
    assert_int_equal(fw_recv(&w, &m, 5 * HEARTBEAT_MS), -1);
    char *log = fetch_text(f, PROTO_LOGS, job, -1);
    expect_in(log, "failed on worker");
    expect_in(log, "out of memory at tile start"); /* one line per event */
    expect_in(log, "blocked from every job");
    free(log);
    /* Kept by name through a restart, and when it joins again. */
    fw_close(&w);
    master_stop(f);
    master_start(f);
    fw_hello(f, &w, "flaky");
    end = clock_now_s() + test_wait_s();
    while (worker_info(f, w.id).state != PROTO_WORKER_BLOCKED && clock_now_s() < end)
        testutil_sleep_ms(10);
    assert_int_equal(worker_info(f, w.id).state, PROTO_WORKER_BLOCKED);
    char error[600];
    assert_int_equal(act(f, PROTO_ACT_UNBLOCK, 0, 0, 0, "nobody", error, sizeof error),
                     PROTO_ERROR);
    expect_in(error, "not blocked");
    assert_int_equal(act(f, PROTO_ACT_UNBLOCK, 0, 0, 0, "flaky", NULL, 0), PROTO_WORKERS_REPLY);
    fw_task(&w, &m);
    assert_true(m.task.job == job);
    fw_finish(&w, &m);
    proto_msg_free(&m);
    assert_int_not_equal(worker_info(f, w.id).state, PROTO_WORKER_BLOCKED);
    fw_close(&w);
}

static void test_metrics(void **state)
{
    fx_t *f = *state;
    uint64_t job = submit_tiny(f, 0);
    fake_worker_t w;
    fw_hello(f, &w, "metered");
    proto_msg_t m;
    fw_task(&w, &m);
    char *text = fetch_text(f, PROTO_METRICS, 0, -1);
    expect_in(text, "# TYPE prismfarm_jobs gauge\n");
    expect_in(text, "prismfarm_jobs{state=\"running\"} 1\n");
    expect_in(text, "prismfarm_tasks_in_flight 1\n");
    char depth[64];
    snprintf(depth, sizeof depth, "prismfarm_queue_depth %d\n", NTASKS - 1);
    expect_in(text, depth);
    expect_in(text, "prismfarm_worker_samples_per_second{worker=\"metered\",id=\"");
    expect_in(text, "prismfarm_received_bytes_total{endpoint=\"workers\"} ");
    expect_in(text, "# TYPE prismfarm_journal_write_seconds_total counter\n");
    /* A journal write (the submission) took some time and was counted. */
    assert_null(strstr(text, "prismfarm_journal_writes_total 0\n"));
    free(text);
    fw_finish(&w, &m);
    proto_msg_free(&m);
    (void)job;
    fw_close(&w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_pause_survives_restart, setup, teardown),
        cmocka_unit_test_setup_teardown(test_priority_and_requeue, setup, teardown),
        cmocka_unit_test_setup_teardown(test_blocklist, setup, teardown),
        cmocka_unit_test_setup_teardown(test_metrics, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
