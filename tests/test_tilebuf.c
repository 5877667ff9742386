/* tilebuf: sums, counts, non-finite rejection and merge order independence. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <string.h>

#include "tilebuf.h"

static void test_add_and_mean(void **state)
{
    (void)state;
    err_t err;
    tilebuf_t *t = tilebuf_new(10, 20, 4, 3, 2, &err);
    assert_non_null(t);
    double a[2] = {1.0, 2.0}, b[2] = {3.0, 6.0};
    assert_int_equal(tilebuf_add_sample(t, 11, 21, a, 0.5), 0);
    assert_int_equal(tilebuf_add_sample(t, 11, 21, b, 1.5), 0);
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
    tilebuf_add_sample(t, 0, 0, good, 1.0);
    assert_int_equal(tilebuf_add_sample(t, 0, 0, nan_s, 1.0), -1);
    assert_int_equal(tilebuf_add_sample(t, 0, 0, inf_s, 1.0), -1);
    assert_int_equal(tilebuf_add_sample(t, 0, 0, good, NAN), -1);
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
            tilebuf_add_sample(left, x, y, v, v[0]);
            double w[2] = {1e9 + x, y * 1e-12};
            tilebuf_add_sample(right, 4 + x, y, w, w[0]);
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

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_add_and_mean),
        cmocka_unit_test(test_nonfinite_dropped_and_counted),
        cmocka_unit_test(test_merge),
        cmocka_unit_test(test_bad_sizes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
