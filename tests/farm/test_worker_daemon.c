/* worker_daemon against a fake master on inproc://: the HELLO / WELCOME / TASK /
 * SCENE_REQUEST / SCENE / RESULT conversation, results equal to a local render_tile, a failed
 * scene reported as TASK_FAILED, and reconnection when the master goes quiet; over TCP, a busy
 * master (silent, its link up) waited for and a closed one reconnected to; jobs of one bundle
 * and settings share one loaded scene. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <zmq.h>

#include "bundle.h"
#include "clock.h"
#include "files_testutil.h"
#include "net.h"
#include "render.h"
#include "scene_load.h"
#include "scene_shelf.h"
#include "test_wait.h"
#include "worker_daemon.h"

typedef struct fixture {
    void *ctx;
    net_t *router;
    pthread_t thread;
    volatile sig_atomic_t stop;
    worker_opts_t opts;
    int rc;
    atomic_int returned; /* worker_run has returned */
    char cache[128];
    char endpoint[256];
    uint8_t *scene_bytes;
    size_t scene_size;
    scene_shelf_t *shelf; /* the worker's scenes, when the test watches them */
} fixture_t;

static void *run_worker(void *arg)
{
    fixture_t *f = arg;
    err_t err;
    f->rc = worker_run(&f->opts, &err);
    if (f->rc)
        fprintf(stderr, "worker_run: %s\n", err.msg);
    atomic_store(&f->returned, 1);
    return NULL;
}

static int setup_threads = 2;
static int setup_shelf = 0;

static int setup_at(void **state, const char *endpoint)
{
    fixture_t *f = calloc(1, sizeof *f);
    f->ctx = zmq_ctx_new();
    f->router = net_new(f->ctx, NET_ROUTER, NULL, NULL);
    if (!f->router || net_bind(f->router, endpoint, NULL) ||
        net_endpoint(f->router, f->endpoint, sizeof f->endpoint, NULL))
        return -1;
    if (testutil_mkdtemp(f->cache, sizeof f->cache, "worker") < 0)
        return -1;
    f->scene_bytes = (uint8_t *)testutil_slurp("data/render/tiny.pbrt", &f->scene_size);
    if (!f->scene_bytes)
        return -1;
    f->opts = (worker_opts_t){.endpoint = f->endpoint, .zmq_ctx = f->ctx, .threads = setup_threads,
                              .name = "test-worker", .cache_dir = f->cache, .stop = &f->stop,
                              .reconnect_max_ms = 200,
                              .insecure = 1 /* loopback TCP in a test */};
    if (setup_shelf && !(f->shelf = f->opts.shelf = scene_shelf_new(NULL)))
        return -1;
    pthread_create(&f->thread, NULL, run_worker, f);
    *state = f;
    return 0;
}

static int setup(void **state)
{
    return setup_at(state, "inproc://master-workers");
}

/* Over TCP, where libzmq's handshake tells the worker its link is up. */
static int setup_tcp(void **state)
{
    return setup_at(state, "tcp://127.0.0.1:*");
}

/* One render thread: a task queued behind another waits for it. */
static int setup_one_thread(void **state)
{
    setup_threads = 1;
    int rc = setup_at(state, "inproc://master-workers-1");
    setup_threads = 2;
    return rc;
}

/* A shelf of the test's, whose counts it reads. */
static int setup_shared(void **state)
{
    setup_shelf = 1;
    int rc = setup_at(state, "inproc://master-workers-shelf");
    setup_shelf = 0;
    return rc;
}

static int teardown(void **state)
{
    fixture_t *f = *state;
    f->stop = 1;
    pthread_join(f->thread, NULL);
    scene_shelf_destroy(&f->shelf);
    net_destroy(&f->router);
    zmq_ctx_term(f->ctx);
    int r = testutil_rmtree(f->cache);
    free(f->scene_bytes);
    free(f);
    return r;
}

/* Receives messages until one of the wanted type arrives (heartbeats are skipped), up to the
 * deadline of a wait (test_wait.h). */
static void expect(fixture_t *f, proto_type_t type, proto_peer_t *from, proto_msg_t *m)
{
    for (double until = clock_now_s() + test_wait_s(); clock_now_s() < until;) {
        err_t err;
        int r = net_recv(f->router, from, m, 50, &err);
        if (r == PROTO_EAGAIN)
            continue;
        if (r != 0)
            fail_msg("recv: %s", err.msg);
        if (m->type == type)
            return;
        proto_msg_free(m);
    }
    fail_msg("no %s from the worker within %.0f s", proto_type_name(type), test_wait_s());
}

static proto_bundle_file_t FILES[1];

static proto_bundle_t bundle_of(fixture_t *f, const char *name)
{
    FILES[0] = (proto_bundle_file_t){.path = name, .data = f->scene_bytes, .size = f->scene_size};
    return (proto_bundle_t){.main = name, .files = FILES, .nfiles = 1};
}

static void send_to(fixture_t *f, const proto_peer_t *to, const proto_msg_t *m)
{
    err_t err;
    if (net_send(f->router, to, m, &err))
        fail_msg("send %s: %s", proto_type_name(m->type), err.msg);
}

static void test_task_round_trip(void **state)
{
    fixture_t *f = *state;
    proto_peer_t w;
    proto_msg_t m;
    expect(f, PROTO_HELLO, &w, &m);
    assert_string_equal(m.hello.name, "test-worker");
    assert_int_equal(m.hello.threads, 2);
    proto_msg_free(&m);
    proto_msg_t welcome = {.type = PROTO_WELCOME, .welcome = {.worker_id = 1, .heartbeat_ms = 1000}};
    send_to(f, &w, &welcome);

    proto_bundle_t b = bundle_of(f, "tiny.pbrt");
    char hash[PROTO_HASH_HEX + 1];
    assert_int_equal(proto_bundle_hash(&b, hash, NULL), 0);
    proto_msg_t task = {.type = PROTO_TASK};
    task.task.job = 7;
    task.task.task = 3;
    task.task.attempt = 1;
    snprintf(task.task.scene, sizeof task.task.scene, "%s", hash);
    task.task.settings = (proto_settings_t){.seed = -1, .dispersion = "fanout"};
    task.task.kind = PROTO_KIND_CAMERA_TILE;
    task.task.tile = (proto_tile_t){.x0 = 8, .y0 = 4, .w = 8, .h = 6, .sample_begin = 2, .sample_end = 4};
    send_to(f, &w, &task);
    expect(f, PROTO_SCENE_REQUEST, &w, &m);
    assert_string_equal(m.scene_request.scene, hash);
    proto_msg_free(&m);
    proto_msg_t scene = {.type = PROTO_SCENE, .scene = {.bundle = b}};
    snprintf(scene.scene.scene, sizeof scene.scene.scene, "%s", hash);
    send_to(f, &w, &scene);
    expect(f, PROTO_RESULT, &w, &m);
    assert_int_equal(m.result.job, 7);
    assert_int_equal(m.result.task, 3);
    assert_int_equal(m.result.tile.rect.x0, 8);
    assert_int_equal(m.result.tile.nbuckets, 8);

    /* The same tile rendered here, with the same overrides, gives the same bytes. */
    scene_overrides_t ov = {.seed = -1, .dispersion = "fanout"};
    err_t err;
    scene_t *sc = scene_load_file("data/render/tiny.pbrt", &ov, &err);
    assert_non_null(sc);
    tilebuf_t *t = tilebuf_new(8, 4, 8, 6, sc->settings.grid.n, &err);
    assert_int_equal(render_tile(sc, NULL, 8, 4, 8, 6, 2, 4, t, NULL, &err), 0);
    /* The worker sends its pass's sums rounded by tilebuf's rule (float32 on the wire). */
    assert_int_equal(tilebuf_round_sums(t), 0);
    assert_int_equal(m.result.tile.sums_bits, 32);
    assert_memory_equal(m.result.tile.sums, tilebuf_sums(t), 8 * 6 * 8 * sizeof(double));
    assert_memory_equal(m.result.tile.counts, tilebuf_counts(t), 8 * 6 * sizeof(uint64_t));
    assert_true(m.result.stats.samples == 8 * 6 * 2);
    proto_msg_free(&m);
    tilebuf_destroy(&t);
    scene_destroy(&sc);

    /* A second task of the same scene needs no SCENE_REQUEST: the bundle is cached. */
    task.task.task = 4;
    task.task.tile.x0 = 0;
    send_to(f, &w, &task);
    expect(f, PROTO_RESULT, &w, &m);
    assert_int_equal(m.result.task, 4);
    proto_msg_free(&m);

    /* A bundle whose scene is broken: the task fails with the loader's message. */
    static const char broken[] = "WorldBegin\nShape \"sphere\" \"float radius\" [ 1 2 ]\n";
    proto_bundle_file_t bf = {.path = "bad.pbrt", .data = (const uint8_t *)broken, .size = sizeof broken - 1};
    proto_bundle_t bb = {.main = "bad.pbrt", .files = &bf, .nfiles = 1};
    assert_int_equal(proto_bundle_hash(&bb, hash, NULL), 0);
    task.task.job = 8;
    snprintf(task.task.scene, sizeof task.task.scene, "%s", hash);
    send_to(f, &w, &task);
    expect(f, PROTO_SCENE_REQUEST, &w, &m);
    proto_msg_free(&m);
    scene.scene.bundle = bb;
    snprintf(scene.scene.scene, sizeof scene.scene.scene, "%s", hash);
    send_to(f, &w, &scene);
    expect(f, PROTO_TASK_FAILED, &w, &m);
    assert_int_equal(m.task_failed.job, 8);
    if (!strstr(m.task_failed.error, "bad.pbrt:2:"))
        fail_msg("unexpected error: %s", m.task_failed.error);
    proto_msg_free(&m);

    /* A SCENE whose bundle does not match its hash is rejected, never cached. */
    task.task.job = 9;
    snprintf(task.task.scene, sizeof task.task.scene, "%064d", 0);
    send_to(f, &w, &task);
    expect(f, PROTO_SCENE_REQUEST, &w, &m);
    proto_msg_free(&m);
    scene.scene.bundle = b;
    snprintf(scene.scene.scene, sizeof scene.scene.scene, "%064d", 0);
    err_t serr;
    /* The encoder itself refuses a mismatching SCENE, so this cannot even be sent. */
    assert_int_not_equal(net_send(f->router, &w, &scene, &serr), 0);
}

/* The worker's HELLO, answered by a WELCOME with heartbeats every heartbeat_ms; *w is it. */
static void welcome(fixture_t *f, proto_peer_t *w, int heartbeat_ms)
{
    proto_msg_t m;
    expect(f, PROTO_HELLO, w, &m);
    proto_msg_free(&m);
    proto_msg_t msg = {.type = PROTO_WELCOME,
                       .welcome = {.worker_id = 1, .heartbeat_ms = heartbeat_ms}};
    send_to(f, w, &msg);
}

/* Issue 15: the worker loads a scene once per bundle and settings, not once per job. Jobs 7
 * and 8 of one bundle with the same settings share a load (job 7's slot still holds it); job
 * 9, with another spp, has a scene of its own. */
static void test_jobs_of_one_bundle_share_a_scene(void **state)
{
    fixture_t *f = *state;
    proto_peer_t w;
    proto_msg_t m;
    welcome(f, &w, 1000);
    proto_bundle_t b = bundle_of(f, "tiny.pbrt");
    char hash[PROTO_HASH_HEX + 1];
    assert_int_equal(proto_bundle_hash(&b, hash, NULL), 0);
    proto_msg_t task = {.type = PROTO_TASK};
    task.task.task = 1;
    task.task.attempt = 1;
    snprintf(task.task.scene, sizeof task.task.scene, "%s", hash);
    task.task.kind = PROTO_KIND_CAMERA_TILE;
    task.task.tile = (proto_tile_t){.x0 = 0, .y0 = 0, .w = 8, .h = 8, .sample_begin = 0, .sample_end = 1};
    const struct {
        uint64_t job;
        int spp;
    } jobs[] = {{7, 0}, {8, 0}, {9, 2}};
    for (int i = 0; i < 3; i++) {
        task.task.job = jobs[i].job;
        task.task.settings = (proto_settings_t){.seed = -1, .spp = jobs[i].spp};
        send_to(f, &w, &task);
        if (i == 0) {
            expect(f, PROTO_SCENE_REQUEST, &w, &m);
            proto_msg_free(&m);
            proto_msg_t scene = {.type = PROTO_SCENE, .scene = {.bundle = b}};
            snprintf(scene.scene.scene, sizeof scene.scene.scene, "%s", hash);
            send_to(f, &w, &scene);
        }
        expect(f, PROTO_RESULT, &w, &m);
        assert_int_equal(m.result.job, jobs[i].job);
        proto_msg_free(&m);
    }
    scene_shelf_stats_t st = scene_shelf_stats(f->shelf);
    assert_int_equal(st.loads, 2);
    assert_int_equal(st.shares, 1);
}

/* Issue 16, item 10: a cancelled tile stops within a row, and so does a worker told to stop.
 * One render thread; a task of 2^24 samples per pixel over the whole image (hours of work) runs
 * while a small task of another job waits behind it. The long task's job is cancelled: the
 * small task's RESULT must come back within the deadline of a wait (it used to wait for the
 * long tile to end). Then another long task, and the worker is stopped: its thread must be
 * joined within the deadline (it used to stay until the tile was done). */
static void test_cancel_stops_a_long_tile(void **state)
{
    fixture_t *f = *state;
    proto_peer_t w;
    welcome(f, &w, 1000);
    proto_bundle_t b = bundle_of(f, "tiny.pbrt");
    char hash[PROTO_HASH_HEX + 1];
    assert_int_equal(proto_bundle_hash(&b, hash, NULL), 0);
    proto_msg_t task = {.type = PROTO_TASK};
    snprintf(task.task.scene, sizeof task.task.scene, "%s", hash);
    task.task.settings = (proto_settings_t){.seed = -1};
    task.task.kind = PROTO_KIND_CAMERA_TILE;
    task.task.attempt = 1;
    /* A small task of job 7 first: its RESULT says the scene is loaded and the thread free. */
    task.task.job = 7;
    task.task.task = 1;
    task.task.tile = (proto_tile_t){.x0 = 0, .y0 = 0, .w = 8, .h = 8, .sample_begin = 0, .sample_end = 1};
    send_to(f, &w, &task);
    proto_msg_t m;
    expect(f, PROTO_SCENE_REQUEST, &w, &m);
    proto_msg_free(&m);
    proto_msg_t scene = {.type = PROTO_SCENE, .scene = {.bundle = b}};
    snprintf(scene.scene.scene, sizeof scene.scene.scene, "%s", hash);
    send_to(f, &w, &scene);
    expect(f, PROTO_RESULT, &w, &m);
    proto_msg_free(&m);
    /* The long one, then a small one of job 8 behind it. */
    task.task.task = 2;
    task.task.tile = (proto_tile_t){.x0 = 0, .y0 = 0, .w = 24, .h = 16, .sample_begin = 0,
                                    .sample_end = 1u << 24};
    send_to(f, &w, &task);
    task.task.job = 8;
    task.task.task = 3;
    task.task.tile = (proto_tile_t){.x0 = 0, .y0 = 0, .w = 8, .h = 8, .sample_begin = 0, .sample_end = 1};
    send_to(f, &w, &task);
    proto_msg_t cancel = {.type = PROTO_CANCEL, .cancel = {.job = 7}};
    send_to(f, &w, &cancel);
    expect(f, PROTO_RESULT, &w, &m);
    assert_int_equal(m.result.job, 8);
    assert_int_equal(m.result.task, 3);
    proto_msg_free(&m);
    /* A long task of job 9, and the worker stopped while it renders. */
    task.task.job = 9;
    task.task.task = 4;
    task.task.tile = (proto_tile_t){.x0 = 0, .y0 = 0, .w = 24, .h = 16, .sample_begin = 0,
                                    .sample_end = 1u << 24};
    send_to(f, &w, &task);
    struct timespec pause = {0, 50 * 1000 * 1000}; /* not a measurement: lets it start, or not */
    nanosleep(&pause, NULL);
    f->stop = 1;
    for (double until = clock_now_s() + test_wait_s(); !atomic_load(&f->returned);) {
        if (clock_now_s() > until)
            fail_msg("the worker did not stop within %.0f s of being told to: its render thread "
                     "finishes the tile first",
                     test_wait_s());
        nanosleep(&pause, NULL);
    }
}

/* A master that stops answering: the worker reconnects and says HELLO again. */
static void test_reconnects_when_master_is_silent(void **state)
{
    fixture_t *f = *state;
    proto_peer_t w;
    proto_msg_t m;
    welcome(f, &w, 100);
    expect(f, PROTO_HEARTBEAT, &w, &m);
    proto_msg_free(&m);
    /* Say nothing: after 3 heartbeat intervals the worker gives up on this connection. */
    expect(f, PROTO_HELLO, &w, &m);
    proto_msg_free(&m);
}

/* A master whose loop is busy (a large EXR, a checkpoint) says nothing while its libzmq I/O
 * thread keeps the TCP link up: the worker waits for it, sending heartbeats, instead of
 * dropping the connection and the tasks it holds. When the master's socket really goes, the
 * link drops and the worker says HELLO to the master that takes its place. */
static void test_waits_for_busy_master_over_tcp(void **state)
{
    fixture_t *f = *state;
    proto_peer_t w;
    proto_msg_t m;
    welcome(f, &w, 100);
    /* Silence until the worker has sent 15 heartbeats, one per 100 ms of its own clock: it has
     * then seen 1.5 s of silence, five times the 3 heartbeats after which a dead master is given
     * up, however slowly this machine runs it -- and has gone on heartbeating, not said HELLO. */
    int heartbeats = 0;
    double t0 = clock_now_s();
    while (heartbeats < 15) {
        if (clock_now_s() - t0 > test_wait_s())
            fail_msg("%d heartbeats from the worker in %.0f s", heartbeats, test_wait_s());
        err_t err;
        int r = net_recv(f->router, &w, &m, 50, &err);
        if (r == PROTO_EAGAIN)
            continue;
        if (r != 0)
            fail_msg("recv: %s", err.msg);
        if (m.type == PROTO_HELLO)
            fail_msg("the worker reconnected to a busy master after %d heartbeats (%.2f s)",
                     heartbeats, clock_now_s() - t0);
        heartbeats += m.type == PROTO_HEARTBEAT;
        proto_msg_free(&m);
    }
    /* The master's socket closes; a new one binds the same port. */
    net_destroy(&f->router);
    f->router = net_new(f->ctx, NET_ROUTER, NULL, NULL);
    assert_non_null(f->router);
    /* libzmq closes the old listener in its I/O thread, a moment after the socket. */
    err_t err;
    int bound = -1;
    for (double until = clock_now_s() + test_wait_s(); bound != 0 && clock_now_s() < until;) {
        bound = net_bind(f->router, f->endpoint, &err);
        if (bound != 0)
            nanosleep(&(struct timespec){.tv_nsec = 20000000}, NULL);
    }
    if (bound != 0)
        fail_msg("bind %s again: %s", f->endpoint, err.msg);
    expect(f, PROTO_HELLO, &w, &m);
    proto_msg_free(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_task_round_trip, setup, teardown),
        cmocka_unit_test_setup_teardown(test_reconnects_when_master_is_silent, setup, teardown),
        cmocka_unit_test_setup_teardown(test_cancel_stops_a_long_tile, setup_one_thread, teardown),
        cmocka_unit_test_setup_teardown(test_waits_for_busy_master_over_tcp, setup_tcp, teardown),
        cmocka_unit_test_setup_teardown(test_jobs_of_one_bundle_share_a_scene, setup_shared,
                                        teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
