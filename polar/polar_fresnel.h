/* polar_fresnel: the Fresnel amplitude coefficients of a smooth interface per polarisation
 * (s: the electric field perpendicular to the plane of incidence, p: in it) for dielectrics,
 * total internal reflection and conductors of complex index, and their Mueller matrices in the
 * s-p frame (x = s, y = p: S1 > 0 is s-polarised light).
 *
 * Guarantees: every coefficient and matrix element is finite for finite indices with positive
 * real part and any cos_i in [0, 1], including normal, grazing and critical-angle incidence and
 * total internal reflection; for a real interface R_s + T_s = R_p + T_p = 1 (power fractions).
 *
 * Sources: Born & Wolf, "Principles of Optics", 7th ed., §1.5.2 (eq. 20-21: the coefficients in
 * the cosine form), §1.5.4 (total reflection), §14.2 (absorbing media: Snell's law with a
 * complex index); the Mueller matrix of the diagonal Jones matrix diag(r_s, r_p) is
 * stokes.h's mueller_jones_diagonal (Chipman, Lam & Young 2018 §6; the same matrix as
 * Wilkie & Weidlich, "Polarised Light in Computer Graphics", SIGGRAPH Asia 2016 course, and
 * Mitsuba 3's specular_reflection). */
#ifndef PRISMFARM_POLAR_FRESNEL_H
#define PRISMFARM_POLAR_FRESNEL_H

#include "stokes.h"

#include <complex.h>
#include <stdbool.h>

typedef struct polar_fresnel {
    double complex rs, rp; /* amplitude reflection coefficients */
    double complex ts, tp; /* amplitude transmission coefficients (electric field) */
    double complex cos_t;  /* cos theta_t (complex beyond the critical angle or into a metal) */
    double eta_t;          /* Re(n_t cos_t) / Re(n_i cos_i): intensity per field squared */
    double Rs, Rp, Ts, Tp; /* power fractions: |r|^2 and eta_t |t|^2 */
    bool tir;              /* no propagating transmitted wave (real indices) */
} polar_fresnel_t;

/* The interface between a medium of index n_i, where the light is, and n_t (complex: n + i k,
 * k >= 0 absorbing), for incidence cosine cos_i (clamped to [0, 1]). The transmitted cosine is
 * the root of cos_t^2 = 1 - (n_i / n_t)^2 (1 - cos_i^2) whose wave n_t cos_t decays or
 * propagates away from the interface (Im(n_t cos_t) >= 0). */
polar_fresnel_t polar_fresnel_eval(double cos_i, double complex n_i, double complex n_t);

/* The same with complex cosines on both sides (inside a thin-film stack, where the angle in a
 * layer follows from Snell's law with complex indices): the coefficients only. */
void polar_fresnel_amplitudes(double complex n_i, double complex cos_i, double complex n_t,
                              double complex cos_t, double complex *rs, double complex *rp,
                              double complex *ts, double complex *tp);

/* A real dielectric interface as optics/fresnel.h takes it: cos_theta_i > 0 from outside
 * (index n_outside), < 0 from inside (the indices swap). */
polar_fresnel_t polar_fresnel_dielectric(double cos_theta_i, double n_outside, double n_inside);

/* A conductor of relative index eta + i k, light from outside (|cos_i|). */
polar_fresnel_t polar_fresnel_conductor(double cos_i, double eta, double k);

/* The reflected and transmitted light's Mueller matrices in the s-p frame: the diagonal Jones
 * matrices diag(r_s, r_p) and sqrt(eta_t) diag(t_s, t_p). M[0][0] is the unpolarised
 * reflectance (R_s + R_p) / 2 (transmittance), M[0][1] the diattenuation's (R_s - R_p) / 2;
 * the lower block is the retardance between s and p (a rotation of (S2, S3) by the phase
 * difference under total internal reflection). Transmission is of power (flux): radiance
 * takes the further (n_t / n_i)^2 of optics (docs/physics.md §3.4). */
mueller_t polar_fresnel_reflection(const polar_fresnel_t *f);
mueller_t polar_fresnel_transmission(const polar_fresnel_t *f);

#endif
