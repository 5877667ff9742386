/* polar: Stokes vectors, Mueller matrices and the polarised Fresnel terms against optics, not
 * against the code: Malus's law, Brewster's angle, the Fresnel coefficients' angle forms,
 * total internal reflection's phase (and a Fresnel rhomb made of it), a conductor's closed
 * form, quarter and half wave plates. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h> /* after the four headers above, which it needs */

#include <complex.h>
#include <math.h>

#include "fresnel.h"
#include "numeric_testutil.h"
#include "polar_frame.h"
#include "polar_fresnel.h"
#include "stokes.h"

#define PI 3.14159265358979323846
#define DEG (PI / 180.0)

static void assert_finite_matrix(const mueller_t *m)
{
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            if (!isfinite(m->m[i][j]))
                fail_msg("Mueller element [%d][%d] = %g is not finite", i, j, m->m[i][j]);
}

/* Malus's law (Malus 1809; Hecht, Optics, eq. 8.6): unpolarised light of intensity I0 through
 * a polariser and then an analyser at theta to it leaves I0 / 2 cos^2 theta. The analyser is
 * built twice: in closed form and as the rotated horizontal polariser R(-theta) P R(theta). */
static void test_malus(void **state)
{
    (void)state;
    const double angles[] = {0.0, 30.0, 45.0, 60.0, 90.0};
    const double expect[] = {0.5, 0.375, 0.25, 0.125, 0.0};
    for (double base = -50.0; base <= 50.0; base += 25.0) {
        mueller_t p = mueller_polariser(base * DEG);
        stokes_t s = mueller_apply(&p, stokes_unpolarised(2.0));
        testutil_assert_near(s.s[0], 1.0, 1e-15);
        testutil_assert_near(stokes_dop(s), 1.0, 1e-12);
        for (size_t i = 0; i < sizeof angles / sizeof angles[0]; i++) {
            double th = (base + angles[i]) * DEG;
            mueller_t a = mueller_polariser(th);
            mueller_t r = mueller_rotator(th), rb = mueller_rotator(-th),
                      h = mueller_polariser(0.0);
            mueller_t t = mueller_mul(&h, &r), a2 = mueller_mul(&rb, &t);
            stokes_t o = mueller_apply(&a, s), o2 = mueller_apply(&a2, s);
            testutil_assert_near(o.s[0], 2.0 * expect[i], 1e-12);
            testutil_assert_near(o2.s[0], 2.0 * expect[i], 1e-12);
            for (int k = 0; k < 4; k++)
                for (int l = 0; l < 4; l++)
                    testutil_assert_near(a.m[k][l], a2.m[k][l], 1e-15);
        }
    }
}

/* Wave plates: a quarter-wave plate with its fast axis horizontal turns light polarised at 45
 * degrees into circular light, S3 = S0 (and -45 degrees into the other hand, S3 = -S0); one at
 * 45 degrees leaves 45-degree light alone; a half-wave plate mirrors the polarisation about its
 * axis (45 -> -45 degrees, 30 -> -30); two quarter-wave plates make a half-wave plate. */
static void test_wave_plates(void **state)
{
    (void)state;
    mueller_t q = mueller_retarder(0.0, PI / 2.0);
    stokes_t c = mueller_apply(&q, stokes_linear(1.0, 45.0 * DEG));
    testutil_assert_near(c.s[3], c.s[0], 1e-15);
    testutil_assert_near(c.s[1], 0.0, 1e-15);
    testutil_assert_near(c.s[2], 0.0, 1e-15);
    c = mueller_apply(&q, stokes_linear(1.0, -45.0 * DEG));
    testutil_assert_near(c.s[3], -c.s[0], 1e-15);
    mueller_t q45 = mueller_retarder(45.0 * DEG, PI / 2.0);
    stokes_t l = mueller_apply(&q45, stokes_linear(1.0, 45.0 * DEG));
    testutil_assert_near(l.s[2], 1.0, 1e-15);
    testutil_assert_near(l.s[3], 0.0, 1e-15);
    mueller_t hw = mueller_retarder(0.0, PI), qq = mueller_mul(&q, &q);
    for (int k = 0; k < 4; k++)
        for (int m = 0; m < 4; m++)
            testutil_assert_near(hw.m[k][m], qq.m[k][m], 1e-15);
    for (double th = -80.0; th <= 80.0; th += 10.0) {
        stokes_t o = mueller_apply(&hw, stokes_linear(1.0, th * DEG));
        testutil_assert_near(stokes_aop(o), -th * DEG, 1e-12);
        testutil_assert_near(stokes_dop(o), 1.0, 1e-12);
    }
    /* A retarder at any angle conserves intensity and degree of polarisation. */
    for (double th = 0.0; th < 180.0; th += 17.0)
        for (double d = 0.0; d < 2.0 * PI; d += 0.7) {
            mueller_t r = mueller_retarder(th * DEG, d);
            stokes_t o = mueller_apply(&r, stokes_make(1.0, 0.3, -0.5, 0.6));
            testutil_assert_near(o.s[0], 1.0, 1e-15);
            testutil_assert_near(o.s[1] * o.s[1] + o.s[2] * o.s[2] + o.s[3] * o.s[3], 0.7, 1e-14);
        }
}

/* Brewster's angle atan(n2 / n1) (Brewster 1815; Born & Wolf §1.5.3): r_p = 0, so unpolarised
 * light reflects fully s-polarised (S1 = S0 in the s-p frame, degree of polarisation 1), from
 * outside and from inside. */
static void test_brewster(void **state)
{
    (void)state;
    const double pairs[][2] = {{1.0, 1.333},  {1.0, 1.5}, {1.0, 1.7},
                               {1.0, 2.4175}, {1.5, 1.0}, {1.333, 1.5168}};
    for (size_t i = 0; i < sizeof pairs / sizeof pairs[0]; i++) {
        double n1 = pairs[i][0], n2 = pairs[i][1], tb = atan(n2 / n1);
        polar_fresnel_t f = polar_fresnel_eval(cos(tb), n1, n2);
        mueller_t m = polar_fresnel_reflection(&f);
        stokes_t s = mueller_apply(&m, stokes_unpolarised(1.0));
        testutil_assert_near(stokes_dop(s), 1.0, 1e-3);
        testutil_assert_near(stokes_dop(s), 1.0, 1e-9);
        testutil_assert_near(s.s[1], s.s[0], 1e-12);
        testutil_assert_near(f.Rp, 0.0, 1e-20);
        /* r_s there is (1 - m^2) / (1 + m^2) in magnitude, m = n2 / n1. */
        double mm = n2 / n1, rs = (1.0 - mm * mm) / (1.0 + mm * mm);
        testutil_assert_near(f.Rs, rs * rs, 1e-14);
    }
}

/* The Fresnel coefficients against their angle forms (Born & Wolf §1.5.2 eq. 21, 35, which the
 * code never evaluates: they are 0/0 at normal incidence), over angles from 0.5 to 89.5
 * degrees and several index pairs below the critical angle:
 *   r_s = -sin(ti - tt) / sin(ti + tt),  r_p = tan(ti - tt) / tan(ti + tt),
 *   T_s = sin 2ti sin 2tt / sin^2(ti + tt),  T_p = T_s / cos^2(ti - tt).
 * Reflection's Mueller matrix has M00 = (R_s + R_p)/2, M01 = (R_s - R_p)/2, M22 = M33 = r_s r_p;
 * transmission's M00 = (T_s + T_p)/2, M22 = sqrt(T_s T_p); M00 is also optics/fresnel.h's
 * unpolarised reflectance, which the renderer uses. */
static void test_fresnel_angle_forms(void **state)
{
    (void)state;
    const double pairs[][2] = {{1.0, 1.2},    {1.0, 1.5},      {1.0, 2.4175}, {1.5, 1.0},
                               {2.4175, 1.0}, {1.333, 1.5168}, {1.0, 1.0001}};
    int checked = 0;
    for (size_t i = 0; i < sizeof pairs / sizeof pairs[0]; i++) {
        double n1 = pairs[i][0], n2 = pairs[i][1];
        for (double deg = 0.5; deg < 90.0; deg += 0.5) {
            double ti = deg * DEG, st = n1 / n2 * sin(ti);
            if (st >= 1.0 - 1e-9)
                continue;
            double tt = asin(st);
            if (fabs(ti - tt) < 1e-6)
                continue; /* almost equal indices: the angle forms are 0/0 */
            double rs = -sin(ti - tt) / sin(ti + tt), rp = tan(ti - tt) / tan(ti + tt);
            double Ts = sin(2.0 * ti) * sin(2.0 * tt) / (sin(ti + tt) * sin(ti + tt));
            double Tp = Ts / (cos(ti - tt) * cos(ti - tt));
            polar_fresnel_t f = polar_fresnel_eval(cos(ti), n1, n2);
            testutil_assert_near(creal(f.rs), rs, 1e-12);
            testutil_assert_near(creal(f.rp), rp, 1e-12);
            testutil_assert_near(cimag(f.rs), 0.0, 1e-15);
            testutil_assert_near(f.Ts, Ts, 1e-12);
            testutil_assert_near(f.Tp, Tp, 1e-12);
            testutil_assert_near(f.Rs + f.Ts, 1.0, 1e-13);
            testutil_assert_near(f.Rp + f.Tp, 1.0, 1e-13);
            mueller_t r = polar_fresnel_reflection(&f), t = polar_fresnel_transmission(&f);
            assert_finite_matrix(&r);
            testutil_assert_near(r.m[0][0], 0.5 * (rs * rs + rp * rp), 1e-12);
            testutil_assert_near(r.m[0][1], 0.5 * (rs * rs - rp * rp), 1e-12);
            testutil_assert_near(r.m[2][2], rs * rp, 1e-12);
            testutil_assert_near(r.m[3][3], rs * rp, 1e-12);
            testutil_assert_near(r.m[2][3], 0.0, 1e-15);
            testutil_assert_near(t.m[0][0], 0.5 * (Ts + Tp), 1e-12);
            testutil_assert_near(t.m[2][2], sqrt(Ts * Tp), 1e-12);
            testutil_assert_near(r.m[0][0] + t.m[0][0], 1.0, 1e-13);
            testutil_assert_near(r.m[0][0], fresnel_dielectric(cos(ti), n1, n2), 1e-13);
            /* From the other side of the same interface, through optics' sign convention. */
            polar_fresnel_t g = polar_fresnel_dielectric(-cos(ti), n2, n1);
            testutil_assert_near(g.Rs, f.Rs, 1e-15);
            checked++;
        }
    }
    assert_true(checked > 900);
}

/* Total internal reflection (Born & Wolf §1.5.4): beyond the critical angle asin(n) (n =
 * n2 / n1 < 1) both polarisations reflect wholly, R_s = R_p = 1, T = 0, with a phase difference
 * delta between them, tan(delta / 2) = cos ti sqrt(sin^2 ti - n^2) / sin^2 ti (eq. 60): the
 * Mueller matrix is a retarder, M22 = M33 = cos delta, |M23| = |M32| = sin delta. A Fresnel rhomb
 * (Fresnel 1823; Hecht §8.11.3) of glass of index 1.51 reflects twice at 54.6 degrees, each
 * reflection retarding by 45 degrees: 45-degree linear light leaves it circular. */
static void test_total_internal_reflection(void **state)
{
    (void)state;
    const double n1s[] = {1.33, 1.5, 1.51, 2.4175};
    for (size_t i = 0; i < sizeof n1s / sizeof n1s[0]; i++) {
        double n = 1.0 / n1s[i], tc = asin(n);
        for (double ti = tc + 1e-4; ti < PI / 2.0; ti += 0.01) {
            polar_fresnel_t f = polar_fresnel_eval(cos(ti), n1s[i], 1.0);
            assert_true(f.tir);
            mueller_t r = polar_fresnel_reflection(&f), t = polar_fresnel_transmission(&f);
            assert_finite_matrix(&r);
            assert_finite_matrix(&t);
            testutil_assert_near(r.m[0][0], 1.0, 1e-12);
            testutil_assert_near(r.m[0][1], 0.0, 1e-12);
            testutil_assert_near(t.m[0][0], 0.0, 0.0);
            double s2 = sin(ti) * sin(ti);
            double delta = 2.0 * atan(cos(ti) * sqrt(s2 - n * n) / s2);
            testutil_assert_near(r.m[2][2], cos(delta), 1e-12);
            testutil_assert_near(r.m[3][3], cos(delta), 1e-12);
            testutil_assert_near(fabs(r.m[3][2]), sin(delta), 1e-12);
            testutil_assert_near(r.m[2][3], -r.m[3][2], 1e-15);
        }
    }
    /* The rhomb: the closed form puts a 45-degree retardance near 54.6 degrees for n = 1.51. */
    double ti = 54.6 * DEG, n = 1.0 / 1.51, s2 = sin(ti) * sin(ti);
    double delta = 2.0 * atan(cos(ti) * sqrt(s2 - n * n) / s2);
    testutil_assert_near(delta / DEG, 45.0, 0.1);
    polar_fresnel_t f = polar_fresnel_eval(cos(ti), 1.51, 1.0);
    mueller_t r = polar_fresnel_reflection(&f), rr = mueller_mul(&r, &r);
    stokes_t o = mueller_apply(&rr, stokes_linear(1.0, 45.0 * DEG));
    testutil_assert_near(o.s[0], 1.0, 1e-12);
    testutil_assert_near(fabs(o.s[3]), 1.0, 1e-5);
}

/* A conductor eta + i k against the closed form of Born & Wolf §14.2 (as pbrt-v3's FrConductor
 * writes it): with 2a^2 = sqrt((eta^2 - k^2 - sin^2)^2 + 4 eta^2 k^2) + eta^2 - k^2 - sin^2 and
 * 2b^2 the same with the last three terms negated,
 *   R_s = ((a - cos)^2 + b^2) / ((a + cos)^2 + b^2),
 *   R_p = R_s ((a - sin tan)^2 + b^2) / ((a + sin tan)^2 + b^2);
 * at normal incidence R = ((eta - 1)^2 + k^2) / ((eta + 1)^2 + k^2). M00 is also optics'
 * fresnel_conductor. */
static void test_conductor(void **state)
{
    (void)state;
    /* Silver, gold, aluminium, copper near 550 nm (Johnson & Christy 1972; Rakic 1995), chromium.
     */
    const double metals[][2] = {
        {0.059, 3.33}, {0.43, 2.45}, {0.96, 6.69}, {1.03, 2.58}, {3.18, 3.31}};
    for (size_t i = 0; i < sizeof metals / sizeof metals[0]; i++) {
        double eta = metals[i][0], k = metals[i][1];
        for (double deg = 0.0; deg < 90.0; deg += 0.5) {
            double ti = deg * DEG, c = cos(ti), s = sin(ti);
            double t0 = eta * eta - k * k - s * s, root = sqrt(t0 * t0 + 4.0 * eta * eta * k * k);
            double a = sqrt(0.5 * (root + t0)), b2 = 0.5 * (root - t0);
            double Rs = ((a - c) * (a - c) + b2) / ((a + c) * (a + c) + b2);
            double st = s * tan(ti);
            double Rp = Rs * ((a - st) * (a - st) + b2) / ((a + st) * (a + st) + b2);
            polar_fresnel_t f = polar_fresnel_conductor(c, eta, k);
            testutil_assert_near(f.Rs, Rs, 1e-12);
            testutil_assert_near(f.Rp, Rp, 1e-12);
            mueller_t m = polar_fresnel_reflection(&f);
            assert_finite_matrix(&m);
            testutil_assert_near(m.m[0][0], fresnel_conductor(c, eta, k), 1e-13);
            /* A non-depolarising element: M22^2 + M23^2 = R_s R_p. */
            testutil_assert_near(m.m[2][2] * m.m[2][2] + m.m[2][3] * m.m[2][3], Rs * Rp, 1e-12);
            if (deg == 0.0)
                testutil_assert_near(
                    f.Rs, ((eta - 1) * (eta - 1) + k * k) / ((eta + 1) * (eta + 1) + k * k), 1e-14);
        }
    }
}

/* Degenerate incidence: grazing (cos down to 0 and subnormals), exactly the critical angle,
 * normal incidence, absurd index ratios, non-finite indices: every coefficient and matrix
 * element finite, R in [0, 1]. */
static void test_degenerate(void **state)
{
    (void)state;
    const double coss[] = {0.0, 4.9e-324, 1e-300, 1e-6, 0.5, 1.0};
    const double ns[][2] = {{1.0, 1.5},   {1.5, 1.0}, {1.0, 1e300},
                            {1e300, 1.0}, {1.0, 1.0}, {1.0, 1e-300}};
    for (size_t i = 0; i < sizeof coss / sizeof coss[0]; i++)
        for (size_t j = 0; j < sizeof ns / sizeof ns[0]; j++) {
            polar_fresnel_t f = polar_fresnel_eval(coss[i], ns[j][0], ns[j][1]);
            mueller_t r = polar_fresnel_reflection(&f), t = polar_fresnel_transmission(&f);
            assert_finite_matrix(&r);
            assert_finite_matrix(&t);
            assert_true(f.Rs >= 0.0 && f.Rs <= 1.0 && f.Rp >= 0.0 && f.Rp <= 1.0);
            assert_true(r.m[0][0] + t.m[0][0] <= 1.0 + 1e-12);
            polar_fresnel_t g = polar_fresnel_conductor(coss[i], ns[j][1], 3.0);
            mueller_t m = polar_fresnel_reflection(&g);
            assert_finite_matrix(&m);
        }
    /* Exactly at the critical angle: R = 1. */
    double tc = asin(1.0 / 1.5);
    polar_fresnel_t f = polar_fresnel_eval(cos(tc), 1.5, 1.0);
    testutil_assert_near(f.Rs, 1.0, 1e-6);
    testutil_assert_near(f.Rp, 1.0, 1e-6);
    /* Grazing: R -> 1. */
    f = polar_fresnel_eval(0.0, 1.0, 1.5);
    testutil_assert_near(0.5 * (f.Rs + f.Rp), 1.0, 1e-15);
    polar_fresnel_t nan_ = polar_fresnel_eval(0.5, NAN, 1.5);
    testutil_assert_near(nan_.Rs, 1.0, 0.0);
}

/* The angle of unit vector a about k measured from x (toward k x x), from the geometry alone. */
static double angle_about(vec3_t x, vec3_t a, vec3_t k)
{
    return atan2(vec3_dot(vec3_cross(x, a), k), vec3_dot(x, a));
}

/* Reference frames (polar/polar_frame.h): light linearly polarised along a world direction a
 * keeps that direction whatever frame measures it -- stokes_linear at a's angle in one frame,
 * re-expressed in another, is stokes_linear at a's angle there -- for propagation directions
 * all over the sphere; a frame made perpendicular is unit and perpendicular; an interface's
 * s is perpendicular to the plane of incidence, and a polariser sheet passes
 * cos^2 of the angle between its axis and the light's. */
static void test_frames(void **state)
{
    (void)state;
    for (int i = 0; i < 200; i++) {
        const double th = acos(1.0 - 2.0 * (i + 0.5) / 200.0), ph = 2.399963 * i;
        const vec3_t k = vec3_make(sin(th) * cos(ph), sin(th) * sin(ph), cos(th));
        const vec3_t x1 = polar_frame_perp(vec3_make(1, 0.3, -0.2), k),
                     x2 = polar_frame_perp(vec3_make(-0.4, 1, 0.7), k),
                     a = polar_frame_perp(vec3_make(0.2, -0.5, 1), k);
        assert_true(fabs(vec3_length(x1) - 1.0) < 1e-12 && fabs(vec3_dot(x1, k)) < 1e-12);
        const stokes_t s1 = stokes_linear(1.0, angle_about(x1, a, k));
        const mueller_t r = polar_frame_change(x1, x2, k);
        const stokes_t s2 = mueller_apply(&r, s1), want = stokes_linear(1.0, angle_about(x2, a, k));
        for (int c = 0; c < 4; c++)
            assert_true(fabs(s2.s[c] - want.s[c]) < 1e-12);
        /* Through a polariser sheet whose axis is at 35 degrees from a, in the carrier's frame
         * x1 (T = R P, normalised: M[0][0] = 1) the light along a is recorded as cos^2(35 deg). */
        const vec3_t axis =
            vec3_add(vec3_scale(a, cos(35 * DEG)), vec3_scale(vec3_cross(k, a), sin(35 * DEG)));
        mueller_t t = mueller_identity();
        vec3_t x = x1;
        const polar_event_t ev = polar_event_sheet(k, axis);
        const mueller_t p = mueller_polariser(0.0);
        polar_carrier_apply(&t, 1, &x, &ev, &p, 0);
        const stokes_t in = stokes_linear(1.0, angle_about(x, a, k)), out = mueller_apply(&t, in);
        assert_true(fabs(out.s[0] - pow(cos(35 * DEG), 2.0)) < 1e-12);
        /* An interface: s perpendicular to k_in and the normal. */
        const vec3_t n = vec3_normalize(vec3_make(0.3, 0.1, 1.0));
        const vec3_t kr = vec3_sub(k, vec3_scale(n, 2.0 * vec3_dot(k, n)));
        const polar_event_t e = polar_event_interface(k, kr, n, x1);
        assert_true(fabs(vec3_dot(e.x_in, n)) < 1e-9 && fabs(vec3_dot(e.x_in, k)) < 1e-9);
        assert_true(fabs(vec3_dot(e.x_out, kr)) < 1e-9);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_malus),
        cmocka_unit_test(test_wave_plates),
        cmocka_unit_test(test_brewster),
        cmocka_unit_test(test_fresnel_angle_forms),
        cmocka_unit_test(test_total_internal_reflection),
        cmocka_unit_test(test_conductor),
        cmocka_unit_test(test_degenerate),
        cmocka_unit_test(test_frames),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
