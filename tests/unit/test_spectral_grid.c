/* Tests for spectral_grid: bucket geometry for the bucket counts and ranges the renderer must
 * support, validation, exact energy conservation of one splat, and Monte-Carlo convergence of
 * splatted continuous-wavelength samples to the analytic bucket averages of a known spectrum;
 * and that the precomputed table (spectral_table_t) gives the grid functions' results bit for
 * bit, at every bucket boundary and the doubles next to it, where rounding decides. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "numeric_testutil.h"
#include "spectral_grid.h"
#include "wavelength.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static const int COUNTS[] = {8, 16, 32, 45};
static const double RANGES[][2] = {{380.0, 720.0}, {300.0, 1000.0}, {360.0, 830.0}};

static void test_geometry(void **state)
{
    (void)state;
    spectral_grid_t d = spectral_grid_default();
    assert_int_equal(d.n, 16);
    testutil_assert_near(d.lambda_min, 380.0, 0.0);
    testutil_assert_near(d.lambda_max, 720.0, 0.0);
    testutil_assert_near(spectral_grid_width(d), 21.25, 1e-12);
    testutil_assert_near(spectral_grid_centre(d, 0), 390.625, 1e-12);
    testutil_assert_near(spectral_grid_centre(d, 15), 709.375, 1e-12);
    assert_int_equal(spectral_grid_index(d, 380.0), 0);
    assert_int_equal(spectral_grid_index(d, 401.25), 1); /* bucket boundaries belong upward */
    assert_int_equal(spectral_grid_index(d, 401.2499), 0);
    assert_int_equal(spectral_grid_index(d, 720.0), 15); /* lambda_max is in the last bucket */
    assert_int_equal(spectral_grid_index(d, 379.999), -1);
    assert_int_equal(spectral_grid_index(d, 720.001), -1);
    assert_int_equal(spectral_grid_index(d, NAN), -1);

    for (int r = 0; r < 3; r++)
        for (int k = 0; k < 4; k++) {
            spectral_grid_t g;
            assert_int_equal(spectral_grid_init(&g, COUNTS[k], RANGES[r][0], RANGES[r][1], NULL),
                             0);
            double total = 0.0;
            for (int i = 0; i < g.n; i++) {
                double lo = spectral_grid_bucket_min(g, i), hi = spectral_grid_bucket_max(g, i);
                total += hi - lo;
                testutil_assert_near(hi - lo, spectral_grid_width(g), 1e-9);
                testutil_assert_near(spectral_grid_centre(g, i), 0.5 * (lo + hi), 1e-9);
                assert_int_equal(spectral_grid_index(g, spectral_grid_centre(g, i)), i);
                assert_int_equal(spectral_grid_index(g, lo), i);
                assert_int_equal(spectral_grid_index(g, nextafter(hi, 0.0)), i);
            }
            testutil_assert_near(total, RANGES[r][1] - RANGES[r][0], 1e-9);
            testutil_assert_near(spectral_grid_bucket_max(g, g.n - 1), RANGES[r][1], 0.0);
        }
}

static void test_validation(void **state)
{
    (void)state;
    err_t err;
    spectral_grid_t g = spectral_grid_default();
    assert_int_equal(spectral_grid_init(&g, 0, 380, 720, &err), -1);
    assert_non_null(strstr(err.msg, "n = 0"));
    assert_int_equal(spectral_grid_init(&g, SPECTRAL_GRID_MAX_BUCKETS + 1, 380, 720, &err), -1);
    assert_int_equal(spectral_grid_init(&g, 16, 720, 380, &err), -1);
    assert_non_null(strstr(err.msg, "lambda_max"));
    assert_int_equal(spectral_grid_init(&g, 16, NAN, 720, &err), -1);
    assert_non_null(strstr(err.msg, "lambda_min"));
    assert_int_equal(spectral_grid_init(&g, 16, 0.0, 720, &err), -1);
    assert_int_equal(spectral_grid_init(&g, 16, 380, INFINITY, &err), -1);
    /* A failed init leaves the grid as it was. */
    assert_int_equal(g.n, 16);
    testutil_assert_near(g.lambda_max, 720.0, 0.0);
}

/* One splat: sum(buckets) * width = value / pdf exactly, for either mode, anywhere in the
 * range including both ends and the half-buckets outside the first and last centres. */
static void test_splat_conserves_one_sample(void **state)
{
    (void)state;
    for (int r = 0; r < 3; r++)
        for (int k = 0; k < 4; k++) {
            spectral_grid_t g = {COUNTS[k], RANGES[r][0], RANGES[r][1]};
            double w = spectral_grid_width(g);
            const double lambdas[] = {g.lambda_min,
                                      g.lambda_min + 0.1 * w,
                                      spectral_grid_centre(g, 0),
                                      0.5 * (g.lambda_min + g.lambda_max),
                                      spectral_grid_centre(g, g.n / 2) + 0.3 * w,
                                      g.lambda_max - 0.2 * w,
                                      g.lambda_max};
            for (int mode = 0; mode < 2; mode++)
                for (size_t j = 0; j < sizeof lambdas / sizeof lambdas[0]; j++) {
                    double b[64] = {0};
                    assert_int_equal(
                        spectral_grid_splat(g, b, lambdas[j], 2.5, 0.004, (spectral_splat_t)mode),
                        0);
                    double sum = 0.0;
                    int touched = 0;
                    for (int i = 0; i < g.n; i++) {
                        sum += b[i] * w;
                        touched += b[i] != 0.0;
                    }
                    testutil_assert_near(sum, 2.5 / 0.004, 1e-9);
                    assert_true(touched >= 1 && touched <= (mode == SPECTRAL_SPLAT_BOX ? 1 : 2));
                }
        }
    /* Tent weights: a quarter of a bucket above centre 3 gives 3/4 to bucket 3, 1/4 to 4. */
    spectral_grid_t d = spectral_grid_default();
    double b[16] = {0};
    double w = spectral_grid_width(d);
    spectral_grid_splat(d, b, spectral_grid_centre(d, 3) + 0.25 * w, 1.0, 1.0, SPECTRAL_SPLAT_TENT);
    testutil_assert_near(b[3], 0.75 / w, 1e-14);
    testutil_assert_near(b[4], 0.25 / w, 1e-14);
    /* Outside the range nothing is deposited; invalid samples are refused, never deposited. */
    memset(b, 0, sizeof b);
    assert_int_equal(spectral_grid_splat(d, b, 379.0, 1.0, 1.0, SPECTRAL_SPLAT_BOX), 0);
    assert_int_equal(spectral_grid_splat(d, b, 500.0, NAN, 1.0, SPECTRAL_SPLAT_BOX), -1);
    assert_int_equal(spectral_grid_splat(d, b, 500.0, 1.0, 0.0, SPECTRAL_SPLAT_BOX), -1);
    assert_int_equal(spectral_grid_splat(d, b, 500.0, 1.0, -1.0, SPECTRAL_SPLAT_TENT), -1);
    assert_int_equal(spectral_grid_splat(d, b, INFINITY, 1.0, 1.0, SPECTRAL_SPLAT_TENT), -1);
    assert_int_equal(spectral_grid_splat(d, b, 500.0, 1.0, 1e-320, SPECTRAL_SPLAT_BOX), -1);
    for (int i = 0; i < 16; i++)
        testutil_assert_near(b[i], 0.0, 0.0);
}

/* A known spectrum with its antiderivative: S = 1 + 0.5 sin(lambda/23) + 0.002 lambda. */
static double known_s(double l)
{
    return 1.0 + 0.5 * sin(l / 23.0) + 0.002 * l;
}
static double known_f(double l)
{
    return l - 11.5 * cos(l / 23.0) + 0.001 * l * l;
}

typedef struct mc {
    double sum[64], sum2[64];
} mc_t;

/* Runs `samples` splats of S, one per sample into a fresh bucket array so that the per-sample
 * contributions' variance is known, and returns the per-bucket means and standard errors. */
static void run_mc(spectral_grid_t g, spectral_splat_t mode, int visible, int samples,
                   uint64_t seed, double *mean, double *stderr_)
{
    mc_t acc;
    memset(&acc, 0, sizeof acc);
    uint64_t rng = seed;
    for (int s = 0; s < samples; s++) {
        wavelength_sample_t ws = visible ? wavelength_sample_visible(testutil_splitmix_u(&rng))
                                         : wavelength_sample_uniform(testutil_splitmix_u(&rng),
                                                                     g.lambda_min, g.lambda_max);
        double b[64] = {0};
        assert_int_equal(spectral_grid_splat(g, b, ws.lambda, known_s(ws.lambda), ws.pdf, mode), 0);
        for (int i = 0; i < g.n; i++) {
            acc.sum[i] += b[i];
            acc.sum2[i] += b[i] * b[i];
        }
    }
    for (int i = 0; i < g.n; i++) {
        mean[i] = acc.sum[i] / samples;
        double var = acc.sum2[i] / samples - mean[i] * mean[i];
        stderr_[i] = sqrt((var > 0.0 ? var : 0.0) / samples);
    }
}

/* Box splats converge to the exact bucket averages (F(hi) - F(lo)) / width, with uniform and
 * with visible-importance wavelengths (non-uniform pdf). Tolerance: 5 standard errors of the
 * mean, measured from the same samples (a fixed seed makes the run deterministic; for an
 * unbiased estimator a 5-sigma miss has probability ~6e-7 per bucket). The standard error is
 * itself checked so the comparison means something: with M samples a bucket hit with
 * probability p has relative error about sqrt((1 - p) / (M p)), 2.1% for uniform sampling
 * into 45 buckets and M = 1e5; the visible pdf puts 10x fewer samples near 830 nm than the
 * uniform one, where it reaches 6.2% (measured, N = 45); bound 10%. */
static void test_mc_box_converges_to_bucket_averages(void **state)
{
    (void)state;
    const int samples = 100000;
    for (int r = 0; r < 3; r++)
        for (int k = 0; k < 4; k++)
            for (int visible = 0; visible <= 1; visible++) {
                spectral_grid_t g = {COUNTS[k], RANGES[r][0], RANGES[r][1]};
                if (visible && (g.lambda_min < WAVELENGTH_VISIBLE_MIN ||
                                g.lambda_max > WAVELENGTH_VISIBLE_MAX))
                    continue; /* the visible pdf is 0 outside 360-830: it cannot estimate there */
                double mean[64], se[64];
                run_mc(g, SPECTRAL_SPLAT_BOX, visible, samples, 1234u + 17u * (uint64_t)(r * 8 + k),
                       mean, se);
                double w = spectral_grid_width(g);
                for (int i = 0; i < g.n; i++) {
                    double lo = spectral_grid_bucket_min(g, i), hi = spectral_grid_bucket_max(g, i);
                    double exact = (known_f(hi) - known_f(lo)) / w;
                    if (!(se[i] < 0.10 * exact))
                        fail_msg("N=%d [%g,%g] vis=%d bucket %d se %g exact %g", g.n, g.lambda_min,
                                 g.lambda_max, visible, i, se[i], exact);
                    if (!(fabs(mean[i] - exact) <= 5.0 * se[i]))
                        fail_msg("N=%d [%g,%g] visible=%d bucket %d: %g vs exact %g (5 se = %g)",
                                 g.n, g.lambda_min, g.lambda_max, visible, i, mean[i], exact,
                                 5.0 * se[i]);
                }
            }
}

/* Tent splats: the total sum(buckets) * width converges to the integral of S over the range,
 * and for a linear spectrum an interior bucket converges to S at its centre (a symmetric
 * triangle filter leaves a linear function unchanged). 5 standard errors as above. */
static double linear_s(double l)
{
    return 0.5 + 0.004 * l;
}

static void test_mc_tent(void **state)
{
    (void)state;
    const int samples = 100000;
    for (int k = 0; k < 4; k++) {
        spectral_grid_t g = {COUNTS[k], 380.0, 720.0};
        double w = spectral_grid_width(g), range = g.lambda_max - g.lambda_min;
        uint64_t rng = 99u + (uint64_t)k;
        double sum[64] = {0}, sum2[64] = {0}, tot = 0.0, tot2 = 0.0;
        double sum_lin[64] = {0}, sum_lin2[64] = {0};
        for (int s = 0; s < samples; s++) {
            wavelength_sample_t ws =
                wavelength_sample_uniform(testutil_splitmix_u(&rng), g.lambda_min, g.lambda_max);
            double b[64] = {0}, bl[64] = {0};
            spectral_grid_splat(g, b, ws.lambda, known_s(ws.lambda), ws.pdf, SPECTRAL_SPLAT_TENT);
            spectral_grid_splat(g, bl, ws.lambda, linear_s(ws.lambda), ws.pdf, SPECTRAL_SPLAT_TENT);
            double t = 0.0;
            for (int i = 0; i < g.n; i++) {
                t += b[i] * w;
                sum_lin[i] += bl[i];
                sum_lin2[i] += bl[i] * bl[i];
                sum[i] += b[i];
                sum2[i] += b[i] * b[i];
            }
            tot += t;
            tot2 += t * t;
        }
        double mean = tot / samples, se = sqrt((tot2 / samples - mean * mean) / samples);
        double exact = known_f(g.lambda_max) - known_f(g.lambda_min);
        assert_true(se < 0.01 * exact);
        assert_true(fabs(mean - exact) <= 5.0 * se);
        (void)range;
        for (int i = 1; i + 1 < g.n; i++) {
            double m = sum_lin[i] / samples, e = sqrt((sum_lin2[i] / samples - m * m) / samples);
            double want = linear_s(spectral_grid_centre(g, i));
            if (!(fabs(m - want) <= 5.0 * e))
                fail_msg("tent N=%d bucket %d: %g vs %g (5 se = %g)", g.n, i, m, want, 5.0 * e);
        }
    }
}

/* The table must agree with spectral_grid_index and spectral_grid_splat exactly: the renderer
 * switched to it on the promise that no pixel changes. Checked at every boundary (and one and
 * two ulps either side, where the quotient can round across), at the range's ends, outside it,
 * at non-finite inputs, and at 20000 random wavelengths per grid, for both splat modes. */
static void check_table_against_grid(spectral_grid_t g)
{
    err_t err;
    spectral_table_t *t = spectral_table_new(g, &err);
    assert_non_null(t);
    uint64_t rng = 0x5EEDull + (uint64_t)g.n;
    for (int k = 0; k < 20000 + 6 * (g.n + 1) + 5; k++) {
        double lambda;
        if (k < 6 * (g.n + 1)) {
            double b = k / 6 < g.n ? spectral_grid_bucket_min(g, k / 6) : g.lambda_max;
            static const int steps[6] = {-2, -1, 0, 1, 2, 0};
            lambda = b;
            for (int s = 0; s < abs(steps[k % 6]); s++)
                lambda = nextafter(lambda, steps[k % 6] < 0 ? -INFINITY : INFINITY);
        } else if (k < 6 * (g.n + 1) + 5) {
            static const double odd_ones[5] = {0.0, 1e300, -1.0, NAN, INFINITY};
            lambda = odd_ones[k - 6 * (g.n + 1)];
        } else {
            double u = testutil_splitmix_u(&rng);
            lambda = g.lambda_min - 5.0 + u * (g.lambda_max - g.lambda_min + 10.0);
        }
        assert_int_equal(spectral_table_index(t, lambda), spectral_grid_index(g, lambda));
        for (int mode = 0; mode < 2; mode++) {
            spectral_splat_t m = mode ? SPECTRAL_SPLAT_TENT : SPECTRAL_SPLAT_BOX;
            double a[SPECTRAL_GRID_MAX_BUCKETS] = {0}, b[SPECTRAL_GRID_MAX_BUCKETS] = {0};
            double value = 0.5 + testutil_splitmix_u(&rng),
                   pdf = k % 97 == 0 ? 1e-310 : 0.002 + testutil_splitmix_u(&rng);
            int ra = spectral_table_splat(t, a, lambda, value, pdf, m);
            int rb = spectral_grid_splat(g, b, lambda, value, pdf, m);
            assert_int_equal(ra, rb);
            assert_memory_equal(a, b, (size_t)g.n * sizeof a[0]);
        }
    }
    spectral_table_destroy(&t);
    assert_null(t);
}

static void test_table_matches_grid(void **state)
{
    (void)state;
    for (size_t c = 0; c < sizeof COUNTS / sizeof COUNTS[0]; c++)
        for (size_t r = 0; r < sizeof RANGES / sizeof RANGES[0]; r++)
            check_table_against_grid((spectral_grid_t){COUNTS[c], RANGES[r][0], RANGES[r][1]});
    /* One bucket, and a range whose boundaries are not representable (1/3 nm steps). */
    check_table_against_grid((spectral_grid_t){1, 380.0, 720.0});
    check_table_against_grid((spectral_grid_t){3, 400.0, 401.0});
    err_t err;
    assert_null(spectral_table_new((spectral_grid_t){0, 380.0, 720.0}, &err));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_geometry),
        cmocka_unit_test(test_validation),
        cmocka_unit_test(test_splat_conserves_one_sample),
        cmocka_unit_test(test_mc_box_converges_to_bucket_averages),
        cmocka_unit_test(test_mc_tent),
        cmocka_unit_test(test_table_matches_grid),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
