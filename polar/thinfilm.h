/* thinfilm: a thin film (a coating of index n_1 and thickness d) between an ambient medium n_0
 * and a substrate n_2 -- a dielectric or a conductor -- reflecting and transmitting per
 * wavelength and polarisation by the Airy sum of its inter-reflections: soap films, oil on
 * water, a coated lens.
 *
 * The amplitudes are the sum of every path through the film (Born & Wolf, "Principles of
 * Optics", 7th ed., §1.6.4 eq. 57-58; Hecht, "Optics", §9.7.1):
 *   r = r01 + t01 t10 r12 e^{2i beta} sum_m (r10 r12 e^{2i beta})^m
 *     = (r01 + r12 e^{2i beta}) / (1 + r01 r12 e^{2i beta}),
 *   t = t01 t12 e^{i beta} / (1 + r01 r12 e^{2i beta}),
 *   beta = 2 pi n_1 d cos theta_1 / lambda,
 * each of r_ij, t_ij the Fresnel coefficient of that interface for the polarisation
 * (polar_fresnel.h; the closed form follows from the Stokes relations r10 = -r01,
 * t01 t10 = 1 - r01^2), the angles from Snell's law n_0 sin theta_0 = n_1 sin theta_1 =
 * n_2 sin theta_2 (complex for absorbing layers and beyond a critical angle, on the branch of
 * a wave that decays away from the interface). R = |r|^2, T = Re(n_2 cos theta_2) /
 * Re(n_0 cos theta_0) |t|^2; for a lossless film R + T = 1 per polarisation.
 *
 * Guarantees: finite results in [0, 1] for finite indices with positive real part, d >= 0,
 * lambda > 0 and cos_0 in [0, 1]; d = 0 gives the bare interface n_0 | n_2. */
#ifndef PRISMFARM_THINFILM_H
#define PRISMFARM_THINFILM_H

#include "stokes.h"

#include <complex.h>

typedef struct thinfilm {
    double complex rs, rp, ts, tp; /* the film's amplitude coefficients */
    double eta_t;                  /* Re(n_2 cos theta_2) / Re(n_0 cos theta_0) */
    double Rs, Rp, Ts, Tp;         /* power fractions per polarisation */
} thinfilm_t;

/* The film for light in n_0 arriving at incidence cosine cos_0, at vacuum wavelength lambda
 * (nm) and film thickness d (nm). */
thinfilm_t thinfilm_eval(double cos_0, double complex n0, double complex n1, double thickness_nm,
                         double complex n2, double lambda_nm);

/* Unpolarised reflectance (R_s + R_p) / 2 and transmittance. */
double thinfilm_reflectance(const thinfilm_t *f);
double thinfilm_transmittance(const thinfilm_t *f);

/* Mueller matrices in the s-p frame (stokes.h's mueller_jones_diagonal): diag(r_s, r_p) and
 * sqrt(eta_t) diag(t_s, t_p). */
mueller_t thinfilm_reflection(const thinfilm_t *f);
mueller_t thinfilm_transmission(const thinfilm_t *f);

#endif
