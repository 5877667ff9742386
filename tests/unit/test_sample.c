/* sample: every sampler checked by Monte-Carlo integration against integrals known in closed
 * form, with the pdf the module reports, plus edge inputs that must not produce NaN.
 *
 * Tolerances: each estimate is a mean of N i.i.d. terms, so it is accepted within 5 standard
 * errors, the standard error being the sample standard deviation over sqrt(N) (a false
 * failure has probability < 1e-6, and the seeds are fixed, so the outcome is deterministic).
 * Each check also requires the standard error to be small (under 1 % of the expected value),
 * so a passing test cannot come from an estimate too noisy to tell right from wrong. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <math.h>
#include <stdio.h>

#include "rng.h"
#include "sample.h"

#define PI 3.14159265358979323846
enum { N = 200000 };

/* Welford's running mean and variance. */
typedef struct mc {
    double n, mean, m2;
} mc_t;

static void mc_add(mc_t *m, double x)
{
    m->n += 1.0;
    double d = x - m->mean;
    m->mean += d / m->n;
    m->m2 += d * (x - m->mean);
}

static double mc_stderr(const mc_t *m)
{
    return sqrt(m->m2 / (m->n - 1.0) / m->n);
}

static void mc_check(const mc_t *m, double expected, const char *what)
{
    double se = mc_stderr(m);
    print_message("%-36s %.6f vs %.6f (se %.1e, %.1f se)\n", what, m->mean, expected, se,
                  se > 0 ? fabs(m->mean - expected) / se : 0.0);
    assert_true(se < 0.01 * fabs(expected) || (expected == 0.0 && se < 0.01));
    /* a constant estimator (se = 0) must hit the value to rounding */
    assert_true(fabs(m->mean - expected) <= 5.0 * se + 1e-12 * fabs(expected));
}

static void uv(uint64_t seed, uint64_t i, double *u1, double *u2)
{
    *u1 = rng_uniform(seed, i, 0, 0);
    *u2 = rng_uniform(seed, i, 0, 1);
}

static void assert_unit(vec3_t d)
{
    assert_true(fabs(vec3_length(d) - 1.0) < 1e-12);
}

/* Cosine hemisphere. Over the hemisphere H: int cos dw = pi; int cos^3 dw = 2 pi / 4 = pi / 2;
 * int x^2 dw = int sin^3 cos^2(phi) = pi * 2/3. The pdf must integrate to 1 over the sphere,
 * estimated with uniform-sphere directions: E[pdf(w) / (1 / 4 pi)] = 1. */
static void test_cosine_hemisphere(void **state)
{
    (void)state;
    mc_t c1 = {0}, c3 = {0}, x2 = {0}, norm = {0};
    for (uint64_t i = 0; i < N; i++) {
        double u1, u2;
        uv(11, i, &u1, &u2);
        vec3_t w = sample_cosine_hemisphere(u1, u2);
        assert_unit(w);
        assert_true(w.z >= 0.0);
        double pdf = sample_cosine_hemisphere_pdf(w.z);
        if (pdf > 0.0) { /* z = 0 exactly has probability ~0 and contributes 0 */
            mc_add(&c1, w.z / pdf);
            mc_add(&c3, w.z * w.z * w.z / pdf);
            mc_add(&x2, w.x * w.x / pdf);
        }
        vec3_t s = sample_uniform_sphere(u1, u2);
        mc_add(&norm, sample_cosine_hemisphere_pdf(s.z) / sample_uniform_sphere_pdf());
    }
    mc_check(&c1, PI, "cosine: int cos dw = pi");
    mc_check(&c3, PI / 2.0, "cosine: int cos^3 dw = pi/2");
    mc_check(&x2, 2.0 * PI / 3.0, "cosine: int x^2 dw = 2pi/3");
    mc_check(&norm, 1.0, "cosine: int pdf dw = 1");
}

static void test_uniform_hemisphere(void **state)
{
    (void)state;
    mc_t c1 = {0}, c3 = {0}, norm = {0};
    for (uint64_t i = 0; i < N; i++) {
        double u1, u2;
        uv(12, i, &u1, &u2);
        vec3_t w = sample_uniform_hemisphere(u1, u2);
        assert_unit(w);
        assert_true(w.z >= 0.0);
        double pdf = sample_uniform_hemisphere_pdf();
        mc_add(&c1, w.z / pdf);
        mc_add(&c3, w.z * w.z * w.z / pdf);
        vec3_t s = sample_uniform_sphere(u1, u2);
        mc_add(&norm, (s.z >= 0.0 ? pdf : 0.0) / sample_uniform_sphere_pdf());
    }
    mc_check(&c1, PI, "hemisphere: int cos dw = pi");
    mc_check(&c3, PI / 2.0, "hemisphere: int cos^3 dw = pi/2");
    mc_check(&norm, 1.0, "hemisphere: int pdf dw = 1");
}

/* Uniform sphere: int 1 dw = 4 pi; int max(cos, 0) dw = pi; int z^2 dw = 4 pi / 3; the mean
 * direction is 0; the octant x, y, z > 0 holds 1/8 of the directions. */
static void test_uniform_sphere(void **state)
{
    (void)state;
    mc_t one = {0}, cpos = {0}, z2 = {0}, mx = {0}, my = {0}, mz = {0}, oct = {0};
    for (uint64_t i = 0; i < N; i++) {
        double u1, u2;
        uv(13, i, &u1, &u2);
        vec3_t w = sample_uniform_sphere(u1, u2);
        assert_unit(w);
        double pdf = sample_uniform_sphere_pdf();
        mc_add(&one, 1.0 / pdf);
        mc_add(&cpos, fmax(w.z, 0.0) / pdf);
        mc_add(&z2, w.z * w.z / pdf);
        mc_add(&mx, w.x);
        mc_add(&my, w.y);
        mc_add(&mz, w.z);
        mc_add(&oct, w.x > 0 && w.y > 0 && w.z > 0);
    }
    mc_check(&one, 4.0 * PI, "sphere: int 1 dw = 4pi");
    mc_check(&cpos, PI, "sphere: int max(cos,0) dw = pi");
    mc_check(&z2, 4.0 * PI / 3.0, "sphere: int z^2 dw = 4pi/3");
    mc_check(&mx, 0.0, "sphere: mean x = 0");
    mc_check(&my, 0.0, "sphere: mean y = 0");
    mc_check(&mz, 0.0, "sphere: mean z = 0");
    mc_check(&oct, 0.125, "sphere: octant fraction = 1/8");
}

/* Cone of half-angle 30 degrees: int_cone cos dw = pi sin^2(theta_max) = pi / 4, every sample
 * inside the cone, and the pdf integrates to 1 over the sphere. cos_theta_max = -1 is the
 * whole sphere (pdf 1 / 4 pi) and 0 the hemisphere; 1 is the documented delta case. */
static void test_uniform_cone(void **state)
{
    (void)state;
    const double cmax = sqrt(3.0) / 2.0;
    mc_t c1 = {0}, norm = {0};
    for (uint64_t i = 0; i < N; i++) {
        double u1, u2;
        uv(14, i, &u1, &u2);
        vec3_t w = sample_uniform_cone(u1, u2, cmax);
        assert_unit(w);
        assert_true(w.z >= cmax - 1e-15);
        double pdf = sample_uniform_cone_pdf(cmax);
        mc_add(&c1, w.z / pdf);
        vec3_t s = sample_uniform_sphere(u1, u2);
        mc_add(&norm, (s.z >= cmax ? pdf : 0.0) / sample_uniform_sphere_pdf());
    }
    mc_check(&c1, PI / 4.0, "cone 30deg: int cos dw = pi/4");
    mc_check(&norm, 1.0, "cone 30deg: int pdf dw = 1");
    assert_true(fabs(sample_uniform_cone_pdf(-1.0) - 1.0 / (4.0 * PI)) < 1e-15);
    assert_true(fabs(sample_uniform_cone_pdf(0.0) - 1.0 / (2.0 * PI)) < 1e-15);
    assert_true(sample_uniform_cone_pdf(1.0) == 0.0);
    assert_true(sample_uniform_cone_pdf(2.0) == 0.0); /* clamped to 1 */
    vec3_t d = sample_uniform_cone(0.3, 0.7, 1.0);
    assert_true(d.x == 0.0 && d.y == 0.0 && d.z == 1.0);
}

/* Disk of radius r = 2.5 (scaled unit samples, pdf 1 / (pi r^2)): int x^2 dA = pi r^4 / 4;
 * the quadrant x, y > 0 has area pi r^2 / 4; the inner disk of radius r / 2 holds 1/4 of the
 * points; the mean point is the centre; no point lies outside. */
static void test_concentric_disk(void **state)
{
    (void)state;
    const double r = 2.5;
    const double pdf = 1.0 / (PI * r * r);
    mc_t x2 = {0}, quad = {0}, inner = {0}, mx = {0}, my = {0};
    for (uint64_t i = 0; i < N; i++) {
        double u1, u2;
        uv(15, i, &u1, &u2);
        vec3_t p = vec3_scale(sample_concentric_disk(u1, u2), r);
        assert_true(p.z == 0.0);
        assert_true(p.x * p.x + p.y * p.y <= r * r * (1.0 + 1e-15));
        mc_add(&x2, p.x * p.x / pdf);
        mc_add(&quad, (p.x > 0 && p.y > 0) / pdf);
        mc_add(&inner, p.x * p.x + p.y * p.y < r * r / 4.0);
        mc_add(&mx, p.x);
        mc_add(&my, p.y);
    }
    mc_check(&x2, PI * r * r * r * r / 4.0, "disk: int x^2 dA = pi r^4/4");
    mc_check(&quad, PI * r * r / 4.0, "disk: quadrant area = pi r^2/4");
    mc_check(&inner, 0.25, "disk: fraction within r/2 = 1/4");
    mc_check(&mx, 0.0, "disk: mean x = 0");
    mc_check(&my, 0.0, "disk: mean y = 0");
}

/* A tilted triangle in 3-D. Its area comes from Heron's formula on the side lengths
 * (independent of the cross product the module uses); the mean point is the centroid
 * (p0 + p1 + p2) / 3; the second moment E[x^2] = (x0^2 + x1^2 + x2^2 + x0 x1 + x0 x2 + x1 x2)
 * / 6; the corner triangle b0 > 1/2 is a half-scale copy holding 1/4 of the points; and
 * int 1 dA = area through the reported pdf. */
static void test_uniform_triangle(void **state)
{
    (void)state;
    const vec3_t p0 = {1.0, 2.0, 3.0}, p1 = {4.0, -1.0, 2.5}, p2 = {-2.0, 0.5, 6.0};
    double a = vec3_length(vec3_sub(p1, p0)), b = vec3_length(vec3_sub(p2, p1)),
           c = vec3_length(vec3_sub(p0, p2));
    double s = 0.5 * (a + b + c);
    double area = sqrt(s * (s - a) * (s - b) * (s - c));
    double pdf = sample_triangle_pdf(p0, p1, p2);
    assert_true(fabs(pdf * area - 1.0) < 1e-12);
    /* the 3-4-5 right triangle has area 6 */
    assert_true(
        fabs(sample_triangle_pdf(vec3_make(0, 0, 0), vec3_make(3, 0, 0), vec3_make(0, 4, 0)) -
             1.0 / 6.0) < 1e-15);
    assert_true(sample_triangle_pdf(p0, p1, vec3_add(p0, vec3_scale(vec3_sub(p1, p0), 2.0))) ==
                0.0);

    mc_t one = {0}, mx = {0}, my = {0}, mz = {0}, x2 = {0}, corner[3] = {{0}};
    for (uint64_t i = 0; i < N; i++) {
        double u1, u2;
        uv(16, i, &u1, &u2);
        sample_bary_t bc = sample_uniform_triangle(u1, u2);
        assert_true(bc.b0 >= 0.0 && bc.b1 >= 0.0 && bc.b2 >= 0.0);
        assert_true(fabs(bc.b0 + bc.b1 + bc.b2 - 1.0) < 1e-15);
        vec3_t p = sample_triangle_point(p0, p1, p2, u1, u2);
        mc_add(&one, 1.0 / pdf);
        mc_add(&mx, p.x);
        mc_add(&my, p.y);
        mc_add(&mz, p.z);
        mc_add(&x2, p.x * p.x);
        mc_add(&corner[0], bc.b0 > 0.5);
        mc_add(&corner[1], bc.b1 > 0.5);
        mc_add(&corner[2], bc.b2 > 0.5);
    }
    mc_check(&one, area, "triangle: int 1 dA = area (Heron)");
    mc_check(&mx, (p0.x + p1.x + p2.x) / 3.0, "triangle: mean x = centroid");
    mc_check(&my, (p0.y + p1.y + p2.y) / 3.0, "triangle: mean y = centroid");
    mc_check(&mz, (p0.z + p1.z + p2.z) / 3.0, "triangle: mean z = centroid");
    mc_check(&x2,
             (p0.x * p0.x + p1.x * p1.x + p2.x * p2.x + p0.x * p1.x + p0.x * p2.x + p1.x * p2.x) /
                 6.0,
             "triangle: E[x^2]");
    for (int k = 0; k < 3; k++)
        mc_check(&corner[k], 0.25, "triangle: corner b_k > 1/2 holds 1/4");
}

/* Local-to-world: +z goes to n, the local axes stay orthonormal and right-handed, and cosine
 * samples around n have mean cosine 2/3 (int cos^2 / pi dw over H = (2 pi / 3) / pi). */
static void test_local_to_world(void **state)
{
    (void)state;
    const vec3_t normals[] = {{0, 0, 1},  {0, 0, -1},     {1, 0, 0},
                              {0, -1, 0}, {0.6, 0, -0.8}, {0.48, -0.6, 0.64}};
    for (size_t k = 0; k < sizeof normals / sizeof normals[0]; k++) {
        vec3_t n = normals[k];
        vec3_t ex = sample_local_to_world(vec3_make(1, 0, 0), n);
        vec3_t ey = sample_local_to_world(vec3_make(0, 1, 0), n);
        vec3_t ez = sample_local_to_world(vec3_make(0, 0, 1), n);
        assert_true(vec3_length(vec3_sub(ez, n)) < 1e-15);
        assert_unit(ex);
        assert_unit(ey);
        assert_true(fabs(vec3_dot(ex, ey)) < 1e-15 && fabs(vec3_dot(ex, n)) < 1e-15 &&
                    fabs(vec3_dot(ey, n)) < 1e-15);
        assert_true(vec3_length(vec3_sub(vec3_cross(ex, ey), n)) < 1e-12);
        mc_t mcos = {0};
        for (uint64_t i = 0; i < N / 4; i++) {
            double u1, u2;
            uv(17 + k, i, &u1, &u2);
            vec3_t w = sample_local_to_world(sample_cosine_hemisphere(u1, u2), n);
            assert_unit(w);
            assert_true(vec3_dot(w, n) >= -1e-15);
            mc_add(&mcos, vec3_dot(w, n));
        }
        mc_check(&mcos, 2.0 / 3.0, "world: mean cos around n = 2/3");
    }
}

/* u exactly 0, the smallest positive double, 1/2, the largest double below 1, exactly 1,
 * out-of-range values and NaN: every sampler returns finite, in-domain values. */
static void test_edge_inputs(void **state)
{
    (void)state;
    const double us[] = {0.0, 0x1p-1074, 1e-300, 0.5, 1.0 - 0x1p-53, 1.0, -0.25, 1.5, NAN};
    const size_t nu = sizeof us / sizeof us[0];
    const double cmaxes[] = {-1.0, 0.0, 0.999999999, 1.0, NAN};
    for (size_t i = 0; i < nu; i++)
        for (size_t j = 0; j < nu; j++) {
            double a = us[i], b = us[j];
            vec3_t d = sample_concentric_disk(a, b);
            assert_true(isfinite(d.x) && isfinite(d.y) && d.x * d.x + d.y * d.y <= 1.0 + 1e-15);
            vec3_t w = sample_cosine_hemisphere(a, b);
            assert_true(isfinite(w.z) && w.z >= 0.0);
            assert_unit(w);
            w = sample_uniform_hemisphere(a, b);
            assert_true(w.z >= 0.0);
            assert_unit(w);
            assert_unit(sample_uniform_sphere(a, b));
            for (size_t k = 0; k < sizeof cmaxes / sizeof cmaxes[0]; k++) {
                assert_unit(sample_uniform_cone(a, b, cmaxes[k]));
                assert_true(isfinite(sample_uniform_cone_pdf(cmaxes[k])));
            }
            sample_bary_t bc = sample_uniform_triangle(a, b);
            assert_true(bc.b0 >= 0.0 && bc.b1 >= 0.0 && bc.b2 >= 0.0);
            assert_true(fabs(bc.b0 + bc.b1 + bc.b2 - 1.0) < 1e-15);
        }
    assert_true(sample_cosine_hemisphere_pdf(-0.5) == 0.0);
    assert_true(sample_cosine_hemisphere_pdf(NAN) == 0.0);
    /* a triangle with subnormal area: pdf 0 instead of Inf */
    assert_true(sample_triangle_pdf(vec3_make(0, 0, 0), vec3_make(1e-160, 0, 0),
                                    vec3_make(0, 1e-160, 0)) == 0.0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cosine_hemisphere), cmocka_unit_test(test_uniform_hemisphere),
        cmocka_unit_test(test_uniform_sphere),    cmocka_unit_test(test_uniform_cone),
        cmocka_unit_test(test_concentric_disk),   cmocka_unit_test(test_uniform_triangle),
        cmocka_unit_test(test_local_to_world),    cmocka_unit_test(test_edge_inputs),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
