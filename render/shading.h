/* shading: what a material is at one hit, for the camera pass (render.c) and the photon pass
 * (photon.c) alike, so that both passes see the same surface: which of a mix's two materials
 * applies, whether the surface is a delta event there (a smooth mirror or glass, handled by
 * the specular code and the thesis's fan-out), and, for every other surface, its bsdf/ model
 * with each lane's parameters at the lane's wavelength. */
#ifndef PRISMFARM_SHADING_H
#define PRISMFARM_SHADING_H

#include "bsdf.h"
#include "scene.h"

/* The material that applies at sf: m itself, or for a mix the one its amount chooses with the
 * uniform u (pbrt-v4's MixMaterial: the second with probability amount, clamped to [0, 1]),
 * repeated through nested mixes. Never returns a mix. */
const material_t *shading_resolve(const scene_t *scene, const material_t *m, const surface_t *sf,
                                  double u);

/* A smooth conductor or dielectric at sf (its roughness, textured or not, is below pbrt-v4's
 * EffectivelySmooth there): the delta code applies. */
int shading_is_delta(const material_t *m, const surface_t *sf);

/* Fills *b for material m (not a mix, not diffuse, not interface; any roughness) at sf for
 * the n lanes' wavelengths, in radiance or importance mode. */
void shading_bsdf(const material_t *m, const surface_t *sf, const double *lambda, int n,
                  bsdf_mode_t mode, bsdf_t *b);

/* A conductor's (or coated conductor's base) complex index at lambda: its eta and k, or
 * pbrt-v4's reading of a reflectance r (ConductorMaterial): eta 1 and
 * k = 2 sqrt(r) / sqrt(1 - r), r clamped to [0, 0.9999], whose Fresnel reflectance at normal
 * incidence is r. */
void shading_conductor_index(const material_t *m, const surface_t *sf, double lambda, double *eta,
                             double *k);

/* The local shading frame at sf for outgoing direction wo: z the shading normal (outward),
 * x and y a tangent basis. Where wo lies on different sides of the shading and the geometric
 * normal (near a smooth mesh's silhouette) z is the geometric normal, as specular_normal
 * decides for the delta events. */
typedef struct shading_frame {
    vec3_t x, y, z;
} shading_frame_t;

shading_frame_t shading_frame_make(const surface_t *sf, vec3_t wo);
vec3_t shading_to_local(const shading_frame_t *f, vec3_t w);
vec3_t shading_to_world(const shading_frame_t *f, vec3_t w);

#endif
