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
 * Weights (an approximation of unpolarised transport, docs/physics.md §14.3): the light
 * entering is split into the two eigen-polarisations of the transmitted waves (o: D along
 * k x c, perpendicular to the principal plane; e: D in it), each projected on the s and p
 * directions of the plane of incidence with the share f_s = (D . s)^2; mode m transmits
 * T_m = f_s T_s + (1 - f_s) T_p (isotropic Fresnel at its own index, which for the e-wave
 * is n(theta) along its refracted wave normal). Entering: P(o) = T_o / 2, P(e) = T_e / 2,
 * P(reflect) = 1 - P(o) - P(e). Leaving in mode m: P(exit) = T_m, P(reflect) = 1 - T_m, the
 * reflected wave in the same mode (o -> o, e -> e; no mode conversion at internal reflection),
 * total internal reflection where the tangential wave vector exceeds 1. The sum is 1 exactly
 * (energy is conserved by construction); a branch chosen in proportion to its probability
 * weighs 1 in importance mode, times (n_i / n_t)^2 in radiance mode, n the index of the wave
 * before and after (so that the factors telescope to 1 on any path from outside to outside,
 * e -> e internal reflections included). uniaxial_branch_mueller gives each branch's Mueller
 * matrix in the same approximation, for a polarised transport to use later.
 *
 * Guarantees: directions unit or zero, every probability in [0, 1] summing to 1, every
 * weight finite and >= 0 for finite inputs with n_o, n_e >= 1. */
#ifndef PRISMFARM_UNIAXIAL_H
#define PRISMFARM_UNIAXIAL_H

#include "bsdf_types.h"
#include "polar_frame.h"
#include "stokes.h"
#include "vec3.h"

#include <stdbool.h>

typedef enum uniaxial_wave {
    UNIAXIAL_OUTSIDE = -1, /* in the isotropic outside medium */
    UNIAXIAL_O = 0,        /* the ordinary wave */
    UNIAXIAL_E = 1,        /* the extraordinary wave */
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
    /* The approximation's pieces, for uniaxial_branch_mueller: the Fresnel intensity terms
     * (R or T) for s and p of each contributing mode, and each mode's share f_s. A reflection
     * entering sums both modes (mode 0 o, 1 e); every other branch has one. */
    int nmodes;
    double term_s[2], term_p[2], frac_s[2];
    vec3_t d_after; /* uniaxial_polarisation of the wave afterwards (zero outside) */
} uniaxial_branch_t;

typedef struct uniaxial_event {
    bsdf_mode_t mode;
    int count;   /* lanes */
    bool grey;   /* every lane has lane 0's indices: every lane weighs the same */
    int nbranch; /* entering: reflect, o, e; leaving: reflect, exit */
    uniaxial_branch_t branch[UNIAXIAL_MAX_BRANCHES];
    vec3_t s_dir; /* unit normal of the plane of incidence (the zero vector at normal incidence) */
    vec3_t d_in;  /* uniaxial_polarisation of the wave arriving (zero from outside) */
    double lane_reflect[BSDF_MAX_LANES]; /* each lane's reflection probability */
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
 * factor, times on a reflection lane j's reflection probability over lane 0's. On a refraction
 * of a non-grey event only lane 0 is meaningful (the caller ends the others, as at a dispersive
 * glass). */
double uniaxial_lane_weight(const uniaxial_event_t *e, int b, int j);

/* Branch b's Mueller matrix in the incident light's (s, p) frame under the approximation above
 * (each mode a partial linear polariser along its D after the Fresnel terms); its [0][0] is the
 * branch's probability. For a polarised transport to replace the unpolarised split later. */
mueller_t uniaxial_branch_mueller(const uniaxial_event_t *e, int b);

/* Branch b's Mueller matrix for the light that crosses the interface, in the frames ev
 * (polar/polar_frame.h: polar_event_interface about the event's normal, k_in and k_out the
 * light's directions). In radiance mode the light travels the branch backward (a camera path:
 * from the wave after to the wave before), in importance mode forward. The same magnitudes as
 * uniaxial_branch_mueller, with each mode's polariser at its D's signed angle in the frame of
 * the crystal's side: light leaving a mode (out of the crystal, or reflected inside) is
 * projected on the mode's D and then takes the s and p Fresnel amplitudes; light entering a
 * mode takes them first and is then projected, so that it travels inside in its mode; light
 * reflected outside takes the two modes' sum. No phases (no retardance between s and p, none
 * between o and e). Where a mode's D is undefined (along the axis) it passes half of any
 * state. For unpolarised light its [0][0] is the branch's probability where the light comes
 * from outside; light leaving a mode is taken to be in it (it entered through a projection), so
 * a carrier divides the matrix by the probability, not by its own [0][0]. */
mueller_t uniaxial_branch_mueller_frames(const uniaxial_event_t *e, int b, const polar_event_t *ev);

#endif
