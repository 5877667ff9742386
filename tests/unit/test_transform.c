/* transform: pbrt-v4's conventions checked against analytic results (rotations of the axes,
 * the LookAt camera frame, normals under non-uniform scale, handedness, inverses). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <math.h>

#include "transform.h"

/* Entries are sums of at most four products of numbers of order 1 (or 10 for the
 * translations used here), each rounded once: a few ulps of 10, far below 1e-12. */
#define TOL 1e-12

static void assert_vec(vec3_t got, double x, double y, double z)
{
    if (fabs(got.x - x) > TOL || fabs(got.y - y) > TOL || fabs(got.z - z) > TOL)
        fail_msg("got (%.17g, %.17g, %.17g), expected (%g, %g, %g)", got.x, got.y, got.z, x, y, z);
}

static void assert_identity(const double m[4][4])
{
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            if (fabs(m[i][j] - (i == j ? 1.0 : 0.0)) > TOL)
                fail_msg("entry [%d][%d] = %.17g, expected %d", i, j, m[i][j], i == j);
}

static void test_translate_scale(void **state)
{
    (void)state;
    transform_t t = transform_translate(vec3_make(1, -2, 3));
    assert_vec(transform_point(&t, vec3_make(1, 1, 1)), 2, -1, 4);
    /* vectors and normals ignore translation */
    assert_vec(transform_vector(&t, vec3_make(1, 1, 1)), 1, 1, 1);
    assert_vec(transform_normal(&t, vec3_make(0, 0, 1)), 0, 0, 1);
    transform_t s = transform_scale(2, 3, 4);
    assert_vec(transform_point(&s, vec3_make(1, 1, 1)), 2, 3, 4);
    transform_t si = transform_inverse(s);
    assert_vec(transform_point(&si, vec3_make(2, 3, 4)), 1, 1, 1);
}

static void test_rotate_axes(void **state)
{
    (void)state;
    transform_t r;
    /* pbrt-v4 Rotate(90, z): +x -> +y, +y -> -x (right-hand rule about the axis). */
    assert_int_equal(transform_rotate(90, vec3_make(0, 0, 1), &r, NULL), 0);
    assert_vec(transform_point(&r, vec3_make(1, 0, 0)), 0, 1, 0);
    assert_vec(transform_point(&r, vec3_make(0, 1, 0)), -1, 0, 0);
    assert_int_equal(transform_rotate(90, vec3_make(1, 0, 0), &r, NULL), 0);
    assert_vec(transform_point(&r, vec3_make(0, 1, 0)), 0, 0, 1);
    /* 120 degrees about (1,1,1) permutes the axes cyclically: x -> y -> z -> x. The axis is
     * normalised by the function, so its length must not matter. */
    assert_int_equal(transform_rotate(120, vec3_make(2, 2, 2), &r, NULL), 0);
    assert_vec(transform_point(&r, vec3_make(1, 0, 0)), 0, 1, 0);
    assert_vec(transform_point(&r, vec3_make(0, 1, 0)), 0, 0, 1);
    assert_vec(transform_point(&r, vec3_make(0, 0, 1)), 1, 0, 0);
    assert_false(transform_swaps_handedness(&r));
    transform_t back = transform_compose(r, transform_inverse(r));
    assert_identity(back.m);

    err_t err;
    assert_int_equal(transform_rotate(30, vec3_make(0, 0, 0), &r, &err), -1);
    assert_string_equal(err.msg, "rotation axis is the zero vector");
}

static void test_compose_order(void **state)
{
    (void)state;
    /* pbrt's CTM = CTM * T: in "Translate 1 0 0  Scale 2 2 2" the scale applies first. */
    transform_t ts =
        transform_compose(transform_translate(vec3_make(1, 0, 0)), transform_scale(2, 2, 2));
    assert_vec(transform_point(&ts, vec3_make(1, 1, 1)), 3, 2, 2);
    transform_t inv = transform_inverse(ts);
    assert_vec(transform_point(&inv, vec3_make(3, 2, 2)), 1, 1, 1);
    double prod[4][4];
    matrix4_mul(ts.m, ts.m_inv, prod);
    assert_identity(prod);
}

static void test_pbrt_array_is_column_major(void **state)
{
    (void)state;
    /* pbrt's "Transform [...]" lists the matrix by columns: the translation is 12..14. */
    const double v[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 3, 4, 5, 1};
    transform_t t = transform_from_pbrt_array(v);
    assert_false(t.singular);
    assert_vec(transform_point(&t, vec3_make(0, 0, 0)), 3, 4, 5);
    assert_vec(transform_point(&t, vec3_make(1, 1, 1)), 4, 5, 6);
    assert_true(transform_is_affine(&t));
    /* A general matrix and its computed inverse multiply to the identity. */
    const double g[16] = {2, 1, 0, 0, -1, 3, 0.5, 0, 0.25, 0, 4, 0, 7, -8, 9, 1};
    transform_t gt = transform_from_pbrt_array(g);
    assert_false(gt.singular);
    double prod[4][4];
    matrix4_mul(gt.m, gt.m_inv, prod);
    assert_identity(prod);
}

static void test_look_at_pbrt_convention(void **state)
{
    (void)state;
    transform_t cfw;
    /* Eye on -z looking at the origin with +y up: camera space equals world space shifted by 5
     * along z, since pbrt's camera looks down +z and +x = up x dir = y x z = +x. */
    assert_int_equal(
        transform_look_at(vec3_make(0, 0, -5), vec3_make(0, 0, 0), vec3_make(0, 1, 0), &cfw, NULL),
        0);
    assert_vec(transform_point(&cfw, vec3_make(0, 0, 0)), 0, 0, 5);
    assert_vec(transform_point(&cfw, vec3_make(1, 0, 0)), 1, 0, 5);
    assert_vec(transform_point(&cfw, vec3_make(0, 1, 0)), 0, 1, 5);
    /* Looking down world +x with +z up (left-handed): camera +x = up x dir = z x x = +y, so a
     * point on world +y appears on the image's right; +z stays up; depth is world x. */
    assert_int_equal(
        transform_look_at(vec3_make(0, 0, 0), vec3_make(1, 0, 0), vec3_make(0, 0, 1), &cfw, NULL),
        0);
    assert_vec(transform_point(&cfw, vec3_make(0, 1, 0)), 1, 0, 0);
    assert_vec(transform_point(&cfw, vec3_make(0, 0, 1)), 0, 1, 0);
    assert_vec(transform_point(&cfw, vec3_make(2, 0, 0)), 0, 0, 2);
    /* world-from-camera is the stored inverse: the camera sits at the eye. */
    transform_t wfc = transform_inverse(cfw);
    assert_vec(transform_point(&wfc, vec3_make(0, 0, 0)), 0, 0, 0);
    /* An oblique case: the look-at point lies on the camera's +z axis at the eye distance. */
    assert_int_equal(
        transform_look_at(vec3_make(1, 2, 3), vec3_make(4, 6, 3), vec3_make(0, 0, 1), &cfw, NULL),
        0);
    assert_vec(transform_point(&cfw, vec3_make(4, 6, 3)), 0, 0, 5);
    assert_false(transform_swaps_handedness(&cfw));

    err_t err;
    assert_int_equal(
        transform_look_at(vec3_make(0, 0, 0), vec3_make(0, 1, 0), vec3_make(0, 2, 0), &cfw, &err),
        -1);
    assert_string_equal(err.msg, "LookAt up vector is parallel to the viewing direction");
    assert_int_equal(
        transform_look_at(vec3_make(1, 1, 1), vec3_make(1, 1, 1), vec3_make(0, 1, 0), &cfw, &err),
        -1);
    assert_string_equal(err.msg, "LookAt eye and look-at point are the same point");
}

static void test_normals_use_inverse_transpose(void **state)
{
    (void)state;
    /* Under Scale 2 1 1 the plane x + y = 0 (normal (1,1,0), tangent (1,-1,0)) becomes
     * x/2 + y = 0, normal (1/2, 1, 0): the mapped normal stays perpendicular to the mapped
     * tangent, which transforming it as a vector would not. */
    transform_t s = transform_scale(2, 1, 1);
    vec3_t n = transform_normal(&s, vec3_make(1, 1, 0));
    vec3_t tangent = transform_vector(&s, vec3_make(1, -1, 0));
    assert_vec(n, 0.5, 1, 0);
    assert_true(fabs(vec3_dot(n, tangent)) < TOL);
}

static void test_handedness_and_singular(void **state)
{
    (void)state;
    transform_t m = transform_scale(-1, 1, 1);
    assert_true(transform_swaps_handedness(&m));
    transform_t m2 = transform_scale(-1, -1, 1);
    assert_false(transform_swaps_handedness(&m2));
    assert_false(transform_swaps_handedness(
        &(transform_t){.m = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}}}));

    transform_t z = transform_scale(0, 1, 1);
    assert_true(z.singular);
    transform_t c = transform_compose(transform_translate(vec3_make(1, 2, 3)), z);
    assert_true(c.singular);
    assert_true(transform_inverse(z).singular);
    /* a singular transform maps normals to zero rather than to NaN */
    vec3_t n = transform_normal(&z, vec3_make(1, 0, 0));
    assert_true(n.x == 0.0 && n.y == 0.0 && n.z == 0.0);
    const double sing[4][4] = {{1, 2, 3, 0}, {2, 4, 6, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
    double out[4][4];
    assert_int_equal(matrix4_invert(sing, out), -1);
    assert_true(transform_from_matrix(sing).singular);
    transform_t id = transform_identity();
    assert_true(transform_is_identity(&id));
    assert_true(transform_is_finite(&id));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_translate_scale),
        cmocka_unit_test(test_rotate_axes),
        cmocka_unit_test(test_compose_order),
        cmocka_unit_test(test_pbrt_array_is_column_major),
        cmocka_unit_test(test_look_at_pbrt_convention),
        cmocka_unit_test(test_normals_use_inverse_transpose),
        cmocka_unit_test(test_handedness_and_singular),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
