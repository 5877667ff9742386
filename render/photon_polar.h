/* photon_polar: polarised photon paths (docs/physics.md §14.3): a photon's Stokes vector per
 * wavelength lane, measured in one frame for all its lanes (they share the direction), through
 * every event the photon pass follows -- smooth dielectrics (coated or not), smooth
 * conductors, polariser and retarder sheets; uniaxial crystals go through
 * render/crystal_scatter.h with the vector this carries. The photon tracer (photon.c) calls it
 * only when the scene carries polarisation (render_settings_t.polarised); without, nothing
 * here runs and photons are what they were, bit for bit.
 *
 * Photons carry flux forward (importance mode), so an element's Mueller matrix M (polar/: the
 * Fresnel matrices of power, the Airy matrices of a coating, a sheet's element) multiplies the
 * Stokes vector S on the left, in the event's frames (polar/polar_frame.h's
 * polar_event_interface and polar_event_sheet for light arriving along the photon's direction):
 * S <- M R S, R the frame change from the photon's frame to the event's (Wilkie & Weidlich,
 * "Polarised Light in Computer Graphics", SIGGRAPH Asia 2016 course, §5). A lane keeps its power
 * w = S0 apart (the photon tracer's weights, which deposits store) and s = S / S0 (s0 = 1)
 * here, so that w is the lane's Stokes S0 at every step and a deposit stores it: the receivers
 * the photon pass stores on (diffuse and glossy) depolarise (docs/physics.md §14).
 *
 * Branch choice: where an event splits the light (reflect or refract), a photon follows one
 * branch with the probability of its power fraction for the photon's own polarisation,
 * (M_b s)_0 -- averaged over the lanes when they differ -- so that polarised light meets glass
 * as it would (p-polarised light at Brewster's angle is never reflected) and a lone lane keeps
 * its power exactly: the flux is conserved wherever the element is lossless. */
#ifndef PRISMFARM_PHOTON_POLAR_H
#define PRISMFARM_PHOTON_POLAR_H

#include "polar_frame.h"
#include "scene.h"

#include <stdbool.h>

/* The most lanes a photon carries (photon.h's PHOTON_MAX_MONOCHROME_RAYS, which photon.c
 * checks against this). */
#define PHOTON_POLAR_MAX_LANES 64

typedef struct photon_polar {
    vec3_t x; /* the lanes' frame: unit, perpendicular to the photon's direction */
    stokes_t s[PHOTON_POLAR_MAX_LANES]; /* each lane's Stokes vector over its S0 */
} photon_polar_t;

/* The polarisation light l emits along unit dir (lights_stokes: partially linearly polarised,
 * or unpolarised) for lanes [0, n), in a frame of its own. */
void photon_polar_emit(photon_polar_t *pp, const light_t *l, vec3_t dir, int n);

/* A diffuse bounce into unit dir: an ideal depolariser, every lane unpolarised (1, 0, 0, 0)
 * in a frame perpendicular to dir; the powers are the caller's. */
void photon_polar_depolarise(photon_polar_t *pp, vec3_t dir, int n);

/* Sheet material m at sf crossed along dir by lanes [0, n) at wavelengths lambda with powers w:
 * a polariser passes (M s)_0 of each (Malus's law: cos^2 of the angle between the light's
 * plane and the axis for linear light, 1/2 for unpolarised), a retarder all. */
void photon_polar_sheet(photon_polar_t *pp, const surface_t *sf, const material_t *m, vec3_t dir,
                        int n, const double *lambda, double *w);

/* A smooth conductor reflecting along `reflect` a photon travelling along dir, about the normal
 * nrm (either side): each lane's complex index (eta[j], k[j]) and, with film not NULL, a
 * coating's Airy matrix over the metal; w[j] *= (M s_j)_0. */
void photon_polar_conductor(photon_polar_t *pp, vec3_t dir, vec3_t reflect, vec3_t nrm,
                            const double *eta, const double *k, const double *lambda,
                            double thickness_nm, const ior_model_t *film_ior, int n, double *w);

/* A smooth dielectric of index n_glass (every lane's: a grey event; outside index 1) at the
 * normal nrm, entering or not: the Fresnel (or, with a coating, Airy) matrices of both branches
 * per lane, reflection chosen with u below the lanes' mean reflectance for their polarisations
 * (1 under total internal reflection), each lane weighed by its own fraction over that
 * probability. *out: the direction followed (the mirror one, or Snell's). */
void photon_polar_dielectric(photon_polar_t *pp, vec3_t dir, vec3_t nrm, bool entering,
                             double n_glass, double thickness_nm, const ior_model_t *film_ior,
                             const double *lambda, int n, double u, double *w, vec3_t *out);

/* The carrier through an event whose Mueller matrix m (m_stride 1: one per lane; 0: one for
 * all) is given in the frames ev: s_j <- m R s_j normalised, w_j *= its S0 (a lane left with
 * no power gets w_j 0), and the frame becomes ev->x_out. */
void photon_polar_apply(photon_polar_t *pp, const polar_event_t *ev, const mueller_t *m,
                        int m_stride, int n, double *w);

#endif
