/* lens: pbrt-v4's realistic-camera lens system with dispersive glass. The focal length of a
 * thick singlet against the lensmaker's formula at three wavelengths (so the dispersion's sign
 * and size: blue focuses shorter by about f / V), a point at the focus distance imaged sharply,
 * the exit pupil bounds covering every ray that passes, rays at the elements' edges never NaN,
 * and bad lens files refused with file:line. */
#define _GNU_SOURCE
#include "camera.h"
#include "glass.h"
#include "lens.h"
#include "pbrt_parser.h"
#include "render.h"
#include "scene_load.h"
#include "tilebuf.h"

#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "scene_builders.h"

/* The lens of scenes/lenses/landscape-bk7-100mm.dat. */
static const char *LANDSCAPE = "# stop, then LB1676\n"
                               "0       50.0   0       12.0\n"
                               "102.4   3.6    1.5168  25.4   N-BK7\n"
                               "-102.4  97.0   0       25.4\n";

static lens_system_t *make(const char *text, double stop_mm, double focus, err_t *err)
{
    lens_params_t p = {.file = "t.dat",
                       .aperture_diameter_mm = stop_mm,
                       .focus_distance = focus,
                       .film_diagonal = 0.035,
                       .xres = 300,
                       .yres = 200,
                       .lambda_min = 380,
                       .lambda_max = 720};
    return lens_system_new(text, strlen(text), &p, err);
}

/* Thick lens in air: 1/f = (n - 1) (1/R1 - 1/R2 + (n - 1) d / (n R1 R2)). */
static double lensmaker(double n, double r1, double r2, double d)
{
    return 1.0 / ((n - 1) * (1 / r1 - 1 / r2 + (n - 1) * d / (n * r1 * r2)));
}

static void test_focal_length_and_dispersion(void **state)
{
    (void)state;
    err_t err;
    lens_system_t *s = make(LANDSCAPE, 12, 1e6, &err);
    if (!s)
        fail_msg("%s", err.msg);
    const glass_t *bk7 = glass_find("N-BK7");
    const double lambdas[3] = {486.1327, LENS_LAMBDA_D, 656.2725}; /* F, d, C */
    double f[3];
    for (int i = 0; i < 3; i++) {
        double efl, fz;
        assert_int_equal(lens_system_focal_length(s, lambdas[i], &efl, &fz), 0);
        /* the file's n_d is N-BK7's catalogue value; the shift is below 1e-5 */
        double n = ior_eval(&bk7->ior, lambdas[i]) + (1.5168 - ior_eval(&bk7->ior, LENS_LAMBDA_D));
        double want = lensmaker(n, 0.1024, -0.1024, 0.0036);
        /* the paraxial ray is at 35 um: its focus differs from the paraxial one by < 1e-6 */
        if (!(fabs(efl - want) < 1e-6 * want))
            fail_msg("EFL at %g nm: %.9g m, lensmaker %.9g m", lambdas[i], efl, want);
        f[i] = efl;
    }
    /* Blue (F) focuses shorter than red (C) by about f / V (V = 64.17 for N-BK7). */
    double df = f[2] - f[0];
    assert_true(df > 0);
    assert_true(fabs(df - f[1] / 64.17) < 0.03 * f[1] / 64.17);
    /* Focused at infinity, the film sits at the d-line focus (within 1 um). */
    double efl, fz;
    lens_system_focal_length(s, LENS_LAMBDA_D, &efl, &fz);
    assert_true(fabs(fz) < 1e-6);
    lens_system_destroy(&s);
    assert_null(s);
}

/* Rays from an on-axis point at the focus distance, through the inner part of the stop,
 * meet the film within a micrometre (the d line); a point at half the distance does not. */
static double spot_radius(const lens_system_t *s, double z_obj, double lambda)
{
    double worst = 0;
    int passed = 0;
    double front = lens_system_front_z(s);
    for (int i = 0; i < 64; i++) {
        double a = 2 * M_PI * i / 64, r = 0.0005; /* 0.5 mm off axis at the front vertex */
        double o[3] = {0, 0, z_obj}, d[3] = {r * cos(a), r * sin(a), front - z_obj};
        double oo[3], od[3];
        if (!lens_trace_from_scene(s, o, d, lambda, oo, od))
            continue;
        passed++;
        double t = -oo[2] / od[2];
        double x = oo[0] + t * od[0], y = oo[1] + t * od[1];
        worst = fmax(worst, sqrt(x * x + y * y));
    }
    assert_true(passed == 64);
    return worst;
}

static void test_focus(void **state)
{
    (void)state;
    err_t err;
    lens_system_t *s = make(LANDSCAPE, 12, 2.0, &err);
    assert_non_null(s);
    double sharp = spot_radius(s, 2.0, LENS_LAMBDA_D), blurred = spot_radius(s, 1.0, LENS_LAMBDA_D);
    if (!(sharp < 1e-6 && blurred > 20 * sharp && blurred > 5e-6))
        fail_msg("spot at the focus distance %g m, at half of it %g m", sharp, blurred);
    /* The focus is the d line's: blue and red land off the film by the axial colour. */
    assert_true(spot_radius(s, 2.0, 450) > 5 * sharp);
    lens_system_destroy(&s);
}

/* Every ray from the film to any point of the rear element that passes the lens goes through
 * the pupil bounds of its film radius (rotated to the film point's angle). */
static void test_pupil_covers(void **state)
{
    (void)state;
    err_t err;
    lens_system_t *s = make(LANDSCAPE, 12, 2.0, &err);
    assert_non_null(s);
    uint64_t x = 88172645463325252ull;
    int passed = 0, outside = 0;
    double rr = lens_system_rear_radius(s), zr = lens_system_rear_z(s), diag = 0.035;
    for (int i = 0; i < 200000; i++) {
        double u[4];
        for (int k = 0; k < 4; k++) {
            x ^= x << 13, x ^= x >> 7, x ^= x << 17;
            u[k] = (double)(x >> 11) / 9007199254740992.0;
        }
        double rf = u[0] * diag / 2, af = 2 * M_PI * u[1];
        double pf[3] = {rf * cos(af), rf * sin(af), 0};
        double rp = rr * 1.5 * sqrt(u[2]), ap = 2 * M_PI * u[3];
        double pr[2] = {rp * cos(ap), rp * sin(ap)};
        double d[3] = {pr[0] - pf[0], pr[1] - pf[1], zr};
        double lambda = 380 + 340 * u[3];
        if (!lens_trace_from_film(s, pf, d, lambda, NULL, NULL))
            continue;
        passed++;
        int k = (int)(rf / (diag / 2) * LENS_PUPIL_INTERVALS);
        double b[4];
        lens_system_pupil(s, k < LENS_PUPIL_INTERVALS ? k : LENS_PUPIL_INTERVALS - 1, b);
        /* rotate the rear point back to the film point's own +x axis */
        double c = cos(-af), sn = sin(-af);
        double lx = c * pr[0] - sn * pr[1], ly = sn * pr[0] + c * pr[1];
        if (!(lx >= b[0] && lx <= b[1] && ly >= b[2] && ly <= b[3]))
            outside++;
    }
    if (!(passed > 10000 && outside == 0))
        fail_msg("%d rays passed, %d outside the pupil bounds", passed, outside);
    lens_system_destroy(&s);
}

/* Rays aimed at the rims of the elements and the stop, grazing the spheres, or at steep angles
 * either pass with a finite unit direction or are refused; lens_system_ray never gives NaN. */
static void test_edges_finite(void **state)
{
    (void)state;
    err_t err;
    lens_system_t *s = make(LANDSCAPE, 12, 2.0, &err);
    assert_non_null(s);
    double zr = lens_system_rear_z(s), rr = lens_system_rear_radius(s);
    int passed = 0;
    for (int i = 0; i <= 2000; i++) {
        /* from the axis to past the rear rim: the stop's and the elements' edges are crossed */
        double r = rr * 1.05 * i / 2000.0;
        for (int j = 0; j < 8; j++) {
            double pf[3] = {0.01 * (j - 4) / 4.0, 0.003 * j / 8.0, 0};
            double d[3] = {r - pf[0], -pf[1], zr};
            double oo[3], od[3];
            if (lens_trace_from_film(s, pf, d, 400 + 40 * j, oo, od)) {
                passed++;
                for (int k = 0; k < 3; k++)
                    assert_true(isfinite(oo[k]) && isfinite(od[k]));
                assert_true(fabs(od[0] * od[0] + od[1] * od[1] + od[2] * od[2] - 1) < 1e-12);
            }
        }
        /* nearly parallel to the film: misses or is refused, never NaN */
        double pf[3] = {0.001, 0, 0}, d[3] = {1, 0, 1e-9 * i};
        double oo[3] = {0}, od[3] = {0};
        if (lens_trace_from_film(s, pf, d, 550, oo, od))
            assert_true(isfinite(od[0]) && isfinite(od[2]));
    }
    assert_true(passed > 0);
    for (int y = 0; y <= 200; y += 5)
        for (int x = 0; x <= 300; x += 5)
            for (int k = 0; k < 4; k++) {
                double o[3], d[3];
                double w = lens_system_ray(s, x, y, k & 1 ? 0.999999 : 0.0, k & 2 ? 1.0 : 0.5,
                                           380 + 85 * k, o, d);
                assert_true(isfinite(w) && w >= 0);
                if (w > 0)
                    for (int c = 0; c < 3; c++)
                        assert_true(isfinite(o[c]) && isfinite(d[c]));
            }
    lens_system_destroy(&s);
}

static void expect_error(const char *text, double focus, const char *want)
{
    err_t err;
    lens_system_t *s = make(text, 12, focus, &err);
    if (s)
        fail_msg("accepted: %s", text);
    if (!strstr(err.msg, want))
        fail_msg("error \"%s\" does not say \"%s\"", err.msg, want);
}

static void test_bad_files(void **state)
{
    (void)state;
    expect_error("0 20 0 12\n102.4 3.6 1.5168\n", 2, "t.dat:2: expected 4 numbers");
    expect_error("0 20 0 12\n102.4 3.6 1.5168 25.4 NoSuchGlass\n-102.4 97 0 25.4\n", 2,
                 "t.dat:2: unknown glass \"NoSuchGlass\"");
    expect_error("0 20 0 12\n102.4 3.6 x 25.4\n", 2, "t.dat:2: \"x\" is not a number");
    expect_error("0 20 1.5 12\n", 2, "t.dat:1: the aperture stop (radius 0) must be in air");
    expect_error("# nothing\n", 2, "t.dat: no lens interfaces");
    expect_error(LANDSCAPE, 0.05, "too short for this lens");
    /* The default glass: nearest in n_d, shifted to it, and counted. */
    err_t err;
    lens_system_t *s = make("0 20 0 12\n102.4 3.6 1.62 25.4\n-102.4 97 0 25.4\n", 12, 2, &err);
    assert_non_null(s);
    assert_int_equal(lens_system_defaulted(s), 1);
    const lens_element_t *e = lens_system_element(s, 1);
    assert_string_equal(e->glass_name, "F2");
    assert_true(fabs(lens_element_eta(e, LENS_LAMBDA_D) - 1.62) < 1e-12);
    assert_true(lens_element_eta(e, 450) > lens_element_eta(e, 650));
    assert_false(lens_system_clamped(s));
    lens_system_destroy(&s);
    /* pbrt-v4: a stop wider than the file's is clamped (and warned by the loader). */
    s = make(LANDSCAPE, 50, 2, &err);
    assert_true(lens_system_clamped(s) &&
                fabs(lens_system_element(s, 0)->aperture_radius - 0.006) < 1e-15);
    lens_system_destroy(&s);
}

/* ---- rendered: the colour fringe of an edge near the frame's side ---- */

#define FX 200
#define FY 32

/* Where the film sees an object point at wavelength lambda: the centroid of the rays from it
 * through the whole stop (a blurred edge's line-spread centroid), in raster x. */
static double predicted_x(const lens_system_t *s, double xo, double zo, double lambda)
{
    const lens_element_t *stop = lens_system_element(s, 0);
    double zs = lens_system_front_z(s), sum = 0;
    int n = 0;
    for (int i = 0; i < 64; i++)
        for (int j = 0; j < 64; j++) {
            double px = stop->aperture_radius * (2 * (i + 0.5) / 64 - 1);
            double py = stop->aperture_radius * (2 * (j + 0.5) / 64 - 1);
            if (px * px + py * py > stop->aperture_radius * stop->aperture_radius)
                continue;
            double o[3] = {xo, 0, zo}, d[3] = {px - xo, py, zs - zo}, oo[3], od[3];
            if (!lens_trace_from_scene(s, o, d, lambda, oo, od))
                continue;
            double t = -oo[2] / od[2];
            sum += oo[0] + t * od[0];
            n++;
        }
    double aspect = (double)FY / FX, ex = 0.035 / sqrt(1 + aspect * aspect);
    return FX * (ex / 2 - sum / n) / ex;
}

/* The edge's position in bucket b: the centroid of the rise of the row-averaged profile. */
static double measured_x(const tilebuf_t *t, int b, int x0)
{
    double prof[FX];
    const int w = tilebuf_width(t);
    for (int x = 0; x < w; x++) {
        prof[x] = 0;
        for (int y = 0; y < tilebuf_height(t); y++)
            prof[x] += tilebuf_sum(t, x, y, b) / (double)tilebuf_count(t, x, y);
    }
    int peak = 1;
    for (int x = 1; x < w; x++)
        if (prof[x] - prof[x - 1] > prof[peak] - prof[peak - 1])
            peak = x;
    double num = 0, den = 0;
    for (int x = peak - 3; x <= peak + 3; x++) {
        if (x < 1 || x >= w)
            continue;
        double g = prof[x] - prof[x - 1];
        num += g * x; /* the step between pixel centres x - 1 and x is at x, in raster units */
        den += g;
    }
    return x0 + num / den;
}

static void test_rendered_fringe(void **state)
{
    (void)state;
    /* A flat-spectrum emitter right of x = 0.22 m, 2 m away: its edge images about 11.6 mm
     * off the axis, near column 169 of 200. Buckets of 100 nm: 400-500 and 600-700; only
     * columns 150-189 are rendered (the crop's pixels are the full render's). 1024 samples
     * a pixel over 32 rows put the edge's noise near 0.05 px. */
    char text[4096];
    snprintf(
        text, sizeof text,
        "Camera \"realistic\" \"string lensfile\" \"../scenes/lenses/landscape-bk7-100mm.dat\"\n"
        "    \"float aperturediameter\" 4 \"float focusdistance\" 2\n"
        "Film \"spectral\" \"integer xresolution\" %d \"integer yresolution\" %d \"float "
        "diagonal\" 35\n"
        "    \"integer nbuckets\" 3 \"float lambdamin\" 400 \"float lambdamax\" 700 \"float "
        "cropwindow\" [0.75 0.95 0 1]\n"
        "PixelFilter \"box\"\n"
        "Sampler \"independent\" \"integer pixelsamples\" 1024\n"
        "Integrator \"path\" \"integer maxdepth\" 1\nWorldBegin\n"
        "AreaLightSource \"diffuse\" \"spectrum L\" [300 1 900 1] \"bool twosided\" true\n"
        "Shape \"trianglemesh\" \"point3 P\" [0.22 -0.3 2  0.7 -0.3 2  0.7 0.3 2  0.22 0.3 2] "
        "\"integer indices\" [0 1 2 0 2 3]\n",
        FX, FY);
    err_t err = {{0}};
    scene_t *sc = sb_load_text(text, NULL);
    assert_int_equal(sc->camera.kind, CAMERA_REALISTIC);
    assert_true(sc->camera.lens_dispersive);
    const render_settings_t *rs = &sc->settings;
    tilebuf_t *t = tilebuf_new(0, 0, rs->xres, rs->yres, rs->grid.n, &err);
    render_stats_t stats = {0};
    if (!t ||
        render_tile(sc, NULL, 0, 0, rs->xres, rs->yres, 0, (uint32_t)rs->spp, t, &stats, &err))
        fail_msg("render: %s", err.msg);
    assert_int_equal(stats.nonfinite, 0);
    double blue = measured_x(t, 0, rs->crop_x0), red = measured_x(t, 2, rs->crop_x0);
    double pb = 0, pr = 0;
    for (int k = 0; k < 10; k++) {
        pb += predicted_x(sc->camera.lens, 0.22, 2.0, 405 + 10 * k) / 10;
        pr += predicted_x(sc->camera.lens, 0.22, 2.0, 605 + 10 * k) / 10;
    }
    print_message("edge at x = %.3f (400-500 nm), %.3f (600-700 nm) px; predicted %.3f, %.3f: red "
                  "- blue %.3f px "
                  "measured, %.3f predicted\n",
                  blue, red, pb, pr, red - blue, pr - pb);
    /* The edge is on the right of the image (x mirrored twice: the lens inverts, the film
     * flips), and red is imaged farther from the centre than blue (lateral colour of a
     * positive crown lens with a front stop). */
    assert_true(blue > FX / 2 && red > blue);
    /* Measured 0.772 px against 0.804 (each edge within 0.02 px of its spot centroid); the
     * noise is about 0.05 px. */
    assert_true(fabs((red - blue) - (pr - pb)) < 0.15);
    assert_true(fabs(blue - pb) < 0.15 && fabs(red - pr) < 0.15);
    tilebuf_destroy(&t);
    scene_destroy(&sc);
}

/* The image is upright and unmirrored, as a perspective camera's: a light up and to the left
 * of the axis lands in the image's upper-left quadrant with both cameras. */
static void brightest_quadrant(const char *camera, int *qx, int *qy)
{
    char text[2048];
    snprintf(
        text, sizeof text,
        "%s\nFilm \"rgb\" \"integer xresolution\" 32 \"integer yresolution\" 24\n"
        "Sampler \"independent\" \"integer pixelsamples\" 16\n"
        "Integrator \"path\" \"integer maxdepth\" 1\nWorldBegin\n"
        "AreaLightSource \"diffuse\" \"rgb L\" [1 1 1] \"bool twosided\" true\n"
        "Shape \"trianglemesh\" \"point3 P\" [-0.2 0.08 2  -0.1 0.08 2  -0.1 0.16 2  -0.2 0.16 2] "
        "\"integer indices\" [0 1 2 0 2 3]\n",
        camera);
    err_t err = {{0}};
    scene_t *sc = sb_load_text(text, NULL);
    const render_settings_t *rs = &sc->settings;
    tilebuf_t *t = tilebuf_new(0, 0, rs->xres, rs->yres, rs->grid.n, &err);
    if (!t || render_tile(sc, NULL, 0, 0, rs->xres, rs->yres, 0, (uint32_t)rs->spp, t, NULL, &err))
        fail_msg("render: %s", err.msg);
    double q[2][2] = {{0, 0}, {0, 0}};
    for (int y = 0; y < 24; y++)
        for (int x = 0; x < 32; x++)
            q[y / 12][x / 16] += tilebuf_xyz_sum(t, x, y, 1);
    *qx = *qy = 0;
    for (int a = 0; a < 2; a++)
        for (int b = 0; b < 2; b++)
            if (q[a][b] > q[*qy][*qx])
                *qy = a, *qx = b;
    assert_true(q[*qy][*qx] > 0);
    tilebuf_destroy(&t);
    scene_destroy(&sc);
}

static void test_upright(void **state)
{
    (void)state;
    int px, py, rx, ry;
    brightest_quadrant("Camera \"perspective\" \"float fov\" 12", &px, &py);
    brightest_quadrant(
        "Camera \"realistic\" \"string lensfile\" \"../scenes/lenses/landscape-bk7-100mm.dat\" "
        "\"float aperturediameter\" 8 \"float focusdistance\" 2",
        &rx, &ry);
    /* camera space +x is the image's right, +y up: the light is upper left */
    assert_int_equal(px, 0);
    assert_int_equal(py, 0);
    assert_int_equal(rx, px);
    assert_int_equal(ry, py);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_focal_length_and_dispersion),
        cmocka_unit_test(test_focus),
        cmocka_unit_test(test_pupil_covers),
        cmocka_unit_test(test_edges_finite),
        cmocka_unit_test(test_bad_files),
        cmocka_unit_test(test_rendered_fringe),
        cmocka_unit_test(test_upright),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
