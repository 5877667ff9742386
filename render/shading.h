/* shading: what a material is at one hit, for the camera pass (render.c) and the photon pass
 * (photon.c) alike, so that both passes see the same surface: which of a mix's two materials
 * applies, whether the surface is a delta event there (a smooth mirror or glass, handled by
 * the specular code and the thesis's fan-out), and, for every other surface, its bsdf/ model
 * with each lane's parameters at the lane's wavelength. */
#ifndef PRISMFARM_SHADING_H
#define PRISMFARM_SHADING_H

#include "bsdf.h"
#include "rng.h"
#include "scene.h"

/* The material that applies at sf: m itself, or for a mix the one its amount chooses with the
 * uniform u (pbrt-v4's MixMaterial: the second with probability amount, clamped to [0, 1]),
 * repeated through nested mixes. Never returns a mix. */
const material_t *shading_resolve(const scene_t *scene, const material_t *m, const surface_t *sf,
                                  double u);

/* Texture t at the surface point sf (its uv, and its point and normal for pbrt-v4's 3D and
 * direction textures: texture_eval_at). */
double shading_texture(const texture_t *t, const surface_t *sf, double lambda);
/* shading_texture at the n wavelengths lambda[0..n-1] into out: the same values, with the
 * texture's wavelength-free work (an image's texel addresses) done once (texture_eval_lanes). */
void shading_texture_lanes(const texture_t *t, const surface_t *sf, const double *lambda, int n,
                           double *out);

/* A smooth conductor or dielectric at sf (its roughness, textured or not, is below pbrt-v4's
 * EffectivelySmooth there): the delta code applies. */
int shading_is_delta(const material_t *m, const surface_t *sf);

/* Fills *b for material m (not a mix, not interface; any roughness) at sf for the n lanes'
 * wavelengths, in radiance or importance mode: the microfacets and thin film every kind
 * shares, then the rest from m's class (scene/material_class.h). */
void shading_bsdf(const material_t *m, const surface_t *sf, const double *lambda, int n,
                  bsdf_mode_t mode, bsdf_t *b);

/* A conductor's (or coated conductor's base) complex index at lambda: its eta and k, or
 * pbrt-v4's reading of a reflectance r (ConductorMaterial): eta 1 and
 * k = 2 sqrt(r) / sqrt(1 - r), r clamped to [0, 0.9999], whose Fresnel reflectance at normal
 * incidence is r. */
void shading_conductor_index(const material_t *m, const surface_t *sf, double lambda, double *eta,
                             double *k);

/* pbrt-v4's BumpMap and NormalMap (materials.h) for material m (not a mix) at sf: with a
 * normal map, ns becomes the map's tangent-space normal in the frame (dp/du, ns x dp/du, ns);
 * with a displacement texture d, dp/du + (d(u + du, v) - d(u, v)) / du ns and likewise in v,
 * du = dv = 0.0005 (pbrt-v4's step without ray differentials; its d dn/du term, the
 * displacement times the normal's own change, is left out), and ns their normalised cross
 * product. Either way ns is turned to ng's side (pbrt-v4 SetShadingGeometry), dp/du and dp/dv
 * follow and sf->smooth is set, so that every material, the diffuse one and the delta code
 * included, shades with it. Nothing is done (a pointer test) when m has neither. Call it once
 * per hit, after scene_surface and shading_resolve, in the camera and photon passes alike. A
 * hair fibre (no maps: pbrt-v4 has none for it) gets ng as its shading normal. */
void shading_perturb(const material_t *m, surface_t *sf);

/* pbrt-v4's alpha test (GeometricPrimitive::Intersect) at a hit sf reached along org + t dir:
 * 1 when the ray passes the surface as if it were not there, which it does where the shape's
 * alpha a is <= 0, and where 0 < a < 1 when a hash of the ray (uniform in [0, 1), the same
 * for the same ray) exceeds a, so with probability 1 - a, deterministically per sample. */
int shading_alpha_pass(const surface_t *sf, vec3_t org, vec3_t dir);

/* geometry_occluded that lets a shadow ray through the cut-outs of shapes with an alpha and
 * through "interface" shapes (by re-tracing from each surface it passes, at most a few
 * hundred); plain geometry_occluded when the scene has neither. */
int shading_occluded(const scene_t *scene, vec3_t org, vec3_t dir, double tmin, double tmax);

/* shading_occluded's rule with participating media (render/volume.h): the shadow ray from org
 * along dir (unit) over [0, tmax) starts in medium `medium` (an index into scene->media, -1:
 * vacuum), passes cut-outs and "interface" shapes (changing medium where a shape separates
 * two, scene_medium_after) and is blocked by any other surface. Returns 0 when blocked or
 * when every lane's transmittance is 0; else 1 with T[j] lane j's transmittance estimate
 * (unbiased, finite, >= 0) for the n wavelengths lambda. */
int shading_transmittance(const scene_t *scene, vec3_t org, vec3_t dir, double tmax, int medium,
                          const double *lambda, int n, rng_stream_t *rng, double *T);

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
