/* tilebuf: sums, counts, non-finite rejection, merge order independence, and the rounding of a
 * pass's sums to float32 values (IEEE 754 round to nearest, ties to even, checked on values
 * picked by hand around float's limits). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <float.h>
#include <math.h>
#include <string.h>
#if defined(__SSE__)
#include <pmmintrin.h>
#include <xmmintrin.h>
#endif

#include "tilebuf.h"

/* A sample's XYZ when only its luminance Y matters to the test. */
#define XYZ_OF_Y(l) ((const double[3]){0.0, (l), 0.0})

static void test_add_and_mean(void **state)
{
    (void)state;
    err_t err;
    tilebuf_t *t = tilebuf_new(10, 20, 4, 3, 2, &err);
    assert_non_null(t);
    double a[2] = {1.0, 2.0}, b[2] = {3.0, 6.0};
    assert_int_equal(tilebuf_add_sample(t, 11, 21, a, XYZ_OF_Y(0.5)), 0);
    assert_int_equal(tilebuf_add_sample(t, 11, 21, b, XYZ_OF_Y(1.5)), 0);
    double m[2];
    tilebuf_mean(t, 11, 21, m);
    assert_true(m[0] == 2.0 && m[1] == 4.0);
    assert_int_equal(tilebuf_count(t, 11, 21), 2);
    assert_true(tilebuf_luminance_sq_sum(t, 11, 21) == 0.25 + 2.25);
    tilebuf_mean(t, 10, 20, m); /* untouched pixel */
    assert_true(m[0] == 0.0 && m[1] == 0.0);
    tilebuf_destroy(&t);
    assert_null(t);
}

static void test_nonfinite_dropped_and_counted(void **state)
{
    (void)state;
    tilebuf_t *t = tilebuf_new(0, 0, 1, 1, 3, NULL);
    double good[3] = {1, 1, 1}, nan_s[3] = {1, NAN, 1}, inf_s[3] = {INFINITY, 0, 0};
    tilebuf_add_sample(t, 0, 0, good, XYZ_OF_Y(1.0));
    assert_int_equal(tilebuf_add_sample(t, 0, 0, nan_s, XYZ_OF_Y(1.0)), -1);
    assert_int_equal(tilebuf_add_sample(t, 0, 0, inf_s, XYZ_OF_Y(1.0)), -1);
    assert_int_equal(tilebuf_add_sample(t, 0, 0, good, XYZ_OF_Y(NAN)), -1);
    assert_int_equal(tilebuf_nonfinite(t), 3);
    assert_int_equal(tilebuf_count(t, 0, 0), 4);
    for (int b = 0; b < 3; b++)
        assert_true(tilebuf_sum(t, 0, 0, b) == 1.0);
    tilebuf_destroy(&t);
}

/* Two tiles merged into an image give the same sums whichever tile arrives first, because each
 * pixel gets contributions from exactly one tile. */
static void test_merge(void **state)
{
    (void)state;
    err_t err;
    tilebuf_t *img1 = tilebuf_new(0, 0, 8, 4, 2, &err), *img2 = tilebuf_new(0, 0, 8, 4, 2, &err);
    tilebuf_t *left = tilebuf_new(0, 0, 4, 4, 2, &err), *right = tilebuf_new(4, 0, 4, 4, 2, &err);
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 4; x++) {
            double v[2] = {x * 0.1 + y, 1e-3 * x};
            tilebuf_add_sample(left, x, y, v, XYZ_OF_Y(v[0]));
            double w[2] = {1e9 + x, y * 1e-12};
            tilebuf_add_sample(right, 4 + x, y, w, XYZ_OF_Y(w[0]));
        }
    assert_int_equal(tilebuf_merge(img1, left, &err), 0);
    assert_int_equal(tilebuf_merge(img1, right, &err), 0);
    assert_int_equal(tilebuf_merge(img2, right, &err), 0);
    assert_int_equal(tilebuf_merge(img2, left, &err), 0);
    assert_memory_equal(tilebuf_sums(img1), tilebuf_sums(img2), 8 * 4 * 2 * sizeof(double));
    assert_true(tilebuf_sum(img1, 5, 2, 0) == 1e9 + 1);

    tilebuf_t *outside = tilebuf_new(6, 0, 4, 4, 2, &err);
    assert_int_equal(tilebuf_merge(img1, outside, &err), -1);
    assert_non_null(strstr(err.msg, "outside"));
    tilebuf_t *other = tilebuf_new(0, 0, 2, 2, 3, &err);
    assert_int_equal(tilebuf_merge(img1, other, &err), -1);
    assert_non_null(strstr(err.msg, "buckets"));
    tilebuf_destroy(&img1);
    tilebuf_destroy(&img2);
    tilebuf_destroy(&left);
    tilebuf_destroy(&right);
    tilebuf_destroy(&outside);
    tilebuf_destroy(&other);
}

static void test_bad_sizes(void **state)
{
    (void)state;
    err_t err;
    assert_null(tilebuf_new(0, 0, 0, 4, 16, &err));
    assert_non_null(strstr(err.msg, "positive"));
    assert_null(tilebuf_new(0, 0, 4, 4, 0, &err));
    assert_null(tilebuf_new(0, 0, 1 << 20, 1 << 20, 16, &err));
    assert_non_null(strstr(err.msg, "too large"));
}

static bool same_bits(double a, double b)
{
    return memcmp(&a, &b, sizeof a) == 0;
}

/* Inputs and the values IEEE 754 binary32 rounding (to nearest, ties to even) gives, or the input
 * itself where the float would be Inf, subnormal or zero for a non-zero input. */
static const struct {
    double in, out;
    bool is_float; /* out is a float value: travels in 4 bytes */
} ROUND[] = {
    {0.0, 0.0, true},
    {-0.0, -0.0, true},
    {1.0, 1.0, true},
    {1.0 + 0x1p-30, 1.0, true},           /* far below half an ulp (2^-24) */
    {1.0 + 0x1p-24, 1.0, true},           /* a tie: to the even 1.0 */
    {1.0 + 3 * 0x1p-24, 1.0 + 0x1p-22, true}, /* a tie: to the even neighbour above */
    {0.1, 0x1.99999ap-4, true},           /* 0.1f */
    {-2.5e-3, -0x1.47ae14p-9, true},      /* -2.5e-3f */
    {1e-39, 1e-39, false},                /* below FLT_MIN (1.18e-38): a float subnormal */
    {-1e-39, -1e-39, false},
    {0x1p-149, 0x1p-149, false},          /* float's smallest subnormal, exactly */
    {DBL_MIN / 4, DBL_MIN / 4, false},    /* a double subnormal */
    {0x1p-126, 0x1p-126, true},           /* FLT_MIN */
    {0x1p-126 * (1 + 0x1p-30), 0x1p-126, true},
    {0x1p-126 - 0x1p-150, 0x1p-126, true}, /* midpoint to the largest subnormal: to even FLT_MIN */
    {0x1.fffffdfffffffp-127, 0x1.fffffdfffffffp-127, false}, /* just below it: a subnormal */
    {0x1.fffffep127, 0x1.fffffep127, true}, /* FLT_MAX */
    {0x1.fffffep127 + 0x1p102, 0x1.fffffep127, true}, /* below the midpoint to 2^128 */
    {0x1.fffffep127 + 0x1p103, 0x1.fffffep127 + 0x1p103, false}, /* the midpoint: to Inf */
    {-0x1.fffffep127 - 0x1p103, -0x1.fffffep127 - 0x1p103, false},
    {3.5e38, 3.5e38, false},
    {DBL_MAX, DBL_MAX, false},
};

static void check_round_table(void)
{
    for (size_t i = 0; i < sizeof ROUND / sizeof ROUND[0]; i++) {
        double got = tilebuf_round_value(ROUND[i].in);
        if (!same_bits(got, ROUND[i].out))
            fail_msg("round(%a) = %a, expected %a", ROUND[i].in, got, ROUND[i].out);
        if (tilebuf_is_float_value(got) != ROUND[i].is_float)
            fail_msg("%a is %sa float value", got, ROUND[i].is_float ? "not " : "");
        /* The rule is idempotent: a rounded sum merged again rounds to itself. */
        if (!same_bits(tilebuf_round_value(got), got))
            fail_msg("round(round(%a)) != round(%a)", ROUND[i].in, ROUND[i].in);
    }
}

static void test_round_value(void **state)
{
    (void)state;
    check_round_table();
    /* The float values are exactly those a float holds: zero and the normal floats. */
    assert_true(tilebuf_is_float_value(FLT_MIN) && tilebuf_is_float_value(-FLT_MAX));
    assert_false(tilebuf_is_float_value(1.0 + 0x1p-30));
    assert_false(tilebuf_is_float_value(0x1p128));
    assert_false(tilebuf_is_float_value(INFINITY) || tilebuf_is_float_value(NAN));
#if defined(__SSE__)
    /* Render threads run with flush-to-zero and denormals-are-zero (Embree's advice): the same
     * results there, subnormals included. */
    unsigned int csr = _mm_getcsr();
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
    check_round_table();
    _mm_setcsr(csr);
#endif
}

/* Whether every sum of t is a float value (what travels in 4 bytes). */
static bool sums_are_float(const tilebuf_t *t)
{
    size_t n = (size_t)tilebuf_width(t) * (size_t)tilebuf_height(t) * (size_t)tilebuf_nbuckets(t);
    for (size_t i = 0; i < n; i++)
        if (!tilebuf_is_float_value(tilebuf_sums(t)[i]))
            return false;
    return true;
}

static void test_round_sums(void **state)
{
    (void)state;
    err_t err;
    /* Three pixels, two buckets: one sum beyond float's range, one below its normal range. */
    tilebuf_t *t = tilebuf_new(0, 0, 3, 1, 2, &err);
    const double s0[2] = {1.0 + 0x1p-30, 1e-39}, s1[2] = {3.5e38, 0.1}, s2[2] = {0.0, FLT_MAX};
    assert_int_equal(tilebuf_add_sample(t, 0, 0, s0, XYZ_OF_Y(1.0 + 0x1p-30)), 0);
    assert_int_equal(tilebuf_add_sample(t, 1, 0, s1, XYZ_OF_Y(0.1)), 0);
    assert_int_equal(tilebuf_add_sample(t, 2, 0, s2, XYZ_OF_Y(0.1)), 0);
    assert_false(sums_are_float(t));
    assert_int_equal(tilebuf_round_sums(t), 2);
    assert_false(sums_are_float(t));
    const double want[6] = {1.0, 1e-39, 3.5e38, 0x1.99999ap-4, 0.0, FLT_MAX};
    assert_memory_equal(tilebuf_sums(t), want, sizeof want);
    /* Per value: a tile's other values (here the two wide ones) change nothing, so a pixel
     * rounds the same in any tile. lum stays a double. */
    tilebuf_t *one = tilebuf_new(0, 0, 1, 1, 2, &err);
    assert_int_equal(tilebuf_add_sample(one, 0, 0, s0, XYZ_OF_Y(1.0 + 0x1p-30)), 0);
    assert_int_equal(tilebuf_round_sums(one), 1);
    assert_true(same_bits(tilebuf_sum(one, 0, 0, 0), tilebuf_sum(t, 0, 0, 0)));
    assert_true(tilebuf_luminance_sum(one, 0, 0) == 1.0 + 0x1p-30);
    tilebuf_destroy(&one);
    /* Every sum in float range: the whole tile is float values. */
    tilebuf_t *f = tilebuf_new(5, 5, 2, 1, 2, &err);
    const double s3[2] = {0.1, 1.0 + 0x1p-30};
    assert_int_equal(tilebuf_add_sample(f, 5, 5, s3, XYZ_OF_Y(1.0)), 0);
    assert_int_equal(tilebuf_add_sample(f, 6, 5, s2, XYZ_OF_Y(1.0)), 0);
    assert_int_equal(tilebuf_round_sums(f), 0);
    assert_true(sums_are_float(f));
    /* Cleared: zeros everywhere, ready for the next pass. */
    tilebuf_clear(f);
    assert_true(tilebuf_sum(f, 6, 5, 1) == 0.0 && tilebuf_count(f, 6, 5) == 0 &&
                tilebuf_luminance_sum(f, 5, 5) == 0.0 && tilebuf_nonfinite(f) == 0);
    tilebuf_destroy(&f);
    tilebuf_destroy(&t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_add_and_mean),
        cmocka_unit_test(test_nonfinite_dropped_and_counted),
        cmocka_unit_test(test_merge),
        cmocka_unit_test(test_bad_sizes),
        cmocka_unit_test(test_round_value),
        cmocka_unit_test(test_round_sums),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
