/* Tests for noise (scene/noise.h), against properties of Perlin's gradient noise that do not
 * come from the code:
 * - it is 0 at every lattice point, and its slope there along an axis is a component of one
 *   of Perlin's gradients (-1, 0 or 1), since the quintic fade is flat at the cell's corners;
 * - it is bounded by 1.5 (a sum of corner weights |g . d| <= |g| |d| in one cell), continuous
 *   (a step of 1e-7 moves it by far less than 1e-5) and not trivial (its spread over random
 *   points is that of a noise, not a constant);
 * - fbm and turbulence are the octave sums pbrt-v4 defines: frequency x1.99, weight omega^i,
 *   and turbulence's 0.2 omega^octaves for the clamped remainder. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <math.h>

#include "noise.h"

/* A fixed sequence of points in [-50, 50)^3 (a 64-bit LCG: deterministic, no library). */
static double next_uniform(uint64_t *s)
{
    *s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
    return (double)(*s >> 11) * 0x1p-53;
}

static vec3_t next_point(uint64_t *s)
{
    double x = next_uniform(s), y = next_uniform(s), z = next_uniform(s);
    return vec3_make(100.0 * x - 50.0, 100.0 * y - 50.0, 100.0 * z - 50.0);
}

static void test_lattice(void **state)
{
    (void)state;
    const double eps = 1e-6;
    int nonzero_slopes = 0;
    for (int x = -20; x <= 20; x += 3)
        for (int y = -20; y <= 20; y += 5)
            for (int z = -20; z <= 20; z += 7) {
                vec3_t p = vec3_make(x, y, z);
                assert_true(noise_perlin(p) == 0.0);
                const vec3_t axes[3] = {vec3_make(eps, 0, 0), vec3_make(0, eps, 0),
                                        vec3_make(0, 0, eps)};
                for (int a = 0; a < 3; a++) {
                    double slope = noise_perlin(vec3_add(p, axes[a])) / eps;
                    double nearest = round(slope);
                    assert_true(fabs(slope - nearest) < 1e-4);
                    assert_true(fabs(nearest) <= 1.0);
                    nonzero_slopes += nearest != 0.0;
                }
            }
    /* Each of Perlin's gradients has two non-zero components of three. */
    assert_true(nonzero_slopes > 0);
    /* Far lattice points too: the coordinates wrap without losing integrality. */
    assert_true(noise_perlin(vec3_make(1e9, -3e8, 123456789.0)) == 0.0);
    assert_true(noise_perlin(vec3_make(NAN, 0, 0)) == 0.0);
    assert_true(isfinite(noise_perlin(vec3_make(1e300, -1e300, 0.5))));
}

static void test_range_and_spread(void **state)
{
    (void)state;
    uint64_t s = 42;
    double sum = 0.0, sum2 = 0.0, lo = 0.0, hi = 0.0;
    const int n = 20000;
    for (int i = 0; i < n; i++) {
        vec3_t p = next_point(&s);
        double v = noise_perlin(p);
        assert_true(fabs(v) <= 1.5);
        lo = fmin(lo, v);
        hi = fmax(hi, v);
        sum += v;
        sum2 += v * v;
        double w = noise_perlin(vec3_add(p, vec3_make(1e-7, -1e-7, 1e-7)));
        assert_true(fabs(w - v) < 1e-5);
    }
    double mean = sum / n, sd = sqrt(sum2 / n - mean * mean);
    /* Zero mean (gradients are symmetric) within a few standard errors; a spread of a few
     * tenths, and both signs reached well beyond it. */
    assert_true(fabs(mean) < 5.0 * sd / sqrt(n) + 0.01);
    assert_true(sd > 0.1 && sd < 0.5);
    assert_true(lo < -0.5 && hi > 0.5);
}

static void test_octave_sums(void **state)
{
    (void)state;
    uint64_t s = 7;
    for (int i = 0; i < 200; i++) {
        vec3_t p = next_point(&s);
        const double omega = 0.6;
        double n0 = noise_perlin(p), n1 = noise_perlin(vec3_scale(p, 1.99)),
               n2 = noise_perlin(vec3_scale(p, 1.99 * 1.99));
        assert_true(fabs(noise_fbm(p, omega, 1) - n0) < 1e-15);
        assert_true(fabs(noise_fbm(p, omega, 3) - (n0 + omega * n1 + omega * omega * n2)) < 1e-12);
        double turb =
            fabs(n0) + omega * fabs(n1) + omega * omega * fabs(n2) + 0.2 * omega * omega * omega;
        assert_true(fabs(noise_turbulence(p, omega, 3) - turb) < 1e-12);
        assert_true(noise_turbulence(p, omega, 3) > 0.0);
        /* The octaves' weights bound the sum: |fbm| <= 1.5 sum omega^i. */
        assert_true(fabs(noise_fbm(p, 0.5, 8)) <= 1.5 * 2.0);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_lattice),
        cmocka_unit_test(test_range_and_spread),
        cmocka_unit_test(test_octave_sums),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
