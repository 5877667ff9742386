/* waveplate: the retardance of a thin birefringent plate -- a uniaxial crystal cut with its
 * optic axis in the plate's plane (a wave plate, a petrographic thin section) -- between its
 * ordinary and extraordinary waves, at any angle of incidence from air (Veiras, Perez &
 * Garea, "Phase shift formulas in uniaxial media: an application to waveplates", Appl. Opt.
 * 49, 2769, 2010; Born & Wolf, Principles of Optics, ch. 15; the index surface of
 * docs/physics.md §15).
 *
 * Guarantees: finite for finite input; exactly 2 pi (n_o - n_e) t / lambda at normal
 * incidence; even in the ray's direction (light crossing either way sees the same plate). */
#ifndef PRISMFARM_WAVEPLATE_H
#define PRISMFARM_WAVEPLATE_H

#include "stokes.h"
#include "vec3.h"

/* The phase (radians) by which the ordinary wave lags the extraordinary one after crossing a
 * plate of thickness thickness_nm with principal indices n_o and n_e at vacuum wavelength
 * lambda_nm, for a ray of unit direction dir through a plate of unit normal `normal` whose
 * optic axis is the unit vector axis in the plate's plane. Both waves share the tangential
 * wave vector t = dir - (dir . normal) normal (Snell from air); their normal components are
 * N_o = sqrt(n_o^2 - |t|^2) and, on the index surface K_c^2 / n_o^2 + K_perp^2 / n_e^2 = 1,
 * N_e = sqrt(n_e^2 - |t|^2 - (n_e^2 / n_o^2 - 1) (t . axis)^2); the phase is
 * 2 pi thickness (N_o - N_e) / lambda. Positive: the extraordinary wave (polarised along the
 * axis) is the fast one (calcite, n_e < n_o); negative: the axis is the slow one (quartz). */
double waveplate_retardance(double n_o, double n_e, double thickness_nm, double lambda_nm,
                            vec3_t dir, vec3_t normal, vec3_t axis);

/* A plate cut across its optic axis (the axis along the plate's normal: a "c-cut" or
 * "z-cut" plate, light along the axis), crossed by light along unit k, as a Mueller matrix in
 * the frame (x, k x x), x a unit vector perpendicular to k. Two effects act together along
 * the plate: the linear retardance delta = 2 pi thickness (N_o - N_e) / lambda of the o wave
 * (polarised along s = k x normal, perpendicular to the plane of incidence) behind the e wave,
 * with N_o = sqrt(n_o^2 - |t|^2) and, on the index surface with the axis along the normal,
 * N_e = n_o sqrt(1 - |t|^2 / n_e^2) (t the tangential part of k); zero at normal incidence --
 * and the optical rotation psi (radians, from x toward y; a dextrorotatory crystal turns the
 * plane clockwise as seen facing the light: psi = -rho thickness). Both at once are R. C.
 * Jones's differential matrix N = [[-i delta/2, -psi], [psi, i delta/2]] integrated over the
 * plate (Jones, JOSA 38, 671, 1948, "A new calculus for the treatment of optical systems.
 * VII"): J = exp(N) = cos g I + (sin g / g) N, g = sqrt(delta^2 / 4 + psi^2), the elliptical
 * retarder whose two limits are the rotator R(psi) and the linear retarder. Lossless
 * (M[0][0] = 1); the same matrix for either direction of k in its own frame (optical
 * activity is reciprocal: light sent back through the plate turns back). */
mueller_t waveplate_axial_mueller(double n_o, double n_e, double psi, double thickness_nm,
                                  double lambda_nm, vec3_t k, vec3_t normal, vec3_t x);

#endif
