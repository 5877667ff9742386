/* Tests for spectrum: tabulated interpolation and its validation, Planck's law against the
 * Stefan-Boltzmann and Wien laws, CIE illuminant A against published values, the photometric
 * integral, the Jakob-Hanika RGB uplift (round trip, bounds, exact greys, timing) and the RGB
 * illuminant, and concurrent evaluation. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "cie.h"
#include "colour.h"
#include "numeric_testutil.h"
#include "pool.h"
#include "rgb_uplift.h"
#include "spectrum.h"

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#define assert_contains(haystack, needle)                                                          \
    do {                                                                                           \
        if (!strstr((haystack), (needle)))                                                         \
            fail_msg("message \"%s\" does not mention \"%s\"", (haystack), (needle));              \
    } while (0)

static void test_tabulated(void **state)
{
    (void)state;
    err_t err;
    /* Samples of the line f = 2 lambda + 1 at uneven spacing: linear interpolation reproduces
     * it exactly inside, and holds the end values outside. */
    const double l[] = {400.0, 410.5, 433.0, 600.0, 700.0};
    double v[5];
    for (int i = 0; i < 5; i++)
        v[i] = 2.0 * l[i] + 1.0;
    spectrum_t *s = spectrum_new_tabulated(l, v, 5, &err);
    assert_non_null(s);
    assert_int_equal(spectrum_kind(s), SPECTRUM_TABULATED);
    for (double x = 400.0; x <= 700.0; x += 3.7)
        testutil_assert_near(spectrum_eval(s, x), 2.0 * x + 1.0, 1e-10);
    testutil_assert_near(spectrum_eval(s, 433.0), 867.0, 0.0);
    testutil_assert_near(spectrum_eval(s, 300.0), 801.0, 0.0);
    testutil_assert_near(spectrum_eval(s, 900.0), 1401.0, 0.0);
    testutil_assert_near(spectrum_eval(s, NAN), 0.0, 0.0);

    /* A scaled copy is independent of its source. */
    spectrum_t *k = spectrum_new_scaled(s, -0.5, &err);
    spectrum_destroy(&s);
    assert_null(s);
    testutil_assert_near(spectrum_eval(k, 500.0), -0.5 * 1001.0, 1e-10);
    spectrum_t *k2 = spectrum_new_scaled(k, 4.0, &err);
    testutil_assert_near(spectrum_eval(k2, 500.0), -2.0 * 1001.0, 1e-10);
    spectrum_destroy(&k);
    spectrum_destroy(&k2);
    assert_null(spectrum_new_scaled(k2 = spectrum_new_constant(1.0, &err), NAN, &err));
    assert_contains(err.msg, "factor");
    spectrum_destroy(&k2);
    spectrum_destroy(&k2); /* destroying NULL is harmless */

    /* One pair is a constant. */
    s = spectrum_new_tabulated((double[]){550.0}, (double[]){0.25}, 1, &err);
    assert_non_null(s);
    testutil_assert_near(spectrum_eval(s, 380.0), 0.25, 0.0);
    testutil_assert_near(spectrum_eval(s, 780.0), 0.25, 0.0);
    spectrum_destroy(&s);

    /* Validation names the pair at fault (counting from 1). */
    assert_null(spectrum_new_tabulated((double[]){400, 500, 450}, (double[]){1, 1, 1}, 3, &err));
    assert_contains(err.msg, "pair 3");
    assert_null(spectrum_new_tabulated((double[]){400, 400}, (double[]){1, 2}, 2, &err));
    assert_contains(err.msg, "pair 2");
    assert_null(spectrum_new_tabulated((double[]){400, 500, 600}, (double[]){1, NAN, 1}, 3, &err));
    assert_contains(err.msg, "pair 2");
    assert_null(spectrum_new_tabulated((double[]){INFINITY}, (double[]){1}, 1, &err));
    assert_contains(err.msg, "pair 1");
    assert_null(spectrum_new_tabulated((double[]){1}, (double[]){1}, 0, &err));
    assert_contains(err.msg, "at least one");
    assert_null(spectrum_new_constant(NAN, &err));
}

/* The interval search against a linear scan, on tables whose spacing is far from even (clustered
 * nodes, one wide gap, two nodes): at nodes, between them and one ulp below, so that a faster
 * search (a proportional guess was tried: docs/performance.md) must give the same bits. */
static void test_tabulated_search(void **state)
{
    (void)state;
    const double clustered[] = {360, 360.5, 361, 361.25, 380, 700, 701, 829, 830};
    const double wide[] = {300, 310, 320, 330, 340, 350, 360, 900};
    const double two[] = {400, 700};
    const struct {
        const double *l;
        size_t n;
    } tables[] = {{clustered, 9}, {wide, 8}, {two, 2}};
    for (size_t k = 0; k < sizeof tables / sizeof tables[0]; k++) {
        const double *l = tables[k].l;
        size_t n = tables[k].n;
        double v[16];
        for (size_t i = 0; i < n; i++)
            v[i] = 1.0 + 0.37 * (double)i * (double)(i % 3);
        err_t err = {0};
        spectrum_t *s = spectrum_new_tabulated(l, v, n, &err);
        assert_non_null(s);
        for (int j = 0; j <= 4000; j++) {
            const double x = 290.0 + 0.15 * j;
            double lam[3] = {x, nextafter(x, 0.0), x};
            if (j % 7 == 0)
                lam[2] = l[(size_t)j % n];
            for (int q = 0; q < 3; q++) {
                double want;
                if (lam[q] <= l[0])
                    want = v[0];
                else if (lam[q] >= l[n - 1])
                    want = v[n - 1];
                else {
                    size_t lo = 0;
                    while (l[lo + 1] <= lam[q])
                        lo++;
                    double f = (lam[q] - l[lo]) / (l[lo + 1] - l[lo]);
                    want = v[lo] + f * (v[lo + 1] - v[lo]);
                }
                double got = spectrum_eval(s, lam[q]);
                if (memcmp(&got, &want, sizeof got))
                    fail_msg("table %zu at %.17g nm: %.17g, the scan gives %.17g", k, lam[q], got,
                             want);
            }
        }
        spectrum_destroy(&s);
    }
}

/* pi * integral of B over all wavelengths = sigma T^4 (Stefan-Boltzmann, sigma = 5.670374419e-8
 * W m^-2 K^-4, CODATA 2018). Integrated in ln(lambda) from 10 nm to 1e7 nm by the trapezoid
 * rule with 40000 steps (error ~1e-9 for this smooth integrand); the Rayleigh-Jeans tail beyond
 * 1e7 nm, 2 c k T / (3 lambda^3), is below 1e-12 of the total. */
static void test_blackbody_stefan_boltzmann(void **state)
{
    (void)state;
    err_t err;
    const double temps[] = {1000.0, 2856.0, 5778.0, 10000.0};
    for (int t = 0; t < 4; t++) {
        spectrum_t *b = spectrum_new_blackbody(temps[t], 0, &err);
        assert_non_null(b);
        const int steps = 40000;
        double u0 = log(10.0), u1 = log(1e7), h = (u1 - u0) / steps, sum = 0.0;
        for (int i = 0; i <= steps; i++) {
            double lambda = exp(u0 + h * i);
            double f = spectrum_eval(b, lambda) * lambda; /* d lambda = lambda du */
            sum += (i == 0 || i == steps) ? 0.5 * f : f;
        }
        double exitance = 3.14159265358979323846 * sum * h;
        double sigma_t4 = 5.670374419e-8 * pow(temps[t], 4.0);
        testutil_assert_near(exitance / sigma_t4, 1.0, 1e-6);
        spectrum_destroy(&b);
    }
}

/* Wien's displacement law: the peak of B(lambda) is at 2897.77 um K / T. The peak is found by
 * golden-section search to 1e-4 nm; the tolerance is 0.5 nm. The normalised spectrum (pbrt-v4)
 * is 1 at that peak and below 1 elsewhere. */
static double golden_max(const spectrum_t *s, double a, double b)
{
    const double g = 0.5 * (sqrt(5.0) - 1.0);
    double c = b - g * (b - a), d = a + g * (b - a);
    while (b - a > 1e-4) {
        if (spectrum_eval(s, c) > spectrum_eval(s, d))
            b = d;
        else
            a = c;
        c = b - g * (b - a);
        d = a + g * (b - a);
    }
    return 0.5 * (a + b);
}

static void test_blackbody_wien(void **state)
{
    (void)state;
    err_t err;
    const double temps[] = {2000.0, 3000.0, 5000.0, 6504.0, 10000.0, 20000.0};
    for (int t = 0; t < 6; t++) {
        spectrum_t *b = spectrum_new_blackbody(temps[t], 1, &err);
        assert_non_null(b);
        double peak = golden_max(b, 50.0, 5000.0);
        testutil_assert_near(peak, 2897.77e3 / temps[t], 0.5);
        testutil_assert_near(spectrum_eval(b, peak), 1.0, 1e-9);
        assert_true(spectrum_eval(b, peak * 0.9) < 1.0 && spectrum_eval(b, peak * 1.1) < 1.0);
        spectrum_destroy(&b);
    }
    /* Far in the Wien tail exp() overflows: the value is 0, not NaN. */
    spectrum_t *cold = spectrum_new_blackbody(300.0, 0, &err);
    testutil_assert_near(spectrum_eval(cold, 1.0), 0.0, 0.0);
    testutil_assert_near(spectrum_eval(cold, -5.0), 0.0, 0.0);
    spectrum_destroy(&cold);
    assert_null(spectrum_new_blackbody(0.0, 0, &err));
    assert_contains(err.msg, "temperature");
    assert_null(spectrum_new_blackbody(NAN, 1, &err));
    assert_null(spectrum_new_blackbody(INFINITY, 1, &err));
}

/* Illuminant A from its analytic definition against published tables: CIE 15:2004 Table T.1
 * (300 nm: 0.930483) and colour-science's test data DATA_A (colour/colorimetry/tests/
 * test_illuminants.py, 360-830 nm at 5 nm, 8 decimals). D65 at its table points. */
static void test_cie_illuminants(void **state)
{
    (void)state;
    err_t err;
    spectrum_t *a = spectrum_new_cie_a(&err);
    assert_int_equal(spectrum_kind(a), SPECTRUM_CIE_A);
    const double lambda[] = {360, 380, 400, 500, 560, 600, 700, 780, 830};
    const double value[] = {6.14461778,   9.79509961,   14.70803845,  59.86109896, 100.0,
                            129.04273891, 198.26122323, 241.67538835, 261.60233977};
    for (int i = 0; i < 9; i++)
        testutil_assert_near(spectrum_eval(a, lambda[i]), value[i], 1e-7 * value[i] + 1e-8);
    testutil_assert_near(spectrum_eval(a, 300.0), 0.930483, 1e-6);
    spectrum_destroy(&a);

    spectrum_t *d = spectrum_new_cie_d65(&err);
    testutil_assert_near(spectrum_eval(d, 560.0), 100.0, 1e-12);
    testutil_assert_near(spectrum_eval(d, 600.0), 90.0062, 1e-9);
    testutil_assert_near(spectrum_eval(d, 602.5), 0.5 * (90.0062 + 89.8026), 1e-9);
    testutil_assert_near(spectrum_eval(d, 250.0), 0.0, 0.0);
    spectrum_destroy(&d);
}

/* Photometric integral: a constant 1 gives the y-bar integral (pbrt-v4 CIE_Y_integral,
 * 106.856895, up to float32 rounding); a triangle that is nonzero only at 555 nm on the 1 nm
 * grid gives y-bar(555) = 1 exactly. */
static void test_photometric(void **state)
{
    (void)state;
    err_t err;
    spectrum_t *one = spectrum_new_constant(1.0, &err);
    testutil_assert_near(spectrum_photometric(one), 106.856895, 5e-5);
    testutil_assert_near(spectrum_photometric_light(one), spectrum_photometric(one), 0.0);
    spectrum_destroy(&one);
    spectrum_t *tri =
        spectrum_new_tabulated((double[]){554, 555, 556}, (double[]){0, 1, 0}, 3, &err);
    testutil_assert_near(spectrum_photometric(tri), 1.0, 1e-15);
    spectrum_destroy(&tri);
}

/* RGB of a reflectance under D65, computed here independently of the solver:
 * RGB = M sum(s D65 cmf) / sum(D65 y-bar) over 360..830 nm at 1 nm. */
static rgb_t reflectance_rgb(const spectrum_t *s)
{
    double x = 0, y = 0, z = 0, norm = 0;
    for (int i = 0; i < CIE_SAMPLE_COUNT; i++) {
        double lambda = 360.0 + i, d = cie_d65_eval(lambda), v = spectrum_eval(s, lambda);
        x += v * d * cie_x_bar(lambda);
        y += v * d * cie_y_bar(lambda);
        z += v * d * cie_z_bar(lambda);
        norm += d * cie_y_bar(lambda);
    }
    return colour_xyz_to_linear_srgb((xyz_t){x / norm, y / norm, z / norm});
}

static double max_diff(rgb_t a, rgb_t b)
{
    return fmax(fabs(a.r - b.r), fmax(fabs(a.g - b.g), fabs(a.b - b.b)));
}

/* Jakob & Hanika 2019 uplift: round trip within 2e-3 (a fixed bound; the solver reaches
 * ~1e-10 on reachable colours, greys are off by the 1.8e-4 between the sRGB matrix's white
 * and the tabulated D65), values in [0, 1] everywhere (checked 200-2000 nm), greys exactly
 * flat. */
static void test_rgb_uplift_round_trip(void **state)
{
    (void)state;
    err_t err;
    const rgb_t colours[] = {
        {0.8, 0.1, 0.1},   {0.1, 0.8, 0.1},  {0.05, 0.1, 0.9},      {0.2, 0.3, 0.4},
        {0.9, 0.6, 0.1},   {1.0, 0.0, 0.0},  {0.0, 1.0, 0.0},       {0.0, 0.0, 1.0},
        {1.0, 1.0, 0.0},   {0.0, 1.0, 1.0},  {1.0, 0.0, 1.0},       {0.02, 0.02, 0.5},
        {0.001, 0.9, 0.9}, {0.0, 0.0, 1e-4}, {0.0, 0.0, 0.0},       {0.18, 0.18, 0.18},
        {0.5, 0.5, 0.5},   {1.0, 1.0, 1.0},  {0.999, 0.999, 0.001},
    };
    double worst = 0.0;
    for (size_t i = 0; i < sizeof colours / sizeof colours[0]; i++) {
        rgb_t c = colours[i];
        spectrum_t *s = spectrum_new_rgb_reflectance(c, &err);
        assert_non_null(s);
        assert_int_equal(spectrum_kind(s), SPECTRUM_RGB_REFLECTANCE);
        double e = max_diff(reflectance_rgb(s), c);
        if (e > worst)
            worst = e;
        if (!(e < 2e-3))
            fail_msg("uplift of (%g, %g, %g): round trip error %g", c.r, c.g, c.b, e);
        for (double l = 200.0; l <= 2000.0; l += 0.1) {
            double v = spectrum_eval(s, l);
            if (!(v >= 0.0 && v <= 1.0))
                fail_msg("uplift of (%g, %g, %g) is %g at %g nm", c.r, c.g, c.b, v, l);
        }
        if (c.r == c.g && c.g == c.b)
            for (double l = 300.0; l <= 900.0; l += 7.3)
                assert_true(spectrum_eval(s, l) == c.r);
        spectrum_destroy(&s);
    }
    print_message("JH uplift: worst RGB round-trip error %.3g over %zu colours\n", worst,
                  sizeof colours / sizeof colours[0]);

    /* Components are clamped into [0, 1]; NaN is an error. */
    spectrum_sigmoid_t a, b;
    assert_int_equal(spectrum_sigmoid_fit((rgb_t){1.5, -0.2, 0.5}, &a, &err), 0);
    assert_int_equal(spectrum_sigmoid_fit((rgb_t){1.0, 0.0, 0.5}, &b, &err), 0);
    assert_true(memcmp(a.c, b.c, sizeof a.c) == 0);
    testutil_assert_near(a.target.r, 1.0, 0.0);
    assert_int_equal(spectrum_sigmoid_fit((rgb_t){NAN, 0.0, 0.5}, &a, &err), -1);
    assert_contains(err.msg, "finite");
    assert_null(spectrum_new_rgb_reflectance((rgb_t){0.1, INFINITY, 0.1}, &err));

    /* The boundary residual: (1, 1, 0.9999) asks for more red than a reflectance <= 1 gives
     * under D65 (constant 1 gives R = 0.99999), so it is approached, not met; the documented
     * residual stays below 5e-4 and the spectrum stays in [0, 1]. */
    assert_int_equal(spectrum_sigmoid_fit((rgb_t){1.0, 1.0, 0.9999}, &a, &err), 0);
    print_message("JH uplift: residual for the unreachable (1, 1, 0.9999): %.3g\n", a.residual);
    assert_true(a.residual < 5e-4);
    testutil_assert_near(spectrum_sigmoid(1e300), 1.0, 0.0);
    testutil_assert_near(spectrum_sigmoid(-1e300), 0.0, 0.0);
    testutil_assert_near(spectrum_sigmoid(0.0), 0.5, 0.0);
    testutil_assert_near(spectrum_sigmoid(1.0), 0.5 + 0.5 / sqrt(2.0), 1e-15);
}

/* CPU seconds this process has used: unlike the wall clock, it does not grow while other work
 * has the cores. */
static double cpu_seconds(void)
{
    struct timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* The uplift table is fitted when prismfarm is built (spectral/bake/rgb_uplift_bake.c): at
 * a node's own colour a new table gives exactly the coefficients that fitting that colour now
 * gives, in the compute threads' floating-point mode (pool.h) that the bake used, for nodes
 * spread over the three faces (a node (i, j) of face f is the colour with channel f at 1/2 and
 * the other two, in order, at i / 128 and j / 128), checked on a pool thread for that mode. */
typedef struct baked_check {
    int checked, bad;
    char first[300];
} baked_check_t;

static int baked_check_run(void *user, int index, err_t *err)
{
    (void)index;
    baked_check_t *r = user;
    rgb_uplift_t *t = rgb_uplift_new(err);
    if (!t)
        return -1;
    for (int f = 0; f < 3; f++)
        for (int i = 0; i < RGB_UPLIFT_RES; i += (i == 56 ? 7 : 8))
            for (int j = 0; j < RGB_UPLIFT_RES; j += (j == 56 ? 7 : 8)) {
                float v[3];
                int a = f == 0 ? 1 : 0, c = f == 2 ? 1 : 2;
                v[f] = 0.5f;
                v[a] = (float)i / (2 * RGB_UPLIFT_RES);
                v[c] = (float)j / (2 * RGB_UPLIFT_RES);
                spectrum_sigmoid_t fit;
                double out[4];
                if (spectrum_sigmoid_fit((rgb_t){v[0], v[1], v[2]}, &fit, err) ||
                    rgb_uplift_coef(t, v, out, err)) {
                    rgb_uplift_destroy(&t);
                    return -1;
                }
                r->checked++;
                int same = out[3] == 1.0;
                for (int q = 0; q < 3; q++)
                    same &= out[q] == fit.c[q];
                if (!same && r->bad++ == 0)
                    snprintf(
                        r->first, sizeof r->first,
                        "node (%d, %d, %d): (%a, %a, %a) in the table, (%a, %a, %a) fitted now", f,
                        i, j, out[0], out[1], out[2], fit.c[0], fit.c[1], fit.c[2]);
            }
    rgb_uplift_destroy(&t);
    return 0;
}

static void test_rgb_uplift_baked(void **state)
{
    (void)state;
    err_t err;
    baked_check_t r = {0};
    if (pool_for(1, 1, baked_check_run, &r, &err) != 0)
        fail_msg("%s", err.msg);
    if (r.bad)
        fail_msg("%d of %d nodes differ; %s", r.bad, r.checked, r.first);
    assert_true(r.checked == 3 * 9 * 9);
}

/* How long one solve takes in CPU time (reported; the bound, thousands of times what a solve
 * takes even under a sanitizer, only catches a pathological regression). */
static void test_rgb_uplift_timing(void **state)
{
    (void)state;
    err_t err;
    const rgb_t colours[] = {
        {0.8, 0.1, 0.1}, {0.1, 0.8, 0.1}, {0.05, 0.1, 0.9}, {0.2, 0.3, 0.4}, {1.0, 1.0, 0.0}};
    const int reps = 20;
    double t0 = cpu_seconds();
    int iters = 0;
    for (int r = 0; r < reps; r++)
        for (int i = 0; i < 5; i++) {
            spectrum_sigmoid_t fit;
            assert_int_equal(spectrum_sigmoid_fit(colours[i], &fit, &err), 0);
            iters += fit.iterations;
        }
    double per = (cpu_seconds() - t0) / (reps * 5);
    print_message("JH uplift: %.1f CPU us per solve, %.1f Gauss-Newton steps on average\n",
                  per * 1e6, (double)iters / (reps * 5));
    assert_true(per < 0.05);
}

/* rgb "L" on lights: the XYZ of the RGB illuminant equals the XYZ of linear sRGB rgb, to the
 * uplift's round trip (2e-3 relative); (1, 1, 1) is D65 with Y = 1; black is zero; the pbrt-v4
 * light normaliser counts only the D65 part, whose y-bar integral is CIE_Y_INTEGRAL. */
static void test_rgb_illuminant(void **state)
{
    (void)state;
    err_t err;
    const rgb_t colours[] = {{1, 1, 1}, {10, 5, 1}, {0.2, 0.5, 0.9}, {3, 0, 0}, {0.01, 0.02, 0.0}};
    for (int i = 0; i < 5; i++) {
        spectrum_t *s = spectrum_new_rgb_illuminant(colours[i], &err);
        assert_non_null(s);
        xyz_t got = spectrum_to_xyz(s);
        xyz_t want = colour_linear_srgb_to_xyz(colours[i]);
        double scale = want.x + want.y + want.z;
        testutil_assert_near(got.x / scale, want.x / scale, 2e-3);
        testutil_assert_near(got.y / scale, want.y / scale, 2e-3);
        testutil_assert_near(got.z / scale, want.z / scale, 2e-3);
        testutil_assert_near(spectrum_photometric_light(s), CIE_Y_INTEGRAL, 1e-9);
        for (double l = 300.0; l <= 830.0; l += 1.0)
            assert_true(spectrum_eval(s, l) >= 0.0);
        spectrum_destroy(&s);
    }
    spectrum_t *w = spectrum_new_rgb_illuminant((rgb_t){1, 1, 1}, &err);
    double x, y;
    colour_xyz_to_xy(spectrum_to_xyz(w), &x, &y);
    testutil_assert_near(x, 0.3127, 1e-3);
    testutil_assert_near(y, 0.3290, 1e-3);
    testutil_assert_near(spectrum_to_xyz(w).y, 1.0, 2e-4);
    spectrum_t *w2 = spectrum_new_scaled(w, 3.0, &err);
    testutil_assert_near(spectrum_photometric_light(w2), 3.0 * CIE_Y_INTEGRAL, 1e-9);
    spectrum_destroy(&w);
    spectrum_destroy(&w2);
    spectrum_t *k = spectrum_new_rgb_illuminant((rgb_t){0, 0, 0}, &err);
    for (double l = 300.0; l <= 830.0; l += 10.0)
        testutil_assert_near(spectrum_eval(k, l), 0.0, 0.0);
    spectrum_destroy(&k);
    assert_null(spectrum_new_rgb_illuminant((rgb_t){-1, 0, 0}, &err));
    assert_contains(err.msg, ">= 0");
    assert_null(spectrum_new_rgb_illuminant((rgb_t){NAN, 0, 0}, &err));
}

/* spectrum_eval only reads: four threads evaluating the same spectra agree bit for bit with
 * a serial pass. */
typedef struct eval_job {
    spectrum_t *const *spectra;
    int count;
    double out[8][1000];
} eval_job_t;

static void *eval_all(void *arg)
{
    eval_job_t *job = arg;
    for (int s = 0; s < job->count; s++)
        for (int i = 0; i < 1000; i++)
            job->out[s][i] = spectrum_eval(job->spectra[s], 300.0 + 0.6 * i);
    return NULL;
}

static void test_concurrent_eval(void **state)
{
    (void)state;
    err_t err;
    spectrum_t *spectra[6] = {
        spectrum_new_tabulated((double[]){400, 500, 600}, (double[]){0.1, 0.9, 0.3}, 3, &err),
        spectrum_new_blackbody(3000.0, 1, &err),
        spectrum_new_cie_d65(&err),
        spectrum_new_cie_a(&err),
        spectrum_new_rgb_reflectance((rgb_t){0.7, 0.2, 0.4}, &err),
        spectrum_new_rgb_illuminant((rgb_t){2, 1, 0.5}, &err),
    };
    for (int s = 0; s < 6; s++)
        assert_non_null(spectra[s]);
    static eval_job_t serial, jobs[4];
    serial.spectra = spectra;
    serial.count = 6;
    eval_all(&serial);
    pthread_t th[4];
    for (int t = 0; t < 4; t++) {
        jobs[t].spectra = spectra;
        jobs[t].count = 6;
        assert_int_equal(pthread_create(&th[t], NULL, eval_all, &jobs[t]), 0);
    }
    for (int t = 0; t < 4; t++) {
        assert_int_equal(pthread_join(th[t], NULL), 0);
        assert_memory_equal(jobs[t].out, serial.out, sizeof serial.out);
    }
    for (int s = 0; s < 6; s++) {
        testutil_assert_near(spectrum_eval(spectra[s], NAN), 0.0, 0.0);
        spectrum_destroy(&spectra[s]);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tabulated),
        cmocka_unit_test(test_tabulated_search),
        cmocka_unit_test(test_blackbody_stefan_boltzmann),
        cmocka_unit_test(test_blackbody_wien),
        cmocka_unit_test(test_cie_illuminants),
        cmocka_unit_test(test_photometric),
        cmocka_unit_test(test_rgb_uplift_round_trip),
        cmocka_unit_test(test_rgb_uplift_timing),
        cmocka_unit_test(test_rgb_illuminant),
        cmocka_unit_test(test_rgb_uplift_baked),
        cmocka_unit_test(test_concurrent_eval),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
