/* master: the daemon loop driven by fake workers and clients (proto_net DEALERs) over inproc://
 * and tcp://127.0.0.1 with ports the system chooses. A job's life from SUBMIT to FETCH, with
 * real render_tile results: the EXR holds exactly the sum of the tiles' passes in pass order
 * (docs/farm.md), and matches a local render to float rounding; a broken scene refused with its
 * file:line; a silent worker's tasks re-issued to another worker with identical pixel data;
 * malformed bytes and another protocol version refused while the master keeps serving; cancel
 * and repeated task failures; STATUS long polls, task prefetch and preview spacing. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <dirent.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <fcntl.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>
#include <zmq.h>

#include "bundle.h"
#include "clock.h"
#include "farm_testutil.h"
#include "image_exr.h"
#include "local_render.h"
#include "master.h"
#include "master_testutil.h"
#include "net.h"
#include "polar_pilot.h"
#include "render.h"
#include "scene_load.h"
#include "settings.h"
#include "test_wait.h"
#include "worker_daemon.h"

/* The test scene: 24 x 16 pixels, 4 spp, 8 buckets (tests/data/render/tiny.pbrt). With 8-pixel
 * tiles that is 3 x 2 = 6 tiles and, by farm.md's passes [0,1) [1,2) [2,4), 3 passes: 18 tasks. */
#define TILE 8
#define XRES 24
#define YRES 16
#define SPP 4
#define NBUCKETS 8
#define NTILES 6
#define NTASKS 18
#define HEARTBEAT_MS 100

typedef testutil_master_t fx_t;
typedef testutil_worker_t fake_worker_t;

/* Starts a master on tcp://127.0.0.1 with system-chosen ports (tcp != 0) or on inproc://;
 * prefetch 0 and a preview after every pass unless farm_defaults. A worker silent for
 * worker_timeout_s is lost; 0 means never in a test (the deadline of a wait, test_wait.h). */
static int start(void **state, int tcp, int max_task_failures, int farm_defaults,
                 double worker_timeout_s)
{
    fx_t *f = testutil_master_new("master", tcp != 0, HEARTBEAT_MS);
    if (!f)
        return -1;
    *state = f;
    f->opts.sched.tile_size = TILE;
    /* A fake worker heartbeats only while the test waits for a message (testutil_worker_recv),
     * not while it renders a tile or asks the master something: without a timeout of its own a
     * test has the deadline's (master_testutil.h), so it never loses a worker by accident. */
    if (worker_timeout_s > 0)
        f->opts.sched.worker_timeout_s = worker_timeout_s;
    f->opts.sched.max_task_failures = max_task_failures;
    f->opts.sched.max_worker_job_failures = 10;
    /* These tests count the TASKs a worker of N threads is sent and fetch the preview of the
     * first pass: no prefetch, a preview after every pass. test_prefetch_and_previews sets
     * the defaults back. */
    f->opts.task_prefetch = 0;
    f->opts.preview_interval_s = 0;
    if (farm_defaults) {
        f->opts.task_prefetch = master_opts_default().task_prefetch;
        /* Far longer than the test job takes, however loaded the machine. */
        f->opts.preview_interval_s = 30;
    }
    return testutil_master_start(f);
}

static int setup_inproc(void **state)
{
    return start(state, 0, 4, 0, 0);
}

/* The lost-worker test: a worker silent for 2 s is lost. The worker that stays heartbeats every
 * 100 ms while it waits for tasks and is silent only while it renders one (milliseconds). */
static int setup_losing(void **state)
{
    return start(state, 0, 4, 0, 2.0);
}

static int setup_tcp(void **state)
{
    return start(state, 1, 4, 0, 0);
}

static int setup_failing(void **state)
{
    return start(state, 0, 3, 0, 0);
}

static int setup_defaults(void **state)
{
    return start(state, 0, 4, 1, 0);
}

static int teardown(void **state)
{
    return testutil_master_destroy((fx_t **)state);
}

/* ---------------------------------------------------------------- peers */

static proto_bundle_file_t FILES[1];

static proto_bundle_t tiny_bundle(fx_t *f)
{
    FILES[0] =
        (proto_bundle_file_t){.path = "tiny.pbrt", .data = f->scene_bytes, .size = f->scene_size};
    return (proto_bundle_t){.main = "tiny.pbrt", .files = FILES, .nfiles = 1};
}

static void fw_result(fake_worker_t *w, const proto_msg_t *t, const tilebuf_t *tb)
{
    testutil_worker_result(w, t, tb, (proto_task_stats_t){.samples = 1});
}

/* ---------------------------------------------------------------- the expected image */

/* The job rendered here by farm.md's rule, independently of sched: 8-pixel tiles, passes of
 * sample indices [0,1) [1,2) [2,4), each pass's sums rounded (tilebuf_round_sums) and each
 * tile's passes summed in pass order. */
/* tiny.pbrt as the master renders the job: polarisation as the plan decides it once for the job
 * (render/polar_pilot.h), which the TASKs carry to the workers. */
static scene_t *load_tiny_as_planned(void)
{
    err_t err;
    scene_overrides_t ov = {.spp = SPP, .seed = -1};
    scene_t *sc = scene_load_file("data/render/tiny.pbrt", &ov, &err);
    assert_non_null(sc);
    polar_decision_t polar;
    assert_int_equal(polar_pilot_decide(sc, 0.0, &polar, &err), 0);
    polar_pilot_record(sc, &polar);
    return sc;
}

static tilebuf_t *expected_image(void)
{
    err_t err;
    scene_t *sc = load_tiny_as_planned();
    tilebuf_t *image = tilebuf_new(0, 0, XRES, YRES, NBUCKETS, &err);
    static const uint32_t passes[][2] = {{0, 1}, {1, 2}, {2, 4}};
    for (int p = 0; p < 3; p++)
        for (int ty = 0; ty < YRES; ty += TILE)
            for (int tx = 0; tx < XRES; tx += TILE) {
                tilebuf_t *t = tilebuf_new(tx, ty, TILE, TILE, NBUCKETS, &err);
                assert_int_equal(
                    render_tile(sc, NULL, tx, ty, TILE, TILE, passes[p][0], passes[p][1], t, NULL, &err),
                    0);
                tilebuf_round_sums(t);
                assert_int_equal(tilebuf_merge(image, t, &err), 0);
                tilebuf_destroy(&t);
            }
    scene_destroy(&sc);
    return image;
}

/* FETCHes the job's EXR and checks its spectral pixels: bit-identical (as float32) to the
 * expected image's bucket means, and equal to a local render of the same scene (one render_tile
 * over [0, 4) per tile) to float rounding. The two sums differ only in how 4 non-negative
 * doubles are associated (relative difference < 4 * 2^-53), so after rounding to float32 they
 * differ by at most one float ulp: a relative tolerance of 2^-22 (two ulps) is generous. */
static void check_exr(fx_t *f, uint64_t job)
{
    proto_msg_t req = {.type = PROTO_FETCH, .fetch = {.job = job, .what = PROTO_FETCH_EXR}}, r;
    testutil_call(f, &req, &r);
    if (r.type != PROTO_FILE)
        fail_msg("FETCH exr answered %s: %s", proto_type_name(r.type),
                 r.type == PROTO_ERROR ? r.error.message : "");
    assert_string_equal(r.file.name, "tiny.exr");
    char path[128];
    snprintf(path, sizeof path, "%s/fetched.exr", f->spool);
    FILE *out = fopen(path, "wb");
    assert_non_null(out);
    assert_int_equal(fwrite(r.file.data, 1, r.file.size, out), r.file.size);
    fclose(out);
    proto_msg_free(&r);
    err_t err;
    image_exr_t *exr = image_exr_read(path, &err);
    if (!exr)
        fail_msg("%s", err.msg);
    assert_int_equal(image_exr_width(exr), XRES);
    assert_int_equal(image_exr_height(exr), YRES);
    assert_int_equal(image_exr_n_spectral(exr), NBUCKETS);
    const float *spec = image_exr_spectral(exr);

    tilebuf_t *want = expected_image();
    scene_t *sc = load_tiny_as_planned();
    tilebuf_t *local = tilebuf_new(0, 0, XRES, YRES, NBUCKETS, &err);
    local_render_opts_t lo = {.threads = 1, .tile_size = TILE};
    assert_int_equal(local_render(sc, &lo, local, NULL, NULL, &err), 0);
    int exact = 0, near = 0, nonzero = 0;
    double a[NBUCKETS], b[NBUCKETS];
    for (int y = 0; y < YRES; y++)
        for (int x = 0; x < XRES; x++) {
            tilebuf_mean(want, x, y, a);
            tilebuf_mean(local, x, y, b);
            assert_true(tilebuf_count(want, x, y) == SPP);
            for (int k = 0; k < NBUCKETS; k++) {
                float got = spec[((size_t)y * XRES + (size_t)x) * NBUCKETS + (size_t)k];
                exact += got == (float)a[k];
                near += fabs((double)got - b[k]) <= 0x1p-22 * fmax(fabs((double)got), fabs(b[k]));
                nonzero += got > 0;
            }
        }
    assert_int_equal(exact, XRES * YRES * NBUCKETS);
    assert_int_equal(near, XRES * YRES * NBUCKETS);
    assert_true(nonzero > XRES * YRES * NBUCKETS / 2); /* a lit scene, not a black image */
    tilebuf_destroy(&want);
    tilebuf_destroy(&local);
    scene_destroy(&sc);
    image_exr_destroy(&exr);
}

/* ---------------------------------------------------------------- tests */

/* SUBMIT, TASKs, SCENE_REQUEST, RESULTs, a progressive preview, then the final EXR; over tcp
 * with system-chosen ports. */
static void test_job_life(void **state)
{
    fx_t *f = *state;
    assert_non_null(strstr(f->wep, "tcp://127.0.0.1:"));
    assert_null(strchr(f->wep, '*'));
    char path[256], line[300];
    snprintf(path, sizeof path, "%s/endpoints", f->spool);
    FILE *ep = fopen(path, "r");
    assert_non_null(ep);
    assert_non_null(fgets(line, sizeof line, ep));
    fclose(ep);
    assert_true(!strncmp(line, "workers ", 8) && !strncmp(line + 8, f->wep, strlen(f->wep)));

    uint64_t job = testutil_submit_tiny(f, SPP, 0);
    assert_true(job == 1);
    proto_job_info_t info = testutil_status(f, job, NULL, 0);
    assert_int_equal(info.state, JOB_QUEUED);
    assert_true(info.samples_total == (uint64_t)XRES * YRES * SPP);
    proto_msg_t req = {.type = PROTO_FETCH, .fetch = {.job = job, .what = PROTO_FETCH_EXR}}, r;
    testutil_call(f, &req, &r);
    assert_int_equal(r.type, PROTO_ERROR);
    proto_msg_free(&r);

    fake_worker_t w;
    testutil_worker_hello(f, &w, "fake", 2);
    proto_bundle_t b = tiny_bundle(f);
    char hash[PROTO_HASH_HEX + 1];
    assert_int_equal(proto_bundle_hash(&b, hash, NULL), 0);
    int done = 0, asked = 0, previewed = 0;
    uint32_t seen[NTASKS] = {0};
    while (done < NTASKS) {
        proto_msg_t m;
        if (testutil_worker_recv(&w, &m, test_wait_ms()))
            fail_msg("no task after %d results", done);
        if (m.type == PROTO_SCENE) {
            assert_string_equal(m.scene.scene, hash);
            assert_string_equal(m.scene.bundle.main, "tiny.pbrt");
            assert_int_equal(m.scene.bundle.nfiles, 1);
            assert_int_equal(m.scene.bundle.files[0].size, f->scene_size);
            assert_memory_equal(m.scene.bundle.files[0].data, f->scene_bytes, f->scene_size);
            asked = 2;
            proto_msg_free(&m);
            continue;
        }
        assert_int_equal(m.type, PROTO_TASK);
        assert_true(m.task.job == job);
        assert_string_equal(m.task.scene, hash);
        assert_int_equal(m.task.settings.spp, SPP);
        assert_true(m.task.task < NTASKS);
        if (!asked) {
            proto_msg_t sr = {.type = PROTO_SCENE_REQUEST};
            memcpy(sr.scene_request.scene, m.task.scene, sizeof sr.scene_request.scene);
            testutil_worker_send(&w, &sr);
            asked = 1;
        }
        seen[m.task.task]++;
        tilebuf_t *tb = testutil_worker_render(&w, &m);
        fw_result(&w, &m, tb);
        tilebuf_destroy(&tb);
        proto_msg_free(&m);
        done++;
        if (done == NTILES) {
            /* Pass 0 is whole: a preview PNG can be fetched while the job runs. */
            proto_msg_t fr = {.type = PROTO_FETCH, .fetch = {.job = job, .what = PROTO_FETCH_PNG}};
            for (double until = clock_now_s() + test_wait_s(); !previewed && clock_now_s() < until;) {
                testutil_call(f, &fr, &r);
                if (r.type == PROTO_FILE) {
                    assert_string_equal(r.file.name, "tiny-preview.png");
                    assert_memory_equal(r.file.data, "\x89PNG\r\n\x1a\n", 8);
                    previewed = 1;
                }
                proto_msg_free(&r);
                testutil_sleep_ms(10);
            }
        }
    }
    assert_int_equal(asked, 2);
    assert_true(previewed);
    for (int i = 0; i < NTASKS; i++)
        assert_int_equal(seen[i], 1);
    testutil_wait_state(f, job, JOB_DONE);
    info = testutil_status(f, job, NULL, 0);
    assert_true(info.samples_done == (uint64_t)XRES * YRES * SPP);
    assert_true(info.samples_done == info.samples_total);
    assert_true(info.nonfinite == 0);
    check_exr(f, job);
    req.fetch.what = PROTO_FETCH_PNG;
    testutil_call(f, &req, &r);
    assert_int_equal(r.type, PROTO_FILE);
    assert_string_equal(r.file.name, "tiny.png");
    proto_msg_free(&r);

    proto_msg_t wq = {.type = PROTO_WORKERS};
    testutil_call(f, &wq, &r);
    assert_int_equal(r.type, PROTO_WORKERS_REPLY);
    assert_int_equal(r.workers_reply.nworkers, 1);
    assert_string_equal(r.workers_reply.workers[0].name, "fake");
    assert_true(r.workers_reply.workers[0].tasks_done == NTASKS);
    assert_int_equal(r.workers_reply.workers[0].state, PROTO_WORKER_IDLE);
    proto_msg_free(&r);
    proto_msg_t jq = {.type = PROTO_JOBS};
    testutil_call(f, &jq, &r);
    assert_int_equal(r.type, PROTO_JOBS_REPLY);
    assert_int_equal(r.jobs_reply.njobs, 1);
    assert_string_equal(r.jobs_reply.jobs[0].name, "tiny.pbrt");
    assert_int_equal(r.jobs_reply.jobs[0].state, JOB_DONE);
    proto_msg_free(&r);
    testutil_worker_close(&w);
}

/* Issue 16, item 2: a worker returns a result for a task the master gave another worker, and one
 * for a task it never gave anyone. Both used to be merged (first result wins): the job was done
 * with those tiles wrong. Now both are refused and logged with the worker and its key's name,
 * the honest results are merged, and the job's pixels are exact. */
static void test_forged_results(void **state)
{
    fx_t *f = *state;
    fake_worker_t w[2];
    testutil_worker_hello(f, &w[0], "honest", 1);
    testutil_worker_hello(f, &w[1], "forger", 1);
    uint64_t job = testutil_submit_tiny(f, SPP, 0);
    proto_msg_t t[2];
    for (int i = 0; i < 2; i++) {
        do {
            if (testutil_worker_recv(&w[i], &t[i], test_wait_ms()))
                fail_msg("worker %d got no task", i);
        } while (t[i].type != PROTO_TASK && (proto_msg_free(&t[i]), 1));
    }
    assert_true(t[0].task.task != t[1].task.task);
    /* The master's log, for the refusals: stderr into a file while the forger works. */
    char logpath[128];
    snprintf(logpath, sizeof logpath, "%s/master.log", f->spool);
    fflush(stderr);
    int saved = dup(2), fd = open(logpath, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    assert_true(saved >= 0 && fd >= 0);
    dup2(fd, 2);
    close(fd);
    f->opts.verbose = true;
    err_t err;
    /* A zero tile over the honest worker's task, and over a task of pass 2 never issued. */
    proto_msg_t forged = t[0];
    forged.task.task = t[0].task.task;
    tilebuf_t *zero = tilebuf_new(t[0].task.tile.x0, t[0].task.tile.y0, t[0].task.tile.w,
                                  t[0].task.tile.h, NBUCKETS, &err);
    assert_non_null(zero);
    fw_result(&w[1], &forged, zero);
    tilebuf_destroy(&zero);
    forged.task.task = (uint64_t)2 * NTILES; /* pass 2, tile 0: samples [2, 4) */
    forged.task.tile = (proto_tile_t){.x0 = 0, .y0 = 0, .w = TILE, .h = TILE, .sample_begin = 2,
                                      .sample_end = 4};
    forged.task.attempt = 1;
    zero = tilebuf_new(0, 0, TILE, TILE, NBUCKETS, &err);
    fw_result(&w[1], &forged, zero);
    tilebuf_destroy(&zero);
    /* Then both work honestly to the end. */
    int done = 0;
    for (int i = 0; i < 2; i++) {
        tilebuf_t *tb = testutil_worker_render(&w[i], &t[i]);
        fw_result(&w[i], &t[i], tb);
        tilebuf_destroy(&tb);
        proto_msg_free(&t[i]);
        done++;
    }
    double deadline = clock_now_s() + test_wait_s();
    while (done < NTASKS && clock_now_s() < deadline)
        for (int i = 0; i < 2; i++) {
            proto_msg_t m;
            if (testutil_worker_recv(&w[i], &m, 20))
                continue;
            if (m.type == PROTO_TASK) {
                tilebuf_t *tb = testutil_worker_render(&w[i], &m);
                fw_result(&w[i], &m, tb);
                tilebuf_destroy(&tb);
                done++;
            }
            proto_msg_free(&m);
        }
    assert_int_equal(done, NTASKS);
    testutil_wait_state(f, job, JOB_DONE);
    check_exr(f, job);
    f->opts.verbose = getenv("PRISMFARM_TEST_VERBOSE") != NULL;
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    char *log = testutil_slurp(logpath, NULL);
    assert_non_null(log);
    char want[256];
    snprintf(want, sizeof want,
             "refused a result from worker %llu 'forger' (key 'none: no CURVE') for job %llu "
             "task %u: that task was issued to worker %llu, not to this one",
             (unsigned long long)w[1].id, (unsigned long long)job, (unsigned)t[0].task.task,
             (unsigned long long)w[0].id);
    if (!strstr(log, want))
        fail_msg("no '%s' in the master's log:\n%s", want, log);
    snprintf(want, sizeof want, "for job %llu task %d: that task was never issued to any worker",
             (unsigned long long)job, 2 * NTILES);
    if (!strstr(log, want))
        fail_msg("no '%s' in the master's log:\n%s", want, log);
    free(log);
    testutil_worker_close(&w[0]);
    testutil_worker_close(&w[1]);
}

/* A scene that does not parse is refused at once with the loader's file:line:col, as the
 * bundle names the file, and nothing of it stays in the spool. */
static void test_broken_scene(void **state)
{
    fx_t *f = *state;
    size_t size;
    uint8_t *bytes = (uint8_t *)testutil_slurp("data/render/broken.pbrt", &size);
    assert_non_null(bytes);
    proto_bundle_file_t file = {.path = "scenes/broken.pbrt", .data = bytes, .size = size};
    proto_msg_t req = {
        .type = PROTO_SUBMIT,
        .submit = {.name = "broken",
                   .settings = {.seed = -1},
                   .bundle = {.main = "scenes/broken.pbrt", .files = &file, .nfiles = 1}}};
    proto_msg_t r;
    testutil_call(f, &req, &r);
    assert_int_equal(r.type, PROTO_ERROR);
    /* Line 4 of broken.pbrt is the LookAt with too few numbers. */
    if (strncmp(r.error.message, "scenes/broken.pbrt:4:", 21) || !strstr(r.error.message, "LookAt"))
        fail_msg("unexpected error: %s", r.error.message);
    assert_null(strstr(r.error.message, f->spool));
    proto_msg_free(&r);

    /* A valid scene with an override the loader rejects: also refused, naming the scene. */
    req.submit.name = "tiny";
    req.submit.bundle = tiny_bundle(f);
    req.submit.settings.integrator = "bogus";
    testutil_call(f, &req, &r);
    assert_int_equal(r.type, PROTO_ERROR);
    if (strncmp(r.error.message, "tiny.pbrt:", 10) || !strstr(r.error.message, "bogus"))
        fail_msg("unexpected error: %s", r.error.message);
    proto_msg_free(&r);
    free(bytes);

    /* A scene that names a file outside its bundle: the answer names the file but never shows
     * its contents (the first line of /etc/passwd starts "root:x:0:0"). */
    static const char *const evil[] = {
        "WorldBegin\nInclude \"/etc/passwd\"\n",
        "WorldBegin\nInclude \"../../../../../../../../etc/passwd\"\n"};
    for (int k = 0; k < 2; k++) {
        proto_bundle_file_t ef = {
            .path = "evil.pbrt", .data = (const uint8_t *)evil[k], .size = strlen(evil[k])};
        req.submit.settings.integrator = NULL;
        req.submit.bundle = (proto_bundle_t){.main = "evil.pbrt", .files = &ef, .nfiles = 1};
        testutil_call(f, &req, &r);
        assert_int_equal(r.type, PROTO_ERROR);
        if (!strstr(r.error.message, "etc/passwd") || strstr(r.error.message, "root:"))
            fail_msg("unexpected error: %s", r.error.message);
        proto_msg_free(&r);
    }

    char dir[128];
    snprintf(dir, sizeof dir, "%s/scenes", f->spool);
    assert_int_equal(testutil_count_entries(dir), 0);
    snprintf(dir, sizeof dir, "%s/tmp", f->spool);
    assert_int_equal(testutil_count_entries(dir), 0);
    proto_msg_t jq = {.type = PROTO_JOBS};
    testutil_call(f, &jq, &r);
    assert_int_equal(r.type, PROTO_JOBS_REPLY);
    assert_int_equal(r.jobs_reply.njobs, 0);
    proto_msg_free(&r);
}

/* The state the master lists for worker id. */
static proto_worker_state_t worker_state_of(fx_t *f, uint64_t id)
{
    proto_msg_t wq = {.type = PROTO_WORKERS}, r;
    testutil_call(f, &wq, &r);
    assert_int_equal(r.type, PROTO_WORKERS_REPLY);
    proto_worker_state_t state = PROTO_WORKER_IDLE;
    int found = 0;
    for (size_t i = 0; i < r.workers_reply.nworkers; i++)
        if (r.workers_reply.workers[i].id == id) {
            state = r.workers_reply.workers[i].state;
            found = 1;
        }
    proto_msg_free(&r);
    if (!found)
        fail_msg("the master lists no worker %llu", (unsigned long long)id);
    return state;
}

/* A worker that goes silent holding two tasks: once the master reports it lost (after the
 * timeout, not before) they are issued again to the other worker (attempt 2), the job completes
 * with the same pixel data, and the silent worker is told to say HELLO again when it
 * reappears. The other worker joins only after the loss, so that the silence that loses a
 * worker is only ever the silent one's. */
static void test_silent_worker(void **state)
{
    fx_t *f = *state;
    uint64_t job = testutil_submit_tiny(f, SPP, 0);
    fake_worker_t a, b;
    double t0 = clock_now_s(); /* before a's last message: its HELLO */
    testutil_worker_hello(f, &a, "silent", 2);
    proto_msg_t held[2];
    for (int i = 0; i < 2; i++) {
        testutil_expect(a.net, PROTO_TASK, &held[i]);
        assert_true(held[i].task.attempt == 1);
    }
    for (double until = clock_now_s() + test_wait_s();
         worker_state_of(f, a.id) != PROTO_WORKER_LOST; testutil_sleep_ms(20))
        if (clock_now_s() > until)
            fail_msg("the silent worker is not lost after %.0f s", test_wait_s());
    assert_true(clock_now_s() - t0 >= f->opts.sched.worker_timeout_s);
    testutil_worker_hello(f, &b, "steady", 2);
    int results[NTASKS] = {0};
    uint32_t reissued = 0;
    int done = 0;
    while (done < NTASKS) {
        proto_msg_t m;
        if (testutil_worker_recv(&b, &m, test_wait_ms()))
            fail_msg("worker b got nothing after %d results", done);
        assert_int_equal(m.type, PROTO_TASK);
        if (m.task.task == held[0].task.task || m.task.task == held[1].task.task) {
            assert_true(m.task.attempt == 2);
            reissued++;
            /* Not before the worker timeout has passed since a's HELLO. */
            assert_true(clock_now_s() - t0 >= f->opts.sched.worker_timeout_s);
        }
        tilebuf_t *tb = testutil_worker_render(&b, &m);
        fw_result(&b, &m, tb);
        tilebuf_destroy(&tb);
        results[m.task.task]++;
        done++;
        proto_msg_free(&m);
    }
    assert_int_equal(reissued, 2);
    for (int i = 0; i < NTASKS; i++)
        assert_int_equal(results[i], 1);
    testutil_wait_state(f, job, JOB_DONE);
    check_exr(f, job);

    proto_msg_t r;
    proto_msg_t wq = {.type = PROTO_WORKERS};
    testutil_call(f, &wq, &r);
    assert_int_equal(r.workers_reply.nworkers, 2);
    assert_string_equal(r.workers_reply.workers[0].name, "silent");
    assert_int_equal(r.workers_reply.workers[0].state, PROTO_WORKER_LOST);
    assert_true(r.workers_reply.workers[1].tasks_done == NTASKS);
    proto_msg_free(&r);

    /* The silent worker finally answers: its late result is harmless, and it must HELLO again. */
    tilebuf_t *tb = testutil_worker_render(&a, &held[0]);
    fw_result(&a, &held[0], tb);
    tilebuf_destroy(&tb);
    testutil_expect(a.net, PROTO_REFUSE, &r);
    assert_string_equal(r.refuse.reason, "unknown worker: send HELLO");
    proto_msg_free(&r);
    proto_msg_t hello = {.type = PROTO_HELLO,
                         .hello = {.name = "silent", .threads = 2, .software = "test"}};
    testutil_worker_send(&a, &hello);
    testutil_expect(a.net, PROTO_WELCOME, &r);
    assert_true(r.welcome.worker_id == a.id); /* the same connection keeps its id */
    proto_msg_free(&r);
    check_exr(f, job); /* the late copy changed nothing */
    for (int i = 0; i < 2; i++)
        proto_msg_free(&held[i]);
    testutil_worker_close(&a);
    testutil_worker_close(&b);
}

/* Garbage, extra frames, another protocol version and misdirected messages are refused, and the
 * master keeps serving. */
static void test_bad_peers(void **state)
{
    fx_t *f = *state;
    proto_msg_t r;
    const char *endpoints[2] = {f->wep, f->cep};
    for (int k = 0; k < 2; k++) {
        net_t *n = testutil_connect(f, endpoints[k]);
        void *s = net_socket(n);
        assert_int_equal(zmq_send(s, "\x81\xa1v", 3, 0), 3); /* a map cut short */
        testutil_expect(n, PROTO_REFUSE, &r);
        assert_non_null(strstr(r.refuse.reason, "malformed message"));
        proto_msg_free(&r);
        assert_int_equal(zmq_send(s, "a", 1, ZMQ_SNDMORE), 1);
        assert_int_equal(zmq_send(s, "b", 1, 0), 1);
        testutil_expect(n, PROTO_REFUSE, &r);
        assert_non_null(strstr(r.refuse.reason, "frames after the message"));
        proto_msg_free(&r);
        /* protocol.md: a peer of another version is refused with this exact text. */
        proto_msg_t hello = {.type = PROTO_HELLO,
                             .version = 4,
                             .hello = {.name = "future", .threads = 1, .software = "prismfarm 9"}};
        testutil_send(n, &hello);
        testutil_expect(n, PROTO_REFUSE, &r);
        assert_string_equal(r.refuse.reason,
                            "protocol version 4 not supported by this master (speaks 3)");
        proto_msg_free(&r);
        net_destroy(&n);
    }
    /* A worker message from a peer that never said HELLO. */
    net_t *w = testutil_connect(f, f->wep);
    proto_msg_t hb = {.type = PROTO_HEARTBEAT};
    testutil_send(w, &hb);
    testutil_expect(w, PROTO_REFUSE, &r);
    assert_string_equal(r.refuse.reason, "unknown worker: send HELLO");
    proto_msg_free(&r);
    net_destroy(&w);
    /* A worker's message on the client endpoint, and questions about jobs that do not exist. */
    proto_msg_t hello = {.type = PROTO_HELLO,
                         .hello = {.name = "lost", .threads = 1, .software = "x"}};
    testutil_call(f, &hello, &r);
    assert_int_equal(r.type, PROTO_ERROR);
    proto_msg_free(&r);
    proto_msg_t st = {.type = PROTO_STATUS, .status = {.job = 42}};
    testutil_call(f, &st, &r);
    assert_int_equal(r.type, PROTO_ERROR);
    assert_string_equal(r.error.message, "no job 42");
    proto_msg_free(&r);
    proto_msg_t fe = {.type = PROTO_FETCH, .fetch = {.job = 42, .what = PROTO_FETCH_PNG}};
    testutil_call(f, &fe, &r);
    assert_int_equal(r.type, PROTO_ERROR);
    proto_msg_free(&r);
    /* Still serving: a job runs to completion with a worker that joins now. */
    uint64_t job = testutil_submit_tiny(f, SPP, 0);
    fake_worker_t fw;
    testutil_worker_hello(f, &fw, "after", 4);
    for (int done = 0; done < NTASKS; done++) {
        proto_msg_t m;
        if (testutil_worker_recv(&fw, &m, test_wait_ms()))
            fail_msg("no task");
        assert_int_equal(m.type, PROTO_TASK);
        tilebuf_t *tb = testutil_worker_render(&fw, &m);
        fw_result(&fw, &m, tb);
        tilebuf_destroy(&tb);
        proto_msg_free(&m);
    }
    testutil_wait_state(f, job, JOB_DONE);
    testutil_worker_close(&fw);
}

/* CANCEL stops a running job, tells its workers, and the next job proceeds; the scene of a
 * second submission of the same bundle is stored once. */
static void test_cancel(void **state)
{
    fx_t *f = *state;
    uint64_t job = testutil_submit_tiny(f, SPP, 0);
    fake_worker_t w;
    testutil_worker_hello(f, &w, "w", 2);
    proto_msg_t t1, t2, r;
    testutil_expect(w.net, PROTO_TASK, &t1);
    testutil_expect(w.net, PROTO_TASK, &t2);
    proto_msg_t c = {.type = PROTO_CANCEL, .cancel = {.job = job}};
    testutil_call(f, &c, &r);
    assert_int_equal(r.type, PROTO_STATUS_REPLY);
    assert_int_equal(r.status_reply.njobs, 1);
    assert_int_equal(r.status_reply.jobs[0].state, JOB_CANCELLED);
    proto_msg_free(&r);
    proto_msg_t m;
    if (testutil_worker_recv(&w, &m, test_wait_ms()))
        fail_msg("no CANCEL for the worker");
    assert_int_equal(m.type, PROTO_CANCEL);
    assert_true(m.cancel.job == job);
    proto_msg_free(&m);
    /* A result that was already on its way is dropped. */
    tilebuf_t *tb = testutil_worker_render(&w, &t1);
    fw_result(&w, &t1, tb);
    tilebuf_destroy(&tb);
    proto_msg_t fe = {.type = PROTO_FETCH, .fetch = {.job = job, .what = PROTO_FETCH_EXR}};
    testutil_call(f, &fe, &r);
    assert_int_equal(r.type, PROTO_ERROR);
    assert_non_null(strstr(r.error.message, "cancelled"));
    proto_msg_free(&r);
    c.cancel.job = 77;
    testutil_call(f, &c, &r);
    assert_int_equal(r.type, PROTO_ERROR);
    proto_msg_free(&r);

    uint64_t job2 = testutil_submit_tiny(f, SPP, 0);
    assert_true(job2 == job + 1);
    /* The worker's two slots were freed by the cancel: two tasks of the new job follow. */
    for (int i = 0; i < 2; i++) {
        if (testutil_worker_recv(&w, &m, test_wait_ms()))
            fail_msg("no task of the second job");
        assert_int_equal(m.type, PROTO_TASK);
        assert_true(m.task.job == job2);
        proto_msg_free(&m);
    }
    char dir[128];
    snprintf(dir, sizeof dir, "%s/scenes", f->spool);
    assert_int_equal(testutil_count_entries(dir), 2); /* <hash>/ and <hash>.scene */
    proto_msg_free(&t1);
    proto_msg_free(&t2);
    testutil_worker_close(&w);
}

/* A task that fails max_task_failures (3) times fails its job with the last error, and the
 * workers are told to drop the job. */
static void test_failing_task(void **state)
{
    fx_t *f = *state;
    uint64_t job = testutil_submit_tiny(f, SPP, 0);
    fake_worker_t w;
    testutil_worker_hello(f, &w, "clumsy", 1);
    for (uint32_t attempt = 1; attempt <= 3; attempt++) {
        proto_msg_t m;
        testutil_expect(w.net, PROTO_TASK, &m);
        /* One slot: the failed task is the first pending one, so it comes straight back. */
        assert_true(m.task.task == 0);
        assert_true(m.task.attempt == attempt);
        proto_msg_t fail = {
            .type = PROTO_TASK_FAILED,
            .task_failed = {
                .job = job, .task = 0, .attempt = attempt, .error = "scene.pbrt:3:7: boom"}};
        testutil_worker_send(&w, &fail);
        proto_msg_free(&m);
    }
    proto_msg_t m;
    testutil_expect(w.net, PROTO_CANCEL, &m);
    assert_true(m.cancel.job == job);
    proto_msg_free(&m);
    char error[600];
    proto_job_info_t info = testutil_status(f, job, error, sizeof error);
    assert_int_equal(info.state, JOB_FAILED);
    if (!strstr(error, "3 times") || !strstr(error, "last error: scene.pbrt:3:7: boom"))
        fail_msg("unexpected error: %s", error);
    testutil_worker_close(&w);
}

typedef struct real_worker {
    worker_opts_t opts;
    volatile sig_atomic_t stop;
    char cache[64];
    int rc;
} real_worker_t;

static void *run_worker(void *arg)
{
    real_worker_t *w = arg;
    err_t err;
    w->rc = worker_run(&w->opts, &err);
    if (w->rc)
        fprintf(stderr, "worker_run: %s\n", err.msg);
    return NULL;
}

/* The farm's own worker daemon (worker/worker_daemon.h) against this master: the job completes
 * with the same EXR pixels as the fake workers' and the expected image. */
static void test_real_worker(void **state)
{
    fx_t *f = *state;
    real_worker_t w = {.rc = 0};
    assert_int_equal(testutil_mkdtemp(w.cache, sizeof w.cache, "master-worker"), 0);
    w.opts = (worker_opts_t){.endpoint = f->wep,
                             .zmq_ctx = f->ctx,
                             .threads = 2,
                             .name = "real",
                             .cache_dir = w.cache,
                             .stop = &w.stop,
                             .reconnect_max_ms = 200,
                             .verbose = f->opts.verbose};
    pthread_t th;
    pthread_create(&th, NULL, run_worker, &w);
    uint64_t job = testutil_submit_tiny(f, SPP, 0);
    testutil_wait_state(f, job, JOB_DONE);
    check_exr(f, job);
    w.stop = 1;
    pthread_join(th, NULL);
    assert_int_equal(w.rc, 0);
    assert_int_equal(testutil_rmtree(w.cache), 0);
}


/* Serves every task of the job with a fake worker until `total` results are sent; returns
 * the time the last one was sent. */
static double fw_serve(fake_worker_t *w, int total)
{
    double last = 0;
    for (int done = 0; done < total;) {
        proto_msg_t m;
        if (testutil_worker_recv(w, &m, test_wait_ms()))
            fail_msg("no task after %d results", done);
        if (m.type == PROTO_TASK) {
            tilebuf_t *tb = testutil_worker_render(w, &m);
            fw_result(w, &m, tb);
            last = clock_now_s();
            tilebuf_destroy(&tb);
            done++;
        }
        proto_msg_free(&m);
    }
    return last;
}

/* STATUS with `wait` (docs/protocol.md): held until the wait runs out while the job is
 * queued, answered the moment the job is done however long the wait, and at once for a job
 * that is over; `wait` beyond 60000 ms cannot be encoded, and a wait round-trips. */
static void test_status_long_poll(void **state)
{
    fx_t *f = *state;
    uint64_t job = testutil_submit_tiny(f, SPP, 0);

    /* No worker: the job stays queued, so the answer comes at the end of the wait (300 ms),
     * not before -- and then, not at the end of some longer wait: well before the 60 s the
     * next step waits (however loaded the machine, a held reply is due at 300 ms). */
    proto_msg_t req = {.type = PROTO_STATUS, .status = {.job = job, .wait_ms = 300}}, r;
    double t0 = clock_now_s();
    testutil_call(f, &req, &r);
    double waited = clock_now_s() - t0;
    assert_int_equal(r.type, PROTO_STATUS_REPLY);
    assert_int_equal(r.status_reply.jobs[0].state, JOB_QUEUED);
    proto_msg_free(&r);
    if (waited < 0.3 || waited > 30.0)
        fail_msg("a 300 ms long poll on a queued job was answered after %.3f s", waited);

    /* A 60 s wait (the longest) on a job that completes meanwhile: answered when the last
     * result is merged, not when the wait runs out. The job takes the fake worker milliseconds
     * and the reply is late by the merge, the EXR and a message; a master that answered only at
     * the end of the wait would answer 60 s after the question, one that polls rarely would
     * answer late by its period. Half the wait tells the two apart on any machine. */
    net_t *c = testutil_connect(f, f->cep);
    req.status.wait_ms = 60000;
    double asked = clock_now_s();
    testutil_send(c, &req);
    fake_worker_t w;
    testutil_worker_hello(f, &w, "fast", 2);
    double last = fw_serve(&w, NTASKS);
    testutil_recv(c, &r, 2 * 60000);
    double late = clock_now_s() - last, waited_all = clock_now_s() - asked;
    assert_int_equal(r.type, PROTO_STATUS_REPLY);
    assert_int_equal(r.status_reply.jobs[0].state, JOB_DONE);
    proto_msg_free(&r);
    net_destroy(&c);
    print_message("long poll answered %.3f s after the last result\n", late);
    if (waited_all > 30.0)
        fail_msg("the long poll was answered %.3f s after it was asked (%.3f s after the last "
                 "result), not when the job was done", waited_all, late);

    /* The job is over: a long poll on it is answered at once, not after its 60 s. */
    t0 = clock_now_s();
    testutil_call(f, &req, &r);
    assert_int_equal(r.type, PROTO_STATUS_REPLY);
    assert_int_equal(r.status_reply.jobs[0].state, JOB_DONE);
    proto_msg_free(&r);
    if (clock_now_s() - t0 > 30.0)
        fail_msg("a long poll on a finished job was answered after %.3f s", clock_now_s() - t0);

    /* The field on the wire: in range round-trips, out of range is refused by the encoder. */
    proto_limits_t lim = proto_limits_default();
    msgpack_sbuffer buf;
    msgpack_sbuffer_init(&buf);
    req.status.wait_ms = 1234;
    assert_int_equal(proto_encode(&req, &lim, &buf, NULL), 0);
    proto_msg_t back;
    assert_int_equal(proto_decode(buf.data, buf.size, &lim, &back, NULL), 0);
    assert_int_equal(back.type, PROTO_STATUS);
    assert_true(back.status.job == job && back.status.wait_ms == 1234);
    proto_msg_free(&back);
    msgpack_sbuffer_clear(&buf);
    req.status.wait_ms = 60001;
    err_t err;
    assert_int_equal(proto_encode(&req, &lim, &buf, &err), PROTO_EMALFORMED);
    assert_non_null(strstr(err.msg, "wait"));
    msgpack_sbuffer_destroy(&buf);
    testutil_worker_close(&w);
}

/* With the master's defaults, a worker of 2 threads is sent 4 tasks (twice its threads) and
 * the next one only when a result comes back; a job whose passes all finish within the
 * preview interval gets no preview, only its final EXR and PNG. */
static void test_prefetch_and_previews(void **state)
{
    fx_t *f = *state;
    uint64_t job = testutil_submit_tiny(f, SPP, 0);
    fake_worker_t w;
    testutil_worker_hello(f, &w, "prefetching", 2);
    proto_msg_t held[NTASKS];
    int nheld = 0, done = 0;
    for (; nheld < 4; nheld++)
        testutil_expect(w.net, PROTO_TASK, &held[nheld]);
    proto_msg_t m;
    if (testutil_worker_recv(&w, &m, 300) == 0)
        fail_msg("a fifth %s while 4 tasks are held by 2 threads", proto_type_name(m.type));
    /* One result frees one slot: exactly one TASK follows. */
    for (;;) {
        tilebuf_t *tb = testutil_worker_render(&w, &held[--nheld]);
        fw_result(&w, &held[nheld], tb);
        tilebuf_destroy(&tb);
        proto_msg_free(&held[nheld]);
        if (++done == NTASKS)
            break;
        if (done + nheld < NTASKS) {
            testutil_expect(w.net, PROTO_TASK, &held[nheld]);
            nheld++;
            assert_true(nheld <= 4);
        }
        if (done == 1 && testutil_worker_recv(&w, &m, 100) == 0)
            fail_msg("a second %s after one result", proto_type_name(m.type));
    }
    testutil_wait_state(f, job, JOB_DONE);
    check_exr(f, job);
    char path[256];
    snprintf(path, sizeof path, "%s/jobs/%llu/preview.png", f->spool, (unsigned long long)job);
    assert_int_equal(access(path, F_OK), -1);
    snprintf(path, sizeof path, "%s/jobs/%llu/tiny.png", f->spool, (unsigned long long)job);
    assert_int_equal(access(path, F_OK), 0);
    testutil_worker_close(&w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_job_life, setup_tcp, teardown),
        cmocka_unit_test_setup_teardown(test_broken_scene, setup_inproc, teardown),
        cmocka_unit_test_setup_teardown(test_forged_results, setup_inproc, teardown),
        cmocka_unit_test_setup_teardown(test_silent_worker, setup_losing, teardown),
        cmocka_unit_test_setup_teardown(test_bad_peers, setup_inproc, teardown),
        cmocka_unit_test_setup_teardown(test_cancel, setup_inproc, teardown),
        cmocka_unit_test_setup_teardown(test_failing_task, setup_failing, teardown),
        cmocka_unit_test_setup_teardown(test_real_worker, setup_inproc, teardown),
        cmocka_unit_test_setup_teardown(test_status_long_poll, setup_inproc, teardown),
        cmocka_unit_test_setup_teardown(test_prefetch_and_previews, setup_defaults, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
