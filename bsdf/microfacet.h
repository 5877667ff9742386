/* microfacet: the Trowbridge-Reitz (GGX) distribution of microfacet normals, anisotropic, in
 * a local shading frame (z is the macro normal, x the u direction), with sampling of the
 * normals visible from a direction (Heitz 2018, "Sampling the GGX Distribution of Visible
 * Normals"). pbrt-v4's TrowbridgeReitzDistribution is the reference for what each value means
 * (its RoughnessToAlpha and EffectivelySmooth included). Every function returns a finite value
 * for any unit input, at grazing angles and for alpha down to 1e-4 (and 0 for alpha = 0 is
 * never asked: such a surface is smooth and takes the delta path). */
#ifndef PRISMFARM_MICROFACET_H
#define PRISMFARM_MICROFACET_H

#include "vec3.h"

#include <stdbool.h>

/* Below this alpha (both axes) a surface is treated as perfectly smooth (pbrt-v4: 1e-3). */
#define MICROFACET_SMOOTH_ALPHA 1e-3

typedef struct microfacet {
    double alpha_x, alpha_y;
} microfacet_t;

/* pbrt-v4's RoughnessToAlpha: alpha = sqrt(roughness) ("remaproughness" true). */
double microfacet_roughness_to_alpha(double roughness);

/* The distribution for a material's u/v roughness, remapped or not; negative or non-finite
 * roughness is taken as 0. */
microfacet_t microfacet_make(double uroughness, double vroughness, bool remap);

/* Both alphas below MICROFACET_SMOOTH_ALPHA: the surface is a perfect mirror or refractor. */
bool microfacet_smooth(const microfacet_t *m);

/* D(wm): density of microfacet normals (per projected area; integrates D(wm) cos(wm) = 1). */
double microfacet_d(const microfacet_t *m, vec3_t wm);
/* Smith's Lambda(w), masking G1(w) = 1 / (1 + Lambda(w)), and the height-correlated
 * masking-shadowing G(wo, wi) = 1 / (1 + Lambda(wo) + Lambda(wi)). */
double microfacet_lambda(const microfacet_t *m, vec3_t w);
double microfacet_g1(const microfacet_t *m, vec3_t w);
double microfacet_g(const microfacet_t *m, vec3_t wo, vec3_t wi);
/* D_w(wm) = G1(w) / |cos w| D(wm) max(0, w . wm): the density of normals visible from w,
 * which is also the pdf of microfacet_sample_wm. A w below the plane is first flipped to +z
 * (as microfacet_sample_wm does), so wm is always on the +z side. */
double microfacet_pdf(const microfacet_t *m, vec3_t w, vec3_t wm);
/* A visible normal for direction w (on either side: the normal returned is on w's side of
 * the macro surface's plane flipped to +z as pbrt-v4 does) from two uniforms in [0, 1). */
vec3_t microfacet_sample_wm(const microfacet_t *m, vec3_t w, double u1, double u2);

#endif
