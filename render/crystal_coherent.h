/* crystal_coherent: a camera path through a thin uniaxial crystal ("bool coherent") whose
 * ordinary and extraordinary waves cross it as one ray, with their relative phase -- and, in an
 * optically active crystal (quartz), the turning of the plane of polarisation -- carried, so that
 * a plate between polarisers shows its interference colours (the Michel-Levy chart) and a
 * quartz plate cut across its axis turns linear light (docs/physics.md §15.2).
 *
 * The path runs against the light, and a traversal's Mueller matrix is only known once the
 * light's whole route through the crystal is: the state holds, per lane, the Jones matrix from
 * the two waves at the path's current vertex inside to the field leaving the crystal, in the
 * basis of the waves (polar/jones.h), and multiplies on the segment's propagation and each
 * internal reflection (both waves into both: mode conversion) until the path leaves; then the
 * product's Mueller matrix goes to the carrier at once. Each lane has its own indices, phases
 * and boundary amplitudes; every lane follows lane 0's mean ray (the mean of its o and e ray
 * directions: the walk-off and the lanes' spread are taken as below a pixel, which is what
 * "coherent" asserts). Branches (reflect or leave) are chosen with lane 0's unpolarised
 * transmittance and divided out of the matrices, so scalar weights are untouched.
 *
 * Guarantees: every matrix finite; the estimate is unbiased for the model (incoherent between
 * different numbers of internal reflections: no multiple-beam fringes); energy is conserved
 * (each boundary's power-normalised matrices are lossless). Pure: randomness is the caller's u. */
#ifndef PRISMFARM_CRYSTAL_COHERENT_H
#define PRISMFARM_CRYSTAL_COHERENT_H

#include "bsdf_types.h"
#include "jones.h"
#include "polar_frame.h"
#include "scene.h"

typedef struct crystal_coherent {
    int n;                        /* lanes */
    jones_t j[BSDF_MAX_LANES];    /* field leaving the crystal <- waves at the current vertex */
    mueller_t mm[BSDF_MAX_LANES]; /* the traversal's matrices once the path has left */
    double prob;                  /* product of the branch probabilities so far */
    vec3_t k_exit, x_exit;        /* the light leaving the crystal, and its frame */
    vec3_t k_seg;                 /* lane 0's inner wave's K (light's way) on the segment */
    vec3_t hint;                  /* the s direction at normal incidence */
} crystal_coherent_t;

/* The path, travelling along dir from outside, has entered a coherent crystal (chosen with
 * probability prob, lane 0's transmittance) at a face with unit outward normal m; x: the path's
 * polarisation frame. Lanes [0, n) with principal indices no, ne. Sets *out (the mean ray on
 * which the path goes on). */
void crystal_coherent_enter(crystal_coherent_t *c, vec3_t axis, vec3_t dir, vec3_t m, int n,
                            const double *no, const double *ne, double prob, vec3_t x, vec3_t *out);

/* The path, inside since the vertex org, reaches the crystal's face at p (unit outward normal
 * m) travelling along dir; lanes at wavelengths lambda (nm) with indices no, ne. u picks leave
 * or reflect. On reflection returns 0 with *out the new mean ray; on leaving returns 1 with *out
 * the direction outside, *ev the traversal's frames and c->mm[j] its Mueller matrices, divided
 * by the branch probabilities, for polar_carrier_apply. */
int crystal_coherent_inside(crystal_coherent_t *c, const material_t *mat, vec3_t axis, vec3_t org,
                            vec3_t p, vec3_t m, const double *lambda, const double *no,
                            const double *ne, double u, vec3_t *out, polar_event_t *ev);

#endif
