/* numeric_testutil: the numeric helpers the tests share: testutil_assert_near (a value within
 * an absolute tolerance of the expected one, NaN never), a fixed-seed stream of doubles
 * (splitmix64) and the chi-square quantile the statistical tests bound their statistics with.
 * Header-only (each test is its own executable); include after cmocka.h. */
#ifndef PRISMFARM_NUMERIC_TESTUTIL_H
#define PRISMFARM_NUMERIC_TESTUTIL_H

#include <math.h>
#include <stdint.h>

/* Fails the test unless |a - b| <= tol (so a NaN always fails), naming the expression a, both
 * values and how far apart they are; the failure is reported at the caller's line. */
#define testutil_assert_near(a, b, tol)                                                            \
    do {                                                                                           \
        double a_ = (a), b_ = (b), t_ = (tol);                                                     \
        if (!(fabs(a_ - b_) <= t_))                                                                \
            fail_msg("%s = %.17g, expected %.17g within %.3g (off by %.3g)", #a, a_, b_, t_,       \
                     fabs(a_ - b_));                                                               \
    } while (0)

/* splitmix64 (Steele, Lea & Flood 2014): the next double in [0, 1) of the stream state, a
 * fixed-seed stream of the test's own, so that a failure reproduces. */
static inline double testutil_splitmix_u(uint64_t *state)
{
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return (double)(z >> 11) * 0x1.0p-53;
}

/* The Wilson-Hilferty approximation of the chi-square quantile with df degrees of freedom at
 * the standard-normal quantile z (accurate to < 0.1 % for df > 30); z = 4.75 is an upper tail
 * of 1e-6. */
static inline double testutil_chi2_quantile(double df, double z)
{
    double h = 2.0 / (9.0 * df);
    double c = 1.0 - h + z * sqrt(h);
    return df * c * c * c;
}

#endif
