/* envmap: an image environment as pbrt-v4's ImageInfiniteLight has it. A square image is in
 * pbrt-v4's equal-area octahedral layout (equal_area.h: the image centre is light-space +z, u
 * runs along the columns and v down the rows from the top); an image twice as wide as high is
 * lat-long in pbrt-v3's layout (u = phi / 2 pi from +x towards +y, v = theta / pi from +z at
 * the top row), which pbrt-v4 itself does not read; each texel's linear-sRGB colour is
 * an RGB illuminant spectrum m * s(lambda) times the light's D65 (pbrt-v4 RGBIlluminantSpectrum,
 * m = 2 max(r, g, b), s the smooth uplift of rgb / m), looked up at the nearest texel as pbrt-v4
 * does. The uplift coefficients are computed once per texel at load by rgb_uplift (the rule
 * image textures share), so that a lookup costs one sigmoid. Directions are drawn by a
 * piecewise-constant density over the texels proportional to their channel average (pbrt-v4
 * Image::GetSamplingDistribution; times sin(theta) for lat-long), which is a density over
 * directions proportional to that average, or by the compensated density below (light sampling
 * under MIS only). Immutable once made, safe to share between threads. */
#ifndef PRISMFARM_ENVMAP_H
#define PRISMFARM_ENVMAP_H

#include "err.h"
#include "vec3.h"

#include <stdbool.h>
#include <stddef.h>

typedef struct envmap envmap_t;

/* rgb: width * height * 3 linear sRGB floats, top row first. Refuses an image neither square
 * nor 2:1 (no layout fits it), a negative, NaN or infinite texel. name is for messages. */
envmap_t *envmap_new(const float *rgb, int width, int height, const char *name, err_t *err);

/* The rule every light's image obeys (environments, goniometric, projection and area lights'
 * images): 0 when each of the width * height * 3 floats is finite and >= 0, else -1 with err
 * naming the image (name) and the first bad texel's (x, y), top row 0, and what is wrong. */
int envmap_check_texels(const float *rgb, int width, int height, const char *name, err_t *err);
void envmap_destroy(envmap_t **self_p);

/* The image's width. */
int envmap_resolution(const envmap_t *self);
/* Whether the image is lat-long (2:1) rather than equal-area (square). */
bool envmap_is_latlong(const envmap_t *self);

/* The texel that light-space direction w (any length > 0) looks up. */
size_t envmap_texel(const envmap_t *self, vec3_t w);
/* That texel's m * s(lambda): its radiance per unit of the light's D65 value at lambda. */
double envmap_texel_value(const envmap_t *self, size_t texel, double lambda);

/* A light-space unit direction drawn with (u0, u1), its texel and its solid-angle pdf. */
vec3_t envmap_sample(const envmap_t *self, double u0, double u1, size_t *texel, double *pdf);
/* The solid-angle pdf envmap_sample has for light-space direction w. */
double envmap_pdf(const envmap_t *self, vec3_t w);

/* The compensated distribution (pbrt-v4 ImageInfiniteLight's compensatedDistribution; PBR 4th
 * ed. sec. 12.5.3; Karlik et al. 2019, "MIS Compensation"), built at load beside the plain one:
 * a density over directions proportional to max(c - c_avg, 0), c a texel's channel average and
 * c_avg its mean over directions. It is 0 exactly where c <= c_avg, so it is only for light
 * sampling that another strategy (BSDF or phase sampling, under MIS) completes: that strategy
 * alone covers the dim directions, and the light's samples go to what stands out (the sun). An
 * image with no texel above its average (a uniform one) has none, and the plain distribution
 * serves in its place, as pbrt-v4 does. The _as functions take the distribution to use:
 * compensated false is envmap_sample / envmap_pdf. */
bool envmap_has_compensated(const envmap_t *self);
vec3_t envmap_sample_as(const envmap_t *self, bool compensated, double u0, double u1, size_t *texel,
                        double *pdf);
double envmap_pdf_as(const envmap_t *self, bool compensated, vec3_t w);

/* Mean over directions of the texels' luminance Y (linear sRGB). */
double envmap_mean_luminance(const envmap_t *self);
/* pbrt-v4's "illuminance" normaliser k_e (lights.cpp, ImageInfiniteLight): 2 pi / N times the
 * sum over texels with z > 0 of Y cos(theta) (lat-long: each texel weighted by its solid
 * angle, so that k_e stays half the upper illuminance). That is half the illuminance the map gives
 * a surface facing light-space +z (4 pi / N per texel), so a pbrt-v4 map scaled to "illuminance" E
 * delivers 2 E; kept as pbrt-v4 has it, so that its scenes render alike. */
double envmap_upper_illuminance(const envmap_t *self);

#endif
