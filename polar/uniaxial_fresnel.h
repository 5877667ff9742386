/* uniaxial_fresnel: the exact amplitudes of the plane waves at a smooth boundary between an
 * isotropic outside medium (real index n1) and a uniaxial crystal (n_o, n_e, optic axis c): for
 * each incident wave -- from outside s or p, from inside the ordinary (o) or extraordinary (e)
 * wave -- the complex amplitudes and power fractions of the four waves leaving the boundary:
 * outside s and p (reflected or transmitted) and inside o and e (transmitted or reflected). An
 * o or e wave reflected inside the crystal feeds both reflected modes (mode conversion), each
 * with its own direction.
 *
 * Physics (docs/physics.md §15.1): every wave has the same tangential wave vector t (Snell's
 * law, in units of the vacuum wavenumber); the crystal's waves are K = t + beta m on the index
 * surface (o: |K| = n_o; e: (K.c)^2 (1/n_o^2 - 1/n_e^2) + |K|^2/n_e^2 = 1), with fields
 * E_o ~ K x c and E_e ~ n_o^2 c - (K.c) K (the eigenvectors of Maxwell's wave equation
 * K x (K x E) + eps E = 0, eps = n_o^2 I + (n_e^2 - n_o^2) c c^T), H ~ K x E; the tangential
 * E and H are continuous, four linear equations in the four outgoing amplitudes (Born & Wolf,
 * Principles of Optics, 7th ed., §1.5 and §15.3; P. Yeh, JOSA 69, 742 (1979), §II;
 * J. Lekner, J. Phys.: Condens. Matter 3, 6121 (1991)); power fractions are the normal
 * components of the time-averaged Poynting vector Re(E x H*) . m. Evanescent waves (beyond a
 * critical angle, complex beta decaying away from the boundary) take part in the fields and
 * carry no power.
 *
 * Guarantees: for real indices >= 1 and |t| below every incident wave's index the power
 * fractions of each propagating incident wave sum to 1 (a lossless boundary, to rounding) and
 * satisfy reciprocity; every result is finite; ok is false only for a degenerate system (then
 * the caller keeps the light in its wave). */
#ifndef PRISMFARM_UNIAXIAL_FRESNEL_H
#define PRISMFARM_UNIAXIAL_FRESNEL_H

#include "vec3.h"

#include <complex.h>
#include <stdbool.h>

/* The waves at the boundary, incident or outgoing: the outside medium's s and p (s along the
 * unit vector s_dir perpendicular to the plane of incidence, p = k x s) and the crystal's modes. */
enum { UF_S = 0, UF_P = 1, UF_O = 2, UF_E = 3, UF_WAVES = 4 };
#define UF_ALL 15u /* every incident wave (bit 1 << UF_S ...) */

typedef struct uniaxial_fresnel_wave {
    double complex K[3]; /* wave vector in units of the vacuum wavenumber */
    double complex E[3]; /* unit electric field (sum of |E_i|^2 = 1); real when propagating */
    double flux;         /* Re((E x H*) . m), H = K x E: power across the boundary, along m */
    bool propagating;    /* a real K (an evanescent wave carries no power) */
} uniaxial_fresnel_wave_t;

typedef struct uniaxial_fresnel {
    /* incident: outside toward the crystal (s, p), inside toward the outside (o, e); outgoing:
     * outside away from the crystal (s, p), inside into the crystal (o, e). */
    uniaxial_fresnel_wave_t in[UF_WAVES], out[UF_WAVES];
    double complex amp[UF_WAVES][UF_WAVES]; /* [incident][outgoing] field amplitudes, unit E in */
    double power[UF_WAVES][UF_WAVES]; /* |amp|^2 |flux_out| / |flux_in|; 0 unless both propagate */
    bool ok;
} uniaxial_fresnel_t;

/* Solves the boundary with unit normal m (from the crystal toward the outside), tangential
 * wave vector t (perpendicular to m), unit optic axis, principal indices no, ne and outside
 * index n1. s_hint: the s direction where t = 0 (made perpendicular to m); else s = t x m
 * normalised. */
void uniaxial_fresnel_solve(vec3_t t, vec3_t m, vec3_t axis, double no, double ne, double n1,
                            vec3_t s_hint, uniaxial_fresnel_t *f);

/* The same for the incident waves in the bit mask incident (1u << UF_S | ...) only: the other
 * rows of amp and power are zero and their in[] waves unset. A solved row equals
 * uniaxial_fresnel_solve's bit for bit (each incident wave is its own right-hand side); an
 * event that needs only the light arriving in one wave (or from outside) saves the rest. */
void uniaxial_fresnel_solve_incident(vec3_t t, vec3_t m, vec3_t axis, double no, double ne,
                                     double n1, vec3_t s_hint, unsigned incident,
                                     uniaxial_fresnel_t *f);

/* The same solve always in complex arithmetic. uniaxial_fresnel_solve takes a real system
 * where every one of the eight waves propagates (the common case) and this one only where a
 * wave is evanescent; the real path performs the complex one's operations on the real parts,
 * so the two agree bit for bit. For tests. */
void uniaxial_fresnel_solve_complex(vec3_t t, vec3_t m, vec3_t axis, double no, double ne,
                                    double n1, vec3_t s_hint, uniaxial_fresnel_t *f);

/* The Jones matrix (j[row][col] = re, im) that takes the field of light arriving along k_in,
 * in the frame (x_in, k_in x x_in), to the field leaving along k_out in (x_out, k_out x x_out),
 * scaled so that |J e|^2 is power (the Stokes S0 of a beam, Poynting flux across the
 * boundary): in_outside, the light arrives from outside (its s and p), else in crystal mode
 * in_mode (UF_O or UF_E: the arriving field is projected on that mode's E); out_outside, it
 * leaves outside (s and p), else in mode out_mode. Its Mueller matrix (stokes.h mueller_jones)
 * is the branch's. */
void uniaxial_fresnel_jones(const uniaxial_fresnel_t *f, bool in_outside, int in_mode,
                            bool out_outside, int out_mode, vec3_t k_in, vec3_t x_in, vec3_t k_out,
                            vec3_t x_out, double j[2][2][2]);

#endif
