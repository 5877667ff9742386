/* sample: maps uniform numbers in [0, 1) to points and directions on continuous domains, each
 * with its pdf (solid angle for directions, area for points). Every function is pure, accepts
 * any u in [0, 1] (including exactly 0 and 1; values outside are clamped, NaN reads as 0) and
 * returns finite values, never NaN. */
#ifndef PRISMFARM_SAMPLE_H
#define PRISMFARM_SAMPLE_H

#include "vec3.h"

/* Cosine-weighted direction on the hemisphere around +z (Malley's method: a uniform disk
 * point lifted onto the hemisphere); pdf cos(theta) / pi. */
vec3_t sample_cosine_hemisphere(double u1, double u2);
/* pdf of sample_cosine_hemisphere for a direction with this z; 0 below the horizon. */
double sample_cosine_hemisphere_pdf(double cos_theta);

/* Uniform direction on the hemisphere z >= 0; pdf 1 / (2 pi). */
vec3_t sample_uniform_hemisphere(double u1, double u2);
double sample_uniform_hemisphere_pdf(void);

/* Uniform direction on the unit sphere; pdf 1 / (4 pi). */
vec3_t sample_uniform_sphere(double u1, double u2);
double sample_uniform_sphere_pdf(void);

/* Uniform direction inside the cone around +z of half-angle theta_max (given as its cosine,
 * clamped to [-1, 1]); pdf 1 / (2 pi (1 - cos_theta_max)). A cone of zero angle
 * (cos_theta_max = 1) is a delta direction: the sample is +z and the pdf is reported as 0, so
 * callers treat it like a point light rather than divide by it. */
vec3_t sample_uniform_cone(double u1, double u2, double cos_theta_max);
double sample_uniform_cone_pdf(double cos_theta_max);

/* Uniform point on the unit disk in the z = 0 plane, by the concentric map of Shirley and Chiu
 * 1997 (low distortion, keeps strata compact); pdf 1 / pi per unit area. Scale by r for a disk
 * of radius r (pdf 1 / (pi r^2)). */
vec3_t sample_concentric_disk(double u1, double u2);

/* Barycentric coordinates (b0, b1, b2), b0 + b1 + b2 = 1, uniform over a triangle, by the
 * low-distortion square-to-triangle map of Heitz 2019 ("A Low-Distortion Map Between Triangle
 * and Square"). */
typedef struct sample_bary {
    double b0, b1, b2;
} sample_bary_t;
sample_bary_t sample_uniform_triangle(double u1, double u2);
/* The point b0 p0 + b1 p1 + b2 p2 of sample_uniform_triangle; its pdf is 1 / area. */
vec3_t sample_triangle_point(vec3_t p0, vec3_t p1, vec3_t p2, double u1, double u2);
/* 1 / area of the triangle, or 0 for a degenerate (zero-area) triangle. */
double sample_triangle_pdf(vec3_t p0, vec3_t p1, vec3_t p2);

/* Maps a direction given in the local frame whose +z is the unit normal n into world space,
 * using the orthonormal basis of vec3_basis (Duff et al. 2017). */
vec3_t sample_local_to_world(vec3_t local, vec3_t n);

#endif
