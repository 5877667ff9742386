/* The farm end to end, as users run it: `prismfarm render` (a master and workers in one process) with 1 and 3 workers, and separate
 * master and worker processes on loopback TCP with a worker killed half-way, all giving
 * bit-identical EXR pixel data; the farm and `render --direct` giving the same pixels by
 * construction (per-pass float32 rounding of tile sums, docs/farm.md "Same pixels"), also for
 * sums beyond float's range; plus the client commands against a live master. The TCP farm
 * runs with CURVE keys (docs/security.md), as a real one does. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#define CLI_RUN_TIMEOUT_MS 120000
#include "cli_run.h"
#include "farm_testutil.h"
#include "image_exr.h"
#include "passes.h"
#include "polar_pilot.h"
#include "pool.h"
#include "render.h"
#include "scene_load.h"

#include <dirent.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#if defined(__SSE__)
#include <pmmintrin.h>
#include <xmmintrin.h>
#endif

static void test_render_any_worker_count(void **state)
{
    (void)state;
    /* The in-process farm's temporary spool (the scene, the job's outputs, the worker's cache
     * with the extracted bundle) goes in $TMPDIR and is removed, with everything in it. */
    const char *tmp = testutil_scratch("tmp");
    assert_int_equal(mkdir(tmp, 0700), 0);
    assert_int_equal(setenv("TMPDIR", tmp, 1), 0);
    const run_t *r = run("render", "data/render/tiny.pbrt", "-o", testutil_scratch("one.exr"),
                         "--workers", "1", "--threads", "1", "--tile", "8", "--quiet", NULL);
    assert_int_equal(unsetenv("TMPDIR"), 0);
    if (r->status != 0)
        fail_msg("exit %d: %s", r->status, r->err);
    expect_in(r->out, "wrote ");
    if (testutil_count_entries(tmp) != 0)
        fail_msg("%d entries left in the render's TMPDIR %s: %s", testutil_count_entries(tmp), tmp,
                 r->err);
    r = run("render", "data/render/tiny.pbrt", "-o", testutil_scratch("three.exr"), "--workers",
            "3", "--threads", "1", "--tile", "8", "--quiet", NULL);
    if (r->status != 0)
        fail_msg("exit %d: %s", r->status, r->err);
    testutil_assert_same_pixels(testutil_scratch("one.exr"), testutil_scratch("three.exr"));
    struct stat st;
    assert_int_equal(stat(testutil_scratch("three.png"), &st), 0);

    /* The plan decides polarisation once, before the job starts, and every worker renders
     * with its decision (render/polar_pilot.h): one scene it turns on (glass plates, a 6 %
     * change), one it leaves off (a metal reflects once: no change), 1 and 3 workers the same
     * bytes each. */
    const char *const polar[2][2] = {{"data/render/polar_on.pbrt", "polarisation on: "},
                                     {"data/render/polar_off.pbrt", "polarisation off: "}};
    for (int k = 0; k < 2; k++) {
        char one[64], three[64];
        snprintf(one, sizeof one, "polar%d_1.exr", k);
        snprintf(three, sizeof three, "polar%d_3.exr", k);
        r = run("render", polar[k][0], "-o", testutil_scratch(one), "--workers", "1", "--threads",
                "1", "--tile", "8", NULL);
        if (r->status != 0)
            fail_msg("%s: exit %d: %s", polar[k][0], r->status, r->err);
        expect_in(r->err, polar[k][1]);
        r = run("render", polar[k][0], "-o", testutil_scratch(three), "--workers", "3", "--threads",
                "1", "--tile", "4", "--quiet", NULL);
        if (r->status != 0)
            fail_msg("%s: exit %d: %s", polar[k][0], r->status, r->err);
        testutil_assert_same_pixels(testutil_scratch(one), testutil_scratch(three));
    }
}

/* The image docs/farm.md ("Same pixels") defines, computed here from render_tile alone: per
 * tile of size `tile` and per pass of the cut, the pass's sums rounded by tilebuf's rule, added
 * in pass order. With rounded = 0, the plain sums of one render_tile call over all samples
 * instead (what --direct summed before the rule). *wide counts pass sums that stayed doubles. */
static tilebuf_t *reference_image(const char *scene_path, int spp, int tile, int rounded,
                                  size_t *wide)
{
    err_t err;
    scene_overrides_t ov = {.spp = spp, .seed = -1};
    scene_t *sc = scene_load_file(scene_path, &ov, &err);
    if (!sc)
        fail_msg("%s", err.msg);
    /* Polarisation as the plan decides it for the job (render/polar_pilot.h). */
    polar_decision_t polar;
    if (polar_pilot_decide(sc, 0.0, &polar, &err) < 0)
        fail_msg("%s", err.msg);
    polar_pilot_record(sc, &polar);
    const render_settings_t *rs = &sc->settings;
#if defined(__SSE__)
    /* The floating-point mode of every render thread (base/pool.h sets it). */
    unsigned int csr = _mm_getcsr();
#endif
    pool_fp_mode_set();
    tilebuf_t *image = tilebuf_new(0, 0, rs->xres, rs->yres, rs->grid.n, &err);
    uint32_t b[PASSES_MAX_BOUNDS];
    int npasses = passes_bounds(spp, b);
    *wide = 0;
    for (int y0 = 0; y0 < rs->yres; y0 += tile)
        for (int x0 = 0; x0 < rs->xres; x0 += tile) {
            int w = rs->xres - x0 < tile ? rs->xres - x0 : tile;
            int h = rs->yres - y0 < tile ? rs->yres - y0 : tile;
            for (int p = 0; p < (rounded ? npasses : 1); p++) {
                tilebuf_t *t = tilebuf_new(x0, y0, w, h, rs->grid.n, &err);
                assert_int_equal(render_tile(sc, NULL, x0, y0, w, h, rounded ? b[p] : 0,
                                             rounded ? b[p + 1] : (uint32_t)spp, t, NULL, &err),
                                 0);
                if (rounded)
                    *wide += tilebuf_round_sums(t);
                assert_int_equal(tilebuf_merge(image, t, &err), 0);
                tilebuf_destroy(&t);
            }
        }
#if defined(__SSE__)
    _mm_setcsr(csr);
#endif
    scene_destroy(&sc);
    return image;
}

/* How many spectral values of the EXR differ from the float32 means of image. */
static size_t exr_differences(const char *exr, const tilebuf_t *image)
{
    err_t err;
    image_exr_t *x = image_exr_read(exr, &err);
    if (!x)
        fail_msg("%s", err.msg);
    int w = image_exr_width(x), h = image_exr_height(x), nb = image_exr_n_spectral(x);
    assert_int_equal(w, tilebuf_width(image));
    assert_int_equal(h, tilebuf_height(image));
    assert_int_equal(nb, tilebuf_nbuckets(image));
    const float *spec = image_exr_spectral(x);
    double mean[64];
    size_t n = 0;
    for (int y = 0; y < h; y++)
        for (int px = 0; px < w; px++) {
            tilebuf_mean(image, px, y, mean);
            for (int k = 0; k < nb; k++) {
                float want = (float)mean[k], got = spec[((size_t)y * (size_t)w + (size_t)px) * (size_t)nb + (size_t)k];
                n += memcmp(&want, &got, sizeof want) != 0;
            }
        }
    image_exr_destroy(&x);
    return n;
}

/* Farm (2 workers of 1 thread, 7-pixel tiles: the last column and row are partial) against
 * --direct (2 threads, its own 32-pixel tiles) at 24 spp (6 passes): the same pixels, and both
 * exactly the reference image of docs/farm.md's rule. The check has teeth: the plain sums of
 * one render_tile call (what --direct used to add) differ from it in some values. */
static void expect_farm_is_direct(const char *scene_path, const char *name, size_t *wide_out)
{
    char farm[64], direct[64];
    snprintf(farm, sizeof farm, "%s_farm.exr", name);
    snprintf(direct, sizeof direct, "%s_direct.exr", name);
    const run_t *r = run("render", scene_path, "--spp", "24", "-o", testutil_scratch(farm),
                         "--workers", "2", "--threads", "1", "--tile", "7", "--quiet", NULL);
    if (r->status != 0)
        fail_msg("farm: exit %d: %s", r->status, r->err);
    r = run("render", scene_path, "--spp", "24", "-o", testutil_scratch(direct), "--direct",
            "--threads", "2", "--quiet", NULL);
    if (r->status != 0)
        fail_msg("--direct: exit %d: %s", r->status, r->err);
    testutil_assert_same_pixels(testutil_scratch(farm), testutil_scratch(direct));
    size_t wide;
    tilebuf_t *ref = reference_image(scene_path, 24, 5, 1, &wide);
    size_t d = exr_differences(testutil_scratch(farm), ref);
    if (d != 0)
        fail_msg("%s: %zu values of the farm's image differ from the reference", name, d);
    tilebuf_destroy(&ref);
    size_t unused;
    tilebuf_t *plain = reference_image(scene_path, 24, 32, 0, &unused);
    d = exr_differences(testutil_scratch(farm), plain);
    print_message("%s: %zu of the pass sums stayed doubles; the unrounded sums differ in %zu "
                  "values of the EXR\n", name, wide, d);
    assert_true(d > 0);
    tilebuf_destroy(&plain);
    *wide_out = wide;
}

static void test_render_matches_direct(void **state)
{
    (void)state;
    size_t wide;
    expect_farm_is_direct("data/render/tiny.pbrt", "tiny", &wide);
    assert_int_equal(wide, 0); /* every tile travelled as float32 */

    /* A light of radiance 1e38 fills the middle of the view: a pass of 8 samples sums 8e38 >
     * FLT_MAX (3.4e38) in the pixels that see it, so those tiles travel as float64 -- and the
     * pixels are still --direct's. */
    const char *huge = testutil_scratch("huge.pbrt");
    FILE *f = fopen(huge, "w");
    assert_non_null(f);
    fprintf(f, "LookAt 0 0 -3  0 0 0  0 1 0\n"
               "Camera \"perspective\" \"float fov\" [ 40 ]\n"
               "Film \"spectral\" \"integer xresolution\" [ 16 ] \"integer yresolution\" [ 12 ]\n"
               "    \"integer nbuckets\" [ 8 ]\n"
               "Integrator \"path\" \"integer maxdepth\" [ 3 ]\n"
               "WorldBegin\n"
               "LightSource \"infinite\" \"float L\" [ 0.5 ]\n"
               "AttributeBegin\n"
               "AreaLightSource \"diffuse\" \"float L\" [ 1e38 ]\n"
               "Shape \"trianglemesh\" \"point3 P\" [ -0.5 -0.5 0  0.5 -0.5 0  0.5 0.5 0  -0.5 0.5 0 ]\n"
               "    \"integer indices\" [ 0 2 1  0 3 2 ]\n"
               "AttributeEnd\n"
               "Material \"dielectric\" \"string glass\" \"N-SF11\"\n"
               "Translate 0.9 0.3 0\n"
               "Shape \"sphere\" \"float radius\" [ 0.4 ]\n");
    assert_int_equal(fclose(f), 0);
    expect_farm_is_direct(huge, "huge", &wide);
    assert_true(wide > 0);
}

/* Separate processes over TCP on loopback; one worker is killed with SIGKILL while it holds
 * tasks. Its tasks go back to the queue, and the result is the same bytes as with one worker. */
static void test_processes_and_a_killed_worker(void **state)
{
    (void)state;
    const char *spool = testutil_scratch("spool");
    pid_t master =
        testutil_start_master(testutil_scratch("master.log"), spool, "tcp://127.0.0.1:*",
                              "tcp://127.0.0.1:*", "--heartbeat", "200", "--tile", "8", NULL);
    char wep[256], cep[256];
    testutil_read_endpoints(spool, wep, cep, testutil_scratch("master.log"));
    pid_t w1 = testutil_start_worker(testutil_scratch("w1.log"), wep, "w1", testutil_scratch("c1"));
    pid_t w2 = testutil_start_worker(testutil_scratch("w2.log"), wep, "w2", testutil_scratch("c2"));
    /* Both in service before the job, so that both are given its first tasks. */
    const run_t *r = NULL;
    for (double until = testutil_now_s() + test_wait_s();; testutil_sleep_ms(50)) {
        r = run("workers", "--master", cep, NULL);
        assert_int_equal(r->status, 0);
        if (strstr(r->out, "w1") && strstr(r->out, "w2"))
            break;
        if (testutil_now_s() > until)
            fail_msg("w1 and w2 not both listed after %.0f s:\n%s", test_wait_s(), r->out);
    }

    /* A job large enough to be caught half-way: w2 is killed once the job has started (both
     * workers were sent tasks), with the job still running or already done -- either way its
     * pixels must be those of one worker. */
    r = run("submit", "data/render/tiny.pbrt", "--master", cep, "--spp", "64", "--name", "big",
            NULL);
    if (r->status != 0)
        fail_msg("submit: exit %d: %s", r->status, r->err);
    assert_string_equal(r->out, "1\n");
    testutil_wait_file_has(testutil_scratch("master.log"), "job 1 'big' started");
    testutil_stop(w2, SIGKILL);
    r = run("workers", "--master", cep, NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "w1");
    /* Wait for the job with the surviving worker. */
    for (double until = testutil_now_s() + test_wait_s();; testutil_sleep_ms(100)) {
        r = run("status", "1", "--master", cep, "--json", NULL);
        assert_int_equal(r->status, 0);
        if (strstr(r->out, "\"done\"") || strstr(r->out, "\"failed\"") ||
            testutil_now_s() > until)
            break;
    }
    expect_in(r->out, "\"state\": \"done\"");
    r = run("fetch", "1", "-o", testutil_scratch("killed.exr"), "--master", cep, NULL);
    if (r->status != 0)
        fail_msg("fetch: %s", r->err);
    /* The same job with a single worker from the start. */
    r = run("submit", "data/render/tiny.pbrt", "--master", cep, "--spp", "64", "--name", "again",
            "--wait", "-o", testutil_scratch("single.exr"), "--quiet", NULL);
    if (r->status != 0)
        fail_msg("submit --wait: exit %d: %s", r->status, r->err);
    testutil_assert_same_pixels(testutil_scratch("killed.exr"), testutil_scratch("single.exr"));
    /* A remote job with a target error: the client, which does not know the job's spp cap,
     * follows the error and says afterwards how close its first prediction came. */
    r = run("submit", "data/render/tiny.pbrt", "--master", cep, "--spp", "1024",
            "--target-error", "0.1", "--name", "target", "--wait", "-o",
            testutil_scratch("target.exr"), NULL);
    if (r->status != 0)
        fail_msg("submit --wait --target-error: exit %d: %s", r->status, r->err);
    expect_in(r->out, "(target reached)");
    expect_in(r->out, "prediction after ");
    expect_in(r->out, "x the predicted time");
    /* And the same bytes as `prismfarm render` of the scene with the same seed and spp (another
     * tile size changes nothing: passes are per job, so each pixel sums the same samples in the
     * same order). */
    r = run("render", "data/render/tiny.pbrt", "--spp", "64", "-o", testutil_scratch("render.exr"),
            "--quiet", NULL);
    if (r->status != 0)
        fail_msg("render: exit %d: %s", r->status, r->err);
    testutil_assert_same_pixels(testutil_scratch("single.exr"), testutil_scratch("render.exr"));
    /* The master decides polarisation for a submitted job as `render` does for its own: the
     * glass plates' pilot turns it on (its log says so), and the bytes are render's. */
    r = run("submit", "data/render/polar_on.pbrt", "--master", cep, "--name", "polar", "--wait",
            "-o", testutil_scratch("polar_farm.exr"), "--quiet", NULL);
    if (r->status != 0)
        fail_msg("submit polar_on: exit %d: %s", r->status, r->err);
    testutil_wait_file_has(testutil_scratch("master.log"), "polarisation on (the pilot measured");
    r = run("render", "data/render/polar_on.pbrt", "-o", testutil_scratch("polar_render.exr"),
            "--direct", "--quiet", NULL);
    if (r->status != 0)
        fail_msg("render polar_on: exit %d: %s", r->status, r->err);
    testutil_assert_same_pixels(testutil_scratch("polar_farm.exr"),
                                testutil_scratch("polar_render.exr"));

    /* Errors a user sees: a broken scene, a job that does not exist. */
    r = run("submit", "data/render/broken.pbrt", "--master", cep, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "broken.pbrt:4:");
    r = run("fetch", "99", "-o", testutil_scratch("none.exr"), "--master", cep, NULL);
    assert_int_equal(r->status, 1);
    r = run("jobs", "--master", cep, NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "big");
    expect_in(r->out, "again");

    testutil_stop(w1, SIGTERM);
    testutil_stop(master, SIGTERM);
}

static void test_client_without_master(void **state)
{
    (void)state;
    /* Nothing listens on port 9: said at once (the one "no master" rule, client_rpc.h). */
    const run_t *r = run("jobs", "--master", "tcp://127.0.0.1:9", "--timeout", "0.5", NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "refused the connection: nothing listens on port 9 of 127.0.0.1 (is it "
                      "running, on this port?)");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_render_any_worker_count),
        cmocka_unit_test(test_render_matches_direct),
        cmocka_unit_test(test_processes_and_a_killed_worker),
        cmocka_unit_test(test_client_without_master),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_keys_setup, testutil_scratch_teardown);
}
