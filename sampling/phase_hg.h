/* phase_hg: the Henyey-Greenstein phase function (Henyey & Greenstein 1941) of participating
 * media, with pbrt-v4's convention that both directions point away from the scattering point
 * (forward scattering, g > 0, favours wi = -wo). p integrates to 1 over the sphere; sampling
 * inverts its cumulative distribution exactly, so a sample's weight p / pdf is 1. Every value
 * is finite for any g: g is clamped to [-PHASE_HG_G_MAX, PHASE_HG_G_MAX]. */
#ifndef PRISMFARM_PHASE_HG_H
#define PRISMFARM_PHASE_HG_H

#include "vec3.h"

/* |g| = 1 is a delta (p = 0/0); this close to it the lobe is already narrower than a pixel
 * at any distance a scene has, and p stays below 1e9. */
#define PHASE_HG_G_MAX 0.9999

/* g clamped as every function here uses it (NaN reads as 0). */
double phase_hg_clamp(double g);

/* p(wo, wi) = (1 - g^2) / (4 pi (1 + g^2 + 2 g wo.wi)^(3/2)) for unit wo, wi. */
double phase_hg_eval(vec3_t wo, vec3_t wi, double g);

/* A direction wi drawn with density phase_hg_eval(wo, wi, g) from uniform u1, u2 in [0, 1]
 * (pbrt-v4 SampleHenyeyGreenstein: the cosine by inversion, a uniform azimuth); *pdf is that
 * density (never NaN). */
vec3_t phase_hg_sample(vec3_t wo, double g, double u1, double u2, double *pdf);

#endif
