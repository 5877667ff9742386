/* crystal_scatter: a path's event at the surface of a uniaxial crystal (bsdf/uniaxial.h), one
 * rule for the camera pass (radiance mode) and the photon tracer (importance mode): the dichroic
 * absorption along the segment just travelled inside the crystal, the lanes' principal indices,
 * the branch (reflect; refract into the o or e wave; leave) chosen in proportion to lane 0's
 * probabilities, the lanes' weights, and the wave the path travels in afterwards. Its callers
 * keep only their path policy. Pure: the randomness is the caller's u. */
#ifndef PRISMFARM_CRYSTAL_SCATTER_H
#define PRISMFARM_CRYSTAL_SCATTER_H

#include "bsdf_types.h"
#include "scene.h"

/* m: a material with m->uniaxial; sf: the hit; org, dir: the ray that reached it (org where
 * the last segment started, for the absorption inside); *wave: the wave the path travels in
 * inside the crystal (UNIAXIAL_O or UNIAXIAL_E; read only when the hit is from inside),
 * updated. Lanes [0, n) at wavelengths lambda with throughputs weight, multiplied in place.
 * On a refraction whose lanes' indices differ, only lane 0 can follow (its direction is lane
 * 0's): its weight takes the lane count and *end_secondaries is set, and the caller ends the
 * other lanes (pbrt-v4's TerminateSecondary, as at a dispersive glass). *out: the direction
 * to follow. Returns 1 when the path carries nothing on (every weight 0), else 0. */
int crystal_scatter(const material_t *m, const surface_t *sf, vec3_t org, vec3_t dir, int *wave,
                    int n, const double *lambda, double *weight, bsdf_mode_t mode, double u,
                    vec3_t *out, int *end_secondaries);

#endif
