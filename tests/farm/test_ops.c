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
#include "master_testutil.h"
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

typedef testutil_master_t fx_t;
typedef testutil_worker_t fake_worker_t;

static void master_start(fx_t *f)
{
    if (testutil_master_start(f) < 0)
        fail_msg("master_run: %s", f->err);
}

static void master_stop(fx_t *f)
{
    assert_int_equal(testutil_master_stop(f), 0);
}

static int setup(void **state)
{
    fx_t *f = testutil_master_new("ops", false, HEARTBEAT_MS);
    if (!f)
        return -1;
    f->opts.sched.tile_size = TILE;
    f->opts.sched.max_worker_job_failures = 10;
    f->opts.sched.max_worker_failures_in_row = 2;
    f->opts.task_prefetch = 0;
    f->opts.preview_interval_s = 30;
    *state = f;
    return testutil_master_start(f);
}

static int teardown(void **state)
{
    return testutil_master_destroy((fx_t **)state);
}

/* ---------------------------------------------------------------- clients */

static proto_job_info_t status_of(fx_t *f, uint64_t job)
{
    return testutil_status(f, job, NULL, 0);
}

/* An ACT; returns the reply's type, the error's text in *error. */
static proto_type_t act(fx_t *f, proto_act_t what, uint64_t job, uint32_t task, int prio,
                        const char *worker, char *error, size_t size)
{
    proto_msg_t req = {.type = PROTO_ACT,
                       .act = {.act = what, .job = job, .task = task, .priority = prio,
                               .worker = worker}},
                r;
    testutil_call(f, &req, &r);
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
    testutil_call(f, &req, &r);
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
    testutil_call(f, &req, &r);
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

static void fw_task(fake_worker_t *w, proto_msg_t *m)
{
    if (testutil_worker_recv(w, m, test_wait_ms()) < 0)
        fail_msg("worker %llu: no TASK", (unsigned long long)w->id);
    if (m->type != PROTO_TASK)
        fail_msg("worker %llu: expected a TASK, got %s", (unsigned long long)w->id,
                 proto_type_name(m->type));
}

/* Renders the task and returns its result. */
static void fw_finish(fake_worker_t *w, const proto_msg_t *t)
{
    tilebuf_t *tb = testutil_worker_render(w, t);
    const proto_tile_t *r = &t->task.tile;
    testutil_worker_result(
        w, t, tb,
        (proto_task_stats_t){.samples = (uint64_t)r->w * (uint64_t)r->h *
                                        (r->sample_end - r->sample_begin),
                             .elapsed = 0.01});
    tilebuf_destroy(&tb);
}

static void fw_fail(fake_worker_t *w, const proto_msg_t *t, const char *why)
{
    proto_msg_t fail = {.type = PROTO_TASK_FAILED,
                        .task_failed = {.job = t->task.job, .task = t->task.task,
                                        .attempt = t->task.attempt, .error = why}};
    testutil_worker_send(w, &fail);
}

/* ---------------------------------------------------------------- tests */

static void test_pause_survives_restart(void **state)
{
    fx_t *f = *state;
    uint64_t job = testutil_submit_tiny(f, SPP, 0);
    fake_worker_t w;
    testutil_worker_hello(f, &w, "node1", 1);
    proto_msg_t held, m;
    fw_task(&w, &held);
    act_ok(f, PROTO_ACT_PAUSE, job, 0, 0, NULL);
    assert_int_equal(status_of(f, job).state, JOB_PAUSED);
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
    assert_int_equal(testutil_worker_recv(&w, &m, 5 * HEARTBEAT_MS), -1);
    testutil_worker_close(&w);

    /* Paused through a restart, and its log kept. */
    master_stop(f);
    master_start(f);
    assert_int_equal(status_of(f, job).state, JOB_PAUSED);
    char *log = fetch_text(f, PROTO_LOGS, job, -1);
    expect_in(log, "assigned to worker");
    expect_in(log, "job paused by (no key)");
    expect_in(log, "merged");
    expect_in(log, "job resumed by a restarted master");
    free(log);
    testutil_worker_hello(f, &w, "node1", 1);
    assert_int_equal(testutil_worker_recv(&w, &m, 5 * HEARTBEAT_MS), -1);
    act_ok(f, PROTO_ACT_RESUME, job, 0, 0, NULL);
    for (int i = 1; i < NTASKS; i++) {
        fw_task(&w, &m);
        assert_true(m.task.job == job);
        fw_finish(&w, &m);
        proto_msg_free(&m);
    }
    testutil_wait_state(f, job, JOB_DONE);
    log = fetch_text(f, PROTO_LOGS, job, -1);
    expect_in(log, "job resumed by (no key)");
    expect_in(log, "job done at 4 of 4 spp");
    free(log);
    assert_int_equal(act(f, PROTO_ACT_PAUSE, job, 0, 0, NULL, error, sizeof error), PROTO_ERROR);
    expect_in(error, "only a queued or running job");
    testutil_worker_close(&w);
}

static void test_priority_and_requeue(void **state)
{
    fx_t *f = *state;
    uint64_t low = testutil_submit_tiny(f, SPP, 0);
    uint64_t high = testutil_submit_tiny(f, SPP, 0);
    act_ok(f, PROTO_ACT_PRIORITY, high, 0, 7, NULL);
    assert_int_equal(status_of(f, high).priority, 7);
    fake_worker_t a, b;
    testutil_worker_hello(f, &a, "stuck", 1);
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
    testutil_worker_hello(f, &b, "helper", 1);
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
    testutil_worker_close(&a);
    testutil_worker_close(&b);
}

static void test_blocklist(void **state)
{
    fx_t *f = *state;
    uint64_t job = testutil_submit_tiny(f, SPP, 0);
    fake_worker_t w;
    testutil_worker_hello(f, &w, "flaky", 1);
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
    assert_int_equal(testutil_worker_recv(&w, &m, 5 * HEARTBEAT_MS), -1);
    char *log = fetch_text(f, PROTO_LOGS, job, -1);
    expect_in(log, "failed on worker");
    expect_in(log, "out of memory at tile start"); /* one line per event */
    expect_in(log, "blocked from every job");
    free(log);
    /* Kept by name through a restart, and when it joins again. */
    testutil_worker_close(&w);
    master_stop(f);
    master_start(f);
    testutil_worker_hello(f, &w, "flaky", 1);
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
    testutil_worker_close(&w);
}

static void test_metrics(void **state)
{
    fx_t *f = *state;
    uint64_t job = testutil_submit_tiny(f, SPP, 0);
    fake_worker_t w;
    testutil_worker_hello(f, &w, "metered", 1);
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
    testutil_worker_close(&w);
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
