/* hair: the scattering of a hair fibre, pbrt-v4's HairBxDF -- d'Eon et al. 2011's
 * energy-conserving longitudinal lobes M_p and Chiang et al. 2016's logistic azimuthal lobes
 * N_p and roughness mappings -- for a path's lanes at once: the lobes R, TT, TRT (p = 0..2)
 * and the sum of every higher order p >= 3 (isotropic in azimuth), over a smooth dielectric
 * cylinder of index eta whose interior absorbs sigma_a[j] (per unit of the fibre's radius),
 * with the cuticle scales tilting the lobes by alpha.
 *
 * Frame: the bsdf's local one, with x along the fibre (its dp/du) and z the surface normal;
 * theta is the angle from the normal plane (sin theta = w.x) and phi = atan2(w.z, w.y) the
 * azimuth around the fibre. The result depends on the azimuths only through phi_i - phi_o,
 * so any rotation of the frame about x (the shading normal a curve reports) gives the same
 * numbers. h in [-1, 1] is where across the fibre's width the ray arrived (pbrt-v4:
 * h = -1 + 2 v of the hit).
 *
 * Guarantees: f (without the cosine; f |w_i.z| is the scattered fraction per solid angle)
 * and pdf are finite and >= 0 for any unit wo, wi; with sigma_a = 0 the integral of
 * f |cos| over the sphere is 1 up to the longitudinal lobes' normalisation (d'Eon's M_p is
 * normalised for an untilted lobe; tests/unit/test_hair.c measures it) and the sample's
 * f |cos| / pdf is 1. Lane j's pdf is the density of hair_sample with hero j (pbrt-v4 picks
 * the lobe by A_p averaged over its wavelengths; here each lane by its own A_p, and the
 * renderer's spectral MIS mixes the lanes' densities). eta is one number for every lane: the
 * keratin's dispersion is not modelled (pbrt-v4 likewise takes a float eta). The model is
 * reciprocal where alpha = 0 and h = 0 (tests/unit/test_hair.c); pbrt-v4's model with a
 * scale tilt or an offset h is not, and neither is this one. */
#ifndef PRISMFARM_HAIR_H
#define PRISMFARM_HAIR_H

#include "bsdf_types.h"

/* f for every lane of b (kind BSDF_HAIR; these three are the row bsdf_model_hair's,
 * bsdf_model.h). */
void hair_eval(const bsdf_t *b, vec3_t wo, vec3_t wi, double *f);
/* Each lane's pdf of sampling wi from wo (solid angle). */
void hair_pdf(const bsdf_t *b, vec3_t wo, vec3_t wi, double *pdf);
/* Samples wi from lane hero's lobes (uc picks the lobe and is then reused for the azimuth,
 * u1 and u2 the longitudinal angle), with every lane's f and pdf there. False when wo lies
 * along the fibre or no lobe carries energy. */
bool hair_sample(const bsdf_t *b, vec3_t wo, int hero, double uc, double u1, double u2,
                 bsdf_sample_t *out);

/* pbrt-v4's SigmaAFromReflectance (Chiang et al. 2016 eq. 9): the absorption that gives a
 * multiply scattered colour c in (0, 1] for azimuthal roughness beta_n;
 * sigma_a = (ln c / (5.969 - 0.215 b + 2.532 b^2 - 10.73 b^3 + 5.574 b^4 + 0.245 b^5))^2. */
double hair_sigma_a_from_reflectance(double c, double beta_n);

/* pbrt-v4's SigmaAFromConcentration: the linear-sRGB absorption of eumelanin ce and
 * pheomelanin cp concentrations, ce (0.419, 0.697, 1.37) + cp (0.187, 0.4, 1.05) (Chiang et
 * al. 2016, from d'Eon et al. 2011). */
void hair_sigma_a_from_concentration(double ce, double cp, double rgb[3]);

#endif
