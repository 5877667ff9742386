/* uniaxial: a smooth interface between an isotropic outside (index 1) and a uniaxial
 * birefringent crystal (ordinary index n_o, extraordinary n_e, optic axis c), as delta lobes
 * for a path's spectral lanes, in radiance or importance mode (bsdf/delta.h's sibling).
 *
 * Physics (docs/physics.md §15; Born & Wolf, Principles of Optics, §15.3; Yariv & Yeh, Optical
 * Waves in Crystals, ch. 4): the ordinary wave obeys Snell's law with n_o; the extraordinary
 * wave's index depends on the angle theta between its wave normal k and c,
 *   1 / n(theta)^2 = cos^2 theta / n_o^2 + sin^2 theta / n_e^2,
 * the tangential component of the wave vector is continuous across the interface, and energy
 * flows along the ray (Poynting) direction s, tan theta_s = (n_o^2 / n_e^2) tan theta in the
 * plane of k and c, which differs from k by the walk-off angle. Paths travel along s; at every
 * crystal interface the caller says which wave (o or e) the path is inside and the wave normal
 * is recovered from s.
 *
 * Weights (docs/physics.md §15.1): the exact plane-wave amplitudes of the boundary
 * (polar/uniaxial_fresnel.h: tangential E and H continuous). Entering, unpolarised light (the
 * mean of s and p) splits into the reflected light and the o and e waves by their power
 * fractions. Inside, the light is in its wave's polarisation, so a wave reaching the surface
 * splits exactly into the light leaving, the o wave reflected and the e wave reflected (mode
 * conversion: each reflected wave with its own direction, the tangential wave vector
 * conserved), total internal reflection where no outside wave propagates. A branch chosen in
 * proportion to lane 0's power fraction weighs 1 in importance mode, times (n_i / n_t)^2 in
 * radiance mode, n the index of the wave before and after (the factors telescope to 1 on any
 * path from outside to outside, converted reflections included). uniaxial_branch_mueller_frames
 * gives each branch's Mueller matrix from the same amplitudes, phases included.
 *
 * Guarantees: directions unit or zero, every probability in [0, 1] summing to 1, every
 * weight finite and >= 0 for finite inputs with n_o, n_e >= 1. */
#ifndef PRISMFARM_UNIAXIAL_H
#define PRISMFARM_UNIAXIAL_H

#include "bsdf_types.h"
#include "polar_frame.h"
#include "stokes.h"
#include "uniaxial_fresnel.h"
#include "vec3.h"

#include <stdbool.h>

typedef enum uniaxial_wave {
    UNIAXIAL_OUTSIDE = -1, /* in the isotropic outside medium */
    UNIAXIAL_O = 0,        /* the ordinary wave */
    UNIAXIAL_E = 1,        /* the extraordinary wave */
    UNIAXIAL_COHERENT = 2, /* both, as one ray (render/crystal_coherent.h); never an event's */
} uniaxial_wave_t;

/* The extraordinary index along a wave normal at angle theta to the optic axis:
 * 1 / n^2 = cos^2 theta / n_o^2 + sin^2 theta / n_e^2 (n_o at 0, n_e at 90 degrees). */
double uniaxial_e_index(double no, double ne, double cos_theta);

/* The index of wave w along the unit wave normal k (axis unit). */
double uniaxial_index(uniaxial_wave_t w, vec3_t k, vec3_t axis, double no, double ne);

/* The unit ray (energy) direction of wave w whose wave normal is k: k itself for o; for e
 * s ~ k_perp / n_e^2 + k_par / n_o^2 (the normal to the index ellipsoid). */
vec3_t uniaxial_ray_from_wave(uniaxial_wave_t w, vec3_t k, vec3_t axis, double no, double ne);

/* The inverse: the unit wave normal of wave w travelling along the ray s,
 * k ~ n_e^2 s_perp + n_o^2 s_par. */
vec3_t uniaxial_wave_from_ray(uniaxial_wave_t w, vec3_t s, vec3_t axis, double no, double ne);

/* The walk-off angle (radians, >= 0) between the e-wave's normal and its ray at angle theta
 * from the axis: atan((n_o^2 / n_e^2) tan theta) - theta in magnitude. */
double uniaxial_walkoff(double no, double ne, double theta);

/* The absorption coefficient of wave w along k from the principal ones (any unit): alpha_o for
 * o, alpha_o cos^2 theta + alpha_e sin^2 theta for e (the weak-absorption limit of the
 * complex index ellipsoid). */
double uniaxial_absorption(uniaxial_wave_t w, vec3_t k, vec3_t axis, double alpha_o,
                           double alpha_e);

/* The line of the electric displacement D of wave w along the unit wave normal k: o along
 * k x c (perpendicular to the principal plane), e along (k x c) x k (in it, perpendicular to
 * k). Unit, its sign meaningless; the zero vector where k is along the axis (the principal
 * plane undefined: both waves alike) or w is UNIAXIAL_OUTSIDE. */
vec3_t uniaxial_polarisation(uniaxial_wave_t w, vec3_t k, vec3_t axis);

#define UNIAXIAL_MAX_BRANCHES 3

typedef struct uniaxial_branch {
    vec3_t dir;            /* the ray direction the path follows */
    vec3_t wave;           /* its wave normal (dir itself outside and for o) */
    uniaxial_wave_t after; /* the wave the path is in afterwards */
    bool reflects;         /* back to the side the ray came from */
    double prob;           /* lane 0's share of the energy */
    double factor;         /* radiance mode (n_i / n_t)^2, importance 1 */
    double n_after;        /* the index of the wave afterwards (1 outside) */
} uniaxial_branch_t;

typedef struct uniaxial_event {
    bsdf_mode_t mode;
    int count;   /* lanes */
    bool grey;   /* every lane has lane 0's indices: every lane weighs the same */
    int nbranch; /* entering: reflect, o, e; leaving: reflect in the same wave, exit, reflect
                    converted into the other wave */
    uniaxial_branch_t branch[UNIAXIAL_MAX_BRANCHES];
    uniaxial_wave_t before; /* the wave arriving (UNIAXIAL_OUTSIDE entering) */
    vec3_t m;               /* the unit normal from the crystal toward the outside */
    vec3_t t;               /* the tangential wave vector (units of the vacuum wavenumber) */
    vec3_t axis;
    double no, ne;           /* lane 0's principal indices */
    uniaxial_fresnel_t fres; /* lane 0's boundary amplitudes */
    /* The inputs, for the other lanes' shares (computed when a reflection asks for them:
     * refraction goes on with lane 0 alone, and each lane costs a boundary solve). */
    vec3_t dir_in, nrm;
    bool entering;
    uniaxial_wave_t inside;
    double lane_no[BSDF_MAX_LANES], lane_ne[BSDF_MAX_LANES];
} uniaxial_event_t;

/* One crossing of the crystal's surface by a ray travelling along dir toward it, about the
 * unit normal nrm (either side). entering: the ray comes from outside; else it travels inside
 * as wave `inside` (O or E). no[j], ne[j]: lane j's principal indices (count lanes; lane 0
 * decides the directions, as the hero does). axis: the unit optic axis in the same space. */
void uniaxial_event_make(vec3_t dir, vec3_t nrm, bool entering, uniaxial_wave_t inside, vec3_t axis,
                         const double *no, const double *ne, int count, bsdf_mode_t mode,
                         uniaxial_event_t *e);

/* The branch a uniform u in [0, 1) picks in proportion to lane 0's probabilities. */
int uniaxial_choose(const uniaxial_event_t *e, double u);

/* Lane j's factor on branch b after b was chosen with uniaxial_choose: the branch's radiance
 * factor, times on a reflection lane j's probability of that branch over lane 0's (a boundary
 * solve at lane j's indices, made here). On a refraction
 * of a non-grey event only lane 0 is meaningful (the caller ends the others, as at a dispersive
 * glass). */
double uniaxial_lane_weight(const uniaxial_event_t *e, int b, int j);

/* Branch b's Mueller matrix for the light that crosses the interface, in the frames ev
 * (polar/polar_frame.h: polar_event_interface about the event's normal, k_in and k_out the
 * light's directions), from lane 0's exact amplitudes (uniaxial_fresnel_jones; phases
 * included). In radiance mode the light travels the branch backward (a camera path: from the
 * wave after to the wave before; the boundary solved again for the reversed waves), in
 * importance mode forward. Light leaving a crystal wave is projected on that wave's field (it
 * is in that wave), so for light in the wave the power passed is the branch's probability; for
 * light from outside [0][0] is the probability (unpolarised light). A carrier divides by the
 * probability. */
mueller_t uniaxial_branch_mueller_frames(const uniaxial_event_t *e, int b, const polar_event_t *ev);

/* The same in the event's own s-p frames (x = s = k_in x n), importance mode: the light
 * travels the path's way. */
mueller_t uniaxial_branch_mueller(const uniaxial_event_t *e, int b);

#endif
