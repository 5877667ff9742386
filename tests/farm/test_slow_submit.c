/* A submission whose scene takes longer to load than the client waits for a silent master
 * (issue 15: `prismfarm submit` and `render` gave up after 60 s while the master loaded):
 * the master answers the SUBMIT at once with a PROGRESS and sends one every PROGRESS_S while
 * the scene loads, each of which restarts the client's wait, so the real `prismfarm submit`
 * with --timeout 4 still gets its job after a load of 6 s and more.
 *
 * The slow load is real but held by the test, not timed: the master (in this process, on
 * ipc://) is given a scene shelf (scene_shelf.h) on which a thread of the test is loading the
 * submission's scene, behind a gate the test opens only once the client has printed the
 * master's third periodic PROGRESS -- at least 3 x PROGRESS_S = 6 s after the submission,
 * beyond the client's 4 s. The master's own load waits for that one, so the job's scene is the
 * one that took that long. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <zmq.h>

#include "bundle.h"
#include "farm_testutil.h"
#include "master.h"
#include "scene_load.h"
#include "scene_shelf.h"
#include "settings.h"
#include "test_wait.h"

typedef struct gate {
    pthread_mutex_t lock;
    pthread_cond_t cond;
    int started, open;
    const char *scene_path;
} gate_t;

static scene_t *gated_load(void *arg, err_t *err)
{
    gate_t *g = arg;
    pthread_mutex_lock(&g->lock);
    g->started = 1;
    pthread_cond_broadcast(&g->cond);
    while (!g->open)
        pthread_cond_wait(&g->cond, &g->lock);
    pthread_mutex_unlock(&g->lock);
    /* What `prismfarm submit` asks for: the file's own settings, seed -1 (settings.h). */
    scene_overrides_t ov = {.seed = -1};
    return scene_load_file(g->scene_path, &ov, err);
}

typedef struct slow_loader {
    pthread_t thread;
    scene_shelf_t *shelf;
    const char *key;
    gate_t *gate;
    scene_t *scene;
    err_t err;
} slow_loader_t;

static void *run_slow_loader(void *arg)
{
    slow_loader_t *s = arg;
    s->scene = scene_shelf_get(s->shelf, s->key, gated_load, s->gate, &s->err);
    return NULL;
}

typedef struct master_thread {
    pthread_t thread;
    master_opts_t opts;
    volatile sig_atomic_t stop;
    int rc;
    err_t err;
} master_thread_t;

static void *run_master(void *arg)
{
    master_thread_t *m = arg;
    m->rc = master_run(&m->opts, &m->err);
    return NULL;
}

static void test_load_longer_than_client_timeout(void **state)
{
    (void)state;
    /* The scene as the client bundles it: one file, the bundle's main file by its name. */
    size_t size = 0;
    uint8_t *bytes = (uint8_t *)testutil_slurp("data/render/tiny.pbrt", &size);
    assert_non_null(bytes);
    char scene_path[512], cep[600], wep[600], spool[512], log[512];
    snprintf(scene_path, sizeof scene_path, "%s", testutil_scratch("slow.pbrt"));
    snprintf(spool, sizeof spool, "%s", testutil_scratch("spool"));
    snprintf(log, sizeof log, "%s", testutil_scratch("submit.log"));
    snprintf(cep, sizeof cep, "ipc://%s", testutil_scratch("clients.ipc"));
    snprintf(wep, sizeof wep, "ipc://%s", testutil_scratch("workers.ipc"));
    testutil_write_text(scene_path, (const char *)bytes, 0644);
    proto_bundle_file_t file = {.path = "slow.pbrt", .data = bytes, .size = size};
    proto_bundle_t bundle = {.main = "slow.pbrt", .files = &file, .nfiles = 1};
    char hash[PROTO_HASH_HEX + 1], key[SETTINGS_KEY_SIZE];
    err_t err;
    if (proto_bundle_hash(&bundle, hash, &err) < 0)
        fail_msg("%s", err.msg);
    proto_settings_t settings = {.seed = -1};
    settings_scene_key(hash, bundle.main, &settings, key);

    scene_shelf_t *shelf = scene_shelf_new(&err);
    assert_non_null(shelf);
    gate_t gate = {.scene_path = scene_path};
    pthread_mutex_init(&gate.lock, NULL);
    pthread_cond_init(&gate.cond, NULL);
    slow_loader_t loader = {.shelf = shelf, .key = key, .gate = &gate};
    assert_int_equal(pthread_create(&loader.thread, NULL, run_slow_loader, &loader), 0);
    pthread_mutex_lock(&gate.lock);
    while (!gate.started)
        pthread_cond_wait(&gate.cond, &gate.lock);
    pthread_mutex_unlock(&gate.lock);

    void *ctx = zmq_ctx_new();
    assert_non_null(ctx);
    master_thread_t m = {.opts = master_opts_default()};
    m.opts.worker_endpoint = wep;
    m.opts.client_endpoint = cep;
    m.opts.spool_dir = spool;
    m.opts.zmq_ctx = ctx;
    m.opts.stop = &m.stop;
    m.opts.journal = 0;
    m.opts.verbose = 0;
    m.opts.shelf = shelf;
    assert_int_equal(pthread_create(&m.thread, NULL, run_master, &m), 0);
    char endpoints[600];
    snprintf(endpoints, sizeof endpoints, "%s/endpoints", spool);
    testutil_wait_file_has(endpoints, "clients ");

    pid_t submit =
        testutil_spawn(log, "submit", scene_path, "--master", cep, "--timeout", "4", NULL);
    /* At once: the bundle arrived (before any periodic PROGRESS). */
    testutil_wait_file_has(log, "prismfarm submit: the master received the scene (1 file");
    const char *periodic = "prismfarm submit: the master is loading the scene (";
    for (double until = testutil_now_s() + test_wait_s() + 10;
         testutil_file_count(log, periodic) < 3; testutil_sleep_ms(20)) {
        int st;
        if (waitpid(submit, &st, WNOHANG) == submit) {
            testutil_forget_child(submit);
            testutil_fail_quoting(log, "the client ended while the scene loaded; its stderr:");
        }
        if (testutil_now_s() > until)
            testutil_fail_quoting(log, "no third PROGRESS; the client's stderr:");
    }
    pthread_mutex_lock(&gate.lock);
    gate.open = 1;
    pthread_cond_broadcast(&gate.cond);
    pthread_mutex_unlock(&gate.lock);
    assert_int_equal(pthread_join(loader.thread, NULL), 0);
    if (!loader.scene)
        fail_msg("the slow load failed: %s", loader.err.msg);

    int st = testutil_stop(submit, 0); /* signal 0: only waits for its exit */
    assert_true(WIFEXITED(st));
    if (WEXITSTATUS(st) != 0)
        testutil_fail_quoting(log, "the slow submission failed; its stderr:");
    /* The master's job took the scene the test loaded slowly: one load, one share. */
    scene_shelf_stats_t stats = scene_shelf_stats(shelf);
    assert_int_equal(stats.loads, 1);
    assert_int_equal(stats.shares, 1);

    m.stop = 1;
    assert_int_equal(pthread_join(m.thread, NULL), 0);
    if (m.rc)
        fail_msg("master: %s", m.err.msg);
    scene_destroy(&loader.scene);
    scene_shelf_destroy(&shelf);
    zmq_ctx_term(ctx);
    pthread_cond_destroy(&gate.cond);
    pthread_mutex_destroy(&gate.lock);
    free(bytes);
}

static int teardown(void **state)
{
    testutil_kill_children(state);
    return testutil_scratch_teardown(state);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_load_longer_than_client_timeout),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_setup, teardown);
}
