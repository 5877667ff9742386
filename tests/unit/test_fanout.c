/* fanout: monochrome samples carry exactly the polychrome energy for every shift S, at the
 * ends of the grid too; scaled Fresnel terms average to the polychrome transmittance and
 * stay finite when everything is totally reflected; fanout_refract obeys Snell per
 * wavelength and conserves energy: R_P + mean(k t_i) = 1. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h> /* after the four headers above, which it needs */

#include <float.h>
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>

#include "dispersion.h"
#include "fanout.h"
#include "fresnel.h"
#include "glass.h"
#include "numeric_testutil.h"

#define PI 3.14159265358979323846
#define N 16
#define LMIN 380.0
#define LMAX 720.0
#define WIDTH ((LMAX - LMIN) / N)

/* Sums of 16 to 32 terms near 1 round by a few 1e-16: a bound of 1e-12 relative leaves four
 * orders of margin. */
#define SUM_TOL 1e-12

static void grid(double *lambda)
{
    for (int i = 0; i < N; i++)
        lambda[i] = LMIN + (i + 0.5) * WIDTH;
}

static double total(const fanout_sample_t *s, int count)
{
    double sum = 0.0;
    for (int i = 0; i < count; i++)
        sum += s[i].energy[0] + s[i].energy[1];
    return sum;
}

/* Checks one split: energies sum to sum(P), each sample keeps its own P_i, shares follow
 * (1 - |S|, |S|), bucket indices are in range and lambda' stays inside [LMIN, LMAX]. */
static void check_split(const double *energy, double shift)
{
    double lambda[N];
    grid(lambda);
    fanout_sample_t s[N];
    err_t err;
    assert_int_equal(fanout_split(lambda, energy, N, shift, s, &err), 0);
    double expected = 0.0;
    for (int i = 0; i < N; i++)
        expected += energy[i];
    double got = total(s, N);
    if (fabs(got - expected) > SUM_TOL * fabs(expected))
        fail_msg("S = %g: monochrome total %.17g, polychrome %.17g", shift, got, expected);
    for (int i = 0; i < N; i++) {
        assert_int_equal(s[i].bucket[0], i);
        assert_true(s[i].bucket[1] >= 0 && s[i].bucket[1] < N);
        assert_true(abs(s[i].bucket[1] - i) <= 1);
        testutil_assert_near(s[i].energy[0] + s[i].energy[1], energy[i], 1e-15 * fabs(energy[i]));
        assert_true(s[i].lambda_nm >= LMIN - 1e-9 && s[i].lambda_nm <= LMAX + 1e-9);
        /* lambda' lies in bucket i: within half a bucket of its centre. */
        assert_true(fabs(s[i].lambda_nm - lambda[i]) <= 0.5 * WIDTH + 1e-9);
        bool end = (i == 0 && shift < 0) || (i == N - 1 && shift > 0);
        if (!end && shift != 0.0) {
            assert_int_equal(s[i].bucket[1], i + (shift > 0 ? 1 : -1));
            testutil_assert_near(s[i].energy[1], fabs(shift) * energy[i], 1e-15 * fabs(energy[i]));
        } else {
            assert_true(s[i].energy[1] == 0.0);
        }
    }
}

static void test_split_conserves_energy(void **state)
{
    (void)state;
    double energy[N];
    for (int i = 0; i < N; i++)
        energy[i] = 1.0 + 0.37 * i * i - 0.01 * i * i * i; /* uneven, positive */
    const double shifts[] = {-0.5, -0.25, 0.0, -0.0, 0.25, 0.5, 1e-17, -1e-17};
    for (size_t k = 0; k < sizeof shifts / sizeof shifts[0]; k++)
        check_split(energy, shifts[k]);
    uint64_t rng = 20240601;
    for (int k = 0; k < 2000; k++)
        check_split(energy, testutil_splitmix_u(&rng) - 0.5);
}

/* Energy only in the first or only in the last bucket: the end rule must keep it all. */
static void test_split_end_buckets(void **state)
{
    (void)state;
    const double shifts[] = {-0.5, -0.3, 0.0, 0.3, 0.5};
    for (int end = 0; end < 2; end++) {
        double energy[N] = {0};
        energy[end ? N - 1 : 0] = 2.5;
        for (size_t k = 0; k < sizeof shifts / sizeof shifts[0]; k++)
            check_split(energy, shifts[k]);
    }
    /* Worked by hand: S = -0.5 at bucket 0 stays in bucket 0 at lambda_min; S = +0.5 at the
     * last bucket stays there at lambda_max. */
    double lambda[N], energy[N] = {0};
    grid(lambda);
    energy[0] = 1.0;
    energy[N - 1] = 3.0;
    fanout_sample_t s[N];
    assert_int_equal(fanout_split(lambda, energy, N, -0.5, s, NULL), 0);
    testutil_assert_near(s[0].lambda_nm, LMIN, 1e-12);
    assert_true(s[0].energy[0] == 1.0 && s[0].energy[1] == 0.0);
    assert_int_equal(fanout_split(lambda, energy, N, 0.5, s, NULL), 0);
    testutil_assert_near(s[N - 1].lambda_nm, LMAX, 1e-12);
    assert_true(s[N - 1].energy[0] == 3.0);
    /* ... and bucket 0 at S = +0.5 sits on its upper edge with the energy halved. */
    testutil_assert_near(s[0].lambda_nm, LMIN + WIDTH, 1e-12);
    assert_true(s[0].energy[0] == 0.5 && s[0].energy[1] == 0.5 && s[0].bucket[1] == 1);
}

/* Over many random S, the wavelengths of sample i cover all of bucket i (no gaps between
 * buckets: dispersion is rendered without holes in the spectrum). 4000 uniform S leave a gap
 * at either end of about WIDTH/4000 on average; 1% of the width fails with odds e^-40. */
static void test_split_covers_buckets(void **state)
{
    (void)state;
    double lambda[N], energy[N];
    grid(lambda);
    for (int i = 0; i < N; i++)
        energy[i] = 1.0;
    double lo[N], hi[N];
    for (int i = 0; i < N; i++) {
        lo[i] = INFINITY;
        hi[i] = -INFINITY;
    }
    uint64_t rng = 7;
    fanout_sample_t s[N];
    for (int k = 0; k < 4000; k++) {
        assert_int_equal(fanout_split(lambda, energy, N, testutil_splitmix_u(&rng) - 0.5, s, NULL),
                         0);
        for (int i = 0; i < N; i++) {
            lo[i] = fmin(lo[i], s[i].lambda_nm);
            hi[i] = fmax(hi[i], s[i].lambda_nm);
        }
    }
    for (int i = 0; i < N; i++) {
        assert_true(lo[i] - (LMIN + i * WIDTH) < 0.01 * WIDTH);
        assert_true((LMIN + (i + 1) * WIDTH) - hi[i] < 0.01 * WIDTH);
    }
}

static void test_split_rejects(void **state)
{
    (void)state;
    double lambda[N], energy[N] = {0};
    grid(lambda);
    fanout_sample_t s[N];
    err_t err;
    assert_int_equal(fanout_split(lambda, energy, N, 0.5000001, s, &err), -1);
    assert_int_equal(fanout_split(lambda, energy, N, NAN, s, &err), -1);
    assert_int_equal(fanout_split(lambda, energy, 0, 0.1, s, &err), -1);
    energy[3] = INFINITY;
    assert_int_equal(fanout_split(lambda, energy, N, 0.1, s, &err), -1);
    energy[3] = 0.0;
    lambda[5] = lambda[4];
    assert_int_equal(fanout_split(lambda, energy, N, 0.1, s, &err), -1);
    /* One bucket: nothing to shift towards, all energy stays. */
    double l1 = 550.0, e1 = 4.0;
    assert_int_equal(fanout_split(&l1, &e1, 1, 0.4, s, &err), 0);
    assert_true(s[0].lambda_nm == 550.0 && s[0].energy[0] == 4.0 && s[0].energy[1] == 0.0);
}

/* k = T_P / mean(t_i) (thesis eq. 5.3 read spectrally, see fanout.h), worked by hand:
 * t = {0.9, 0.6, 0.3} (mean 0.6), T_P = 0.45 gives k = 0.75 and k t = {0.675, 0.45, 0.225},
 * whose mean is T_P. Equal t_i = T_P (no dispersion) give k = 1. */
static void test_fresnel_scale(void **state)
{
    (void)state;
    double t[3] = {0.9, 0.6, 0.3}, scaled[4];
    double k = fanout_fresnel_scale(t, 3, 0.45, scaled);
    testutil_assert_near(k, 0.75, 1e-15);
    testutil_assert_near(scaled[0], 0.675, 1e-15);
    testutil_assert_near(scaled[1], 0.45, 1e-15);
    testutil_assert_near(scaled[2], 0.225, 1e-15);
    double flat[4] = {0.96, 0.96, 0.96, 0.96};
    testutil_assert_near(fanout_fresnel_scale(flat, 4, 0.96, scaled), 1.0, 1e-15);
    testutil_assert_near(scaled[3], 0.96, 1e-15);

    /* Every wavelength totally reflected: k = 0, nothing transmitted, nothing non-finite. */
    double zero[4] = {0, 0, 0, 0}, out[4] = {9, 9, 9, 9};
    k = fanout_fresnel_scale(zero, 4, 0.7, out);
    assert_true(k == 0.0);
    for (int i = 0; i < 4; i++)
        assert_true(out[i] == 0.0);

    /* A subnormal sum would overflow N T_P / sum: scaled stays finite, k is capped. */
    double tiny[2] = {5e-324, 0.0}, out2[2];
    k = fanout_fresnel_scale(tiny, 2, 0.9, out2);
    assert_true(isfinite(k) && k == DBL_MAX);
    assert_true(out2[0] == 1.8 && out2[1] == 0.0);

    /* A NaN term counts as 0 and never propagates; a NaN T_P transmits nothing. */
    double bad[2] = {NAN, 0.5}, out3[4];
    k = fanout_fresnel_scale(bad, 2, 0.5, out3);
    assert_true(isfinite(k) && out3[0] == 0.0 && isfinite(out3[1]));
    k = fanout_fresnel_scale(flat, 4, NAN, out3);
    assert_true(k == 0.0);
}

static const ior_model_t *catalogue(const char *name)
{
    const glass_t *g = glass_find(name);
    assert_non_null(g);
    return &g->ior;
}

/* Air into N-BK7 at 45 degrees, 16 bucket wavelengths: each ray obeys Snell with its own
 * n(lambda), blue bends more than red, and R_P + mean(k t_i) = 1: with a flat spectrum P the
 * reflected R_P sum P plus the transmitted sum k t_i P is sum P, as a furnace needs. */
static void test_refract_into_glass(void **state)
{
    (void)state;
    ior_model_t air = ior_constant(1.0);
    const ior_model_t *glass = catalogue("N-BK7");
    vec3_t n = vec3_make(0.0, 0.0, 1.0);
    vec3_t d = vec3_normalize(vec3_make(1.0, 0.0, -1.0));
    double lambda[N];
    grid(lambda);
    fanout_ray_t rays[N];
    fanout_poly_t poly;
    err_t err;
    assert_int_equal(fanout_refract(&air, glass, d, n, lambda, N, rays, &poly, &err), 0);
    assert_false(poly.tir);
    double sum = 0.0, sum_t = 0.0;
    for (int i = 0; i < N; i++) {
        assert_false(rays[i].tir);
        assert_true(rays[i].n_incident == 1.0);
        assert_true(rays[i].n_transmitted == ior_eval(glass, lambda[i]));
        double sin_t = vec3_length(vec3_cross(rays[i].dir, n));
        testutil_assert_near(sin(PI / 4), rays[i].n_transmitted * sin_t, 1e-12);
        testutil_assert_near(vec3_length(rays[i].dir), 1.0, 1e-12);
        assert_true(rays[i].dir.z < 0.0);
        if (i > 0) /* longer wavelength, lower n, bent less: larger x component */
            assert_true(rays[i].dir.x > rays[i - 1].dir.x);
        sum += rays[i].transmittance;
        sum_t += 1.0 - fresnel_dielectric(-vec3_dot(d, n), 1.0, rays[i].n_transmitted);
    }
    testutil_assert_near(poly.reflectance + sum / N, 1.0, 1e-12);
    testutil_assert_near(poly.scale * sum_t / N, poly.transmittance, 1e-12);
    /* Dispersion changes t_i by well under 1% here, so k is close to 1. */
    testutil_assert_near(poly.scale, 1.0, 1e-2);
    /* The polychrome ray, refracted at the mean index, lies between blue and red. */
    assert_true(poly.refract_dir.x > rays[0].dir.x && poly.refract_dir.x < rays[N - 1].dir.x);
    /* A non-dispersive medium makes every monochrome ray the polychrome one: k = 1. */
    ior_model_t flat = ior_constant(1.5);
    assert_int_equal(fanout_refract(&air, &flat, d, n, lambda, N, rays, &poly, &err), 0);
    testutil_assert_near(poly.scale, 1.0, 1e-14);
    /* T_P at 45 degrees into n = 1.5, by hand: cos_t = sqrt(1 - 0.5 / 2.25), r_s = -0.3033370,
     * r_p = r_s^2 = 0.0920134 (Abeles: r_p = r_s^2 at 45 degrees), T = 1 - (r_s^2 + r_p^2)/2. */
    testutil_assert_near(poly.transmittance, 0.94976009, 1e-8);
    for (int i = 0; i < N; i++)
        testutil_assert_near(rays[i].transmittance, poly.transmittance, 1e-15);
}

/* Leaving N-SF11 (n 1.77-1.81, critical angles 33.5-34.4 degrees). At 60 degrees every
 * wavelength is totally reflected: no Inf/NaN, k = 0, R_P = 1. At 34.0 degrees blue is
 * reflected and red not, exactly where n(lambda) sin(theta) >= 1, and energy is conserved. */
static void test_refract_total_reflection(void **state)
{
    (void)state;
    ior_model_t air = ior_constant(1.0);
    const ior_model_t *glass = catalogue("N-SF11");
    vec3_t n = vec3_make(0.0, 0.0, 1.0); /* points out into the air */
    double lambda[N];
    grid(lambda);
    fanout_ray_t rays[N];
    fanout_poly_t poly;
    double theta = 60.0 * PI / 180.0;
    vec3_t d = vec3_make(sin(theta), 0.0, cos(theta)); /* travelling up, from inside */
    assert_int_equal(fanout_refract(&air, glass, d, n, lambda, N, rays, &poly, NULL), 0);
    assert_true(poly.tir && poly.reflectance == 1.0 && poly.transmittance == 0.0);
    assert_true(poly.scale == 0.0);
    for (int i = 0; i < N; i++) {
        assert_true(rays[i].tir && rays[i].transmittance == 0.0);
        assert_true(isfinite(rays[i].dir.x) && rays[i].dir.z < 0.0); /* mirrored back down */
    }

    theta = 34.0 * PI / 180.0;
    d = vec3_make(sin(theta), 0.0, cos(theta));
    assert_int_equal(fanout_refract(&air, glass, d, n, lambda, N, rays, &poly, NULL), 0);
    int reflected = 0;
    double sum = 0.0;
    for (int i = 0; i < N; i++) {
        bool expect_tir = ior_eval(glass, lambda[i]) * sin(theta) >= 1.0;
        assert_true(rays[i].tir == expect_tir);
        assert_true(isfinite(rays[i].transmittance) && rays[i].transmittance >= 0.0);
        reflected += rays[i].tir;
        sum += rays[i].transmittance;
    }
    assert_true(reflected > 0 && reflected < N);
    testutil_assert_near(poly.reflectance + sum / N, 1.0, 1e-12);

    /* Grazing (d in the surface): nothing gets through, nothing non-finite. */
    d = vec3_make(1.0, 0.0, 0.0);
    assert_int_equal(fanout_refract(&air, glass, d, n, lambda, N, rays, &poly, NULL), 0);
    assert_true(poly.reflectance == 1.0 && poly.scale == 0.0);
    for (int i = 0; i < N; i++)
        assert_true(rays[i].transmittance == 0.0 && isfinite(rays[i].dir.x));

    err_t err;
    assert_int_equal(
        fanout_refract(&air, glass, vec3_make(0, 0, 0), n, lambda, N, rays, &poly, &err), -1);
    assert_int_equal(fanout_refract(&air, glass, d, n, lambda, 0, rays, &poly, &err), -1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_split_conserves_energy),
        cmocka_unit_test(test_split_end_buckets),
        cmocka_unit_test(test_split_covers_buckets),
        cmocka_unit_test(test_split_rejects),
        cmocka_unit_test(test_fresnel_scale),
        cmocka_unit_test(test_refract_into_glass),
        cmocka_unit_test(test_refract_total_reflection),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
