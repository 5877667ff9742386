/* Adaptive sampling end to end (docs/rendering.md, "Adaptive sampling"), on a scene whose left
 * is a flat wall under a uniform sky and whose right holds a glass sphere's caustic of a small
 * lamp (data/render/adaptive.pbrt): under a target error the flat tiles stop with fewer samples
 * than the caustic's; the image is the same bytes through `render --direct`, the in-process farm
 * of 1 and of 3 workers, and a master killed mid-job and started again on its spool; the final
 * estimate is within the target; `--adaptive off`, and any job without a target, give the bytes
 * of a render without adaptive sampling. */
#define CLI_RUN_TIMEOUT_MS 180000
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "cli_run.h"
#include "farm_testutil.h"
#include "jobinfo.h"
#include "journal_testutil.h"

#include <signal.h>
#include <stdlib.h>
#include <string.h>

#define SCENE "data/render/adaptive.pbrt" /* 48 x 32 pixels: 6 x 4 tiles of 8 */
#define TILE "8"
#define TARGET 0.3

/* The value of key in the text, as a double; fails the test when absent. */
static double value_of(const char *info, const char *key)
{
    char k[64];
    snprintf(k, sizeof k, ";%s=", key);
    const char *p = strstr(info, k);
    if (!p)
        fail_msg("no %s in %s", key, info);
    return strtod(p + strlen(k), NULL);
}

static void render_ok(const char *what, const run_t *r)
{
    if (r->status != 0)
        fail_msg("%s: exit %d: %s", what, r->status, r->err);
}

static void test_flat_tiles_stop_first_and_every_farm_agrees(void **state)
{
    (void)state;
    const char *direct = testutil_scratch("on_direct.exr"), *one = testutil_scratch("on_1.exr"),
               *three = testutil_scratch("on_3.exr");
    const run_t *r = run("render", SCENE, "--target-error", "0.3", "--adaptive", "on", "--tile",
                         TILE, "--direct", "--threads", "2", "-o", direct, "--quiet", NULL);
    render_ok("--direct", r);
    expect_in(r->out, "adaptive: ");
    expect_in(r->out, "(target error reached)");
    r = run("render", SCENE, "--target-error", "0.3", "--adaptive", "on", "--tile", TILE,
            "--workers", "1", "--threads", "2", "-o", one, "--quiet", NULL);
    render_ok("1 worker", r);
    expect_in(r->out, "adaptive: ");
    r = run("render", SCENE, "--target-error", "0.3", "--adaptive", "on", "--tile", TILE,
            "--workers", "3", "--threads", "1", "-o", three, "--quiet", NULL);
    render_ok("3 workers", r);
    testutil_assert_same_pixels(direct, one);
    testutil_assert_same_pixels(one, three);

    char *info = testutil_exr_info(one);
    tilegrid_t g;
    int *spp = NULL;
    err_t err;
    if (jobinfo_tile_spp(info, &g, &spp, &err) != 1)
        fail_msg("no tile_spp in %s", info);
    assert_int_equal(g.tiles_x, 6);
    assert_int_equal(g.tiles_y, 4);
    /* The flat wall's tiles (the left third) stopped at the least spp, below the most any tile
     * got, which a tile of the caustic's right half got. */
    int most = 0, at = -1;
    for (int t = 0; t < 24; t++)
        if (spp[t] > most) {
            most = spp[t];
            at = t;
        }
    for (int t = 0; t < 24; t++)
        if (t % 6 < 2) {
            if (spp[t] != 16)
                fail_msg("flat tile %d got %d spp: %s", t, spp[t], info);
        }
    assert_true(most > 16);
    assert_true(at % 6 >= 3);
    /* Ended by its target, with the estimate within it. */
    assert_non_null(strstr(info, ";stop=target;"));
    double rel = value_of(info, "rel_rmse");
    assert_true(rel > 0 && rel <= TARGET);
    /* The samples the EXR counts are those the tiles got. */
    double samples = 0;
    for (int t = 0; t < 24; t++) {
        int x0, y0, w, h;
        tilegrid_rect(&g, t, &x0, &y0, &w, &h);
        samples += (double)w * h * spp[t];
    }
    assert_true(value_of(info, "samples") == samples);
    free(spp);
    free(info);
}

static void test_off_and_without_target_change_nothing(void **state)
{
    (void)state;
    /* --adaptive off: whole passes for every tile, as before adaptive sampling; farm and
     * --direct agree, and the record has no adaptive keys. */
    const char *off_d = testutil_scratch("off_direct.exr"),
               *off_f = testutil_scratch("off_farm.exr");
    render_ok("off --direct",
              run("render", SCENE, "--target-error", "0.3", "--adaptive", "off", "--tile", TILE,
                  "--direct", "--threads", "2", "-o", off_d, "--quiet", NULL));
    const run_t *r = run("render", SCENE, "--target-error", "0.3", "--adaptive", "off", "--tile",
                         TILE, "--workers", "2", "--threads", "1", "-o", off_f, "--quiet", NULL);
    render_ok("off farm", r);
    assert_null(strstr(r->out, "adaptive: "));
    testutil_assert_same_pixels(off_d, off_f);
    /* Off is the default. */
    const char *dflt = testutil_scratch("default_direct.exr");
    render_ok("default --direct", run("render", SCENE, "--target-error", "0.3", "--tile", TILE,
                                      "--direct", "--threads", "2", "-o", dflt, "--quiet", NULL));
    testutil_assert_same_pixels(off_d, dflt);
    char *info = testutil_exr_info(off_f);
    assert_null(strstr(info, ";adaptive="));
    assert_null(strstr(info, "tile_spp"));
    /* Every pixel at the spp the job reached: the samples are the image's pixels times it. */
    assert_true(value_of(info, "samples") == 48.0 * 32.0 * value_of(info, "spp_done"));
    double off_samples = value_of(info, "samples");
    free(info);
    /* On, the same target took fewer samples. */
    info = testutil_exr_info(testutil_scratch("on_1.exr"));
    assert_true(value_of(info, "samples") < off_samples / 2);
    free(info);

    /* A target never reached with --adaptive off runs every pass: the very bytes of the same
     * spp without a target (the render before stopping rules and adaptive sampling). */
    const char *plain = testutil_scratch("plain64.exr"),
               *unreached = testutil_scratch("unreached.exr");
    render_ok("plain", run("render", SCENE, "--spp", "64", "--tile", TILE, "--workers", "1",
                           "--threads", "2", "-o", plain, "--quiet", NULL));
    render_ok("unreached",
              run("render", SCENE, "--spp", "64", "--target-error", "0.001", "--adaptive", "off",
                  "--tile", TILE, "--direct", "--threads", "2", "-o", unreached, "--quiet", NULL));
    testutil_assert_same_pixels(plain, unreached);
    /* Without a target, --adaptive on changes nothing (there is no error to aim at), with a
     * time limit either. */
    const char *on_no_target = testutil_scratch("on_no_target.exr");
    r = run("render", SCENE, "--spp", "64", "--adaptive", "on", "--time-limit", "1h", "--tile",
            TILE, "--workers", "1", "--threads", "2", "-o", on_no_target, "--quiet", NULL);
    render_ok("no target", r);
    assert_null(strstr(r->out, "adaptive: "));
    testutil_assert_same_pixels(plain, on_no_target);
    info = testutil_exr_info(on_no_target);
    assert_null(strstr(info, ";adaptive="));
    free(info);
    /* A bad value is refused. */
    r = run("render", SCENE, "--adaptive", "maybe", "--direct", "-o", testutil_scratch("bad.exr"),
            NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "--adaptive expects on or off, got 'maybe'");
}

/* A master killed mid-job (after the flat tiles stopped, with a checkpoint and results journaled
 * after it) and started again on its spool finishes the job with the bytes of an uninterrupted
 * run: the tiles it stopped stay stopped, the others go on. The target (0.02) is out of reach,
 * so the tiles that do not stop run to the job's spp: 1024 (11 passes, the kill after pass 6 or
 * so leaves 31/32 of them) costs the reference and the farm a third of what 4096 did. */
#define RESTART_SPP "1024"
static void test_master_killed(void **state)
{
    (void)state;
    const char *ref = testutil_scratch("restart_ref.exr");
    render_ok("reference", run("render", SCENE, "--spp", RESTART_SPP, "--target-error", "0.02",
                               "--adaptive", "on", "--workers", "1", "--threads", "2", "--tile",
                               TESTUTIL_JOURNAL_TILE, "-o", ref, "--quiet", NULL));
    char *info = testutil_exr_info(ref);
    assert_non_null(strstr(info, ";adaptive=on;"));
    free(info);
    const char *spool = testutil_scratch("ad-spool"), *mlog1 = testutil_scratch("ad-master1.log"),
               *mlog2 = testutil_scratch("ad-master2.log");
    pid_t master = testutil_journal_master(mlog1, spool, "tcp://127.0.0.1:*", "tcp://127.0.0.1:*");
    char wep[256], cep[256];
    testutil_read_endpoints(spool, wep, cep, mlog1);
    pid_t w = testutil_journal_worker(testutil_scratch("ad-w.log"), wep, "w");
    const run_t *r = run("submit", SCENE, "--master", cep, "--spp", RESTART_SPP, "--target-error",
                         "0.02", "--adaptive", "on", "--insecure", NULL);
    if (r->status != 0)
        fail_msg("submit: exit %d: %s", r->status, r->err);
    assert_string_equal(r->out, "1\n");
    /* Past the first boundary where tiles may stop (16 spp: 5 passes), a checkpoint, and
     * results journaled after it. */
    testutil_wait_journal(spool, test_wait_s(), "6 passes, a checkpoint and results after it",
                          "SELECT COUNT(*) FROM passes WHERE job=1 AND pass>=6",
                          "SELECT checkpoint FROM jobs WHERE id=1",
                          "SELECT COUNT(*) FROM results WHERE job=1 AND kind=0", NULL);
    testutil_stop(master, SIGKILL);
    master = testutil_journal_master(mlog2, spool, wep, cep);
    testutil_journal_finish(cep, ref, testutil_scratch("ad-out.exr"), mlog2);
    char *log = testutil_slurp(mlog2, NULL);
    const char *resumed = log ? strstr(log, "job 1 'adaptive' resumed: ") : NULL;
    if (!resumed) {
        free(log);
        testutil_fail_quoting(mlog2, "the restarted master did not resume job 1:");
    }
    int done = 0, passes = 0;
    assert_int_equal(
        sscanf(resumed, "job 1 'adaptive' resumed: %d of %d passes merged", &done, &passes), 2);
    print_message("the master was killed with %d of %d passes merged in its checkpoint\n", done,
                  passes);
    free(log);
    testutil_stop(w, SIGTERM);
    testutil_stop(master, SIGTERM);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_flat_tiles_stop_first_and_every_farm_agrees),
        cmocka_unit_test(test_off_and_without_target_change_nothing),
        cmocka_unit_test(test_master_killed),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_setup, testutil_scratch_teardown);
}
