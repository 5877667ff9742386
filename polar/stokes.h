/* stokes: polarised light as Stokes vectors S = (S0, S1, S2, S3) and optical elements as 4x4
 * Mueller matrices (Stokes 1852; Mueller 1943): linear polarisers, linear retarders (quarter
 * and half wave plates) and the rotation of the reference frame a Stokes vector is measured
 * in. Plain values and pure functions; every result is finite for finite input.
 *
 * Conventions (Chipman, Lam & Young, "Polarized Light and Optical Systems", 2018, ch. 6;
 * Collett, "Field Guide to Polarization", 2005): for a field with complex amplitudes (Ex, Ey)
 * in the frame (x, y), S0 = |Ex|^2 + |Ey|^2 (the intensity), S1 = |Ex|^2 - |Ey|^2 (along x minus
 * along y), S2 = 2 Re(Ex Ey*) (45 degrees minus 135), S3 = 2 Im(Ex Ey*) (circular; its sign is
 * the handedness a horizontal quarter-wave plate gives 45-degree light). Angles run from x
 * toward y. An element at angle theta is R(-theta) M R(theta), R the frame rotation below. */
#ifndef PRISMFARM_STOKES_H
#define PRISMFARM_STOKES_H

typedef struct stokes {
    double s[4];
} stokes_t;

typedef struct mueller {
    double m[4][4];
} mueller_t;

stokes_t stokes_make(double s0, double s1, double s2, double s3);
/* Unpolarised light of intensity i: (i, 0, 0, 0). */
stokes_t stokes_unpolarised(double i);
/* Light of intensity i fully polarised along angle theta (radians, from x toward y). */
stokes_t stokes_linear(double i, double theta);

/* Degree of polarisation sqrt(S1^2 + S2^2 + S3^2) / S0 (0 when S0 <= 0). */
double stokes_dop(stokes_t s);
/* Angle of linear polarisation atan2(S2, S1) / 2, in (-pi/2, pi/2]. */
double stokes_aop(stokes_t s);

mueller_t mueller_identity(void);
/* M S, and the product A B (B acts first). */
stokes_t mueller_apply(const mueller_t *m, stokes_t s);
mueller_t mueller_mul(const mueller_t *a, const mueller_t *b);
mueller_t mueller_scale(const mueller_t *m, double k);

/* The same light measured in a frame rotated by phi (from x toward y): S1 and S2 turn by
 * -2 phi, S0 and S3 stay (Chipman et al. 2018 eq. 6.39). */
mueller_t mueller_rotator(double phi);

/* An ideal linear polariser transmitting along angle theta (Chipman et al. 2018 Table 6.1):
 * 1/2 [[1, c, s, 0], [c, c^2, c s, 0], [s, c s, s^2, 0], [0, 0, 0, 0]], c = cos 2theta,
 * s = sin 2theta. */
mueller_t mueller_polariser(double theta);

/* An ideal linear retarder of retardance delta (radians; pi/2 a quarter-wave plate, pi a half
 * wave) with its fast axis at theta: R(-theta) M0 R(theta), M0 the rotation of (S2, S3) by
 * delta, M0[2] = (0, 0, cos d, -sin d), M0[3] = (0, 0, sin d, cos d) (Chipman et al. 2018
 * Table 6.2: a horizontal quarter-wave plate turns 45-degree light right circular). */
mueller_t mueller_retarder(double theta, double delta);

/* The Mueller matrix of a non-depolarising element with the diagonal Jones matrix
 * diag(a, b) (complex amplitude factors along x and y: a diattenuating retarder; Fresnel
 * reflection and transmission in the s-p frame), given as real and imaginary parts:
 *   1/2 [[|a|^2 + |b|^2, |a|^2 - |b|^2, 0, 0], [|a|^2 - |b|^2, |a|^2 + |b|^2, 0, 0],
 *        [0, 0, 2 Re(a b*), -2 Im(a b*)], [0, 0, 2 Im(a b*), 2 Re(a b*)]]
 * which follows from the definitions above (E' = (a Ex, b Ey), Ex' Ey'* = a b* Ex Ey*). The
 * retarder above is diag(1, e^{-i delta}) up to a common phase. */
mueller_t mueller_jones_diagonal(double a_re, double a_im, double b_re, double b_im);

/* The Mueller matrix of any non-depolarising element, its Jones matrix J (row-major, complex
 * entries as real and imaginary parts: j[r][c][0] + i j[r][c][1]): column c is the Stokes
 * vector of J C J^dagger for the coherency matrix C = E E^dagger of the unit Stokes vector e_c,
 * with C = 1/2 [[S0 + S1, S2 + i S3], [S2 - i S3, S0 - S1]] from the definitions above (Azzam
 * & Bashara, Ellipsometry and Polarized Light, 1977, §2.6). For diagonal J it is
 * mueller_jones_diagonal. */
mueller_t mueller_jones(const double j[2][2][2]);

#endif
