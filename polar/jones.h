/* jones: 2 x 2 complex Jones matrices for light carried coherently -- the two waves of a
 * uniaxial crystal as one ray (docs/physics.md §15.2): their product, their Mueller matrix, the
 * homogeneous elliptical retarder of a crystal segment (linear birefringence and optical
 * activity at once), and a uniaxial boundary's matrices in the basis of the crystal's two waves.
 *
 * Amplitudes are power-normalised (|a|^2 is the power a wave carries across the boundary, the
 * normal Poynting flux, as uniaxial_fresnel_jones scales them), so that a product of the
 * matrices below is the Jones matrix of a whole traversal and its Mueller matrix's [0][0] is
 * the traversal's transmittance for unpolarised light. Guarantees: finite for finite input;
 * a wave that does not propagate contributes zero. */
#ifndef PRISMFARM_JONES_H
#define PRISMFARM_JONES_H

#include "stokes.h"
#include "uniaxial_fresnel.h"
#include "vec3.h"

#include <complex.h>

typedef struct jones {
    double complex m[2][2]; /* [row][column] */
} jones_t;

jones_t jones_identity(void);

/* a b: b acts first. */
jones_t jones_mul(const jones_t *a, const jones_t *b);

/* The Mueller matrix of the non-depolarising element J (stokes.h mueller_jones). */
mueller_t jones_mueller(const jones_t *j);

/* A homogeneous segment in the basis (a, b) of two orthogonal linear eigenwaves, right-handed
 * with the light's direction k (b = k x a): the waves gain the phases phi_a and phi_b (radians,
 * 2 pi n L / lambda) and, by optical activity, the plane of polarisation turns by psi (radians,
 * from a toward b). Both act together along the segment: R. C. Jones's differential matrix
 * N = [[i phi_a, -psi], [psi, i phi_b]] integrated over it (Jones, "A new calculus for the
 * treatment of optical systems. VII", JOSA 38, 671, 1948),
 *   exp(N) = e^{i (phi_a + phi_b) / 2} (cos g I + (sin g / g) N'),
 *   N' = [[i delta / 2, -psi], [psi, -i delta / 2]], delta = phi_a - phi_b,
 *   g = sqrt(delta^2 / 4 + psi^2)   (N'^2 = -g^2 I),
 * the general elliptical retarder; psi = 0 is the linear retarder diag(e^{i phi_a}, e^{i phi_b}),
 * delta = 0 the rotator. Unitary. */
jones_t jones_elliptical(double phi_a, double phi_b, double psi);

/* A uniaxial boundary solved for the light's own direction (polar/uniaxial_fresnel.h, f's
 * "incident" and "outgoing" waves), in the basis of the crystal's waves (column or row 0 the o
 * wave, 1 the e wave, each along the solver's unit field E):
 *   exit:    light arriving from inside in f->in[O], f->in[E] to the field leaving outside
 *            along k_out, in the frame (x_out, k_out x x_out);
 *   enter:   light arriving from outside along k_in, in the frame (x_in, k_in x x_in), to the
 *            waves going in, f->out[O], f->out[E];
 *   reflect: the waves arriving from inside to the waves reflected back in (mode conversion
 *            included: the off-diagonal terms). */
jones_t jones_uniaxial_exit(const uniaxial_fresnel_t *f, vec3_t k_out, vec3_t x_out);
jones_t jones_uniaxial_enter(const uniaxial_fresnel_t *f, vec3_t k_in, vec3_t x_in);
jones_t jones_uniaxial_reflect(const uniaxial_fresnel_t *f);

#endif
