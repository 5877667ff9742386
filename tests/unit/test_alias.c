/* alias: input validation, empirical frequencies against the pmf, zero weights never drawn,
 * and precision of the pmf for a million weights spanning 18 decades. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "alias.h"
#include "numeric_testutil.h"
#include "rng.h"

/* Neumaier's compensated sum, so the test's own rounding (~n eps for n = 1e6, 2e-10) does not
 * swamp the 1e-12 it checks. */
static double sum_exact(const double *x, size_t n)
{
    double s = 0.0, c = 0.0;
    for (size_t i = 0; i < n; i++) {
        double t = s + x[i];
        c += fabs(s) >= fabs(x[i]) ? (s - t) + x[i] : (x[i] - t) + s;
        s = t;
    }
    return s + c;
}

static void expect_reject(const double *w, size_t n, const char *needle)
{
    err_t err = {{0}};
    alias_t *a = alias_new(w, n, &err);
    assert_null(a);
    print_message("rejected: %s\n", err.msg);
    assert_non_null(strstr(err.msg, needle));
}

static void test_rejects_bad_weights(void **state)
{
    (void)state;
    const double neg[] = {1.0, 2.0, -0.5, 1.0};
    const double nan_w[] = {1.0, NAN};
    const double inf_w[] = {INFINITY, 1.0};
    const double zeros[] = {0.0, 0.0, 0.0};
    const double huge[] = {1.5e308, 1.5e308};
    expect_reject(NULL, 3, "NULL");
    expect_reject(neg, 0, "n = 0");
    expect_reject(neg, 4, "weight[2]");
    expect_reject(nan_w, 2, "weight[1]");
    expect_reject(inf_w, 2, "weight[0]");
    expect_reject(zeros, 3, "all 3 weights are zero");
    expect_reject(huge, 2, "overflows");
    assert_null(alias_new(zeros, 3, NULL)); /* err is optional */
    alias_t *none = NULL;
    alias_destroy(&none); /* destroying nothing is fine */
    alias_destroy(NULL);
}

static void test_single_entry(void **state)
{
    (void)state;
    const double w[] = {3.7};
    alias_t *a = alias_new(w, 1, NULL);
    assert_non_null(a);
    assert_int_equal(alias_size(a), 1);
    assert_true(alias_pmf(a, 0) == 1.0);
    assert_true(alias_pmf(a, 1) == 0.0);
    const double us[] = {0.0, 1e-300, 0.5, 1.0 - 0x1p-53, 1.0, -3.0, 7.0, NAN};
    for (size_t k = 0; k < sizeof us / sizeof us[0]; k++) {
        double pmf = -1.0;
        assert_int_equal(alias_sample(a, us[k], &pmf), 0);
        assert_true(pmf == 1.0);
    }
    alias_destroy(&a);
    assert_null(a);
}

/* 12 weights with zeros among them. pmf_i = w_i / 40 exactly as the hand sum 40 says.
 * 1e6 random draws: the chi-square statistic over the 9 non-zero entries (8 degrees of freedom)
 * stays below its 1e-6 quantile (~44; checked loosely as above the 5-sigma point
 * 8 + 5 * 4 = 28); zero-weight entries are never drawn; the returned pmf matches alias_pmf.
 * Then M = 2^22 stratified u = (k + 1/2) / M: each of the n columns gets M / n points split
 * at its threshold, so every index's count is off from M pmf_i by at most 1 per column that
 * can give to it plus table round-off: |freq_i - pmf_i| <= 2 (n + 1) / M = 6.2e-6. */
static void test_frequencies(void **state)
{
    (void)state;
    enum { K = 12, DRAWS = 1000000, M = 1 << 22 };
    const double w[K] = {1.0, 0.0, 7.5, 2.5, 0.0, 12.0, 0.5, 3.75, 0.0, 5.0, 4.0, 3.75};
    assert_true(sum_exact(w, K) == 40.0);
    alias_t *a = alias_new(w, K, NULL);
    assert_non_null(a);
    for (size_t i = 0; i < K; i++)
        assert_true(alias_pmf(a, i) == w[i] / 40.0);

    unsigned long count[K] = {0};
    for (uint64_t d = 0; d < DRAWS; d++) {
        double pmf;
        size_t i = alias_sample(a, rng_uniform(77, d, 0, 0), &pmf);
        assert_true(i < K);
        assert_true(pmf == alias_pmf(a, i));
        count[i]++;
    }
    double chi2 = 0.0;
    int df = -1;
    for (size_t i = 0; i < K; i++) {
        if (w[i] == 0.0) {
            assert_int_equal(count[i], 0);
            continue;
        }
        double e = DRAWS * alias_pmf(a, i);
        chi2 += (count[i] - e) * (count[i] - e) / e;
        df++;
    }
    double limit = testutil_chi2_quantile(df, 4.75);
    assert_int_equal(df, 8);
    assert_true(limit > 28.0 && limit < 60.0);
    print_message("chi2 = %.2f (df %d, limit %.1f)\n", chi2, df, limit);
    assert_true(chi2 < limit);

    unsigned long strat[K] = {0};
    for (uint32_t k = 0; k < M; k++)
        strat[alias_sample(a, (k + 0.5) / M, NULL)]++;
    double worst = 0.0;
    for (size_t i = 0; i < K; i++)
        worst = fmax(worst, fabs((double)strat[i] / M - alias_pmf(a, i)));
    print_message("stratified: max |freq - pmf| = %.2e (bound %.2e)\n", worst, 2.0 * (K + 1) / M);
    assert_true(worst <= 2.0 * (K + 1) / M);
    assert_int_equal(strat[1] + strat[4] + strat[8], 0);
    alias_destroy(&a);
}

/* One positive weight among 1e5 zeros: every column but one must send its whole mass to it,
 * including at coin = 0 exactly (u = j / n) and at the clamped top end. */
static void test_zeros_never_drawn(void **state)
{
    (void)state;
    enum { N = 100000 };
    double *w = calloc(N, sizeof *w);
    assert_non_null(w);
    w[N / 3] = 1e-300;
    alias_t *a = alias_new(w, N, NULL);
    assert_non_null(a);
    assert_true(alias_pmf(a, N / 3) == 1.0);
    for (uint32_t j = 0; j < N; j++) {
        assert_int_equal(alias_sample(a, (double)j / N, NULL), N / 3);
        assert_int_equal(alias_sample(a, (j + 0.5) / N, NULL), N / 3);
    }
    assert_int_equal(alias_sample(a, 1.0, NULL), N / 3);
    assert_int_equal(alias_sample(a, 1.0 - 0x1p-53, NULL), N / 3);
    alias_destroy(&a);
    free(w);
}

/* 1e6 log-uniform weights from 1e-9 to 1e9, every 1000th set to zero:
 * - the pmfs sum to 1 within 1e-12 and keep the weights' ratios to 1e-15 (relative);
 * - 2e6 random draws grouped by the decade of the weight pass the chi-square test at its 1e-6
 *   quantile. A decade holds about ten times the mass of the one below, so the light decades
 *   expect fewer than 5 draws; they are merged upward until a group expects 5 (the validity
 *   rule of thumb), which leaves about 6 groups (5 degrees of freedom, limit ~37);
 * - no zero-weight entry is drawn. */
static void test_large_wide_range(void **state)
{
    (void)state;
    enum { N = 1000000, DRAWS = 2000000, DEC = 18 };
    double *w = malloc(N * sizeof *w);
    double *p = malloc(N * sizeof *p);
    assert_non_null(w);
    assert_non_null(p);
    size_t lo = 0, hi = 0;
    for (uint64_t i = 0; i < N; i++) {
        w[i] = i % 1000 == 999 ? 0.0 : pow(10.0, -9.0 + 18.0 * rng_uniform(5, i, 0, 0));
        if (w[i] > 0.0 && (w[lo] == 0.0 || w[i] < w[lo]))
            lo = i;
        if (w[i] > w[hi])
            hi = i;
    }
    alias_t *a = alias_new(w, N, NULL);
    assert_non_null(a);
    for (size_t i = 0; i < N; i++)
        p[i] = alias_pmf(a, i);
    double total = sum_exact(p, N);
    print_message("sum of pmf - 1 = %.2e\n", total - 1.0);
    assert_true(fabs(total - 1.0) < 1e-12);
    double ratio = (p[hi] / p[lo]) / (w[hi] / w[lo]);
    assert_true(fabs(ratio - 1.0) < 1e-15 * 4);

    double expect[DEC] = {0};
    unsigned long count[DEC] = {0};
    for (size_t i = 0; i < N; i++) {
        if (w[i] > 0.0) {
            int d = (int)floor(log10(w[i]) + 9.0);
            expect[d < 0 ? 0 : d >= DEC ? DEC - 1 : d] += p[i];
        }
    }
    for (uint64_t k = 0; k < DRAWS; k++) {
        size_t i = alias_sample(a, rng_uniform(6, k, 0, 0), NULL);
        assert_true(w[i] > 0.0);
        int d = (int)floor(log10(w[i]) + 9.0);
        count[d < 0 ? 0 : d >= DEC ? DEC - 1 : d]++;
    }
    /* merge low-expectation decades (the light ones) upward into the next */
    double chi2 = 0.0, e_acc = 0.0, c_acc = 0.0;
    int df = -1;
    for (int d = 0; d < DEC; d++) {
        e_acc += expect[d] * DRAWS;
        c_acc += (double)count[d];
        if (e_acc >= 5.0 || d == DEC - 1) {
            chi2 += (c_acc - e_acc) * (c_acc - e_acc) / e_acc;
            df++;
            e_acc = c_acc = 0.0;
        }
    }
    double limit = testutil_chi2_quantile(df, 4.75);
    print_message("decade chi2 = %.2f (df %d, limit %.1f)\n", chi2, df, limit);
    assert_true(df >= 5);
    assert_true(chi2 < limit);
    alias_destroy(&a);
    free(w);
    free(p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rejects_bad_weights), cmocka_unit_test(test_single_entry),
        cmocka_unit_test(test_frequencies),         cmocka_unit_test(test_zeros_never_drawn),
        cmocka_unit_test(test_large_wide_range),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
