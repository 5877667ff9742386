#include "transform.h"

#include <math.h>
#include <string.h>

static const double PI = 3.14159265358979323846;

static transform_t make(const double m[4][4], const double m_inv[4][4])
{
    transform_t t;
    memcpy(t.m, m, sizeof t.m);
    memcpy(t.m_inv, m_inv, sizeof t.m_inv);
    t.singular = false;
    return t;
}

static transform_t make_singular(const double m[4][4])
{
    transform_t t;
    memcpy(t.m, m, sizeof t.m);
    memset(t.m_inv, 0, sizeof t.m_inv);
    t.singular = true;
    return t;
}

transform_t transform_identity(void)
{
    static const double id[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
    return make(id, id);
}

transform_t transform_translate(vec3_t d)
{
    const double m[4][4] = {{1, 0, 0, d.x}, {0, 1, 0, d.y}, {0, 0, 1, d.z}, {0, 0, 0, 1}};
    const double mi[4][4] = {{1, 0, 0, -d.x}, {0, 1, 0, -d.y}, {0, 0, 1, -d.z}, {0, 0, 0, 1}};
    return make(m, mi);
}

transform_t transform_scale(double sx, double sy, double sz)
{
    const double m[4][4] = {{sx, 0, 0, 0}, {0, sy, 0, 0}, {0, 0, sz, 0}, {0, 0, 0, 1}};
    if (sx == 0.0 || sy == 0.0 || sz == 0.0)
        return make_singular(m);
    const double mi[4][4] = {
        {1.0 / sx, 0, 0, 0}, {0, 1.0 / sy, 0, 0}, {0, 0, 1.0 / sz, 0}, {0, 0, 0, 1}};
    return make(m, mi);
}

int transform_rotate(double angle_deg, vec3_t axis, transform_t *out, err_t *err)
{
    double len = vec3_length(axis);
    if (!isfinite(angle_deg) || !isfinite(len))
        return err_set(err, "rotation angle and axis must be finite");
    if (len == 0.0)
        return err_set(err, "rotation axis is the zero vector");
    vec3_t a = vec3_scale(axis, 1.0 / len);
    double theta = angle_deg * (PI / 180.0);
    double s = sin(theta), c = cos(theta);
    /* Rodrigues' rotation formula as a matrix (pbrt-v4 transform.h, Rotate(sin, cos, axis)). */
    double m[4][4] = {{a.x * a.x + (1 - a.x * a.x) * c, a.x * a.y * (1 - c) - a.z * s,
                       a.x * a.z * (1 - c) + a.y * s, 0},
                      {a.x * a.y * (1 - c) + a.z * s, a.y * a.y + (1 - a.y * a.y) * c,
                       a.y * a.z * (1 - c) - a.x * s, 0},
                      {a.x * a.z * (1 - c) - a.y * s, a.y * a.z * (1 - c) + a.x * s,
                       a.z * a.z + (1 - a.z * a.z) * c, 0},
                      {0, 0, 0, 1}};
    /* A rotation's inverse is its transpose. */
    double mi[4][4];
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            mi[i][j] = m[j][i];
    *out = make(m, mi);
    return 0;
}

int transform_look_at(vec3_t eye, vec3_t look, vec3_t up, transform_t *out, err_t *err)
{
    vec3_t d = vec3_sub(look, eye);
    if (!isfinite(vec3_length(d)) || !isfinite(vec3_length(up)) || !isfinite(vec3_length(eye)))
        return err_set(err, "LookAt needs finite points and up vector");
    if (vec3_length(d) == 0.0)
        return err_set(err, "LookAt eye and look-at point are the same point");
    if (vec3_length(up) == 0.0)
        return err_set(err, "LookAt up vector is the zero vector");
    vec3_t dir = vec3_normalize(d);
    vec3_t right = vec3_cross(vec3_normalize(up), dir);
    /* Parallel up and dir leave no frame: pbrt-v4 reports the same condition. */
    if (vec3_length(right) < 1e-12)
        return err_set(err, "LookAt up vector is parallel to the viewing direction");
    right = vec3_normalize(right);
    vec3_t new_up = vec3_cross(dir, right);
    /* world-from-camera has the camera frame as its columns and the eye as translation; the
     * frame is orthonormal, so camera-from-world is its transpose with -R^T eye. */
    double wfc[4][4] = {{right.x, new_up.x, dir.x, eye.x},
                        {right.y, new_up.y, dir.y, eye.y},
                        {right.z, new_up.z, dir.z, eye.z},
                        {0, 0, 0, 1}};
    double cfw[4][4] = {{right.x, right.y, right.z, -vec3_dot(right, eye)},
                        {new_up.x, new_up.y, new_up.z, -vec3_dot(new_up, eye)},
                        {dir.x, dir.y, dir.z, -vec3_dot(dir, eye)},
                        {0, 0, 0, 1}};
    *out = make(cfw, wfc);
    return 0;
}

transform_t transform_from_matrix(const double m[4][4])
{
    double inv[4][4];
    if (matrix4_invert(m, inv) != 0)
        return make_singular(m);
    return make(m, inv);
}

transform_t transform_from_pbrt_array(const double v[16])
{
    double m[4][4];
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            m[i][j] = v[j * 4 + i];
    return transform_from_matrix(m);
}

void matrix4_mul(const double a[4][4], const double b[4][4], double out[4][4])
{
    double r[4][4];
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            double s = 0.0;
            for (int k = 0; k < 4; k++)
                s += a[i][k] * b[k][j];
            r[i][j] = s;
        }
    memcpy(out, r, sizeof r);
}

transform_t transform_compose(transform_t a, transform_t b)
{
    transform_t r;
    matrix4_mul(a.m, b.m, r.m);
    /* det(ab) = det(a) det(b): the product of a singular matrix is singular. */
    if (a.singular || b.singular) {
        memset(r.m_inv, 0, sizeof r.m_inv);
        r.singular = true;
        return r;
    }
    matrix4_mul(b.m_inv, a.m_inv, r.m_inv);
    r.singular = false;
    return r;
}

transform_t transform_inverse(transform_t t)
{
    if (t.singular)
        return t;
    return make(t.m_inv, t.m);
}

transform_t transform_transpose(transform_t t)
{
    transform_t r;
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            r.m[i][j] = t.m[j][i];
            r.m_inv[i][j] = t.m_inv[j][i];
        }
    r.singular = t.singular;
    return r;
}

vec3_t transform_point(const transform_t *t, vec3_t p)
{
    const double(*m)[4] = t->m;
    double x = m[0][0] * p.x + m[0][1] * p.y + m[0][2] * p.z + m[0][3];
    double y = m[1][0] * p.x + m[1][1] * p.y + m[1][2] * p.z + m[1][3];
    double z = m[2][0] * p.x + m[2][1] * p.y + m[2][2] * p.z + m[2][3];
    double w = m[3][0] * p.x + m[3][1] * p.y + m[3][2] * p.z + m[3][3];
    if (w == 1.0)
        return vec3_make(x, y, z);
    if (w == 0.0)
        return vec3_make(0.0, 0.0, 0.0);
    return vec3_make(x / w, y / w, z / w);
}

vec3_t transform_vector(const transform_t *t, vec3_t v)
{
    const double(*m)[4] = t->m;
    return vec3_make(m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z,
                     m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
                     m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z);
}

vec3_t transform_normal(const transform_t *t, vec3_t n)
{
    const double(*mi)[4] = t->m_inv;
    return vec3_make(mi[0][0] * n.x + mi[1][0] * n.y + mi[2][0] * n.z,
                     mi[0][1] * n.x + mi[1][1] * n.y + mi[2][1] * n.z,
                     mi[0][2] * n.x + mi[1][2] * n.y + mi[2][2] * n.z);
}

bool transform_swaps_handedness(const transform_t *t)
{
    const double(*m)[4] = t->m;
    double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                 m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                 m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    return det < 0.0;
}

bool transform_is_affine(const transform_t *t)
{
    return t->m[3][0] == 0.0 && t->m[3][1] == 0.0 && t->m[3][2] == 0.0 && t->m[3][3] == 1.0;
}

bool transform_is_identity(const transform_t *t)
{
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            if (t->m[i][j] != (i == j ? 1.0 : 0.0))
                return false;
    return true;
}

bool transform_is_finite(const transform_t *t)
{
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            if (!isfinite(t->m[i][j]))
                return false;
    return true;
}

int matrix4_invert(const double m[4][4], double out[4][4])
{
    double a[4][8];
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            a[i][j] = m[i][j];
            a[i][j + 4] = (i == j) ? 1.0 : 0.0;
        }
    for (int col = 0; col < 4; col++) {
        int pivot = col;
        for (int r = col + 1; r < 4; r++)
            if (fabs(a[r][col]) > fabs(a[pivot][col]))
                pivot = r;
        if (!(fabs(a[pivot][col]) > 0.0))
            return -1;
        if (pivot != col)
            for (int j = 0; j < 8; j++) {
                double tmp = a[col][j];
                a[col][j] = a[pivot][j];
                a[pivot][j] = tmp;
            }
        double inv_p = 1.0 / a[col][col];
        for (int j = 0; j < 8; j++)
            a[col][j] *= inv_p;
        for (int r = 0; r < 4; r++) {
            if (r == col)
                continue;
            double f = a[r][col];
            if (f != 0.0)
                for (int j = 0; j < 8; j++)
                    a[r][j] -= f * a[col][j];
        }
    }
    double r[4][4];
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            r[i][j] = a[i][j + 4];
            if (!isfinite(r[i][j]))
                return -1;
        }
    memcpy(out, r, sizeof r);
    return 0;
}
