/* equiangular: equiangular sampling of a distance along a ray segment toward a point (Kulla &
 * Fajardo 2012, "Importance sampling techniques for path tracing in participating media",
 * §3): t on [0, tmax) with density proportional to 1 / |org + t dir - c|^2, the falloff of the
 * light that a point c sends to the segment's points, so that single scattering from a small
 * light near the ray has bounded variance where free-flight sampling's is unbounded.
 *
 * Guarantees: for any segment (tmax may be INFINITY) and any point, including one on the ray
 * or at its origin, the density is finite and > 0 on [0, tmax) and 0 outside it, integrates to
 * 1 there, and a sample is finite and lies in [0, tmax). The ray-to-point distance D the
 * density uses is floored at EQUIANGULAR_D_MIN times the segment's scale: the density with the
 * floored D is still exactly the one sampled (no energy is dropped; only its shape widens to a
 * Cauchy of that width), and it keeps the density finite when c lies on the ray. A segment of
 * no length, or a configuration whose numbers are not finite, is reported unusable. */
#ifndef PRISMFARM_EQUIANGULAR_H
#define PRISMFARM_EQUIANGULAR_H

#include "vec3.h"

/* The floor of the ray-to-point distance, relative to |c - org| + tmax (finite part). */
#define EQUIANGULAR_D_MIN 1e-7

typedef struct equiangular {
    double delta;  /* the foot of c on the ray: t at the closest approach */
    double D;      /* the (floored) distance from c to the ray */
    double a;      /* (0 - delta) / D */
    double dtheta; /* atan((tmax - delta) / D) - atan(a), in (0, pi) */
    double tmax;
} equiangular_t;

/* The sampler of the segment org + t dir (dir unit), t in [0, tmax), toward c: 1, or 0 when
 * the segment cannot be sampled (tmax <= 0, a NaN, an overflow). */
int equiangular_make(vec3_t org, vec3_t dir, double tmax, vec3_t c, equiangular_t *out);

/* t = delta + D tan(theta_a + u dtheta) for u in [0, 1), written through the tangent's
 * addition formula so that a segment far from c (theta near +-pi/2) keeps its digits; clamped
 * into [0, tmax) against rounding. */
double equiangular_sample(const equiangular_t *e, double u);

/* The density of t: D / (dtheta ((t - delta)^2 + D^2)) on [0, tmax), else 0. */
double equiangular_pdf(const equiangular_t *e, double t);

#endif
