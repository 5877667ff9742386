/* delta: the smooth interfaces as delta lobes (bsdf/delta.h) against optics: Snell's direction,
 * the normal-incidence and total reflection terms, the transport modes (radiance takes
 * (n_i / n_t)^2, flux T alone, a branch chosen in proportion weighs exactly 1), the hero's lane
 * weights and a conductor mirror. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h> /* after the four headers above, which it needs */

#include <math.h>

#include "delta.h"
#include "numeric_testutil.h"

#define PI 3.14159265358979323846

/* Normal incidence on glass of index 1.5 from outside: R = 0.04 (Hecht eq. 4.47), the ray goes
 * straight on; radiance mode weighs the refraction (1 - R) / n^2, importance (1 - R). Leaving
 * the glass the factor is n^2, so in and out the camera path's weight is T^2 (a slab's
 * single-pass transmittance), whatever n. */
static void test_modes(void **state)
{
    (void)state;
    const double n = 1.5;
    const vec3_t down = vec3_make(0.0, 0.0, -1.0), up = vec3_make(0.0, 0.0, 1.0);
    delta_dielectric_t in, out, imp;
    delta_dielectric_make(down, up, true, &n, 1, BSDF_RADIANCE, &in);
    delta_dielectric_make(down, up, true, &n, 1, BSDF_IMPORTANCE, &imp);
    testutil_assert_near(in.prob_reflect, 0.04, 1e-15);
    assert_true(in.refracts);
    testutil_assert_near(in.refract.z, -1.0, 1e-15);
    testutil_assert_near(in.reflect.z, 1.0, 1e-15);
    testutil_assert_near(delta_dielectric_weight(&in, false, 1.0), 0.96 / 2.25, 1e-15);
    testutil_assert_near(delta_dielectric_weight(&imp, false, 1.0), 0.96, 1e-15);
    testutil_assert_near(delta_dielectric_weight(&imp, true, 1.0), 0.04, 1e-15);
    delta_dielectric_make(down, up, false, &n, 1, BSDF_RADIANCE, &out);
    testutil_assert_near(delta_dielectric_weight(&in, false, 1.0) *
                             delta_dielectric_weight(&out, false, 1.0),
                         0.96 * 0.96, 1e-14);
    /* Chosen in proportion: flux keeps its power exactly, radiance gains only (n_i/n_t)^2. */
    bool reflect;
    vec3_t dir;
    for (double u = 0.0; u < 1.0; u += 0.01) {
        assert_true(delta_dielectric_choose(&imp, u, &reflect, &dir) == 1.0);
        assert_int_equal(reflect, u < imp.prob_reflect);
        double w = delta_dielectric_choose(&in, u, &reflect, &dir);
        testutil_assert_near(w, reflect ? 1.0 : 1.0 / 2.25, 1e-15);
    }
}

/* Snell's law at 40 degrees from outside and total internal reflection from inside beyond the
 * critical angle asin(1/n): probability of reflection 1, no refracted direction. */
static void test_snell_tir(void **state)
{
    (void)state;
    const double n = 1.5, th = 40.0 * PI / 180.0;
    const vec3_t nrm = vec3_make(0.0, 0.0, 1.0);
    delta_dielectric_t e;
    delta_dielectric_make(vec3_make(sin(th), 0.0, -cos(th)), nrm, true, &n, 1, BSDF_RADIANCE, &e);
    testutil_assert_near(e.refract.x, sin(th) / n, 1e-15);
    testutil_assert_near(delta_dielectric_weight(&e, true, 1.0) +
                             delta_dielectric_weight(&e, false, 1.0) * n * n,
                         1.0, 1e-15);
    const double tc = asin(1.0 / n);
    for (double a = tc + 1e-6; a < PI / 2.0; a += 0.05) {
        delta_dielectric_make(vec3_make(sin(a), 0.0, cos(a)), nrm, false, &n, 1, BSDF_RADIANCE, &e);
        assert_false(e.refracts);
        assert_true(e.prob_reflect == 1.0);
        assert_true(delta_dielectric_weight(&e, false, 1.0) == 0.0);
    }
}

/* Hero lanes: reflection keeps every lane, each weighed by its own R over the hero's. */
static void test_hero_lanes(void **state)
{
    (void)state;
    const double ns[4] = {1.52, 1.53, 1.55, 1.60}, th = 70.0 * PI / 180.0;
    delta_dielectric_t e;
    delta_dielectric_make(vec3_make(sin(th), 0.0, -cos(th)), vec3_make(0.0, 0.0, 1.0), true, ns, 4,
                          BSDF_RADIANCE, &e);
    for (int j = 0; j < 4; j++) {
        double cs = cos(th), st = sin(th) / ns[j], ct = sqrt(1.0 - st * st);
        double rs = (cs - ns[j] * ct) / (cs + ns[j] * ct),
               rp = (ns[j] * cs - ct) / (ns[j] * cs + ct);
        double R = 0.5 * (rs * rs + rp * rp);
        testutil_assert_near(delta_dielectric_reflect_lane(&e, j, false), R, 1e-14);
        testutil_assert_near(delta_dielectric_reflect_lane(&e, j, true), R / e.prob_reflect, 1e-13);
    }
    assert_true(delta_dielectric_reflect_lane(&e, 0, true) == 1.0);
}

/* A conductor mirror: the mirror direction from either side of the normal, R = 1 for a perfect
 * mirror and ((eta-1)^2 + k^2) / ((eta+1)^2 + k^2) at normal incidence. */
static void test_conductor(void **state)
{
    (void)state;
    const vec3_t d = vec3_normalize(vec3_make(1.0, 0.0, -1.0));
    delta_conductor_t a = delta_conductor_make(d, vec3_make(0.0, 0.0, 1.0));
    delta_conductor_t b = delta_conductor_make(d, vec3_make(0.0, 0.0, -1.0));
    testutil_assert_near(a.reflect.z, -d.z, 1e-15);
    testutil_assert_near(b.reflect.z, -d.z, 1e-15);
    testutil_assert_near(a.cos_i, sqrt(0.5), 1e-15);
    testutil_assert_near(delta_conductor_weight(&a, 0.0, 1.0), 1.0, 0.0);
    delta_conductor_t nrm =
        delta_conductor_make(vec3_make(0.0, 0.0, -1.0), vec3_make(0.0, 0.0, 1.0));
    testutil_assert_near(delta_conductor_weight(&nrm, 0.43, 2.45),
                         (0.57 * 0.57 + 2.45 * 2.45) / (1.43 * 1.43 + 2.45 * 2.45), 1e-14);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_modes),
        cmocka_unit_test(test_snell_tir),
        cmocka_unit_test(test_hero_lanes),
        cmocka_unit_test(test_conductor),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
