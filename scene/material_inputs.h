/* material_inputs: the parts several material classes (material_class.h) share, so that each
 * is written once. At load time, from the scene description into the material_t: an index of
 * refraction (a number, (wavelength, n) pairs, a spectrum file, a named spectrum, the glass
 * catalogue, Sellmeier or Cauchy terms), a roughness, a conductor's complex index, a coating's
 * medium, a crystal's principal indices. At a hit, from the material_t into a bsdf_t: a
 * texture's value at the surface, a conductor's index, a coating's medium and index. Loading
 * fails with -1 and err naming the scene file's place; the hit-time parts cannot fail. */
#ifndef PRISMFARM_MATERIAL_INPUTS_H
#define PRISMFARM_MATERIAL_INPUTS_H

#include "bsdf.h"
#include "scene.h"
#include "scene_desc.h"

struct loader; /* loader.h: the loading parts are the loader's (material_class.h) */

/* ---- loading ---- */

/* The index of refraction in into *out; material names the material in messages. A tabulated
 * index's pairs are copied into a spectrum the scene owns (the model borrows them). */
int material_inputs_ior(scene_t *sc, const scene_ior_t *in, const char *material, ior_model_t *out,
                        err_t *err);

/* A roughness input: NULL when it is the constant 0 (the smooth case needs no texture). */
int material_inputs_roughness(struct loader *L, const scene_float_input_t *in,
                              const texture_t **out, err_t *err);

/* A conductor's eta and k (or its reflectance, pbrt-v4's alternative); a textured eta or k
 * fails. */
int material_inputs_conductor(struct loader *L, const scene_material_t *dm, material_t *m,
                              err_t *err);

/* A coating's medium (pbrt-v4's LayeredBxDF): thickness, g, albedo, maxdepth, nsamples. */
int material_inputs_layer(struct loader *L, const scene_material_t *dm, material_t *m, err_t *err);

/* A crystal's indices (a uniaxial material's, a retarder plate's): the catalogue's, or the
 * given ones, which replace them. */
int material_inputs_crystal(struct loader *L, const scene_material_t *dm, material_t *m,
                            err_t *err);

/* ---- at a hit ---- */

/* Texture t at the surface point sf (its uv, and its point and normal for pbrt-v4's 3D and
 * direction textures: texture_eval_at). */
double material_inputs_texture(const texture_t *t, const surface_t *sf, double lambda);

/* material_inputs_texture at the n wavelengths lambda[0..n-1] into out, the texture's
 * wavelength-free work done once (texture_eval_lanes). */
void material_inputs_texture_lanes(const texture_t *t, const surface_t *sf, const double *lambda,
                                   int n, double *out);

/* The same, each value clamped to [0, 1] (an albedo). */
void material_inputs_texture_lanes01(const texture_t *t, const surface_t *sf, const double *lambda,
                                     int n, double *out);

/* v clamped to [0, 1]. */
static inline double material_inputs_clamp01(double v)
{
    return v > 0.0 ? (v < 1.0 ? v : 1.0) : 0.0;
}

/* A conductor's (or coated conductor's base) complex index at lambda: its eta and k, or
 * pbrt-v4's reading of a reflectance r (ConductorMaterial): eta 1 and
 * k = 2 sqrt(r) / sqrt(1 - r), r clamped to [0, 0.9999], whose Fresnel reflectance at normal
 * incidence is r; with neither (a scene built in code) a perfect mirror. */
void material_inputs_conductor_index(const material_t *m, const surface_t *sf, double lambda,
                                     double *eta, double *k);

/* A coating's medium at sf into b (thickness, g, maxdepth, nsamples, each lane's albedo), with
 * pbrt-v4's defaults and clamps. */
void material_inputs_layer_at(const material_t *m, const surface_t *sf, const double *lambda, int n,
                              bsdf_t *b);

/* A coating's index at lambda; pbrt-v4 replaces a zero index by 1 (a coating of eta 0 is no
 * coating). */
double material_inputs_coat_eta(const material_t *m, double lambda);

#endif
