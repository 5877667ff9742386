/* Material "measured" as a user runs it: a scene whose RGL-layout .bsdf file (made here from
 * an analytic GGX conductor, support/measured_testutil.h) sits in ../assets renders through
 * the farm -- the bundle carries the file -- with --direct's pixels; check and render refuse a
 * missing or damaged file at the scene's file:line, naming the file. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#define CLI_RUN_TIMEOUT_MS 120000
#include "cli_run.h"
#include "files_testutil.h"
#include "image_exr.h"
#include "measured_testutil.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* Line 9 holds the material; its filename parameter starts at column 21. */
static const char SCENE[] =
    "LookAt 0 1.2 -3  0 0.5 0  0 1 0\n"
    "Camera \"perspective\" \"float fov\" [ 40 ]\n"
    "Film \"rgb\" \"integer xresolution\" [ 24 ] \"integer yresolution\" [ 16 ]\n"
    "Sampler \"independent\" \"integer pixelsamples\" [ 4 ]\n"
    "Integrator \"path\" \"integer maxdepth\" [ 4 ]\n"
    "WorldBegin\n"
    "LightSource \"infinite\" \"rgb L\" [ 0.3 0.3 0.3 ]\n"
    "AttributeBegin\n"
    "Material \"measured\" \"string filename\" \"%s\"\n"
    "Translate 0 0.5 0\n"
    "Shape \"sphere\" \"float radius\" [ 0.5 ]\n"
    "AttributeEnd\n"
    "AttributeBegin\n"
    "  Translate 1 2.5 -1\n"
    "  AreaLightSource \"diffuse\" \"blackbody L\" [ 5000 ] \"float scale\" [ 8 ]\n"
    "  Shape \"sphere\" \"float radius\" [ 0.3 ]\n"
    "AttributeEnd\n";

static void write_scene(const char *path, const char *bsdf)
{
    char text[sizeof SCENE + 256];
    snprintf(text, sizeof text, SCENE, bsdf);
    testutil_write_text(path, text, 0644);
}

static void write_bytes(const char *path, const uint8_t *b, size_t n)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(b, 1, n, f), n);
    assert_int_equal(fclose(f), 0);
}

static void test_measured_through_the_farm(void **state)
{
    (void)state;
    size_t len = 0;
    uint8_t *b = measured_testutil_ggx(0.3, 6, 24, 4, &len);
    assert_non_null(b);
    mkdir(testutil_scratch("assets"), 0755);
    mkdir(testutil_scratch("shots"), 0755);
    write_bytes(testutil_scratch("assets/ggx.bsdf"), b, len);
    free(b);
    char scene[512];
    snprintf(scene, sizeof scene, "%s", testutil_scratch("shots/measured.pbrt"));
    write_scene(scene, "../assets/ggx.bsdf");
    const char *d = testutil_scratch("m_direct.exr"), *f = testutil_scratch("m_farm.exr");
    const run_t *r = run("render", scene, "-o", d, "--direct", NULL);
    if (r->status != 0)
        fail_msg("--direct: exit %d: %s", r->status, r->err);
    expect_in(r->out, " 0 non-finite samples");
    r = run("render", scene, "-o", f, "--workers", "2", "--tile", "8", "--quiet", NULL);
    if (r->status != 0)
        fail_msg("farm: exit %d: %s", r->status, r->err);
    err_t err;
    image_exr_t *x = image_exr_read(d, &err), *y = x ? image_exr_read(f, &err) : NULL;
    if (!x || !y)
        fail_msg("%s", err.msg);
    const size_t n = 24 * 16;
    assert_memory_equal(image_exr_rgb(x), image_exr_rgb(y), n * 3 * sizeof(float));
    assert_int_equal(image_exr_n_spectral(x), image_exr_n_spectral(y));
    assert_memory_equal(image_exr_spectral(x), image_exr_spectral(y),
                        n * (size_t)image_exr_n_spectral(x) * sizeof(float));
    /* The sphere in the middle of the frame is lit by the measured reflection. */
    const float *rgb = image_exr_rgb(x);
    double centre = 0.0;
    for (int yy = 6; yy < 10; yy++)
        for (int xx = 10; xx < 14; xx++)
            centre += rgb[3 * (yy * 24 + xx)];
    assert_true(centre > 0.0 && isfinite(centre));
    image_exr_destroy(&x);
    image_exr_destroy(&y);
    r = run("check", scene, NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "it renders");
}

static void test_missing_and_damaged_files_refused(void **state)
{
    (void)state;
    const char *scene = testutil_scratch("missing.pbrt");
    write_scene(scene, "nothere.bsdf");
    const run_t *r = run("check", scene, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->out, "missing.pbrt:9:21: cannot open measured BSDF");
    expect_in(r->out, "nothere.bsdf");
    r = run("render", scene, "-o", testutil_scratch("missing.exr"), "--quiet", NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "missing.pbrt:9:21:");
    /* Cut short inside its data: the loader names the field and the file's end. */
    size_t len = 0;
    uint8_t *b = measured_testutil_ggx(0.5, 3, 4, 2, &len);
    assert_non_null(b);
    write_bytes(testutil_scratch("cut.bsdf"), b, len - 16);
    free(b);
    scene = testutil_scratch("cut.pbrt");
    write_scene(scene, "cut.bsdf");
    r = run("check", scene, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->out, "cut.pbrt:9:21: Material \"measured\": ");
    expect_in(r->out, "cut.bsdf: field \"spectra\" needs bytes");
    r = run("render", scene, "-o", testutil_scratch("cut.exr"), "--quiet", NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "past the file's end");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_measured_through_the_farm),
        cmocka_unit_test(test_missing_and_damaged_files_refused),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_setup, testutil_scratch_teardown);
}
