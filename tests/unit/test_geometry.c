/* geometry: Embree triangles and analytic spheres/disks against hand-computed hits. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <string.h>

#include "geometry.h"
#include "numeric_testutil.h"

/* A counter-clockwise triangle (seen from +z) has its normal toward +z in pbrt's convention:
 * cross(p0 - p2, p1 - p2). */
static void test_triangle_normal_follows_pbrt(void **state)
{
    (void)state;
    err_t err;
    geometry_t *g = geometry_new(1, &err);
    assert_non_null(g);
    double pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    uint32_t idx[3] = {0, 1, 2};
    assert_int_equal(geometry_add_mesh(g, pos, 3, idx, 1, 7, 0, &err), 0);
    assert_int_equal(geometry_commit(g, &err), 0);
    hit_t h;
    assert_int_equal(geometry_intersect(g, vec3_make(0.25, 0.25, 5), vec3_make(0, 0, -1), 0, INFINITY, &h), 1);
    testutil_assert_near(h.t, 5.0, 1e-6);
    assert_int_equal(h.shape, 7);
    testutil_assert_near(h.ng.z, 1.0, 1e-12);
    /* Misses beside the triangle and beyond tmax. */
    assert_int_equal(geometry_intersect(g, vec3_make(0.75, 0.75, 5), vec3_make(0, 0, -1), 0, INFINITY, &h), 0);
    assert_int_equal(geometry_intersect(g, vec3_make(0.25, 0.25, 5), vec3_make(0, 0, -1), 0, 4.0, &h), 0);
    assert_int_equal(geometry_occluded(g, vec3_make(0.25, 0.25, 5), vec3_make(0, 0, -1), 0, 6.0), 1);
    assert_int_equal(geometry_occluded(g, vec3_make(0.25, 0.25, 5), vec3_make(0, 0, -1), 0, 4.0), 0);
    geometry_destroy(&g);
    assert_null(g);
}

static void test_flipped_mesh(void **state)
{
    (void)state;
    geometry_t *g = geometry_new(1, NULL);
    double pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    uint32_t idx[3] = {0, 1, 2};
    assert_int_equal(geometry_add_mesh(g, pos, 3, idx, 1, 0, 1, NULL), 0);
    assert_int_equal(geometry_commit(g, NULL), 0);
    hit_t h;
    assert_int_equal(geometry_intersect(g, vec3_make(0.2, 0.2, 1), vec3_make(0, 0, -1), 0, INFINITY, &h), 1);
    testutil_assert_near(h.ng.z, -1.0, 1e-12);
    geometry_destroy(&g);
}

/* An ellipsoid: a unit sphere scaled by (2, 1, 1) and moved to x = 10. */
static void test_scaled_sphere(void **state)
{
    (void)state;
    err_t err;
    geometry_t *g = geometry_new(1, &err);
    transform_t a = transform_from_matrix((double[4][4]){{2, 0, 0, 10}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}});
    assert_int_equal(geometry_add_sphere(g, &a, 1.0, 3, 0, &err), 0);
    assert_int_equal(geometry_commit(g, &err), 0);
    hit_t h;
    assert_int_equal(geometry_intersect(g, vec3_make(0, 0, 0), vec3_make(1, 0, 0), 0, INFINITY, &h), 1);
    testutil_assert_near(h.t, 8.0, 1e-9);
    testutil_assert_near(h.ng.x, -1.0, 1e-12);
    /* From inside, the far wall at x = 12 with the outward normal. */
    assert_int_equal(geometry_intersect(g, vec3_make(10, 0, 0), vec3_make(1, 0, 0), 0, INFINITY, &h), 1);
    testutil_assert_near(h.t, 2.0, 1e-9);
    testutil_assert_near(h.ng.x, 1.0, 1e-12);
    /* The normal on an ellipsoid at (10 + 2 cos θ, sin θ, 0) is ∝ (cos θ / 2, sin θ, 0). */
    double th = 0.7;
    vec3_t target = vec3_make(10 + 2 * cos(th), sin(th), 0);
    vec3_t n = vec3_normalize(vec3_make(cos(th) / 2, sin(th), 0));
    vec3_t org = vec3_fma(target, n, 3.0);
    assert_int_equal(geometry_intersect(g, org, vec3_neg(n), 0, INFINITY, &h), 1);
    testutil_assert_near(h.t, 3.0, 1e-9);
    testutil_assert_near(vec3_dot(h.ng, n), 1.0, 1e-9);
    geometry_destroy(&g);
}

/* Spheres far from the origin and tiny ones: the quadratic must stay accurate. */
static void test_sphere_scales(void **state)
{
    (void)state;
    double scales[] = {1e-3, 1.0, 1e5};
    for (int i = 0; i < 3; i++) {
        double s = scales[i];
        geometry_t *g = geometry_new(1, NULL);
        transform_t a = transform_translate(vec3_make(0, 0, 100 * s));
        assert_int_equal(geometry_add_sphere(g, &a, s, 0, 0, NULL), 0);
        assert_int_equal(geometry_commit(g, NULL), 0);
        hit_t h;
        assert_int_equal(geometry_intersect(g, vec3_make(0, 0, 0), vec3_make(0, 0, 1), 0, INFINITY, &h), 1);
        testutil_assert_near(h.t, 99 * s, 1e-9 * s * 100);
        geometry_destroy(&g);
    }
}

static void test_disk(void **state)
{
    (void)state;
    geometry_t *g = geometry_new(1, NULL);
    transform_t a = transform_identity();
    assert_int_equal(geometry_add_disk(g, &a, 0.5, 2.0, 9, 0, NULL), 0);
    assert_int_equal(geometry_commit(g, NULL), 0);
    hit_t h;
    assert_int_equal(geometry_intersect(g, vec3_make(0.3, 0.3, 0), vec3_make(0, 0, 1), 0, INFINITY, &h), 1);
    testutil_assert_near(h.t, 2.0, 1e-12);
    testutil_assert_near(h.ng.z, 1.0, 1e-12);
    assert_int_equal(h.shape, 9);
    /* (0.4, 0.4) lies outside radius 0.5. */
    assert_int_equal(geometry_intersect(g, vec3_make(0.4, 0.4, 0), vec3_make(0, 0, 1), 0, INFINITY, &h), 0);
    vec3_t lo, hi;
    geometry_bounds(g, &lo, &hi);
    assert_true(lo.x <= -0.5 && hi.x >= 0.5 && lo.z <= 2.0 && hi.z >= 2.0);
    geometry_destroy(&g);
}

static void test_bad_input(void **state)
{
    (void)state;
    err_t err;
    geometry_t *g = geometry_new(1, &err);
    double pos[9] = {0, 0, 0, 1, 0, 0, 0, NAN, 0};
    uint32_t idx[3] = {0, 1, 5};
    assert_int_equal(geometry_add_mesh(g, pos, 3, idx, 1, 4, 0, &err), -1);
    assert_non_null(strstr(err.msg, "vertex 5"));
    idx[2] = 2;
    assert_int_equal(geometry_add_mesh(g, pos, 3, idx, 1, 4, 0, &err), -1);
    assert_non_null(strstr(err.msg, "not finite"));
    transform_t singular = transform_scale(1, 0, 1);
    assert_int_equal(geometry_add_sphere(g, &singular, 1.0, 5, 0, &err), -1);
    assert_non_null(strstr(err.msg, "singular"));
    transform_t id = transform_identity();
    assert_int_equal(geometry_add_sphere(g, &id, -1.0, 6, 0, &err), -1);
    assert_non_null(strstr(err.msg, "radius"));
    geometry_destroy(&g);
}

static void test_offset_escapes_surface(void **state)
{
    (void)state;
    /* A ray leaving a sphere surface far from the origin must not hit the same surface. */
    geometry_t *g = geometry_new(1, NULL);
    transform_t a = transform_translate(vec3_make(1e5, 0, 0));
    geometry_add_sphere(g, &a, 10.0, 0, 0, NULL);
    geometry_commit(g, NULL);
    hit_t h;
    assert_int_equal(geometry_intersect(g, vec3_make(1e5 - 100, 0.3, 0.2), vec3_make(1, 0, 0), 0, INFINITY, &h), 1);
    vec3_t out_dir = vec3_normalize(vec3_make(-1, 0.5, 0));
    vec3_t o = geometry_offset(h.p, h.ng, out_dir);
    assert_int_equal(geometry_intersect(g, o, out_dir, 0, INFINITY, &h), 0);
    geometry_destroy(&g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_triangle_normal_follows_pbrt),
        cmocka_unit_test(test_flipped_mesh),
        cmocka_unit_test(test_scaled_sphere),
        cmocka_unit_test(test_sphere_scales),
        cmocka_unit_test(test_disk),
        cmocka_unit_test(test_bad_input),
        cmocka_unit_test(test_offset_escapes_surface),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
