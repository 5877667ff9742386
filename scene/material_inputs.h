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

#include <stdbool.h>

struct material_params; /* material_params.h: the loading parts are the loader's */

/* ---- loading: reading a class's parameters (material_params.h) into the material_t ---- */

/* An index of refraction as a scene writes it (a desc-form value, checked; material_inputs_ior
 * makes the model). */
typedef enum scene_ior_kind {
    SCENE_IOR_SPECTRUM,  /* "float eta" 1.5 or "spectrum eta" "glass-BK7" or (lambda, n) pairs */
    SCENE_IOR_GLASS,     /* extension "string glass" "N-BK7": a catalogue name */
    SCENE_IOR_SELLMEIER, /* extension "float sellmeier" [B1 C1 B2 C2 ...], C in um^2 */
    SCENE_IOR_CAUCHY,    /* extension "float cauchy" [A B]: n = A + B / lambda_um^2 */
} scene_ior_kind_t;

typedef struct scene_ior {
    scene_ior_kind_t kind;
    scene_spectrum_t spectrum; /* SPECTRUM */
    const char *glass;         /* GLASS */
    size_t nterms;             /* SELLMEIER: number of (B, C) pairs */
    const double *sellmeier;   /* SELLMEIER: B1 C1 B2 C2 ... */
    double cauchy[2];          /* CAUCHY: A, B (B in um^2) */
    pbrt_loc_t loc;
} scene_ior_t;

/* The index "<prefix>eta" (pbrt-v4; default 1.5) or prismfarm's "<prefix>glass",
 * "<prefix>sellmeier", "<prefix>cauchy", at most one of them, as written. */
int material_inputs_read_ior(struct material_params *mp, const char *prefix, scene_ior_t *out);

/* The index of refraction in into *out; material names the material in messages. A tabulated
 * index's pairs are copied into a spectrum the scene owns (the model borrows them). */
int material_inputs_ior(scene_t *sc, const scene_ior_t *in, const char *material, ior_model_t *out,
                        err_t *err);

/* Both: "<prefix>eta" or its forms into *out. */
int material_inputs_load_ior(struct material_params *mp, const char *prefix, ior_model_t *out);

/* pbrt-v4's roughness: "<prefix>uroughness" and "<prefix>vroughness" over "<prefix>roughness"
 * (0), none negative, into *u and *v as written (for material_inputs_smoothness) and into the
 * textures *tu and *tv (NULL for the constant 0: the smooth case needs no texture). */
int material_inputs_load_roughness(struct material_params *mp, const char *prefix,
                                   scene_float_input_t *u, scene_float_input_t *v,
                                   const texture_t **tu, const texture_t **tv);

/* "bool remaproughness" (true) into m. */
int material_inputs_load_remap(struct material_params *mp, material_t *m);

/* m->smooth and m->rough for a constant roughness (u, v): what pbrt-v4 calls effectively smooth
 * (the delta code everywhere) or not (nowhere); neither when a texture decides per hit. */
void material_inputs_smoothness(material_t *m, const scene_float_input_t *u,
                                const scene_float_input_t *v);

/* A conductor's complex index ("<prefix>eta", "<prefix>k": default metal-Cu) or its
 * "reflectance", pbrt-v4's alternative (not both); a textured eta or k fails. */
int material_inputs_load_conductor(struct material_params *mp, const char *prefix, material_t *m);

/* A coating's medium (pbrt-v4's LayeredBxDF), which both coated classes keep in their record:
 * textures NULL and counts 0 where a coating built in code gives none (the defaults then). */
typedef struct material_layer {
    const texture_t *thickness, *albedo, *g;
    int maxdepth, nsamples;
} material_layer_t;

/* A coating's medium: "thickness" (0.01), "g" (0), "albedo" (0), "maxdepth" (10),
 * "nsamples" (1). */
int material_inputs_load_layer(struct material_params *mp, material_layer_t *layer);

/* prismfarm's thin film on smooth glass or metal: "filmthickness" in nm (0: none) of index
 * "filmeta" (1.33). */
int material_inputs_load_film(struct material_params *mp, material_t *m);

/* Whether the parameters name a crystal or an "o." or "e." index (a retarder's plate mode). */
bool material_inputs_names_crystal(struct material_params *mp);

/* A crystal's principal indices (a uniaxial material's, a retarder plate's): "string crystal"
 * from the catalogue, or both indices with the "o." and "e." prefixes of
 * material_inputs_read_ior, which replace the catalogue's; what names the material kind in
 * messages. */
int material_inputs_load_crystal(struct material_params *mp, const char *what, crystal_t *out);

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
 * pbrt-v4's defaults and clamps (all of them for a NULL layer). */
void material_inputs_layer_at(const material_layer_t *layer, const surface_t *sf,
                              const double *lambda, int n, bsdf_t *b);

/* A coating's index at lambda; pbrt-v4 replaces a zero index by 1 (a coating of eta 0 is no
 * coating). */
double material_inputs_coat_eta(const material_t *m, double lambda);

#endif
