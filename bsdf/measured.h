/* measured: RGL's measured BSDFs (Dupuy & Jakob 2018, "An Adaptive Parameterization for
 * Efficient Material Acquisition and Rendering"), the spectral ".bsdf" files pbrt-v4 renders
 * with Material "measured" (its MeasuredBxDF, the reference for every value here): a
 * reflection-only BRDF stored over the paper's parameterisation, an NDF D and projected area
 * sigma, a visible-normal warp (vndf) and a luminance warp conditioned on the outgoing
 * direction (phi_i, theta_i), and spectra over the luminance warp's domain, so that
 *   f(wo, wi, lambda) = R(u, lambda) D(wm) / (4 sigma(wo) cos(theta_i)),
 * u the point the two warps map to wm, the half vector (paper eq. 14). Sampling runs the two
 * warps (paper §5); the pdf is their inverse.
 *
 * Guarantees: measured_new takes the file's bytes as untrusted (tensor_file.h) and checks
 * every field's type and extent against the others before building anything, with a message
 * naming the file and what was expected; what it allocates is bounded by a small multiple of
 * the file's length. Every f and pdf is finite and >= 0; sample's f and pdf are eval's and
 * pdf's at the returned direction. The model reflects on both sides (a wo below the surface
 * sees the data mirrored, as pbrt-v4's), never transmits. A lane's wavelength outside the
 * file's range takes the nearest end's value. Immutable once made: shared between threads.
 * The BSDF that reads it at a hit's lanes is the row bsdf_model_measured (BSDF_MEASURED,
 * bsdf_model.h) in measured.c. */
#ifndef PRISMFARM_MEASURED_H
#define PRISMFARM_MEASURED_H

#include "err.h"
#include "vec3.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef struct measured measured_t;

/* Parses the file's bytes buf[0..len) (name: for messages). NULL with err on bad input. */
measured_t *measured_new(const uint8_t *buf, size_t len, const char *name, err_t *err);
void measured_destroy(measured_t **self_p);

/* f(wo, wi) without the cosine, for the n lanes' wavelengths lambda[j] (nm), into f[j]. */
void measured_eval(const measured_t *self, vec3_t wo, vec3_t wi, const double *lambda, int n,
                   double *f);

/* The density (solid angle) with which measured_sample picks wi for wo. */
double measured_pdf(const measured_t *self, vec3_t wo, vec3_t wi);

/* A direction for wo from two uniforms in [0, 1), with every lane's f and the pdf; false
 * when the sample falls below the surface (the path ends). */
bool measured_sample(const measured_t *self, vec3_t wo, double u1, double u2, const double *lambda,
                     int n, vec3_t *wi, double *f, double *pdf);

/* The file's description text (may be empty), its wavelength range in nm, whether its data
 * are isotropic, and the bytes held. */
const char *measured_description(const measured_t *self);
void measured_lambda_range(const measured_t *self, double *lo, double *hi);
bool measured_isotropic(const measured_t *self);
size_t measured_bytes(const measured_t *self);

#endif
