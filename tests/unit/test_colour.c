/* Tests for cie and colour: the CMF tables and their integral, chromaticities of standard
 * illuminants against published values, the IEC 61966-2-1 matrices and transfer curve, the
 * tone mapper's curves and hue-preserving gamut clip, and framebuffer buckets to XYZ. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "cie.h"
#include "colour.h"
#include "numeric_testutil.h"
#include "spectrum.h"

#include <math.h>

static xyz_t xyz_of(spectrum_t *s)
{
    assert_non_null(s);
    return spectrum_to_xyz(s);
}

/* The CIE_Y integral: pbrt-v4 publishes CIE_Y_integral = 106.856895 for its float32 copy of the
 * same CVRL table; float32 rounding of 471 entries moves the sum by a few 1e-7 relative. */
static void test_cie_y_integral(void **state)
{
    (void)state;
    double sum = 0.0;
    for (int i = 0; i < CIE_SAMPLE_COUNT; i++)
        sum += cie_y_table[i];
    testutil_assert_near(sum, CIE_Y_INTEGRAL, 1e-9);
    testutil_assert_near(cie_y_integral_value, CIE_Y_INTEGRAL, 1e-9);
    testutil_assert_near(CIE_Y_INTEGRAL, 106.856895, 106.856895 * 5e-7);
}

/* Definition points of the CIE 1931 observer: y-bar peaks at exactly 1 at 555 nm. Interpolation
 * is linear between the 1 nm entries; outside 360-830 and at NaN the CMFs are 0. */
static void test_cie_eval(void **state)
{
    (void)state;
    testutil_assert_near(cie_y_bar(555.0), 1.0, 0.0);
    for (int i = 0; i < CIE_SAMPLE_COUNT; i++)
        assert_true(cie_y_table[i] <= 1.0);
    testutil_assert_near(cie_x_bar(600.5), 0.5 * (cie_x_table[240] + cie_x_table[241]), 1e-15);
    testutil_assert_near(cie_z_bar(450.25), 0.75 * cie_z_table[90] + 0.25 * cie_z_table[91], 1e-15);
    testutil_assert_near(cie_x_bar(359.999), 0.0, 0.0);
    testutil_assert_near(cie_y_bar(830.001), 0.0, 0.0);
    testutil_assert_near(cie_z_bar(NAN), 0.0, 0.0);
    testutil_assert_near(cie_y_bar(830.0), cie_y_table[470], 0.0);
    /* D65: S(560) = 100 by definition; CIE 15 table values at 300 and 500 nm. */
    testutil_assert_near(cie_d65_eval(560.0), 100.0, 1e-12);
    testutil_assert_near(cie_d65_eval(300.0), 0.0341, 1e-12);
    testutil_assert_near(cie_d65_eval(500.0), 109.354, 1e-9);
    testutil_assert_near(cie_d65_eval(299.9), 0.0, 0.0);
    testutil_assert_near(cie_d65_eval(830.1), 0.0, 0.0);
}

/* The integral of a piecewise-linear function is exact by the trapezoid rule on its knots and
 * by the midpoint rule on any sub-interval of one segment. */
static void test_cie_integrate(void **state)
{
    (void)state;
    double trap = 0.0;
    for (int i = 0; i + 1 < CIE_SAMPLE_COUNT; i++)
        trap += 0.5 * (cie_y_table[i] + cie_y_table[i + 1]);
    testutil_assert_near(cie_cmf_integrate(300.0, 900.0).y, trap, 1e-10);
    testutil_assert_near(cie_cmf_integrate(360.0, 830.0).y, trap, 1e-10);
    testutil_assert_near(cie_cmf_integrate(500.25, 500.75).x, 0.5 * cie_x_bar(500.5), 1e-15);
    xyz_t a = cie_cmf_integrate(412.3, 688.9), b = cie_cmf_integrate(688.9, 412.3);
    testutil_assert_near(a.z, -b.z, 1e-15);
    xyz_t split = cie_cmf_integrate(412.3, 530.55), rest = cie_cmf_integrate(530.55, 688.9);
    testutil_assert_near(split.x + rest.x, a.x, 1e-12);
    testutil_assert_near(cie_cmf_integrate(200.0, 359.0).y, 0.0, 0.0);
}

/* docs/physics.md §1.3: a D65 spectrum of any scale maps to the sRGB white (0.3127, 0.3290)
 * within 1e-3. Tighter: CIE 15:2004 gives the D65 chromaticity computed from the tables as
 * (0.31271, 0.32902); the 1 nm sum over linearly interpolated 5 nm data moves it by under 3e-5
 * (data/srgb_matrices.txt recomputes 0.31273, 0.32902). */
static void test_d65_chromaticity_any_scale(void **state)
{
    (void)state;
    err_t err;
    spectrum_t *d65 = spectrum_new_cie_d65(&err);
    assert_non_null(d65);
    for (double scale = 1e-6; scale <= 1.5e6; scale *= 10.0) {
        spectrum_t *s = spectrum_new_scaled(d65, scale, &err);
        double x, y;
        assert_int_equal(colour_xyz_to_xy(xyz_of(s), &x, &y), 0);
        testutil_assert_near(x, 0.3127, 1e-3);
        testutil_assert_near(y, 0.3290, 1e-3);
        testutil_assert_near(x, 0.31271, 5e-5);
        testutil_assert_near(y, 0.32902, 5e-5);
        /* Linear sRGB of D65 is neutral: equal channels to the matrices' 4-decimal white. */
        rgb_t rgb = colour_xyz_to_linear_srgb(xyz_of(s));
        testutil_assert_near(rgb.r / rgb.g, 1.0, 5e-4);
        testutil_assert_near(rgb.b / rgb.g, 1.0, 5e-4);
        spectrum_destroy(&s);
        assert_null(s);
    }
    spectrum_destroy(&d65);
}

/* CIE 15:2004: illuminant A has chromaticity (0.44757, 0.40745). */
static void test_illuminant_a_chromaticity(void **state)
{
    (void)state;
    err_t err;
    spectrum_t *a = spectrum_new_cie_a(&err);
    double x, y;
    assert_int_equal(colour_xyz_to_xy(xyz_of(a), &x, &y), 0);
    testutil_assert_near(x, 0.44757, 1e-3);
    testutil_assert_near(y, 0.40745, 1e-3);
    spectrum_destroy(&a);
}

/* The Planckian locus at 6504 K is at about (0.3135, 0.3236) (CIE 15; the 1960 UCS isotherm
 * tables), distinct from D65's (0.3127, 0.3290) which lies above the locus. */
static void test_blackbody_6504_chromaticity(void **state)
{
    (void)state;
    err_t err;
    for (int normalise = 0; normalise <= 1; normalise++) {
        spectrum_t *b = spectrum_new_blackbody(6504.0, normalise, &err);
        double x, y;
        assert_int_equal(colour_xyz_to_xy(xyz_of(b), &x, &y), 0);
        testutil_assert_near(x, 0.3135, 2e-3);
        testutil_assert_near(y, 0.3236, 2e-3);
        spectrum_destroy(&b);
    }
}

/* IEC 61966-2-1: the sRGB primaries are R (0.64, 0.33), G (0.30, 0.60), B (0.15, 0.06) and
 * white (0.3127, 0.3290). The 4-decimal matrix reproduces them to its rounding: 1e-4. */
static void test_srgb_primaries(void **state)
{
    (void)state;
    const rgb_t in[4] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
    const double xy[4][2] = {{0.64, 0.33}, {0.30, 0.60}, {0.15, 0.06}, {0.3127, 0.3290}};
    for (int i = 0; i < 4; i++) {
        double x, y;
        assert_int_equal(colour_xyz_to_xy(colour_linear_srgb_to_xyz(in[i]), &x, &y), 0);
        testutil_assert_near(x, xy[i][0], 1e-4);
        testutil_assert_near(y, xy[i][1], 1e-4);
    }
    /* White has Y = 1 and the luminance row sums to 1. */
    testutil_assert_near(colour_linear_srgb_to_xyz(in[3]).y, 1.0, 1e-12);
    testutil_assert_near(colour_luminance(in[3]), 1.0, 1e-12);
    /* The two matrices are inverses (the 8-decimal one is printed rounded): 1e-8. */
    const rgb_t probes[3] = {{0.3, 0.7, 0.1}, {1.0, 0.0, 0.5}, {-0.2, 2.0, 0.01}};
    for (int i = 0; i < 3; i++) {
        rgb_t back = colour_xyz_to_linear_srgb(colour_linear_srgb_to_xyz(probes[i]));
        testutil_assert_near(back.r, probes[i].r, 1e-8);
        testutil_assert_near(back.g, probes[i].g, 1e-8);
        testutil_assert_near(back.b, probes[i].b, 1e-8);
    }
    /* XYZ -> sRGB of the D65 white from the standard (0.9505, 1, 1.089) is (1, 1, 1). */
    rgb_t w = colour_xyz_to_linear_srgb((xyz_t){0.9505, 1.0, 1.0890});
    testutil_assert_near(w.r, 1.0, 1e-6);
    testutil_assert_near(w.g, 1.0, 1e-6);
    testutil_assert_near(w.b, 1.0, 1e-6);
    double x, y;
    assert_int_equal(colour_xyz_to_xy((xyz_t){0, 0, 0}, &x, &y), -1);
    testutil_assert_near(x, 0.3127, 0.0);
}

/* Transfer curve at points computed by hand from IEC 61966-2-1's formula:
 * encode(0.0031308) = 12.92 * 0.0031308 = 0.04044994 (both branches meet there to 1e-7),
 * encode(0.18) = 1.055 * 0.18^(1/2.4) - 0.055 = 0.461356 (18% grey is sRGB 118/255),
 * decode(0.5) = ((0.5 + 0.055) / 1.055)^2.4 = 0.214041, decode(0.04045) = 0.0031308. */
static void test_transfer_curve(void **state)
{
    (void)state;
    testutil_assert_near(colour_srgb_encode(0.0), 0.0, 0.0);
    testutil_assert_near(colour_srgb_encode(1.0), 1.0, 1e-15);
    testutil_assert_near(colour_srgb_encode(0.0031308), 0.04044994, 1e-8);
    testutil_assert_near(colour_srgb_encode(0.0031309), 0.04045123, 1e-6);
    testutil_assert_near(colour_srgb_encode(0.18), 0.461356, 1e-6);
    testutil_assert_near(colour_srgb_decode(0.5), 0.214041, 1e-6);
    testutil_assert_near(colour_srgb_decode(0.04045), 0.0031308, 1e-7);
    testutil_assert_near(colour_srgb_encode(-1.0), 0.0, 0.0);
    testutil_assert_near(colour_srgb_encode(7.0), 1.0, 1e-15);
    testutil_assert_near(colour_srgb_encode(NAN), 0.0, 0.0);
    for (double v = 0.0; v <= 1.0; v += 1.0 / 64.0)
        testutil_assert_near(colour_srgb_decode(colour_srgb_encode(v)), v, 1e-12);
}

/* Narkowicz's ACES fit maps 1 to (2.51 + 0.03) / (2.43 + 0.59 + 0.14) = 0.8037975 and 0 to 0;
 * Reinhard maps L to L / (1 + L). A grey stays grey (the curve is applied to luminance). */
static void test_tone_curves(void **state)
{
    (void)state;
    colour_tonemap_t aces = {0.0, COLOUR_CURVE_ACES};
    rgb_t g = colour_tonemap_apply(aces, (rgb_t){1, 1, 1});
    testutil_assert_near(g.r, 2.54 / 3.16, 1e-12);
    testutil_assert_near(g.g, 2.54 / 3.16, 1e-12);
    testutil_assert_near(g.b, 2.54 / 3.16, 1e-12);
    g = colour_tonemap_apply(aces, (rgb_t){1e6, 1e6, 1e6});
    testutil_assert_near(g.g, 1.0, 0.0);
    colour_tonemap_t reinhard = {1.0, COLOUR_CURVE_REINHARD}; /* +1 stop: 0.5 becomes 1 */
    g = colour_tonemap_apply(reinhard, (rgb_t){0.5, 0.5, 0.5});
    testutil_assert_near(g.r, 0.5, 1e-12);
    reinhard.exposure_stops = -2.0; /* 12 -> 3 -> 0.75 */
    g = colour_tonemap_apply(reinhard, (rgb_t){12, 12, 12});
    testutil_assert_near(g.b, 0.75, 1e-12);
    /* Non-finite or non-positive input is black, never NaN. */
    g = colour_tonemap_apply(aces, (rgb_t){NAN, 1, 1});
    testutil_assert_near(g.r + g.g + g.b, 0.0, 0.0);
    g = colour_tonemap_apply(aces, (rgb_t){INFINITY, 1, 1});
    testutil_assert_near(g.r + g.g + g.b, 0.0, 0.0);
    g = colour_tonemap_apply(aces, (rgb_t){-1, -1, -1});
    testutil_assert_near(g.r + g.g + g.b, 0.0, 0.0);
}

/* Hue preservation: the clipped colour is a mix of the input with the grey of the same
 * luminance, so in xy it lies on the segment from the white point toward the input's
 * chromaticity (cross product 0, positive dot product), and its luminance is unchanged. A
 * per-channel clamp fails this (the example below turns (1.6, 0.4, -0.3) from orange-red into
 * a yellower orange). */
static void test_gamut_clip_preserves_hue(void **state)
{
    (void)state;
    const rgb_t cases[] = {
        {1.6, 0.4, -0.3}, {-0.2, 0.8, 0.1}, {0.05, 0.1, 1.9}, {1.2, 0.9, 0.2}, {0.9, -0.05, 0.9}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        rgb_t c = cases[i];
        rgb_t d = colour_gamut_clip(c);
        assert_true(d.r >= 0.0 && d.r <= 1.0 && d.g >= 0.0 && d.g <= 1.0 && d.b >= 0.0 &&
                    d.b <= 1.0);
        double y = colour_luminance(c);
        testutil_assert_near(colour_luminance(d), y, 1e-12);
        double wx, wy, x0, y0, x1, y1;
        colour_xyz_to_xy(colour_linear_srgb_to_xyz((rgb_t){1, 1, 1}), &wx, &wy);
        colour_xyz_to_xy(colour_linear_srgb_to_xyz(c), &x0, &y0);
        colour_xyz_to_xy(colour_linear_srgb_to_xyz(d), &x1, &y1);
        double ax = x0 - wx, ay = y0 - wy, bx = x1 - wx, by = y1 - wy;
        double la = hypot(ax, ay), lb = hypot(bx, by);
        assert_true(lb > 1e-6);
        testutil_assert_near((ax * by - ay * bx) / (la * lb), 0.0,
                             1e-9); /* sine of the hue change */
        assert_true(ax * bx + ay * by > 0.0);
        assert_true(lb < la); /* less saturated, not more */
    }
    /* The per-channel clamp of the first case changes the hue by far more than the above. */
    rgb_t c = cases[0], k = {1.0, 0.4, 0.0};
    double wx, wy, x0, y0, x1, y1;
    colour_xyz_to_xy(colour_linear_srgb_to_xyz((rgb_t){1, 1, 1}), &wx, &wy);
    colour_xyz_to_xy(colour_linear_srgb_to_xyz(c), &x0, &y0);
    colour_xyz_to_xy(colour_linear_srgb_to_xyz(k), &x1, &y1);
    double ax = x0 - wx, ay = y0 - wy, bx = x1 - wx, by = y1 - wy;
    assert_true(fabs((ax * by - ay * bx) / (hypot(ax, ay) * hypot(bx, by))) > 0.01);
    /* In-gamut colours pass unchanged; luminance >= 1 is white, <= 0 black. */
    rgb_t in = colour_gamut_clip((rgb_t){0.2, 0.5, 0.7});
    testutil_assert_near(in.r, 0.2, 1e-15);
    testutil_assert_near(in.b, 0.7, 1e-15);
    rgb_t w = colour_gamut_clip((rgb_t){3.0, 1.0, 0.5});
    testutil_assert_near(w.r + w.g + w.b, 3.0, 0.0);
    rgb_t b = colour_gamut_clip((rgb_t){-1.0, 0.1, 0.1});
    testutil_assert_near(b.r + b.g + b.b, 0.0, 0.0);
}

static void test_srgb8(void **state)
{
    (void)state;
    unsigned char px[3];
    colour_tonemap_t clip = {0.0, COLOUR_CURVE_CLIP};
    colour_tonemap_to_srgb8(clip, (rgb_t){0.18, 0.18, 0.18}, px);
    assert_int_equal(px[0], 118); /* 0.461356 * 255 = 117.65 */
    assert_int_equal(px[2], 118);
    colour_tonemap_to_srgb8(clip, (rgb_t){0, 0, 0}, px);
    assert_int_equal(px[0] + px[1] + px[2], 0);
    colour_tonemap_to_srgb8(clip, (rgb_t){1, 1, 1}, px);
    assert_int_equal(px[0] + px[1] + px[2], 3 * 255);
    colour_tonemap_to_srgb8((colour_tonemap_t){0.0, COLOUR_CURVE_ACES}, (rgb_t){NAN, 0, 0}, px);
    assert_int_equal(px[0] + px[1] + px[2], 0);
    colour_tonemap_to_srgb8((colour_tonemap_t){0.0, COLOUR_CURVE_ACES}, (rgb_t){1e30, 1e30, 1e30},
                            px);
    assert_int_equal(px[0] + px[1] + px[2], 3 * 255);
    /* Pure linear red stays pure red: 255, 0, 0. */
    colour_tonemap_to_srgb8(clip, (rgb_t){1, 0, 0}, px);
    assert_int_equal(px[0], 255);
    assert_int_equal(px[1], 0);
    assert_int_equal(px[2], 0);
}

/* Buckets to XYZ. A constant 1 held over buckets covering 360-830 has the XYZ of the constant
 * spectrum 1, i.e. Y = 1 up to the trapezoid-vs-sum difference of the table's end values
 * (below 1e-7); buckets outside the visible range weigh nothing. */
static void test_buckets_to_xyz(void **state)
{
    (void)state;
    double ones[64];
    for (int i = 0; i < 64; i++)
        ones[i] = 1.0;
    const int ns[] = {8, 16, 32, 45};
    for (int k = 0; k < 4; k++) {
        spectral_grid_t g = {ns[k], 360.0, 830.0};
        xyz_t c = colour_buckets_to_xyz(g, ones);
        testutil_assert_near(c.y, 1.0, 1e-7);
        xyz_t w[64];
        colour_grid_weights(g, w);
        xyz_t c2 = colour_buckets_to_xyz_weighted(g.n, w, ones);
        testutil_assert_near(c2.x, c.x, 1e-14);
        testutil_assert_near(c2.z, c.z, 1e-14);
    }
    /* 300-1000 nm in 14 buckets of 50 nm: bucket 0 (300-350) and 11-13 (850-1000) are outside
     * 360-830; whatever they hold changes nothing. Bucket 10 (800-850) straddles 830. */
    spectral_grid_t wide = {14, 300.0, 1000.0};
    double v[14];
    for (int i = 0; i < 14; i++)
        v[i] = 1.0;
    xyz_t a = colour_buckets_to_xyz(wide, v);
    v[0] = 1e9;
    v[11] = 1e9;
    v[13] = -5.0;
    xyz_t b = colour_buckets_to_xyz(wide, v);
    testutil_assert_near(a.x, b.x, 0.0);
    testutil_assert_near(a.y, b.y, 0.0);
    testutil_assert_near(a.z, b.z, 0.0);
    testutil_assert_near(a.y, 1.0, 1e-7);
    /* D65 held as bucket averages (computed here by a fine midpoint sum) over the default
     * 16 buckets of 380-720 nm keeps D65's chromaticity: the tails cut off below 380 and above
     * 720 nm hold under 0.1% of Y and shift xy by under 1e-3. */
    spectral_grid_t def = spectral_grid_default();
    double d65[16];
    for (int i = 0; i < def.n; i++) {
        double lo = spectral_grid_bucket_min(def, i), hi = spectral_grid_bucket_max(def, i),
               sum = 0.0;
        for (int j = 0; j < 1000; j++)
            sum += cie_d65_eval(lo + (hi - lo) * (j + 0.5) / 1000.0);
        d65[i] = 3.7 * sum / 1000.0;
    }
    double x, y;
    assert_int_equal(colour_xyz_to_xy(colour_buckets_to_xyz(def, d65), &x, &y), 0);
    testutil_assert_near(x, 0.3127, 1e-3);
    testutil_assert_near(y, 0.3290, 1e-3);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cie_y_integral),
        cmocka_unit_test(test_cie_eval),
        cmocka_unit_test(test_cie_integrate),
        cmocka_unit_test(test_d65_chromaticity_any_scale),
        cmocka_unit_test(test_illuminant_a_chromaticity),
        cmocka_unit_test(test_blackbody_6504_chromaticity),
        cmocka_unit_test(test_srgb_primaries),
        cmocka_unit_test(test_transfer_curve),
        cmocka_unit_test(test_tone_curves),
        cmocka_unit_test(test_gamut_clip_preserves_hue),
        cmocka_unit_test(test_srgb8),
        cmocka_unit_test(test_buckets_to_xyz),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
