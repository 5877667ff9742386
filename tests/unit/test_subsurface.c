/* Tests for the "subsurface" material end to end (scenefile's parser, scene/subsurface_load,
 * render/subsurface and bsdf/bssrdf), against numbers that do not come from the code:
 * - a semi-infinite slab (a box 5000 mean free paths deep and 200 wide) under a uniform white
 *   sky, seen straight down, returns the sky times F + (1 - F) rho_eff, with F the Fresnel
 *   reflectance at normal incidence ((eta - 1) / (eta + 1))^2: light refracted in (1 - F, over
 *   eta^2 in radiance) leaves with the profile's integral rho_eff times the exit lobe's eta^2.
 *   Given by its diffuse "reflectance" R, rho_eff is R itself (pbrt-v4's SubsurfaceFromDiffuse
 *   inverts the table), so the slab returns F + (1 - F) R whatever the table says; given by
 *   sigma_a and sigma_s, rho_eff is the table's (test_bssrdf checks that against a random walk).
 *   The sky's own value comes from a white Lambertian slab in the same light. Within 1.5 %
 *   (measured 0.3-0.4 % off; the renders' standard error is about 0.5 %);
 * - the test scene (tests/data/scenes/subsurface.pbrt: a named medium, sigma_a and sigma_s,
 *   reflectance and mfp under a rough boundary) renders through the farm (two workers, small
 *   tiles) to the bytes --direct gives, every pixel finite and every spectral bucket >= 0;
 * - `plan` names the effect and the materials at their lines; "whitted" warns at each. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "bssrdf.h"
#include "cli_run.h"
#include "files_testutil.h"
#include "image_exr.h"

static image_exr_t *render(const char *scene, const char *out, int farm)
{
    const run_t *r =
        farm ? run("render", scene, "-o", out, "--workers", "2", "--tile", "8", "--quiet", NULL)
             : run("render", scene, "-o", out, "--direct", "--quiet", NULL);
    if (r->status != 0)
        fail_msg("render %s: exit %d: %s", scene, r->status, r->err);
    err_t err;
    image_exr_t *x = image_exr_read(out, &err);
    if (!x)
        fail_msg("%s", err.msg);
    return x;
}

/* A slab of MATERIAL 200 wide and 50 deep, its top at z = 0, seen straight down by an
 * orthographic camera over a 2 x 2 window at its middle, under a white sky. */
static const char *SLAB =
    "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\n"
    "Sampler \"zsobol\" \"integer pixelsamples\" 128\n"
    "Integrator \"path\" \"integer maxdepth\" 64\n"
    "LookAt 0 0 10  0 0 0  0 1 0\n"
    "Camera \"orthographic\" \"float screenwindow\" [-1 1 -1 1]\n"
    "WorldBegin\n"
    "LightSource \"infinite\" \"spectrum L\" [400 1 700 1]\n"
    "%s\n"
    "Shape \"trianglemesh\" \"point3 P\" [-100 -100 0  100 -100 0  100 100 0  -100 100 0 "
    "-100 -100 -50  100 -100 -50  100 100 -50  -100 100 -50] \"integer indices\" [0 1 2 0 2 3 "
    "4 6 5 4 7 6  0 4 5 0 5 1  1 5 6 1 6 2  2 6 7 2 7 3  3 7 4 3 4 0]\n";

/* The slab's mean pixel value (the three channels' mean) and its standard error. */
static double slab(const char *name, const char *material, double *se)
{
    char text[2048], path[64], out[64];
    snprintf(text, sizeof text, SLAB, material);
    snprintf(path, sizeof path, "%s.pbrt", name);
    snprintf(out, sizeof out, "%s.exr", name);
    testutil_write_text(testutil_scratch(path), text, 0644);
    image_exr_t *x = render(testutil_scratch(path), testutil_scratch(out), 0);
    const float *a = image_exr_rgb(x);
    const size_t npix = 64;
    double sum = 0.0, sum2 = 0.0;
    for (size_t i = 0; i < npix; i++) {
        const double v = (a[3 * i] + a[3 * i + 1] + a[3 * i + 2]) / 3.0;
        assert_true(isfinite(v));
        sum += v;
        sum2 += v * v;
    }
    image_exr_destroy(&x);
    const double mean = sum / npix;
    *se = sqrt(fmax(0.0, sum2 / npix - mean * mean) / (npix - 1));
    return mean;
}

static void test_slab_albedo(void **state)
{
    (void)state;
    double se_sky, se;
    const double sky =
        slab("white", "Material \"diffuse\" \"spectrum reflectance\" [400 1 700 1]", &se_sky);
    const double eta = 1.33, f = (eta - 1.0) * (eta - 1.0) / ((eta + 1.0) * (eta + 1.0));
    /* From the diffuse reflectance: the slab returns R through the boundary. */
    const double refl[1] = {0.6};
    for (int i = 0; i < 1; i++) {
        char m[256];
        snprintf(m, sizeof m,
                 "Material \"subsurface\" \"spectrum reflectance\" [400 %g 700 %g] "
                 "\"spectrum mfp\" [400 0.01 700 0.01]",
                 refl[i], refl[i]);
        const double v = slab("refl", m, &se) / sky;
        const double want = f + (1.0 - f) * refl[i];
        print_message("reflectance %.2f: slab / sky %.4f (se %.4f), expected %.4f\n", refl[i], v,
                      se / sky, want);
        assert_true(se / sky < 0.006);
        assert_true(fabs(v - want) < 0.015 * want);
    }
    /* From the coefficients: the table's effective albedo at rho = 0.9. */
    bssrdf_table_t *t = bssrdf_table_new(0.0, eta);
    assert_non_null(t);
    const double want = f + (1.0 - f) * bssrdf_rho_eff(t, 0.9);
    bssrdf_table_destroy(&t);
    const double v = slab("sigma",
                          "Material \"subsurface\" \"spectrum sigma_a\" [400 10 700 10] "
                          "\"spectrum sigma_s\" [400 90 700 90]",
                          &se) /
                     sky;
    print_message("rho 0.9: slab / sky %.4f (se %.4f), expected %.4f\n", v, se / sky, want);
    assert_true(fabs(v - want) < 0.015 * want);
}

static void test_scene_through_the_farm(void **state)
{
    (void)state;
    const char *scene = "data/scenes/subsurface.pbrt";
    image_exr_t *x = render(scene, testutil_scratch("farm.exr"), 1);
    image_exr_t *y = render(scene, testutil_scratch("direct.exr"), 0);
    const size_t w = 48, npix = 48 * 24;
    assert_int_equal(image_exr_width(x), (int)w);
    assert_memory_equal(image_exr_rgb(x), image_exr_rgb(y), npix * 3 * sizeof(float));
    const float *a = image_exr_rgb(x), *sp = image_exr_spectral(x);
    assert_int_equal(image_exr_n_spectral(x), image_exr_n_spectral(y));
    assert_memory_equal(sp, image_exr_spectral(y),
                        npix * (size_t)image_exr_n_spectral(x) * sizeof(float));
    /* RGB may dip below 0 for a colour outside sRGB (the ketchup's red); the spectral buckets
     * may not. */
    for (size_t i = 0; i < 3 * npix; i++)
        assert_true(isfinite(a[i]));
    for (size_t i = 0; i < npix * (size_t)image_exr_n_spectral(x); i++)
        assert_true(isfinite(sp[i]) && sp[i] >= 0.0f);
    image_exr_destroy(&x);
    image_exr_destroy(&y);
}

static void test_plan_and_whitted(void **state)
{
    (void)state;
    const run_t *r = run("plan", "data/scenes/subsurface.pbrt", NULL);
    assert_int_equal(r->status, 0);
    assert_non_null(strstr(r->out, "subsurface scattering  yes  BSSRDF"));
    assert_non_null(strstr(r->out, "subsurface scattering: material subsurface.pbrt:22"));
    char text[1024];
    snprintf(text, sizeof text,
             "Integrator \"whitted\"\nWorldBegin\nLightSource \"infinite\"\n"
             "Material \"subsurface\" \"string name\" \"Skin1\"\nShape \"sphere\"\n");
    const char *path = testutil_scratch("whitted.pbrt");
    testutil_write_text(path, text, 0644);
    r = run("check", path, NULL);
    assert_int_equal(r->status, 0);
    assert_non_null(strstr(r->out, "whitted.pbrt:4:1: Material \"subsurface\": the \"whitted\" "
                                   "integrator renders only its dielectric boundary"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_slab_albedo),
        cmocka_unit_test(test_scene_through_the_farm),
        cmocka_unit_test(test_plan_and_whitted),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
