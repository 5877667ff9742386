/* vec3: small 3-vectors of doubles passed by value, for geometry and optics.
 * Header-only; every function is pure. */
#ifndef PRISMFARM_VEC3_H
#define PRISMFARM_VEC3_H

#include <math.h>

/* π to double precision (strict C17 has no M_PI). */
#define PF_PI 3.14159265358979323846

typedef struct vec3 {
    double x, y, z;
} vec3_t;

static inline vec3_t vec3_make(double x, double y, double z) { return (vec3_t){x, y, z}; }
static inline vec3_t vec3_add(vec3_t a, vec3_t b) { return (vec3_t){a.x + b.x, a.y + b.y, a.z + b.z}; }
static inline vec3_t vec3_sub(vec3_t a, vec3_t b) { return (vec3_t){a.x - b.x, a.y - b.y, a.z - b.z}; }
static inline vec3_t vec3_scale(vec3_t a, double s) { return (vec3_t){a.x * s, a.y * s, a.z * s}; }
static inline vec3_t vec3_neg(vec3_t a) { return (vec3_t){-a.x, -a.y, -a.z}; }
static inline vec3_t vec3_mul(vec3_t a, vec3_t b) { return (vec3_t){a.x * b.x, a.y * b.y, a.z * b.z}; }
static inline double vec3_dot(vec3_t a, vec3_t b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline vec3_t vec3_cross(vec3_t a, vec3_t b)
{
    return (vec3_t){a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
static inline double vec3_length(vec3_t a) { return sqrt(vec3_dot(a, a)); }
/* Returns a unit vector; the zero vector stays zero rather than becoming NaN. */
static inline vec3_t vec3_normalize(vec3_t a)
{
    double len = vec3_length(a);
    return len > 0.0 ? vec3_scale(a, 1.0 / len) : a;
}
static inline vec3_t vec3_fma(vec3_t a, vec3_t b, double s) { return (vec3_t){a.x + b.x * s, a.y + b.y * s, a.z + b.z * s}; }

/* An orthonormal basis (t, b, n) around the unit vector n, branch-free
 * (Duff et al. 2017, "Building an Orthonormal Basis, Revisited"). */
static inline void vec3_basis(vec3_t n, vec3_t *t, vec3_t *b)
{
    double sign = copysign(1.0, n.z);
    double a = -1.0 / (sign + n.z);
    double c = n.x * n.y * a;
    *t = (vec3_t){1.0 + sign * n.x * n.x * a, sign * c, -sign * n.x};
    *b = (vec3_t){c, sign + n.y * n.y * a, -n.y};
}

#endif
