/* test_rogue_worker: finding 1 of issue 26 -- one worker that claims 4096 threads, takes tasks,
 * never answers and says HELLO again on fresh connections (keeping the old ones heartbeating)
 * must not stall a job that an honest worker beside it can finish. The master runs in this
 * process on tcp://127.0.0.1 with a task deadline far beyond the test's own deadline, so the job
 * can only finish if a fresh HELLO from the same name gives the old connection's tasks back at
 * once and the worker's standing (probation, strikes) follows it across connections; the rogue
 * ends up blocked (shown in WORKERS) and `unblock` lifts it. On a master without that (main
 * before issue 26), each connection started afresh with 32 tasks held until their deadline and
 * the job never finished within the test's deadline.
 *
 * Every wait is on an event (a message, a job's state), bounded by test_wait.h's deadline; the
 * test never times the machine. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>

#include <cmocka.h>

#include "master_testutil.h"

#define HEARTBEAT_MS 100
#define TILE 8         /* tiny.pbrt is 24x16: 6 tiles */
#define SPP 64         /* 7 passes: 42 tasks */
#define MAX_ROGUE 12   /* connections the rogue opens at most */
#define ROGUE_NAME "rogue"

typedef testutil_master_t fx_t;

/* The rogue's connections, closed by teardown when a failed assertion left them open
 * (zmq_ctx_term waits for every socket). */
static net_t *rogue_nets[MAX_ROGUE];

static int setup(void **state)
{
    fx_t *f = testutil_master_new("rogue", true, HEARTBEAT_MS);
    if (!f)
        return -1;
    f->opts.sched.tile_size = TILE;
    /* Far beyond the test's deadline: no task comes back by expiring. */
    f->opts.sched.task_deadline_s = 10 * test_wait_s();
    f->opts.preview_interval_s = 30;
    *state = f;
    return testutil_master_start(f);
}

static int teardown(void **state)
{
    for (int i = 0; i < MAX_ROGUE; i++)
        net_destroy(&rogue_nets[i]);
    return testutil_master_destroy((fx_t **)state);
}

/* One of the rogue's connections: it heartbeats and drops every TASK. */
typedef struct rogue_conn {
    net_t *net;
    double last_sent;
    int tasks;
} rogue_conn_t;

static void rogue_hello(fx_t *f, rogue_conn_t *c)
{
    memset(c, 0, sizeof *c);
    c->net = testutil_connect(f, f->wep);
    for (int i = 0; i < MAX_ROGUE; i++)
        if (!rogue_nets[i]) {
            rogue_nets[i] = c->net;
            break;
        }
    proto_msg_t hello = {.type = PROTO_HELLO,
                         .hello = {.name = ROGUE_NAME, .threads = 4096, .software = "rogue"}};
    testutil_send(c->net, &hello);
    c->last_sent = clock_now_s();
}

/* Takes what the connection holds; counts its TASKs; heartbeats when due. */
static void rogue_pump(fx_t *f, rogue_conn_t *c)
{
    for (;;) {
        proto_msg_t m;
        err_t err;
        int r = net_recv(c->net, NULL, &m, 0, &err);
        if (r == PROTO_EAGAIN)
            break;
        if (r)
            fail_msg("rogue recv: %s", err.msg);
        c->tasks += m.type == PROTO_TASK;
        proto_msg_free(&m);
    }
    if (clock_now_s() - c->last_sent > f->opts.heartbeat_ms / 1000.0) {
        proto_msg_t hb = {.type = PROTO_HEARTBEAT};
        testutil_send(c->net, &hb);
        c->last_sent = clock_now_s();
    }
}

/* The honest worker: answers every TASK it has with its rendered result. */
static void honest_pump(testutil_worker_t *w)
{
    proto_msg_t m;
    while (testutil_worker_recv(w, &m, 5) == 0) {
        if (m.type == PROTO_TASK) {
            tilebuf_t *tb = testutil_worker_render(w, &m);
            const proto_tile_t *r = &m.task.tile;
            testutil_worker_result(
                w, &m, tb,
                (proto_task_stats_t){.samples = (uint64_t)r->w * (uint64_t)r->h *
                                                (r->sample_end - r->sample_begin),
                                     .elapsed = 0.01});
            tilebuf_destroy(&tb);
        }
        proto_msg_free(&m);
    }
}

/* The WORKERS entries named name: how many, and how many of them are blocked. */
static void workers_named(fx_t *f, const char *name, int *n, int *blocked)
{
    proto_msg_t req = {.type = PROTO_WORKERS}, r;
    testutil_call(f, &req, &r);
    assert_int_equal(r.type, PROTO_WORKERS_REPLY);
    *n = *blocked = 0;
    for (size_t i = 0; i < r.workers_reply.nworkers; i++)
        if (!strcmp(r.workers_reply.workers[i].name, name)) {
            (*n)++;
            *blocked += r.workers_reply.workers[i].state == PROTO_WORKER_BLOCKED;
        }
    proto_msg_free(&r);
}

static void test_rogue_key_does_not_stall_a_job(void **state)
{
    fx_t *f = *state;
    rogue_conn_t rogue[MAX_ROGUE];
    int nrogue = 0;
    /* The rogue first, so that it is offered every task of the job. */
    rogue_hello(f, &rogue[nrogue++]);
    uint64_t job = testutil_submit_tiny(f, SPP, 0);
    double end = clock_now_s() + test_wait_s();
    while (rogue[0].tasks == 0 && clock_now_s() < end) {
        rogue_pump(f, &rogue[0]);
        testutil_sleep_ms(5);
    }
    if (rogue[0].tasks == 0)
        fail_msg("the rogue was given no task");
    testutil_worker_t honest;
    testutil_worker_hello(f, &honest, "honest", 1);

    job_state_t st = JOB_QUEUED;
    double next_status = 0;
    while (clock_now_s() < end) {
        honest_pump(&honest);
        for (int i = 0; i < nrogue; i++)
            rogue_pump(f, &rogue[i]);
        /* Each time its newest connection got a task, it says HELLO again on a fresh one. */
        if (rogue[nrogue - 1].tasks > 0 && nrogue < MAX_ROGUE)
            rogue_hello(f, &rogue[nrogue++]);
        if (clock_now_s() < next_status)
            continue;
        next_status = clock_now_s() + 0.1;
        st = testutil_status(f, job, NULL, 0).state;
        if (st == JOB_DONE || st == JOB_FAILED)
            break;
    }
    int taken = 0;
    for (int i = 0; i < nrogue; i++)
        taken += rogue[i].tasks;
    if (st != JOB_DONE)
        fail_msg("job %llu is %s after the test's deadline (%.0f s): the rogue took %d tasks on "
                 "%d connections",
                 (unsigned long long)job, proto_job_state_name(st), test_wait_s(), taken, nrogue);
    testutil_worker_close(&honest);
    for (int i = 0; i < MAX_ROGUE; i++)
        net_destroy(&rogue_nets[i]);
}

/* Whether WORKERS shows a live worker named name blocked, waiting for it up to the deadline. */
static bool wait_blocked(fx_t *f, const char *name)
{
    double end = clock_now_s() + test_wait_s();
    int n, blocked;
    do {
        workers_named(f, name, &n, &blocked);
        if (blocked > 0)
            return true;
        testutil_sleep_ms(20);
    } while (clock_now_s() < end);
    return false;
}

/* A worker that sends results that are refused (a copy of another worker's task) and nothing
 * else is blocked after max_worker_failures_in_row of them (finding 6 of issue 26: hundreds
 * were never cut off); the block is journaled (a restarted master blocks it again when it says
 * HELLO), WORKERS shows it, and `unblock` lifts it. */
static void test_refused_results_block_the_worker(void **state)
{
    fx_t *f = *state;
    testutil_worker_t honest, rogue;
    testutil_worker_hello(f, &honest, "honest", 1);
    uint64_t job = testutil_submit_tiny(f, SPP, 0);
    proto_msg_t t;
    do {
        if (testutil_worker_recv(&honest, &t, test_wait_ms()) < 0)
            fail_msg("the honest worker got no TASK");
        if (t.type == PROTO_TASK)
            break;
        proto_msg_free(&t);
    } while (1);
    assert_int_equal(t.task.job, job);
    testutil_worker_hello(f, &rogue, ROGUE_NAME, 4096);
    tilebuf_t *tb = testutil_worker_render(&honest, &t);
    proto_task_stats_t stats = {.samples = 1, .elapsed = 0.01};
    for (int k = 0; k < f->opts.sched.max_worker_failures_in_row; k++)
        testutil_worker_result(&rogue, &t, tb, stats);
    if (!wait_blocked(f, ROGUE_NAME))
        fail_msg("the rogue is not blocked after %d refused results",
                 f->opts.sched.max_worker_failures_in_row);
    /* The honest worker's own result is still taken. */
    testutil_worker_result(&honest, &t, tb, stats);
    tilebuf_destroy(&tb);
    proto_msg_free(&t);
    testutil_worker_close(&rogue);
    testutil_worker_close(&honest);

    /* Journaled: a restarted master blocks it as soon as it says HELLO again. */
    assert_int_equal(testutil_master_stop(f), 0);
    if (testutil_master_start(f) < 0)
        fail_msg("master_run: %s", f->err);
    testutil_worker_hello(f, &rogue, ROGUE_NAME, 4096);
    if (!wait_blocked(f, ROGUE_NAME))
        fail_msg("a restarted master does not block the rogue");
    proto_msg_t req = {.type = PROTO_ACT, .act = {.act = PROTO_ACT_UNBLOCK, .worker = ROGUE_NAME}},
                r;
    testutil_call(f, &req, &r);
    if (r.type != PROTO_WORKERS_REPLY)
        fail_msg("unblock answered %s: %s", proto_type_name(r.type),
                 r.type == PROTO_ERROR ? r.error.message : "");
    proto_msg_free(&r);
    int n, blocked;
    workers_named(f, ROGUE_NAME, &n, &blocked);
    assert_true(n >= 1);
    assert_int_equal(blocked, 0);
    testutil_worker_close(&rogue);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_rogue_key_does_not_stall_a_job, setup, teardown),
        cmocka_unit_test_setup_teardown(test_refused_results_block_the_worker, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
