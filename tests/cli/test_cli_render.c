/* prismfarm render, run as a process: output files and their content, determinism across
 * thread counts, and clear errors for bad command lines and broken scenes. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#define CLI_RUN_TIMEOUT_MS 120000
#include "cli_run.h"
#include "farm_testutil.h"
#include "files.h"
#include "image_exr.h"
#include "image_png.h"

#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

static void test_renders_spectral_exr_and_png(void **state)
{
    (void)state;
    const char *exr = testutil_scratch("tiny.exr");
    const run_t *r = run("render", "data/render/tiny.pbrt", "-o", exr, "--threads", "2", NULL);
    if (r->status != 0)
        fail_msg("exit %d: %s", r->status, r->err);
    expect_in(r->out, "wrote ");
    expect_in(r->out, "0 non-finite samples");
    expect_in(r->err, "dispersion on");
    struct stat st;
    assert_int_equal(stat(testutil_scratch("tiny.png"), &st), 0);
    assert_true(st.st_size > 0);
    err_t err;
    image_exr_t *img = image_exr_read(exr, &err);
    if (!img)
        fail_msg("%s", err.msg);
    assert_int_equal(image_exr_width(img), 24);
    assert_int_equal(image_exr_height(img), 16);
    assert_int_equal(image_exr_n_spectral(img), 8);
    /* 8 buckets over 380-720 nm: centres 401.25, 443.75, ... */
    assert_true(fabs(image_exr_wavelengths_nm(img)[0] - 401.25) < 1e-3);
    const char *info = image_exr_attribute(img, "prismfarm");
    assert_non_null(info);
    assert_non_null(strstr(info, "nonfinite=0"));
    assert_non_null(strstr(info, "dispersion=hero"));
    const float *rgb = image_exr_rgb(img);
    double sum = 0;
    for (int i = 0; i < 24 * 16 * 3; i++) {
        assert_true(isfinite(rgb[i]));
        sum += rgb[i];
    }
    assert_true(sum > 0.0); /* the scene is lit */
    image_exr_destroy(&img);
}

/* The farm's PNG is the master's own (fetched, not made again from the EXR): the same pixels
 * as --direct's; another exposure is tone-mapped by the client, and brightens the image. */
static double png_mean(const char *path, const uint8_t *same_as)
{
    err_t err;
    image_png_t *p = image_png_read(path, &err);
    if (!p)
        fail_msg("%s", err.msg);
    assert_int_equal(image_png_width(p), 24);
    assert_int_equal(image_png_height(p), 16);
    const uint8_t *px = image_png_rgba(p);
    if (same_as)
        assert_memory_equal(px, same_as, 24 * 16 * 4);
    double sum = 0;
    for (int i = 0; i < 24 * 16 * 4; i++)
        sum += (i % 4 == 3) ? 0 : px[i];
    image_png_destroy(&p);
    return sum / (24 * 16 * 3);
}

static void test_farm_png_matches_direct(void **state)
{
    (void)state;
    assert_int_equal(run("render", "data/render/tiny.pbrt", "-o", testutil_scratch("d.exr"),
                         "--direct", "--quiet", NULL)
                         ->status,
                     0);
    assert_int_equal(
        run("render", "data/render/tiny.pbrt", "-o", testutil_scratch("f.exr"), "--quiet", NULL)
            ->status,
        0);
    assert_int_equal(run("render", "data/render/tiny.pbrt", "-o", testutil_scratch("e.exr"),
                         "--quiet", "--exposure", "1", NULL)
                         ->status,
                     0);
    err_t err;
    image_png_t *d = image_png_read(testutil_scratch("d.png"), &err);
    if (!d)
        fail_msg("%s", err.msg);
    double direct = png_mean(testutil_scratch("d.png"), NULL);
    double farm = png_mean(testutil_scratch("f.png"), image_png_rgba(d));
    double brighter = png_mean(testutil_scratch("e.png"), NULL);
    image_png_destroy(&d);
    assert_true(farm == direct);
    /* One stop doubles the linear values before the ACES curve: every lit 8-bit value rises. */
    assert_true(brighter > farm + 5);
}

static void test_same_pixels_with_any_thread_count(void **state)
{
    (void)state;
    const char *a = testutil_scratch("t1.exr"), *b = testutil_scratch("t2.exr");
    assert_int_equal(run("render", "data/render/tiny.pbrt", "-o", a, "--threads", "1", "--quiet", NULL)->status, 0);
    assert_int_equal(run("render", "data/render/tiny.pbrt", "-o", b, "--threads", "2", "--quiet",
                         "--dispersion", "hero", NULL)->status, 0);
    image_exr_t *x = image_exr_read(a, NULL), *y = image_exr_read(b, NULL);
    assert_non_null(x);
    assert_non_null(y);
    assert_memory_equal(image_exr_spectral(x), image_exr_spectral(y), 24 * 16 * 8 * sizeof(float));
    assert_memory_equal(image_exr_rgb(x), image_exr_rgb(y), 24 * 16 * 3 * sizeof(float));
    image_exr_destroy(&x);
    image_exr_destroy(&y);
}

/* An Integrator option of scene (its text `on` in the file) is the scene file's and reaches
 * every worker: the farm's pixels are --direct's, and differ from the same scene with `off`
 * in its place. */
static void expect_option_through_the_farm(const char *scene, const char *on, const char *off,
                                           const char *tag)
{
    char farm[64], direct[64], plain[64], off_scene[64];
    snprintf(farm, sizeof farm, "%s_farm.exr", tag);
    snprintf(direct, sizeof direct, "%s_direct.exr", tag);
    snprintf(plain, sizeof plain, "%s_plain.exr", tag);
    snprintf(off_scene, sizeof off_scene, "%s_off.pbrt", tag);
    const char *f = testutil_scratch(farm), *d = testutil_scratch(direct),
               *o = testutil_scratch(off_scene);
    uint8_t *text;
    size_t len;
    err_t err;
    assert_int_equal(files_read(scene, 1 << 20, &text, &len, &err), 0);
    /* files_read's bytes end without a NUL: strstr and %s need one. */
    uint8_t *ended = realloc(text, len + 1);
    assert_non_null(ended);
    text = ended;
    text[len] = 0;
    char *at = strstr((char *)text, on);
    assert_non_null(at);
    size_t size = len + strlen(off) + 1;
    char *copy = malloc(size);
    assert_non_null(copy);
    size_t head = (size_t)(at - (char *)text);
    snprintf(copy, size, "%.*s%s%s", (int)head, (const char *)text, off, at + strlen(on));
    testutil_write_text(o, copy, 0644);
    free(copy);
    free(text);
    assert_int_equal(run("render", scene, "-o", f, "--quiet", NULL)->status, 0);
    assert_int_equal(run("render", scene, "-o", d, "--direct", "--quiet", NULL)->status, 0);
    const char *p = testutil_scratch(plain);
    assert_int_equal(run("render", o, "-o", p, "--quiet", NULL)->status, 0);
    image_exr_t *x = image_exr_read(f, NULL), *y = image_exr_read(d, NULL),
                *z = image_exr_read(p, NULL);
    assert_non_null(x);
    assert_non_null(y);
    assert_non_null(z);
    assert_memory_equal(image_exr_rgb(x), image_exr_rgb(y), 24 * 16 * 3 * sizeof(float));
    assert_memory_not_equal(image_exr_rgb(x), image_exr_rgb(z), 24 * 16 * 3 * sizeof(float));
    image_exr_destroy(&x);
    image_exr_destroy(&y);
    image_exr_destroy(&z);
}

/* pbrt-v4's "bool regularize". */
static void test_regularize_through_the_farm(void **state)
{
    (void)state;
    expect_option_through_the_farm("data/render/regularize.pbrt", "\"bool regularize\" true",
                                   "\"bool regularize\" false", "reg");
}

/* Ray splitting at a dense stone ("integer splitdepth"): deterministic per sample, so the
 * farm's pixels are --direct's. */
static void test_split_through_the_farm(void **state)
{
    (void)state;
    expect_option_through_the_farm("data/render/split.pbrt", "\"integer splitdepth\" 3",
                                   "\"integer splitdepth\" 0", "split");
}

/* Two files hold the same bytes. */
static void expect_same_file(const char *a, const char *b)
{
    uint8_t *x, *y;
    size_t nx, ny;
    err_t err;
    if (files_read(a, 1 << 24, &x, &nx, &err) || files_read(b, 1 << 24, &y, &ny, &err))
        fail_msg("%s", err.msg);
    if (nx != ny || memcmp(x, y, nx))
        fail_msg("%s and %s differ", a, b);
    free(x);
    free(y);
}

/* A Stokes output (Film "bool stokes") through the farm -- two workers, 8-pixel tiles, so each
 * tile result carries the four planes -- has --direct's pixels in every layer, R, G, B and
 * S0-S3, and the same polarisation previews beside the PNG. */
static void test_stokes_through_the_farm(void **state)
{
    (void)state;
    const char *farm = testutil_scratch("stokes_farm.exr"),
               *direct = testutil_scratch("stokes_direct.exr");
    const run_t *r = run("render", "data/render/stokes.pbrt", "-o", farm, "--workers", "2",
                         "--tile", "8", "--quiet", NULL);
    if (r->status != 0)
        fail_msg("farm: exit %d: %s", r->status, r->err);
    r = run("render", "data/render/stokes.pbrt", "-o", direct, "--direct", "--quiet", NULL);
    if (r->status != 0)
        fail_msg("--direct: exit %d: %s", r->status, r->err);
    err_t err;
    image_exr_t *x = image_exr_read(farm, &err), *y = x ? image_exr_read(direct, &err) : NULL;
    if (!x || !y)
        fail_msg("%s", err.msg);
    const size_t npix = 24 * 16;
    assert_int_equal(image_exr_n_spectral(x), 4);
    assert_int_equal(image_exr_n_spectral(y), 4);
    assert_memory_equal(image_exr_rgb(x), image_exr_rgb(y), npix * 3 * sizeof(float));
    assert_memory_equal(image_exr_spectral(x), image_exr_spectral(y), npix * 4 * sizeof(float));
    for (int k = 1; k <= 3; k++) {
        const float *a = image_exr_stokes(x, k), *b = image_exr_stokes(y, k);
        assert_non_null(a);
        assert_non_null(b);
        assert_memory_equal(a, b, npix * 4 * sizeof(float));
        /* Each plane is lit somewhere (the scene's three sheets): a copy of S0 or zeros fail. */
        double most = 0.0;
        for (size_t i = 0; i < npix * 4; i++)
            most = fmax(most, fabs((double)a[i]));
        if (!(most > 0.2))
            fail_msg("S%d peaks at %g", k, most);
    }
    image_exr_destroy(&x);
    image_exr_destroy(&y);
    expect_same_file(testutil_scratch("stokes_farm.png"), testutil_scratch("stokes_direct.png"));
    expect_same_file(testutil_scratch("stokes_farm_dop.png"),
                     testutil_scratch("stokes_direct_dop.png"));
    expect_same_file(testutil_scratch("stokes_farm_aop.png"),
                     testutil_scratch("stokes_direct_aop.png"));
}

/* With a target error the progress follows the error once it has an estimate: the ETA is the
 * predicted time to the target (film/predict.h), said as such, with --direct and the farm. */
static void test_progress_follows_error(void **state)
{
    (void)state;
    const char *exr = testutil_scratch("target.exr");
    const run_t *r = run("render", "data/render/tiny.pbrt", "-o", exr, "--spp", "1024",
                         "--target-error", "0.1", "--direct", NULL);
    if (r->status != 0)
        fail_msg("exit %d: %s", r->status, r->err);
    expect_in(r->err, "to error 0.1, predicted");
    expect_in(r->out, "(target error reached)");
    /* The summary compares the first prediction with what happened. */
    expect_in(r->out, "prediction after ");
    expect_in(r->out, "x the predicted time");
    r = run("render", "data/render/tiny.pbrt", "-o", exr, "--spp", "1024", "--target-error", "0.1",
            NULL);
    if (r->status != 0)
        fail_msg("exit %d: %s", r->status, r->err);
    expect_in(r->err, "to error 0.1, predicted");
    expect_in(r->out, "x the predicted time");
    /* --direct's photon pass has its own line, before the samples' (stderr is no terminal
     * here: a line per tenth), and its count of photons reaches the pass's 30000. */
    r = run("render", "data/photon/beam.pbrt", "-o", exr, "--direct", NULL);
    if (r->status != 0)
        fail_msg("exit %d: %s", r->status, r->err);
    expect_in(r->err, "photons: 100.0%");
    expect_in(r->err, "30000 of 30000 photons");
    const char *ph = strstr(r->err, "photons: "), *cam = strstr(r->err, "render: 100.0%");
    assert_non_null(cam);
    assert_true(ph < cam);
    /* Without a target the samples rule, as before. */
    r = run("render", "data/render/tiny.pbrt", "-o", exr, "--spp", "8", "--direct", NULL);
    assert_int_equal(r->status, 0);
    assert_null(strstr(r->err, "predicted"));
    assert_null(strstr(r->out, "prediction"));
}

static void test_overrides(void **state)
{
    (void)state;
    const char *exr = testutil_scratch("small.exr");
    const run_t *r = run("render", "data/render/tiny.pbrt", "-o", exr, "--res", "8x6", "--spp", "2",
                         "--dispersion", "fanout", "--integrator", "whitted", NULL);
    if (r->status != 0)
        fail_msg("exit %d: %s", r->status, r->err);
    expect_in(r->err, "8x6, 2 spp, integrator whitted");
    image_exr_t *img = image_exr_read(exr, NULL);
    assert_int_equal(image_exr_width(img), 8);
    assert_non_null(strstr(image_exr_attribute(img, "prismfarm"), "dispersion=fanout"));
    image_exr_destroy(&img);
}

static void test_bad_command_lines(void **state)
{
    (void)state;
    const run_t *r = run("render", NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "usage");
    r = run("render", "data/render/tiny.pbrt", "--spp", "zero", NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "--spp expects an integer");
    r = run("render", "data/render/tiny.pbrt", "--res", "10x", NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "--res expects WxH");
    r = run("render", "data/render/tiny.pbrt", "--dispersion", "rainbow", NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "--dispersion expects hero or fanout");
    r = run("render", "data/render/tiny.pbrt", "--frobnicate", "1", NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "unknown option '--frobnicate'");
}

static void test_broken_scene_names_file_and_line(void **state)
{
    (void)state;
    const run_t *r =
        run("render", "data/render/broken.pbrt", "-o", testutil_scratch("broken.exr"), NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "data/render/broken.pbrt:4:");
    r = run("render", "data/render/missing.pbrt", "-o", testutil_scratch("missing.exr"), NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "missing.pbrt");
    struct stat st;
    assert_int_not_equal(stat(testutil_scratch("broken.exr"), &st), 0);
}

/* A shot whose texture and Include sit in ../assets (tests/data/render/updir): the farm's bundle
 * is rooted at the folder that holds both, the master confines the load to it, and the image is
 * the bytes --direct renders; check agrees that it renders. */
static void test_updir_assets_farm_matches_direct(void **state)
{
    (void)state;
    const char *scene = "data/render/updir/shots/scene.pbrt";
    const char *d = testutil_scratch("updir_d.exr"), *f = testutil_scratch("updir_f.exr");
    const run_t *r = run("render", scene, "-o", d, "--direct", "--quiet", NULL);
    if (r->status != 0)
        fail_msg("--direct: exit %d: %s", r->status, r->err);
    r = run("render", scene, "-o", f, "--quiet", NULL);
    if (r->status != 0)
        fail_msg("farm: exit %d: %s", r->status, r->err);
    image_exr_t *x = image_exr_read(d, NULL), *y = image_exr_read(f, NULL);
    assert_non_null(x);
    assert_non_null(y);
    assert_memory_equal(image_exr_rgb(x), image_exr_rgb(y), 24 * 16 * 3 * sizeof(float));
    image_exr_destroy(&x);
    image_exr_destroy(&y);
    r = run("check", scene, NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "it renders");
}

static void write_text(const char *path, const char *text)
{
    FILE *fp = fopen(path, "w");
    assert_non_null(fp);
    assert_true(fputs(text, fp) >= 0);
    assert_int_equal(fclose(fp), 0);
}

/* The bundle rule, before a file is read: an absolute path is refused with the reason (and
 * the file's contents never appear in a message: issue 26, `Include "/etc/passwd"` printed
 * "unknown directive root:x:0:0:..."), and so is a symbolic link out of the scene's folder;
 * check refuses both too, as render does. */
static void test_bundle_refuses_absolute_and_symlink(void **state)
{
    (void)state;
    const char *abs_scene = testutil_scratch("abs.pbrt");
    write_text(abs_scene, "WorldBegin\nInclude \"/etc/passwd\"\n");
    const run_t *r = run("render", abs_scene, "-o", testutil_scratch("abs.exr"), NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "abs.pbrt:2:9: \"/etc/passwd\" is an absolute path, so it cannot travel");
    assert_null(strstr(r->err, "root:"));
    r = run("check", abs_scene, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->out, "\"/etc/passwd\" is an absolute path");
    /* --direct reads the user's own files as pbrt-v4 does; a file that is not a scene is not
     * echoed. */
    r = run("render", abs_scene, "-o", testutil_scratch("abs.exr"), "--direct", NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "expected a directive, got a word that cannot be one");
    assert_null(strstr(r->err, "root:"));

    const char *link_scene = testutil_scratch("link.pbrt");
    write_text(link_scene, "WorldBegin\nInclude \"passwd.pbrt\"\n");
    (void)unlink(testutil_scratch("passwd.pbrt"));
    assert_int_equal(symlink("/etc/passwd", testutil_scratch("passwd.pbrt")), 0);
    r = run("render", link_scene, "-o", testutil_scratch("link.exr"), NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "\"passwd.pbrt\" is a symbolic link that leads out of the folder");
    assert_null(strstr(r->err, "root:"));
}

/* Writes past limit bytes fail (EFBIG) in the commands this test runs from now on, as on a full
 * disk, without root or a device node; RLIM_INFINITY (or the old limit) lifts it again. The
 * test itself writes no file while a command runs. */
static void limit_file_size(rlim_t limit)
{
    struct rlimit rl;
    assert_int_equal(getrlimit(RLIMIT_FSIZE, &rl), 0);
    rl.rlim_cur = limit < rl.rlim_max ? limit : rl.rlim_max;
    assert_int_equal(setrlimit(RLIMIT_FSIZE, &rl), 0);
}

/* An output that cannot be written (the disk fills during the write) is an error that names the
 * file and the system's reason, at once: once it hung the process in OpenEXRCore's error
 * handler, through the farm's master (render) as through --direct. */
static void test_output_write_error(void **state)
{
    (void)state;
    signal(SIGXFSZ, SIG_IGN); /* inherited: a write past the limit fails instead of killing */
    const char *exr = testutil_scratch("full.exr");
    for (int direct = 0; direct < 2; direct++) {
        /* --direct: the header's end (where the old handler hung); the farm writes the scene
         * into its spool first, so there the limit leaves room for it and a chunk fails. */
        limit_file_size(direct ? 200 : 4096);
        const run_t *r = run("render", "data/render/tiny.pbrt", "-o", exr, "--quiet",
                             direct ? "--direct" : NULL, NULL);
        limit_file_size(RLIM_INFINITY);
        if (r->status != 1)
            fail_msg("%s: exit %d: %s", direct ? "--direct" : "farm", r->status, r->err);
        /* The file at fault: -o, or the master's own output in its spool (farm). */
        expect_in(r->err, direct ? exr : "jobs/1/tiny.exr");
        expect_in(r->err, strerror(EFBIG));
        struct stat st;
        assert_int_not_equal(stat(exr, &st), 0);
    }
    signal(SIGXFSZ, SIG_DFL);
}

/* The farm in one process loads its scene once (issue 15: client, master and worker each
 * loaded it): the master and the worker take the client's copy from the process's shelf, a
 * photon job's master phase too, with and without overrides. A party that loaded the scene
 * itself, or asked under another key, would show 2 loads or fewer than 2 shares. */
static void test_farm_loads_scene_once(void **state)
{
    (void)state;
    const char *once = "render: the scene was loaded 1 time in this process and shared 2 times "
                       "by its master and workers";
    const char *scenes[] = {"data/render/tiny.pbrt", "data/photon/beam.pbrt"};
    for (int i = 0; i < 2; i++) {
        const run_t *r = run("render", scenes[i], "-o", testutil_scratch("once.exr"), "--threads",
                             "2", NULL);
        if (r->status != 0)
            fail_msg("%s: exit %d: %s", scenes[i], r->status, r->err);
        if (!strstr(r->err, once))
            fail_msg("%s: expected \"%s\" in:\n%s", scenes[i], once, r->err);
    }
    const run_t *r = run("render", "data/render/tiny.pbrt", "-o", testutil_scratch("once.exr"),
                         "--spp", "2", "--seed", "9", "--integrator", "simplepath", "--dispersion",
                         "fanout", "--res", "12x8", NULL);
    if (r->status != 0)
        fail_msg("exit %d: %s", r->status, r->err);
    if (!strstr(r->err, once))
        fail_msg("with overrides: expected \"%s\" in:\n%s", once, r->err);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_renders_spectral_exr_and_png),
        cmocka_unit_test(test_same_pixels_with_any_thread_count),
        cmocka_unit_test(test_regularize_through_the_farm),
        cmocka_unit_test(test_split_through_the_farm),
        cmocka_unit_test(test_stokes_through_the_farm),
        cmocka_unit_test(test_farm_png_matches_direct),
        cmocka_unit_test(test_overrides),
        cmocka_unit_test(test_progress_follows_error),
        cmocka_unit_test(test_bad_command_lines),
        cmocka_unit_test(test_broken_scene_names_file_and_line),
        cmocka_unit_test(test_output_write_error),
        cmocka_unit_test(test_farm_loads_scene_once),
        cmocka_unit_test(test_updir_assets_farm_matches_direct),
        cmocka_unit_test(test_bundle_refuses_absolute_and_symlink),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_setup, testutil_scratch_teardown);
}
