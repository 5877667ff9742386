/* photon_volume: the participating media's part of the photon integrator (docs/physics.md
 * §12, "Media and the photon pass"): which medium a photon starts in, and the camera pass's
 * volume radiance estimate from the store's volume photons (photon_store_volume_gather) at a
 * scattering point. The photon tracer (photon.h) flies photons through media with volume.h,
 * the same free-flight code as the camera pass, and stores them at their first scattering
 * after a specular chain. Deterministic: results depend only on the scene, the store and the
 * arguments. */
#ifndef PRISMFARM_PHOTON_VOLUME_H
#define PRISMFARM_PHOTON_VOLUME_H

#include "photon_store.h"
#include "scene.h"

/* The medium (index into scene->media, -1: vacuum) at point org, as the scene's medium
 * boundaries say: the medium on org's side of the first boundary shape (inside != outside)
 * that a ray from org meets, passing every other surface, along -dir, then dir, then the six
 * axis directions; the camera's medium where no ray meets a boundary (a scene whose only
 * medium is the camera's, or none). Lights carry no medium of their own here (pbrt-v4's
 * lights take the MediumInterface in effect where they are defined): this finds the same one
 * wherever the boundaries enclose the light. */
int photon_volume_medium_at(const scene_t *scene, vec3_t org, vec3_t dir);

/* Jensen's volume radiance estimate (Jensen & Christensen 1998; Jensen 2001 eq. 10.2) at the
 * camera path's scattering point x, toward wo (unit, pointing away from x, at the camera), in a
 * medium of Henyey-Greenstein g: for each lane j of bucket bucket[j] (< 0: none),
 *   L[j] = sum over the volume photons p of that bucket within r of x of
 *          p_HG(wo, -dir_p) Phi_p / sigma_s,p  /  (N_emitted * bucket width * 4/3 pi r^3),
 * the in-scattered radiance L_s(x, wo) = int p L_i, which the camera path's throughput (its
 * scattering weight includes sigma_s) multiplies. Returns 1 when a photon was found, else 0
 * with L zeroed. n lanes, at most 64. */
int photon_volume_radiance(const photon_store_t *store, vec3_t x, vec3_t wo, double g, int n,
                           const int *bucket, double *L);

#endif
