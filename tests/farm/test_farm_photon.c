/* The photon pass on the farm (docs/farm.md, "Photon jobs"): photon batches traced by the workers,
 * merged by the master in batch order and sent back as one store for the camera phase, give the
 * pixels of `prismfarm render --direct` (one machine, every photon) -- with the photon map and with
 * light maps, with one or two workers, with a worker killed during the photon phase -- and a
 * job refined with more photons gives the pixels of the scene rendered with that many from the
 * start. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#define CLI_RUN_TIMEOUT_MS 240000
#include "cli_run.h"
#include "farm_testutil.h"
#include "image_exr.h"

#include <signal.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* `prismfarm render --direct` of data/photon/NAME.pbrt (one machine, every photon): the
 * reference the farm's pixels must equal, in the scratch folder as direct-NAME.exr. Rendered
 * once per run: the cases that compare with the same scene share it. */
static const char *direct(const char *name)
{
    static char out[16][600];
    static int n;
    char file[64], scene[128];
    snprintf(file, sizeof file, "direct-%s.exr", name);
    snprintf(scene, sizeof scene, "data/photon/%s.pbrt", name);
    char *path = out[n++ % 16];
    snprintf(path, sizeof out[0], "%s", testutil_scratch(file));
    struct stat st;
    if (stat(path, &st) == 0)
        return path;
    const run_t *r = run("render", scene, "--direct", "-o", path, "--quiet", NULL);
    if (r->status != 0)
        fail_msg("render --direct %s: exit %d: %s", scene, r->status, r->err);
    return path;
}

/* The in-process farm (`prismfarm render`) with two workers of one thread against --direct,
 * for both stores, and with volume photons in fog. */
static void test_in_process_both_stores(void **state)
{
    (void)state;
    /* beam_fog: volume photons travel and merge with the surface photons. */
    const char *names[] = {"beam", "beam_lightmap", "beam_fog"};
    for (int i = 0; i < 3; i++) {
        char scene[128];
        snprintf(scene, sizeof scene, "data/photon/%s.pbrt", names[i]);
        const run_t *r = run("render", scene, "--workers", "2", "--threads", "1", "--tile", "16",
                             "-o", testutil_scratch("farm.exr"), "--quiet", NULL);
        if (r->status != 0)
            fail_msg("render %s: exit %d: %s", scene, r->status, r->err);
        testutil_assert_same_pixels(direct(names[i]), testutil_scratch("farm.exr"));
    }
}

/* A job's EXR records its photons in the "prismfarm" attribute. */
static void expect_photons(const char *exr, const char *photons)
{
    err_t err;
    image_exr_t *x = image_exr_read(exr, &err);
    if (!x)
        fail_msg("%s", err.msg);
    const char *info = image_exr_attribute(x, "prismfarm");
    assert_non_null(info);
    char want[64];
    snprintf(want, sizeof want, "photons=%s;", photons);
    if (!strstr(info, want))
        fail_msg("expected '%s' in '%s'", want, info);
    expect_in(info, "integrator=photon+path;");
    image_exr_destroy(&x);
}

/* The state ("idle", "busy", "lost") the master lists for the first worker of this name in
 * `workers --json` output, into state[32]; "" when it lists none. */
static void worker_state(const char *json, const char *name, char *state)
{
    char key[64];
    snprintf(key, sizeof key, "\"name\": \"%s\"", name);
    state[0] = 0;
    const char *at = strstr(json, key);
    const char *end = at ? strchr(at, '}') : NULL;
    const char *s = at ? strstr(at, "\"state\": \"") : NULL;
    if (s && (!end || s < end))
        sscanf(s + strlen("\"state\": \""), "%31[a-z]", state);
}

/* Separate master and worker processes: a job, its refinement, and a worker killed in the
 * photon phase of a bigger job. */
static void test_processes_refine_and_kill(void **state)
{
    (void)state;
    const char *spool = testutil_scratch("spool");
    pid_t master =
        testutil_start_master(testutil_scratch("master.log"), spool, "tcp://127.0.0.1:*",
                              "tcp://127.0.0.1:*", "--heartbeat", "200", "--tile", "16", NULL);
    char wep[256], cep[256];
    testutil_read_endpoints(spool, wep, cep, testutil_scratch("master.log"));

    /* The client following the job shows the photon phase on a line of its own (photons merged
     * of the pass, their rate, ETA) before the samples' line: it is first seen with no worker
     * yet, so its start is on the line whatever the machine's speed. */
    const char *wlog = testutil_scratch("wait.log");
    pid_t waiter =
        testutil_spawn(wlog, "submit", "data/photon/beam.pbrt", "--master", cep, "--name", "beam",
                       "--wait", "-o", testutil_scratch("job.exr"), NULL);
    testutil_wait_file_has(wlog, "photons:   0.0%");
    pid_t w1 = testutil_start_worker(testutil_scratch("w1.log"), wep, "w1", testutil_scratch("c1"));
    pid_t w2 = testutil_start_worker(testutil_scratch("w2.log"), wep, "w2", testutil_scratch("c2"));
    int st = testutil_stop(waiter, 0);
    if (!WIFEXITED(st) || WEXITSTATUS(st) != 0)
        testutil_fail_quoting(wlog, "submit --wait: status %d:", st);
    testutil_expect_file_has(wlog, " 0 of 30000 photons");
    testutil_expect_file_has(wlog, "photons: 100.0%");
    testutil_expect_file_has(wlog, "Mphotons/s");
    testutil_expect_file_has(wlog, "30000 of 30000 photons");
    testutil_expect_file_has(wlog, "job: 100.0%");
    char *wtext = testutil_slurp(wlog, NULL);
    assert_non_null(wtext);
    const char *photons_end = strstr(wtext, "photons: 100.0%"), *samples = strstr(wtext, "job: ");
    const bool phases_in_order = photons_end && samples && samples > photons_end;
    free(wtext);
    if (!phases_in_order)
        testutil_fail_quoting(wlog, "the samples' line began before the photon phase ended:");
    const run_t *r;
    testutil_assert_same_pixels(testutil_scratch("job.exr"), direct("beam"));
    expect_photons(testutil_scratch("job.exr"), "30000");

    /* 20000 more photons: the store then holds photons [0, 50000), as beam_more.pbrt's. */
    r = run("refine", "1", "--photons", "20000", "--master", cep, "--wait", "-o",
            testutil_scratch("refined.exr"), "--quiet", NULL);
    if (r->status != 0)
        fail_msg("refine --wait: exit %d: %s", r->status, r->err);
    expect_in(r->out, "job 1 refined");
    testutil_assert_same_pixels(testutil_scratch("refined.exr"), direct("beam_more"));
    expect_photons(testutil_scratch("refined.exr"), "50000");
    /* The job's log holds the refinement with every other action on it, and names photon
     * batches as requeue and logs JOB TASK take them (p0, not the wire's 2147483648). */
    r = run("logs", "1", "--master", cep, NULL);
    if (r->status != 0)
        fail_msg("logs: exit %d: %s", r->status, r->err);
    expect_in(r->out, "job refined by ");
    expect_in(r->out, ": 20000 more photons in ");
    expect_in(r->out, "task p0 (photon batch 0) attempt 1 assigned to worker ");
    assert_null(strstr(r->out, "2147483648"));
    r = run("logs", "1", "p0", "--master", cep, NULL);
    if (r->status != 0)
        fail_msg("logs 1 p0: exit %d: %s", r->status, r->err);
    expect_in(r->out, "task p0 ");
    assert_null(strstr(r->out, "task p1 "));

    /* What refine refuses: a job that does not exist, bad arguments. */
    r = run("refine", "7", "--photons", "10", "--master", cep, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "no job 7");
    r = run("refine", "1", "--master", cep, NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "--photons N is required");
    r = run("refine", "1", "--photons", "0", "--master", cep, NULL);
    assert_int_equal(r->status, 2);

    /* A job without a photon pass cannot be refined. */
    r = run("submit", "data/render/tiny.pbrt", "--master", cep, "--wait", "-o",
            testutil_scratch("tiny.exr"), "--quiet", NULL);
    if (r->status != 0)
        fail_msg("submit tiny: exit %d: %s", r->status, r->err);
    r = run("refine", "2", "--photons", "10", "--master", cep, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "has no photon pass");

    /* A worker killed while it holds photon batches: they are traced again elsewhere and the
     * pixels are those of one machine's pass. */
    r = run("submit", "data/photon/beam_big.pbrt", "--master", cep, "--name", "big", NULL);
    if (r->status != 0)
        fail_msg("submit big: exit %d: %s", r->status, r->err);
    assert_string_equal(r->out, "3\n");
    /* Killed once the master lists it busy: it holds batches of the job's photon phase. */
    for (double until = testutil_now_s() + test_wait_s();; testutil_sleep_ms(20)) {
        r = run("workers", "--master", cep, "--json", NULL);
        assert_int_equal(r->status, 0);
        char state[32];
        worker_state(r->out, "w2", state);
        if (!strcmp(state, "busy"))
            break;
        if (testutil_now_s() > until)
            fail_msg("w2 not busy with job 3 after %.0f s:\n%s", test_wait_s(), r->out);
    }
    testutil_stop(w2, SIGKILL);
    for (double until = testutil_now_s() + test_wait_s();; testutil_sleep_ms(100)) {
        r = run("status", "3", "--master", cep, "--json", NULL);
        assert_int_equal(r->status, 0);
        if (strstr(r->out, "\"done\"") || strstr(r->out, "\"failed\"") || testutil_now_s() > until)
            break;
    }
    expect_in(r->out, "\"state\": \"done\"");
    r = run("fetch", "3", "-o", testutil_scratch("big.exr"), "--master", cep, NULL);
    if (r->status != 0)
        fail_msg("fetch: %s", r->err);
    testutil_assert_same_pixels(testutil_scratch("big.exr"), direct("beam_big"));

    testutil_stop(w1, SIGTERM);
    testutil_stop(master, SIGTERM);
    /* The master said what it did: batches merged, the store sent, the refinement. */
    const char *mlog = testutil_scratch("master.log");
    testutil_expect_file_has(mlog, "job 1 photon pass merged: 30000 photons in 2 batches");
    /* The finished job's store went to disk and came back for the refinement: one batch for
     * the first 30000 photons, one for the new 20000. */
    testutil_expect_file_has(mlog, "job 1 photon pass merged: 50000 photons in 2 batches");
    if (testutil_file_has(mlog, "keeping its photon store in memory"))
        testutil_fail_quoting(mlog, "the master could not save a photon store:");
    testutil_expect_file_has(mlog, "refined job 1 'beam': 20000 more photons in 1 batch (");
    testutil_expect_file_has(mlog, "photon store ");
    /* w2 died holding batches of job 3 (it prefetches two): the photon phase could only end
     * after the master gave them to w1. */
    char *log = testutil_slurp(mlog, NULL);
    assert_non_null(log);
    const char *lost = strstr(log, "'w2' lost"), *merged = strstr(log, "job 3 photon pass merged");
    int in_order = lost && merged && lost < merged;
    free(log);
    if (!in_order)
        testutil_fail_quoting(mlog, "expected w2 lost before job 3's photon pass merged:");
}

/* A copy of data/photon/FILE in folder dir, with the Integrator line replaced by integrator
 * (NULL: as it is). */
static void copy_scene(const char *file, const char *dir, const char *as, const char *integrator)
{
    char src[512], dst[1200];
    snprintf(src, sizeof src, "data/photon/%s", file);
    char *text = testutil_slurp(src, NULL);
    assert_non_null(text);
    snprintf(dst, sizeof dst, "%s/%s", dir, as);
    FILE *f = fopen(dst, "w");
    assert_non_null(f);
    for (char *line = strtok(text, "\n"); line; line = strtok(NULL, "\n"))
        fprintf(f, "%s\n", integrator && !strncmp(line, "Integrator ", 11) ? integrator : line);
    assert_int_equal(fclose(f), 0);
    free(text);
}

/* Refining a frame sequence refines each of its photon frames: the photon frame then has the
 * pixels of its scene with the photons added, the other frame its own; a sequence without
 * photon frames, or one not finished, is refused and left as it was. */
static void test_refine_sequence(void **state)
{
    (void)state;
    const char *spool = testutil_scratch("sspool");
    pid_t master =
        testutil_start_master(testutil_scratch("smaster.log"), spool, "tcp://127.0.0.1:*",
                              "tcp://127.0.0.1:*", "--heartbeat", "200", "--tile", "16", NULL);
    char wep[256], cep[256];
    testutil_read_endpoints(spool, wep, cep, testutil_scratch("smaster.log"));
    pid_t w = testutil_start_worker(testutil_scratch("sw.log"), wep, "sw", testutil_scratch("sc"));
    char dir[1024], f1[1100], f2[1100], out[1100], exr[1200];
    snprintf(dir, sizeof dir, "%s", testutil_scratch("seq"));
    assert_int_equal(mkdir(dir, 0755), 0);
    copy_scene("world.pbrt", dir, "world.pbrt", NULL);
    copy_scene("prism.pbrt", dir, "prism.pbrt", NULL);
    copy_scene("beam.pbrt", dir, "shot1.pbrt", NULL);
    copy_scene("beam.pbrt", dir, "shot2.pbrt", "Integrator \"path\" \"integer maxdepth\" [ 6 ]");
    snprintf(f1, sizeof f1, "%s/shot1.pbrt", dir);
    snprintf(f2, sizeof f2, "%s/shot2.pbrt", dir);

    const run_t *r;
    /* Job 1 with frames 2 (photon) and 3 (path), still running when refined: refused. */
    r = run("submit", f1, f2, "--master", cep, "--spp", "65536", NULL);
    assert_int_equal(r->status, 0);
    assert_string_equal(r->out, "1\n");
    r = run("refine", "1", "--photons", "20000", "--master", cep, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "job 1: frame 1: job 2 is ");
    expect_in(r->err, ": only a finished job can be refined");
    r = run("cancel", "1", "--master", cep, NULL);
    assert_int_equal(r->status, 0);
    /* Job 4, frames 5 and 6, rendered to their end, then refined as one. */
    r = run("submit", f1, f2, "--master", cep, "--wait", "--quiet", "-o",
            testutil_scratch("s%d.exr"), NULL);
    if (r->status != 0)
        fail_msg("submit the sequence: exit %d: %s", r->status, r->err);
    snprintf(out, sizeof out, "%s/r%%d.exr", testutil_scratch_dir());
    r = run("refine", "4", "--photons", "20000", "--master", cep, "--wait", "-o", out, "--quiet",
            NULL);
    if (r->status != 0)
        fail_msg("refine 4 --wait: exit %d: %s", r->status, r->err);
    expect_in(r->out, "job 4 refined");
    snprintf(exr, sizeof exr, "%s/r1.exr", testutil_scratch_dir());
    testutil_assert_same_pixels(exr, direct("beam_more"));
    expect_photons(exr, "50000");
    snprintf(exr, sizeof exr, "%s/r2.exr", testutil_scratch_dir());
    testutil_assert_same_pixels(exr, testutil_scratch("s2.exr"));
    r = run("status", "4", "--master", cep, "--json", NULL);
    assert_int_equal(r->status, 0);
    assert_int_equal(testutil_count_in(r->out, "\"state\": \"done\""), 3);

    /* A sequence of path frames only: refused. Job 7, frames 8 and 9. */
    copy_scene("beam.pbrt", dir, "shot3.pbrt", "Integrator \"path\" \"integer maxdepth\" [ 5 ]");
    char f3[1100];
    snprintf(f3, sizeof f3, "%s/shot3.pbrt", dir);
    r = run("submit", f2, f3, "--master", cep, "--wait", "--quiet", "-o",
            testutil_scratch("p%d.exr"), NULL);
    if (r->status != 0)
        fail_msg("submit path frames: exit %d: %s", r->status, r->err);
    r = run("refine", "7", "--photons", "10", "--master", cep, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "job 7 is a sequence of 2 frames, none with a photon pass to refine");
    testutil_stop(w, SIGTERM);
    testutil_stop(master, SIGTERM);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_in_process_both_stores),
        cmocka_unit_test(test_processes_refine_and_kill),
        cmocka_unit_test_teardown(test_refine_sequence, testutil_kill_children),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_keys_setup, testutil_scratch_teardown);
}
