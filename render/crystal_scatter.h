/* crystal_scatter: a path's event at the surface of a uniaxial crystal (bsdf/uniaxial.h), one
 * rule for the camera pass (radiance mode) and the photon tracer (importance mode): the dichroic
 * absorption along the segment just travelled inside the crystal, the lanes' principal indices,
 * the branch (reflect; refract into the o or e wave; leave; reflect inside into either wave)
 * chosen in proportion to lane 0's
 * probabilities, the lanes' weights, and the wave the path travels in afterwards. Its callers
 * keep only their path policy. Pure: the randomness is the caller's u. */
#ifndef PRISMFARM_CRYSTAL_SCATTER_H
#define PRISMFARM_CRYSTAL_SCATTER_H

#include "bsdf_types.h"
#include "crystal_coherent.h"
#include "material_uniaxial.h"
#include "polar_frame.h"
#include "scene.h"

/* Polarised transport through the event (docs/physics.md §14-15): x, in, the path's frame
 * (the s direction's fallback at normal incidence); ev and m, out, the light's frames and the
 * chosen branch's Mueller matrix (bsdf/uniaxial.h's uniaxial_branch_mueller_frames at lane 0's
 * indices, shared by every lane) divided by the branch's probability, for polar_carrier_apply:
 * the scalar weights carry that probability, and a carrier through the crystal and out again
 * records, for unpolarised light, what they do. */
typedef struct crystal_polar {
    vec3_t x;
    polar_event_t ev;
    mueller_t m;
    /* A photon's polarisation (importance mode; NULL for a camera path): lane 0's Stokes
     * vector in the frame x (photon_polar.h). The branch is then chosen in proportion to its
     * power fraction for that vector, p_b = (M_b R s)_0 over their sum, and m is M_b / p_b:
     * the photon keeps its power. The sum is 1 for any state arriving from outside and for
     * light inside in its wave's polarisation (bsdf/uniaxial.h: the boundary's exact
     * amplitudes); dividing by it guards rounding. */
    const stokes_t *s_in;
    /* A camera path's state through a coherent crystal (material_uniaxial_t.coherent; NULL: its waves
     * are traced apart). Then, out: pending, nothing to apply yet (the path entered or was
     * reflected inside); lanes, when not NULL, one matrix per lane (the traversal's, applied
     * as it leaves) instead of m for all. */
    crystal_coherent_t *coh;
    int pending;
    const mueller_t *lanes;
} crystal_polar_t;

/* The crystal's optic axis in world space at hit h: the material's (turned with its shape by the
 * loader) and, for an instanced object's shape, further by the instance's transform (an object
 * placed turned turns its crystal's axis with it). */
vec3_t crystal_axis(const scene_t *scene, const hit_t *h, const material_t *m);

/* m: a material with a crystal record (material_uniaxial_of(m) not NULL); sf: the hit; axis: crystal_axis's; org, dir: the ray that reached
 * it (org where the last segment started, for the absorption inside); *wave: the wave the path
 * travels in inside the crystal (UNIAXIAL_O or UNIAXIAL_E; read only when the hit is from inside),
 * updated. Lanes [0, n) at wavelengths lambda with throughputs weight, multiplied in place.
 * On a refraction whose lanes' indices differ, only lane 0 can follow (its direction is lane
 * 0's): its weight takes the lane count and *end_secondaries is set, and the caller ends the
 * other lanes (pbrt-v4's TerminateSecondary, as at a dispersive glass). *out: the direction
 * to follow. pol: NULL without polarisation (then nothing else differs), else filled as above.
 * Returns 1 when the path carries nothing on (every weight 0), else 0. */
int crystal_scatter(const material_t *m, const surface_t *sf, vec3_t axis, vec3_t org, vec3_t dir,
                    int *wave, int n, const double *lambda, double *weight, bsdf_mode_t mode,
                    double u, vec3_t *out, int *end_secondaries, crystal_polar_t *pol);

#endif
