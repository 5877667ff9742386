/* fresnel: reflection and refraction directions and the cosine-form Fresnel reflectance
 * against closed-form optics (normal incidence, Brewster, critical angle, grazing, Snell,
 * transmission from the independent t_s/t_p amplitudes, prism minimum deviation). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h> /* after the four headers above, which it needs */

#include <math.h>
#include <stdbool.h>

#include "dispersion.h"
#include "fresnel.h"
#include "glass.h"
#include "numeric_testutil.h"

#define PI 3.14159265358979323846

static double nbk7(double lambda_nm)
{
    const glass_t *g = glass_find("N-BK7");
    assert_non_null(g);
    return ior_eval(&g->ior, lambda_nm);
}

/* Normal incidence: R = ((n1 - n2) / (n1 + n2))^2 (Hecht, Optics, eq. 4.47), from either
 * side, e.g. 0.04 for n = 1.5 in air. */
static void test_normal_incidence(void **state)
{
    (void)state;
    const double pairs[][2] = {{1.0, 1.5}, {1.0, 2.4175}, {1.333, 1.5168}, {1.0, 1.0001}};
    for (size_t i = 0; i < sizeof pairs / sizeof pairs[0]; i++) {
        double n1 = pairs[i][0], n2 = pairs[i][1];
        double expected = ((n1 - n2) / (n1 + n2)) * ((n1 - n2) / (n1 + n2));
        testutil_assert_near(fresnel_dielectric(1.0, n1, n2), expected, 1e-15);
        testutil_assert_near(fresnel_dielectric(-1.0, n1, n2), expected, 1e-15);
        fresnel_terms_t f = fresnel_dielectric_terms(1.0, n1, n2);
        testutil_assert_near(f.transmittance, 1.0 - expected, 1e-15);
        assert_false(f.tir);
    }
    testutil_assert_near(fresnel_dielectric(1.0, 1.0, 1.5), 0.04, 1e-15);
    /* Equal indices: no interface at all, at every angle including grazing. */
    assert_true(fresnel_dielectric(1.0, 1.5, 1.5) == 0.0);
    assert_true(fresnel_dielectric(0.0, 1.5, 1.5) == 0.0);
}

/* Brewster angle theta_B = atan(n2 / n1) (thesis eq. 3.10): r_p vanishes. From inside the
 * indices swap, so the angle is atan(n_outside / n_inside). The cosine form loses no
 * accuracy there, so 1e-12 holds (the tan form would divide by tan(pi/2)). */
static void test_brewster(void **state)
{
    (void)state;
    const double n_out = 1.0;
    const double lambdas[] = {400.0, IOR_LAMBDA_D_NM, 700.0};
    for (size_t i = 0; i < 3; i++) {
        double n_in = nbk7(lambdas[i]);
        fresnel_terms_t f = fresnel_dielectric_terms(cos(atan(n_in / n_out)), n_out, n_in);
        assert_true(fabs(f.rp) < 1e-12);
        assert_true(f.rs < -0.1); /* s-polarised light is still reflected */
        fresnel_terms_t g = fresnel_dielectric_terms(-cos(atan(n_out / n_in)), n_out, n_in);
        assert_true(fabs(g.rp) < 1e-12);
        assert_true(g.n1 == n_in && g.n2 == n_out);
        /* R = r_s^2 / 2 there. */
        testutil_assert_near(f.reflectance, 0.5 * f.rs * f.rs, 1e-15);
    }
}

/* Critical angle theta_c = asin(n2 / n1) leaving glass (n1 = 1.5) into air. Beyond it R = 1.
 * Just below it, by delta, the transmission vanishes continuously: with
 * cos_t ~ sqrt(2 cot(theta_c) delta), the independent transmittances
 * T_s = 4 n1 n2 cos_i cos_t / (n1 cos_i + n2 cos_t)^2 ~ 4 n2 cos_t / (n1 cos_i) and
 * T_p ~ 4 n1 cos_t / (n2 cos_i) give T ~ 2 cos_t (n2/n1 + n1/n2) / cos_i, to first order. */
static void test_critical_angle(void **state)
{
    (void)state;
    const double n1 = 1.5, n2 = 1.0;
    double theta_c = asin(n2 / n1);
    /* Light comes from inside: cos_theta_i < 0 with n_outside = air, n_inside = glass. */
    fresnel_terms_t beyond = fresnel_dielectric_terms(-cos(theta_c + 1e-9), n2, n1);
    assert_true(beyond.tir);
    assert_true(beyond.reflectance == 1.0 && beyond.transmittance == 0.0);
    assert_true(beyond.cos_t == 0.0);
    assert_true(fresnel_dielectric(-cos(theta_c + 0.3), n2, n1) == 1.0);

    double previous_t = 1.0;
    for (int k = 1; k <= 5; k++) {
        double delta = pow(10.0, -2.0 * k); /* 1e-2 .. 1e-10 rad */
        double theta = theta_c - delta;
        fresnel_terms_t f = fresnel_dielectric_terms(-cos(theta), n2, n1);
        assert_false(f.tir);
        assert_true(f.transmittance < previous_t);
        previous_t = f.transmittance;
        if (delta <= 1e-6) {
            double cos_t = sqrt(2.0 * delta / tan(theta_c));
            double t_asym = 2.0 * cos_t * (n2 / n1 + n1 / n2) / cos(theta_c);
            /* first-order expansion: relative error O(sqrt(delta)) < 1e-2 here */
            testutil_assert_near(f.transmittance, t_asym, 1e-2 * t_asym);
        }
    }
    assert_true(previous_t < 1e-3);
}

/* Grazing incidence: R -> 1 as cos_i -> 0, monotonically, from both sides, and exactly 1
 * below FRESNEL_GRAZING_COS. */
static void test_grazing(void **state)
{
    (void)state;
    assert_true(fresnel_dielectric(1e-7, 1.0, 1.5) == 1.0);
    assert_true(fresnel_dielectric(0.0, 1.0, 1.5) == 1.0);
    assert_true(fresnel_dielectric(-0.0, 1.0, 1.5) == 1.0);
    double previous = 0.0;
    for (double c = 0.1; c >= 1e-6; c *= 0.1) {
        double r = fresnel_dielectric(c, 1.0, 1.5);
        assert_true(r > previous && r <= 1.0);
        previous = r;
    }
    assert_true(previous > 0.9999);
    /* From the dense side grazing is far beyond the critical angle. */
    assert_true(fresnel_dielectric(-1e-7, 1.0, 1.5) == 1.0);
}

/* cos(theta_i) a rounding outside [-1, 1] is clamped; NaN and bad indices give finite R. */
static void test_clamp_and_garbage(void **state)
{
    (void)state;
    double r0 = fresnel_dielectric(1.0, 1.0, 1.5);
    assert_true(fresnel_dielectric(1.0 + 1e-12, 1.0, 1.5) == r0);
    assert_true(fresnel_dielectric(-1.0 - 1e-12, 1.0, 1.5) == r0);
    assert_true(isfinite(fresnel_dielectric(NAN, 1.0, 1.5)));
    assert_true(fresnel_dielectric(0.5, 0.0, 1.5) == 1.0);
    assert_true(fresnel_dielectric(0.5, 1.0, NAN) == 1.0);
    assert_true(fresnel_dielectric(0.5, 1.0, INFINITY) == 1.0);
}

/* R + T = 1 per wavelength, with T from the transmission amplitudes (Born & Wolf 1.5.2):
 * t_s = 2 n1 cos_i / (n1 cos_i + n2 cos_t), t_p = 2 n1 cos_i / (n2 cos_i + n1 cos_t),
 * T = (n2 cos_t) / (n1 cos_i) (t_s^2 + t_p^2) / 2 -- a formula the code does not use.
 * Over 16 wavelengths, 179 angles, both sides of air / N-BK7. */
static void test_energy_sweep(void **state)
{
    (void)state;
    double worst = 0.0;
    for (int l = 0; l < 16; l++) {
        double n_glass = nbk7(380.0 + 340.0 * (l + 0.5) / 16.0);
        for (int side = 0; side < 2; side++) {
            double n1 = side ? n_glass : 1.0, n2 = side ? 1.0 : n_glass;
            for (int a = 1; a < 180; a++) {
                double theta = 0.5 * a * PI / 180.0; /* 0.5 .. 89.5 degrees */
                double cos_i = cos(theta);
                fresnel_terms_t f = fresnel_dielectric_terms(side ? -cos_i : cos_i, 1.0, n_glass);
                assert_true(f.reflectance + f.transmittance == 1.0);
                double sin2_t = (n1 / n2) * (n1 / n2) * sin(theta) * sin(theta);
                if (sin2_t >= 1.0) {
                    assert_true(f.tir && f.reflectance == 1.0);
                    continue;
                }
                double cos_t = sqrt(1.0 - sin2_t);
                double ts = 2.0 * n1 * cos_i / (n1 * cos_i + n2 * cos_t);
                double tp = 2.0 * n1 * cos_i / (n2 * cos_i + n1 * cos_t);
                double t = (n2 * cos_t) / (n1 * cos_i) * 0.5 * (ts * ts + tp * tp);
                worst = fmax(worst, fabs(f.reflectance + t - 1.0));
            }
        }
    }
    assert_true(worst < 1e-12);
}

/* Deterministic unit vectors spread over the sphere (golden-angle spiral). */
static vec3_t spiral(int i, int n)
{
    double z = 1.0 - 2.0 * (i + 0.5) / n;
    double r = sqrt(fmax(0.0, 1.0 - z * z));
    double phi = i * PI * (3.0 - sqrt(5.0));
    return vec3_make(r * cos(phi), r * sin(phi), z);
}

/* Snell: n1 sin(theta_i) = n2 sin(theta_t) to 1e-12, refracted direction unit, coplanar with
 * d and n and on the far side; reflection keeps the angle; both for either normal
 * orientation and both index orders. */
static void test_directions(void **state)
{
    (void)state;
    vec3_t n = vec3_normalize(vec3_make(0.3, -0.2, 0.9));
    const int count = 2000;
    int refracted = 0, reflected = 0;
    for (int i = 0; i < count; i++) {
        vec3_t d = spiral(i, count);
        double cos_i = -vec3_dot(d, n);
        if (fabs(cos_i) < 1e-3)
            continue;
        vec3_t r = fresnel_reflect(d, n);
        testutil_assert_near(vec3_length(r), 1.0, 1e-12);
        testutil_assert_near(vec3_dot(r, n), cos_i, 1e-12);
        for (int order = 0; order < 2; order++) {
            double n1 = order ? 1.7847 : 1.0, n2 = order ? 1.0 : 1.7847;
            vec3_t t, t_flipped;
            bool ok = fresnel_refract(d, n, n1 / n2, &t);
            bool ok_flipped = fresnel_refract(d, vec3_neg(n), n1 / n2, &t_flipped);
            assert_true(ok == ok_flipped);
            double sin_i = vec3_length(vec3_cross(d, n));
            if (!ok) {
                assert_true(n1 * sin_i >= n2 * (1.0 - 1e-12));
                assert_true(vec3_length(t) == 0.0);
                reflected++;
                continue;
            }
            refracted++;
            testutil_assert_near(vec3_length(t), 1.0, 1e-12);
            testutil_assert_near(vec3_length(vec3_sub(t, t_flipped)), 0.0, 1e-15);
            double sin_t = vec3_length(vec3_cross(t, n));
            testutil_assert_near(n1 * sin_i, n2 * sin_t, 1e-12);
            testutil_assert_near(vec3_dot(t, vec3_cross(d, n)), 0.0, 1e-12);
            /* transmitted ray continues across the surface: same side as d */
            assert_true(vec3_dot(t, n) * vec3_dot(d, n) > 0.0);
        }
    }
    assert_true(refracted > 2000 && reflected > 300);
    vec3_t t;
    assert_false(fresnel_refract(vec3_make(0, 0, -1), vec3_make(0, 0, 1), NAN, &t));
    assert_false(fresnel_refract(vec3_make(0, 0, -1), vec3_make(0, 0, 1), 0.0, &t));
    /* Normal incidence goes straight through. */
    assert_true(fresnel_refract(vec3_make(0, 0, -1), vec3_make(0, 0, 1), 1.0 / 1.5, &t));
    testutil_assert_near(t.z, -1.0, 1e-15);
}

/* Deviation of a ray through a prism of apex angle A in the x-y plane, apex up, symmetric
 * about the y axis. Left face outward normal (-cos A/2, sin A/2), right (cos A/2, sin A/2).
 * The ray arrives at incidence angle theta on the left face from below the normal. */
static bool prism_deviation(double n, double apex, double theta, double *deviation, vec3_t *inside)
{
    vec3_t left = vec3_make(-cos(apex / 2), sin(apex / 2), 0.0);
    vec3_t right = vec3_make(cos(apex / 2), sin(apex / 2), 0.0);
    double base = atan2(-left.y, -left.x); /* direction of -left */
    vec3_t d = vec3_make(cos(base + theta), sin(base + theta), 0.0);
    vec3_t t1, t2;
    if (!fresnel_refract(d, left, 1.0 / n, &t1) || !fresnel_refract(t1, right, n, &t2))
        return false;
    *deviation = atan2(vec3_length(vec3_cross(d, t2)), vec3_dot(d, t2));
    if (inside)
        *inside = t1;
    return true;
}

/* Minimum deviation of a 60 degree N-BK7 prism, D = 2 asin(n sin(A/2)) - A (Hecht 5.2.1):
 * the symmetric ray (incidence asin(n sin(A/2))) runs parallel to the base inside and is
 * deviated by D to 1e-12; a golden-section search over the incidence angle finds the same
 * minimum (to 1e-12: D is flat there, so its value converges quadratically). Blue deviates
 * more than red. */
static void test_prism_minimum_deviation(void **state)
{
    (void)state;
    const double apex = PI / 3.0;
    double d_min[3];
    const double lambdas[3] = {IOR_LAMBDA_F_NM, IOR_LAMBDA_D_NM, IOR_LAMBDA_C_NM};
    for (int l = 0; l < 3; l++) {
        double n = nbk7(lambdas[l]);
        double expected = 2.0 * asin(n * sin(apex / 2)) - apex;
        double dev = NAN;
        vec3_t inside = {NAN, NAN, NAN};
        assert_true(prism_deviation(n, apex, asin(n * sin(apex / 2)), &dev, &inside));
        testutil_assert_near(dev, expected, 1e-12);
        testutil_assert_near(inside.y, 0.0, 1e-12);

        double lo = 35.0 * PI / 180.0, hi = 85.0 * PI / 180.0;
        const double g = (sqrt(5.0) - 1.0) / 2.0;
        double a = hi - g * (hi - lo), b = lo + g * (hi - lo), fa = NAN, fb = NAN;
        assert_true(prism_deviation(n, apex, a, &fa, NULL));
        assert_true(prism_deviation(n, apex, b, &fb, NULL));
        for (int it = 0; it < 100; it++) {
            if (fa < fb) {
                hi = b;
                b = a;
                fb = fa;
                a = hi - g * (hi - lo);
                assert_true(prism_deviation(n, apex, a, &fa, NULL));
            } else {
                lo = a;
                a = b;
                fa = fb;
                b = lo + g * (hi - lo);
                assert_true(prism_deviation(n, apex, b, &fb, NULL));
            }
        }
        testutil_assert_near(fmin(fa, fb), expected, 1e-12);
        d_min[l] = expected;
    }
    assert_true(d_min[0] > d_min[1] && d_min[1] > d_min[2]);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_normal_incidence),  cmocka_unit_test(test_brewster),
        cmocka_unit_test(test_critical_angle),    cmocka_unit_test(test_grazing),
        cmocka_unit_test(test_clamp_and_garbage), cmocka_unit_test(test_energy_sweep),
        cmocka_unit_test(test_directions),        cmocka_unit_test(test_prism_minimum_deviation),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
