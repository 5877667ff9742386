/* projmap: the image a projection light casts, as pbrt-v4's ProjectionLight has it. In light
 * space the light looks along +z; the image covers the rectangle [-X, X] x [-Y, Y] of the
 * plane z = 1, the shorter axis spanning the field of view (X = aspect tan(fov / 2), Y =
 * tan(fov / 2) for an image wider than high, else X = tan(fov / 2), Y = tan(fov / 2) / aspect)
 * with columns along +x and rows, from the top, along +y (the light's transform flips y, as
 * pbrt-v4's does, so that the image lands upright). A direction w (w.z >= 1e-3 once
 * normalised, pbrt-v4's hither) that crosses the rectangle reads the nearest texel; any other
 * reads nothing. Each texel's linear-sRGB colour is an RGB illuminant spectrum m s(lambda)
 * times the light's D65 (rgb_uplift, as envmap.h). Directions are drawn by a piecewise-constant
 * density over the texels proportional to their channel average times cos^3 at their centre
 * (pbrt-v4 Image::GetSamplingDistribution with dw/dA), uniform on the plane inside a texel, so
 * the solid-angle density is p(u, v) / (A cos^3 theta), A = 4 X Y: exact, since d omega =
 * cos^3 theta dA on the plane z = 1. Immutable once made, safe to share between threads. */
#ifndef PRISMFARM_PROJMAP_H
#define PRISMFARM_PROJMAP_H

#include "err.h"
#include "vec3.h"

#include <stddef.h>
#include <stdint.h>

typedef struct projmap projmap_t;

/* What projmap_texel gives for a direction outside the frustum. */
#define PROJMAP_OUTSIDE SIZE_MAX

/* rgb: width * height * 3 linear sRGB floats, top row first; fov_deg in (0, 180). Refuses a
 * negative, NaN or infinite texel. name is for messages. */
projmap_t *projmap_new(const float *rgb, int width, int height, double fov_deg, const char *name,
                       err_t *err);
void projmap_destroy(projmap_t **self_p);

/* The half-extents X and Y of the image on the plane z = 1. */
void projmap_extent(const projmap_t *self, double *x, double *y);

/* The texel that light-space direction w (any length > 0) crosses, or PROJMAP_OUTSIDE. */
size_t projmap_texel(const projmap_t *self, vec3_t w);
/* That texel's m * s(lambda): its intensity per unit of the light's D65 value at lambda. */
double projmap_texel_value(const projmap_t *self, size_t texel, double lambda);

/* A light-space unit direction drawn with (u0, u1), its texel and its solid-angle pdf (> 0). */
vec3_t projmap_sample(const projmap_t *self, double u0, double u1, size_t *texel, double *pdf);
/* The solid-angle pdf projmap_sample has for light-space direction w (0 outside). */
double projmap_pdf(const projmap_t *self, vec3_t w);

/* pbrt-v4's power normaliser k_e (lights.cpp, ProjectionLight::Create): A / N times the sum
 * over the N texels of Y cos^3 theta at the texel's centre, Y the texel's luminance: the
 * luminous power (intensity times solid angle) of the light at scale 1, to the midpoint
 * rule's accuracy. */
double projmap_power(const projmap_t *self);
/* The frustum's solid angle, 4 asin(X Y / sqrt((1 + X^2)(1 + Y^2))). */
double projmap_solid_angle(const projmap_t *self);

#endif
