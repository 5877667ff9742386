/* transform: 4x4 homogeneous transforms with their inverses, in pbrt-v4's conventions
 * (left-handed; column vectors, p' = M p; Rotate/LookAt as pbrt-v4's transform.cpp).
 * Every transform carries its inverse; a singular matrix is flagged, never inverted to NaN. */
#ifndef PRISMFARM_TRANSFORM_H
#define PRISMFARM_TRANSFORM_H

#include "err.h"
#include "vec3.h"

#include <stdbool.h>

typedef struct transform {
    double m[4][4];     /* row-major: m[row][col]; a point maps as m * (x, y, z, 1) */
    double m_inv[4][4]; /* the inverse of m; all zero when singular is set */
    bool singular;      /* m has no inverse (e.g. Scale 0 1 1) */
} transform_t;

transform_t transform_identity(void);
transform_t transform_translate(vec3_t delta);
transform_t transform_scale(double sx, double sy, double sz);
/* Rotation by angle_deg degrees about axis (normalised here), counter-clockwise when looking
 * down the axis toward the origin: Rotate 90 about z maps +x to +y (pbrt-v4 Rotate).
 * Fails when the axis is zero or not finite. */
int transform_rotate(double angle_deg, vec3_t axis, transform_t *out, err_t *err);
/* pbrt-v4 LookAt: returns camera-from-world. In camera space the camera sits at the origin and
 * looks down +z, +y is the projection of up and +x = up x dir (left-handed, so +x is image
 * right). Fails when eye == look or up is parallel to the viewing direction. */
int transform_look_at(vec3_t eye, vec3_t look, vec3_t up, transform_t *out, err_t *err);
/* A transform from a row-major matrix; computes the inverse (singular flagged). */
transform_t transform_from_matrix(const double m[4][4]);
/* pbrt's Transform/ConcatTransform take 16 numbers in column-major order (the translation is
 * elements 12, 13, 14): this builds the matrix they mean. */
transform_t transform_from_pbrt_array(const double v[16]);

/* a * b: applies b first, then a (pbrt's CTM = CTM * T). */
transform_t transform_compose(transform_t a, transform_t b);
/* Swaps m and m_inv; the inverse of a singular transform stays flagged singular. */
transform_t transform_inverse(transform_t t);
transform_t transform_transpose(transform_t t);

/* Applies t to a point (with the homogeneous divide; w == 0 maps to the zero vector). */
vec3_t transform_point(const transform_t *t, vec3_t p);
vec3_t transform_vector(const transform_t *t, vec3_t v);
/* Normals map by the inverse transpose (pbrt-v4 Transform::operator()(Normal3f));
 * a singular transform maps every normal to zero. */
vec3_t transform_normal(const transform_t *t, vec3_t n);

/* True when the upper 3x3 has a negative determinant: the transform turns a left-handed frame
 * right-handed, so pbrt flips surface normals (shapes.h: transformSwapsHandedness). */
bool transform_swaps_handedness(const transform_t *t);
/* True when the bottom row is exactly (0, 0, 0, 1). */
bool transform_is_affine(const transform_t *t);
bool transform_is_identity(const transform_t *t);
/* True when every entry of m is finite. */
bool transform_is_finite(const transform_t *t);

/* Inverts a 4x4 matrix by Gauss-Jordan elimination with partial pivoting; returns -1 (out
 * untouched) when it is singular or the inverse would not be finite. */
int matrix4_invert(const double m[4][4], double out[4][4]);
void matrix4_mul(const double a[4][4], const double b[4][4], double out[4][4]);

#endif
