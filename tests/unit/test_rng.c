/* rng: Philox4x32 known answers, order independence, and statistical sanity of rng_uniform. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "numeric_testutil.h"
#include "rng.h"

/* Known-answer vectors published with Random123 (D. E. Shaw Research, examples/kat_vectors):
 * "philox4x32 R ctr[4] key[2] -> out[4]", all hex uint32. The 7-round lines check the round
 * function and key schedule at another depth, so a schedule bumped one round early or late
 * cannot agree with both sets. */
static const struct {
    unsigned rounds;
    uint32_t ctr[4], key[2], out[4];
} KAT[] = {
    {7, {0, 0, 0, 0}, {0, 0}, {0x5f6fb709, 0x0d893f64, 0x4f121f81, 0x4f730a48}},
    {7,
     {0xffffffff, 0xffffffff, 0xffffffff, 0xffffffff},
     {0xffffffff, 0xffffffff},
     {0x5207ddc2, 0x45165e59, 0x4d8ee751, 0x8c52f662}},
    {7,
     {0x243f6a88, 0x85a308d3, 0x13198a2e, 0x03707344},
     {0xa4093822, 0x299f31d0},
     {0x4dfccaba, 0x190a87f0, 0xc47362ba, 0xb6b5242a}},
    {10, {0, 0, 0, 0}, {0, 0}, {0x6627e8d5, 0xe169c58d, 0xbc57ac4c, 0x9b00dbd8}},
    {10,
     {0xffffffff, 0xffffffff, 0xffffffff, 0xffffffff},
     {0xffffffff, 0xffffffff},
     {0x408f276d, 0x41c83b0e, 0xa20bc7c6, 0x6d5451fd}},
    {10,
     {0x243f6a88, 0x85a308d3, 0x13198a2e, 0x03707344},
     {0xa4093822, 0x299f31d0},
     {0xd16cfe09, 0x94fdcceb, 0x5001e420, 0x24126ea1}},
};

static void test_known_answers(void **state)
{
    (void)state;
    for (size_t t = 0; t < sizeof KAT / sizeof KAT[0]; t++) {
        uint32_t out[4];
        rng_philox4x32_r(KAT[t].ctr, KAT[t].key, KAT[t].rounds, out);
        for (int w = 0; w < 4; w++)
            assert_int_equal(out[w], KAT[t].out[w]);
    }
}

/* rng_uniform's documented layout is ctr = (dim / 2, sample, index lo, index hi), key = seed
 * (lo, hi), value = top 53 bits of words (2(dim % 2), 2(dim % 2) + 1). With the pi-digits
 * vector as input, the expected doubles follow from the published output words alone. */
static void test_uniform_from_known_answer(void **state)
{
    (void)state;
    uint64_t seed = 0x299f31d0a4093822ull;
    uint64_t index = 0x0370734413198a2eull;
    uint32_t sample = 0x85a308d3u;
    uint32_t dim = 2u * 0x243f6a88u;
    double expect0 = (double)((0xd16cfe0994fdccebull) >> 11) / 9007199254740992.0;
    double expect1 = (double)((0x5001e42024126ea1ull) >> 11) / 9007199254740992.0;
    assert_true(rng_uniform(seed, index, sample, dim) == expect0);
    assert_true(rng_uniform(seed, index, sample, dim + 1) == expect1);
}

/* A 16 x 16 image, 4 samples per pixel, 12 dimensions per sample, evaluated once pixel by
 * pixel in order and once dimension-major, pixels in reverse, through rng_uniform4 and a
 * stream: every number must be identical bit for bit, as must a copy of a stream. */
enum { PIX = 256, SPP = 4, DIMS = 12 };

static void test_order_independence(void **state)
{
    (void)state;
    const uint64_t seed = 0x5eed5eed12345678ull;
    static double fwd[PIX][SPP][DIMS], rev[PIX][SPP][DIMS], quad[PIX][SPP][DIMS];
    for (uint64_t p = 0; p < PIX; p++) {
        for (uint32_t s = 0; s < SPP; s++) {
            rng_stream_t st = rng_stream_make(seed, 1000 + p, s);
            for (uint32_t d = 0; d < DIMS; d++)
                fwd[p][s][d] = rng_stream_next(&st);
        }
    }
    for (int d = DIMS - 1; d >= 0; d--)
        for (int s = SPP - 1; s >= 0; s--)
            for (int p = PIX - 1; p >= 0; p -= 2) { /* odd pixels, then even: interleaved */
                rev[p][s][d] = rng_uniform(seed, 1000 + (uint64_t)p, (uint32_t)s, (uint32_t)d);
                rev[p - 1][s][d] =
                    rng_uniform(seed, 1000 + (uint64_t)(p - 1), (uint32_t)s, (uint32_t)d);
            }
    for (int p = PIX - 1; p >= 0; p--)
        for (uint32_t s = 0; s < SPP; s++) {
            /* dims 1..4, 5..8, 9..12 (the last overlaps past DIMS) and dim 0 alone: odd
             * starting dims straddle two cipher blocks. */
            double q[4];
            for (uint32_t d0 = 1; d0 < DIMS; d0 += 4) {
                rng_uniform4(seed, 1000 + (uint64_t)p, s, d0, q);
                for (uint32_t k = 0; k < 4 && d0 + k < DIMS; k++)
                    quad[p][s][d0 + k] = q[k];
            }
            rng_uniform4(seed, 1000 + (uint64_t)p, s, 0, q);
            quad[p][s][0] = q[0];
            assert_true(q[1] == quad[p][s][1] && q[2] == quad[p][s][2] && q[3] == quad[p][s][3]);
        }
    for (int p = 0; p < PIX; p++)
        for (int s = 0; s < SPP; s++)
            for (int d = 0; d < DIMS; d++) {
                assert_true(fwd[p][s][d] == rev[p][s][d]);
                assert_true(fwd[p][s][d] == quad[p][s][d]);
            }

    rng_stream_t a = rng_stream_make(seed, 7, 3);
    (void)rng_stream_next(&a);
    rng_stream_t b = a; /* a value type: the copy resumes at the same dimension */
    for (int i = 0; i < 5; i++)
        assert_true(rng_stream_next(&a) == rng_stream_next(&b));
    assert_int_equal(a.next_dim, 6);

    /* The dimension wraps mod 2^32 in rng_uniform4 as documented. */
    double w[4];
    rng_uniform4(seed, 1, 2, UINT32_MAX - 1, w);
    assert_true(w[0] == rng_uniform(seed, 1, 2, UINT32_MAX - 1));
    assert_true(w[1] == rng_uniform(seed, 1, 2, UINT32_MAX));
    assert_true(w[2] == rng_uniform(seed, 1, 2, 0));
    assert_true(w[3] == rng_uniform(seed, 1, 2, 1));
    rng_uniform4(seed, 1, 2, UINT32_MAX, w); /* odd start: three blocks, wrapping */
    for (uint32_t k = 0; k < 4; k++)
        assert_true(w[k] == rng_uniform(seed, 1, 2, UINT32_MAX + k));
}

/* Each key component changes the number: neighbouring seeds, indices (including the high
 * word), samples and dimensions all give different values. */
static void test_key_components_matter(void **state)
{
    (void)state;
    double base = rng_uniform(1, 2, 3, 4);
    assert_true(rng_uniform(2, 2, 3, 4) != base);
    assert_true(rng_uniform(1ull << 32 | 1, 2, 3, 4) != base);
    assert_true(rng_uniform(1, 3, 3, 4) != base);
    assert_true(rng_uniform(1, 2ull | 1ull << 40, 3, 4) != base);
    assert_true(rng_uniform(1, 2, 4, 4) != base);
    assert_true(rng_uniform(1, 2, 3, 5) != base);
    assert_true(rng_uniform(1, 2, 3, 6) != base);
}

/* 1e6 draws over a million pixel indices of one seed:
 * - the mean of U(0,1) is 1/2 with standard error sqrt(1/12 / N) = 2.9e-4; accept 4 sigma;
 * - no draw is 1.0 (nor negative);
 * - 1000 equal buckets: the statistic is chi-square with 999 degrees of freedom; accept below
 *   its z = 4.75 quantile (upper tail probability 1e-6), about 1232;
 * - Pearson correlation of dims 0 and 1 (same block) and of dims 1 and 2 (adjacent blocks)
 *   of one sample, and of dim 0 at indices i and i + 1: each has standard error 1/sqrt(N) =
 *   1e-3 under independence; accept |r| < 5e-3. */
static void test_statistics(void **state)
{
    (void)state;
    enum { N = 1000000, BUCKETS = 1000 };
    const uint64_t seed = 20240601;
    static unsigned count[BUCKETS];
    double sum = 0.0, s01 = 0.0, s12 = 0.0, sidx = 0.0, sq = 0.0;
    double prev0 = rng_uniform(seed, 0, 0, 0);
    for (uint64_t i = 0; i < N; i++) {
        double u[4];
        rng_uniform4(seed, i, 0, 0, u);
        for (int k = 0; k < 4; k++)
            assert_true(u[k] >= 0.0 && u[k] < 1.0);
        sum += u[0];
        sq += (u[0] - 0.5) * (u[0] - 0.5);
        count[(int)(u[0] * BUCKETS)]++;
        s01 += (u[0] - 0.5) * (u[1] - 0.5);
        s12 += (u[1] - 0.5) * (u[2] - 0.5);
        if (i > 0)
            sidx += (prev0 - 0.5) * (u[0] - 0.5);
        prev0 = u[0];
    }
    double mean = sum / N;
    double sigma = sqrt(1.0 / 12.0 / N);
    assert_true(fabs(mean - 0.5) < 4.0 * sigma);
    assert_true(fabs(sq / N - 1.0 / 12.0) < 0.01 * (1.0 / 12.0)); /* variance within 1 % */

    double expected = (double)N / BUCKETS, chi2 = 0.0;
    for (int b = 0; b < BUCKETS; b++)
        chi2 += (count[b] - expected) * (count[b] - expected) / expected;
    double limit = testutil_chi2_quantile(BUCKETS - 1, 4.75);
    /* the 1e-6 quantile can be checked loosely by hand: mean 999, sd sqrt(2 * 999) = 44.7 */
    assert_true(limit > 999 + 4.0 * 44.7 && limit < 999 + 6.0 * 44.7);
    assert_true(chi2 < limit);

    double var = 1.0 / 12.0;
    double r01 = s01 / N / var, r12 = s12 / N / var, ridx = sidx / (N - 1) / var;
    assert_true(fabs(r01) < 5e-3);
    assert_true(fabs(r12) < 5e-3);
    assert_true(fabs(ridx) < 5e-3);
    print_message("mean %.6f (sigma %.1e), chi2 %.1f < %.1f, r01 %.1e r12 %.1e ridx %.1e\n", mean,
                  sigma, chi2, limit, r01, r12, ridx);
}

/* The largest possible output is (2^53 - 1) 2^-53 = 1 - 2^-53, which a double holds exactly,
 * so 1.0 cannot occur; an all-ones key and counter region must respect that too. */
static void test_never_one(void **state)
{
    (void)state;
    double top = (double)(UINT64_MAX >> 11) * 0x1.0p-53; /* the conversion of all-ones words */
    assert_true(top < 1.0);
    assert_true(top == 1.0 - 0x1.0p-53);
    for (uint32_t d = 0; d < 100000; d++)
        assert_true(rng_uniform(UINT64_MAX, UINT64_MAX, UINT32_MAX, d) < 1.0);
}

/* Informational only (not asserted, timing varies by machine): numbers per second. */
static void test_throughput(void **state)
{
    (void)state;
    enum { N = 4000000 };
    struct timespec t0, t1;
    double acc = 0.0;
    assert_int_equal(timespec_get(&t0, TIME_UTC), TIME_UTC);
    for (uint32_t i = 0; i < N; i++)
        acc += rng_uniform(42, i >> 4, 0, i & 15);
    assert_int_equal(timespec_get(&t1, TIME_UTC), TIME_UTC);
    double sec = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
    assert_true(acc > 0.0);
    print_message("rng_uniform: %.3g numbers/s (%d in %.3f s)\n", N / sec, N, sec);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_known_answers),      cmocka_unit_test(test_uniform_from_known_answer),
        cmocka_unit_test(test_order_independence), cmocka_unit_test(test_key_components_matter),
        cmocka_unit_test(test_statistics),         cmocka_unit_test(test_never_one),
        cmocka_unit_test(test_throughput),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
