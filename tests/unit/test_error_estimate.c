/* error_estimate: the relative RMSE of an image's per-pixel mean luminance, against analytic
 * cases: uniform random samples (variance 1/12, so the relative RMSE is 1/sqrt(3 n)), its
 * 1/sqrt(n) convergence, hand-computed small pixels, and the guards (no NaN, ever). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <float.h>
#include <math.h>
#include <string.h>

#include "error_estimate.h"
#include "rng.h"

/* A sample's XYZ when only its luminance Y matters to the test. */
#define XYZ_OF_Y(l) ((const double[3]){0.0, (l), 0.0})

#define SIDE 64 /* P = 4096 pixels */

/* An image whose every pixel has n luminance samples drawn uniformly from [0, 1). */
static tilebuf_t *uniform_image(uint32_t n, uint64_t seed)
{
    tilebuf_t *t = tilebuf_new(0, 0, SIDE, SIDE, 1, NULL);
    assert_non_null(t);
    for (int y = 0; y < SIDE; y++)
        for (int x = 0; x < SIDE; x++)
            for (uint32_t s = 0; s < n; s++) {
                double u = rng_uniform(seed, (uint64_t)(y * SIDE + x), s, 0);
                assert_int_equal(tilebuf_add_sample(t, x, y, &u, XYZ_OF_Y(u)), 0);
            }
    return t;
}

/* One standard deviation of the relative-RMSE estimate over P pixels of n uniform samples,
 * relative to its expectation, to first order (delta method):
 *   - the mean of the P values s_p^2 has variance Var(s^2) / P, with
 *     Var(s^2) = mu4 / n - sigma^4 (n - 3) / (n (n - 1))   (Cramer 1946, 27.4);
 *     for U[0,1): sigma^2 = 1/12, mu4 = 1/80. rmse is its square root: half the relative sd.
 *   - the image mean has relative sd sqrt(sigma^2 / (n P)) / mu, mu = 1/2.
 *   - U[0,1) is symmetric (mu3 = 0), so s^2 and the mean are uncorrelated: add in quadrature. */
static double relative_sd(double n, double P)
{
    const double var = 1.0 / 12.0, mu4 = 1.0 / 80.0, mu = 0.5;
    double var_s2 = mu4 / n - var * var * (n - 3.0) / (n * (n - 1.0));
    double r_v = sqrt(var_s2 / P) / var;
    double r_m = sqrt(var / (n * P)) / mu;
    return sqrt(0.25 * r_v * r_v + r_m * r_m);
}

static void test_uniform_samples_match_analytic(void **state)
{
    (void)state;
    const uint32_t ns[] = {2, 4, 16, 64, 256};
    for (size_t k = 0; k < sizeof ns / sizeof ns[0]; k++) {
        uint32_t n = ns[k];
        tilebuf_t *t = uniform_image(n, 12345);
        error_estimate_t e = error_estimate_image(t);
        double expect = 1.0 / sqrt(3.0 * n);            /* sqrt(1/(12 n)) / (1/2) */
        double tol = 5.0 * relative_sd(n, SIDE * SIDE); /* 5 sigma: 6e-7 chance of a miss */
        assert_true(e.valid);
        assert_int_equal(e.pixels, SIDE * SIDE);
        assert_int_equal(e.skipped, 0);
        if (fabs(e.rel_rmse / expect - 1.0) > tol)
            fail_msg("n=%u: rel. RMSE %.6f, analytic %.6f, tolerance %.4f relative", n, e.rel_rmse,
                     expect, tol);
        /* The parts: rmse = sqrt(1/(12 n)) and mean = 1/2, each within its own 5 sigma. */
        assert_true(fabs(e.mean - 0.5) < 5.0 * sqrt(1.0 / 12.0 / (n * SIDE * SIDE)));
        tilebuf_destroy(&t);
    }
}

/* Quadrupling the samples halves the estimate: the 1/sqrt(n) law of independent samples. The
 * images share their first n samples, which only makes the ratio steadier; the tolerance is
 * the sum of both estimates' 5 sigma. */
static void test_converges_as_one_over_sqrt_n(void **state)
{
    (void)state;
    double prev = 0;
    for (uint32_t n = 4; n <= 1024; n *= 4) {
        tilebuf_t *t = uniform_image(n, 777);
        error_estimate_t e = error_estimate_image(t);
        assert_true(e.valid);
        if (prev > 0) {
            double tol = 5.0 * (relative_sd(n, SIDE * SIDE) + relative_sd(n / 4.0, SIDE * SIDE));
            double ratio = e.rel_rmse / prev;
            if (fabs(ratio / 0.5 - 1.0) > tol)
                fail_msg("n=%u: estimate fell by %.4f, expected 0.5 within %.4f relative", n, ratio,
                         tol);
        }
        prev = e.rel_rmse;
        tilebuf_destroy(&t);
    }
}

static void test_variance_of_mean_by_hand(void **state)
{
    (void)state;
    /* {1, 2, 3, 4}: mean 2.5, s^2 = (2.25 + 0.25 + 0.25 + 2.25) / 3 = 5/3, V = 5/12. */
    assert_true(fabs(error_estimate_variance_of_mean(4, 10, 30) - 5.0 / 12.0) < 1e-15);
    /* {0, 2}: s^2 = 2, V = 1. */
    assert_true(error_estimate_variance_of_mean(2, 2, 4) == 1.0);
    /* One sample or none: no variance. */
    assert_true(error_estimate_variance_of_mean(1, 3, 9) < 0);
    assert_true(error_estimate_variance_of_mean(0, 0, 0) < 0);
    /* Constant 0.1 three times: the one-pass difference is rounding noise, clamped to 0. */
    double v = error_estimate_variance_of_mean(3, 0.1 + 0.1 + 0.1, 0.01 + 0.01 + 0.01);
    assert_true(v >= 0 && v < 1e-17);
    /* Non-finite input: none; saturated squares (tilebuf keeps them at DBL_MAX once a square
     * overflows), or an s1 whose square overflows: unbounded, never NaN. */
    assert_true(error_estimate_variance_of_mean(2, INFINITY, 1) < 0);
    assert_true(error_estimate_variance_of_mean(2, 1, NAN) < 0);
    assert_true(error_estimate_variance_of_mean(2, 2e200, DBL_MAX) == DBL_MAX);
    assert_true(error_estimate_variance_of_mean(2, 2e200, 1e308) == DBL_MAX);
}

/* Three pixels: {0, 2} (V = 1, mean 1), {1, 1, 1, 1} (V = 0, mean 1) and one lone sample
 * (left out): rmse = sqrt((1 + 0) / 2), mean 1, relative sqrt(1/2). */
static void test_small_image_by_hand(void **state)
{
    (void)state;
    tilebuf_t *t = tilebuf_new(0, 0, 3, 1, 1, NULL);
    double zero = 0, two = 2, one = 1, nine = 9;
    tilebuf_add_sample(t, 0, 0, &zero, XYZ_OF_Y(zero));
    tilebuf_add_sample(t, 0, 0, &two, XYZ_OF_Y(two));
    for (int i = 0; i < 4; i++)
        tilebuf_add_sample(t, 1, 0, &one, XYZ_OF_Y(one));
    tilebuf_add_sample(t, 2, 0, &nine, XYZ_OF_Y(nine));
    error_estimate_t e = error_estimate_image(t);
    assert_true(e.valid);
    assert_int_equal(e.pixels, 2);
    assert_int_equal(e.skipped, 1);
    assert_true(fabs(e.rmse - sqrt(0.5)) < 1e-15);
    assert_true(e.mean == 1.0);
    assert_true(fabs(e.rel_rmse - sqrt(0.5)) < 1e-15);
    tilebuf_destroy(&t);
}

static void test_guards(void **state)
{
    (void)state;
    /* Nothing rendered yet, and one sample per pixel: no estimate, and no NaN. */
    tilebuf_t *t = tilebuf_new(0, 0, 4, 4, 1, NULL);
    error_estimate_t e = error_estimate_image(t);
    assert_false(e.valid);
    assert_int_equal(e.pixels, 0);
    assert_int_equal(e.skipped, 16);
    assert_true(e.rel_rmse == 0 && e.rmse == 0 && e.mean == 0);
    double half = 0.5;
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 4; x++)
            tilebuf_add_sample(t, x, y, &half, XYZ_OF_Y(half));
    assert_false(error_estimate_image(t).valid);
    /* A second, equal sample everywhere: converged, exactly 0. */
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 4; x++)
            tilebuf_add_sample(t, x, y, &half, XYZ_OF_Y(half));
    e = error_estimate_image(t);
    assert_true(e.valid);
    assert_true(e.rel_rmse == 0);
    tilebuf_destroy(&t);

    /* A black image: mean 0 and no variance, so nothing left to gain: valid, 0. */
    t = tilebuf_new(0, 0, 2, 2, 1, NULL);
    double z = 0;
    for (int k = 0; k < 3; k++)
        for (int y = 0; y < 2; y++)
            for (int x = 0; x < 2; x++)
                tilebuf_add_sample(t, x, y, &z, XYZ_OF_Y(z));
    e = error_estimate_image(t);
    assert_true(e.valid);
    assert_true(e.rel_rmse == 0);
    tilebuf_destroy(&t);

    /* Noise around a mean of 0 (or below) has no relative error: invalid, finite fields. */
    t = tilebuf_new(0, 0, 1, 1, 1, NULL);
    double a = -1, b = 1;
    tilebuf_add_sample(t, 0, 0, &a, XYZ_OF_Y(a));
    tilebuf_add_sample(t, 0, 0, &b, XYZ_OF_Y(b));
    e = error_estimate_image(t);
    assert_false(e.valid);
    assert_true(isfinite(e.rel_rmse) && isfinite(e.rmse) && isfinite(e.mean));
    tilebuf_destroy(&t);

    /* A sample so large that its square overflows: the pixel's error is unbounded, so the
     * image has no estimate (a target is never reached on its account), and no NaN. */
    t = tilebuf_new(0, 0, 2, 1, 1, NULL);
    double big = 1e200, small = 1;
    tilebuf_add_sample(t, 0, 0, &big, XYZ_OF_Y(big));
    tilebuf_add_sample(t, 0, 0, &big, XYZ_OF_Y(big));
    tilebuf_add_sample(t, 1, 0, &small, XYZ_OF_Y(small));
    tilebuf_add_sample(t, 1, 0, &z, XYZ_OF_Y(z));
    e = error_estimate_image(t);
    assert_false(e.valid);
    assert_int_equal(e.saturated, 1);
    assert_int_equal(e.pixels, 1);
    assert_true(isfinite(e.rel_rmse) && isfinite(e.rmse) && isfinite(e.mean));
    tilebuf_destroy(&t);
}

/* A figure above 1 is said to be noise above the mean; up to 1 nothing is added. */
static void test_note_above_one(void **state)
{
    (void)state;
    assert_string_equal(error_estimate_note(0.5), "");
    assert_string_equal(error_estimate_note(1.0), "");
    assert_non_null(strstr(error_estimate_note(2.45), "above 1"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_note_above_one),
        cmocka_unit_test(test_uniform_samples_match_analytic),
        cmocka_unit_test(test_converges_as_one_over_sqrt_n),
        cmocka_unit_test(test_variance_of_mean_by_hand),
        cmocka_unit_test(test_small_image_by_hand),
        cmocka_unit_test(test_guards),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
