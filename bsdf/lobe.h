/* lobe: the single-lane scattering lobes the bsdf models are built from (pbrt-v4's
 * DiffuseBxDF, ConductorBxDF and DielectricBxDF for one wavelength), in the local frame, with
 * pbrt-v4's reflection/transmission restriction of sampling (BxDFReflTransFlags) that the
 * layered walk needs. Internal to bsdf/: bsdf.h is the interface. Every value returned is
 * finite and >= 0; a lobe that cannot sample returns false. */
#ifndef PRISMFARM_LOBE_H
#define PRISMFARM_LOBE_H

#include "bsdf_types.h"

#include <math.h>

/* Which parts of a lobe a sample may come from (pbrt-v4 BxDFReflTransFlags). */
enum { LOBE_R = 1, LOBE_T = 2, LOBE_ALL = 3 };

typedef struct lobe_sample {
    vec3_t wi;
    double f;   /* without the cosine; for a delta lobe, includes 1 / |cos wi| */
    double pdf; /* solid angle, or the discrete lobe probability for a delta lobe */
    int flags;  /* BSDF_REFLECTION / BSDF_TRANSMISSION | BSDF_SPECULAR */
    double eta; /* relative index along wi (transmission), else 1 */
} lobe_sample_t;

/* f must stay finite: a density that overflows (measure-zero directions) reads as 0. */
static inline double lobe_finite(double x)
{
    return isfinite(x) && x > 0.0 ? x : 0.0;
}

/* A thin-film coating on a conductor or dielectric lobe (polar/thinfilm.h): its Fresnel term
 * becomes the film's unpolarised Airy reflectance at the microfacet (and 1 - R its
 * transmittance). thickness_nm > 0, n the film's index at the lane's wavelength lambda (nm). */
typedef struct lobe_film {
    double thickness_nm, n, lambda;
} lobe_film_t;

/* Lambertian reflection of reflectance r (pbrt-v4 DiffuseBxDF). */
double lobe_diffuse_f(double r, vec3_t wo, vec3_t wi);
double lobe_diffuse_pdf(vec3_t wo, vec3_t wi, int allowed);
bool lobe_diffuse_sample(double r, vec3_t wo, double u1, double u2, int allowed,
                         lobe_sample_t *out);

/* Microfacet (or, when mf is smooth, mirror) reflection of a conductor eta + i k (pbrt-v4
 * ConductorBxDF); reflects on both sides. */
bool lobe_conductor_specular(const microfacet_t *mf);
double lobe_conductor_f(const microfacet_t *mf, double eta, double k, vec3_t wo, vec3_t wi);
double lobe_conductor_pdf(const microfacet_t *mf, vec3_t wo, vec3_t wi, int allowed);
bool lobe_conductor_sample(const microfacet_t *mf, double eta, double k, vec3_t wo, double u1,
                           double u2, int allowed, lobe_sample_t *out);

/* The same under a thin film (NULL: bare, as above), and the conductor's Fresnel reflectance at
 * incidence cosine cos_i (bare: optics/fresnel.h's; filmed: the Airy reflectance). */
double lobe_fresnel_conductor(double cos_i, double eta, double k, const lobe_film_t *film);
double lobe_conductor_f_film(const microfacet_t *mf, double eta, double k, const lobe_film_t *film,
                             vec3_t wo, vec3_t wi);
bool lobe_conductor_sample_film(const microfacet_t *mf, double eta, double k,
                                const lobe_film_t *film, vec3_t wo, double u1, double u2,
                                int allowed, lobe_sample_t *out);

/* A dielectric interface of relative index eta (inside over outside, +z outside): smooth
 * (delta) when mf is smooth or eta == 1, else pbrt-v4's rough dielectric with the
 * generalized half vector (Walter et al. 2007). */
bool lobe_dielectric_specular(const microfacet_t *mf, double eta);
double lobe_dielectric_f(const microfacet_t *mf, double eta, bsdf_mode_t mode, vec3_t wo,
                         vec3_t wi);
double lobe_dielectric_pdf(const microfacet_t *mf, double eta, vec3_t wo, vec3_t wi,
                           int allowed);
bool lobe_dielectric_sample(const microfacet_t *mf, double eta, bsdf_mode_t mode, vec3_t wo,
                            double uc, double u1, double u2, int allowed, lobe_sample_t *out);

/* The same under a thin film on the outside (NULL: bare). */
double lobe_dielectric_f_film(const microfacet_t *mf, double eta, const lobe_film_t *film,
                              bsdf_mode_t mode, vec3_t wo, vec3_t wi);
double lobe_dielectric_pdf_film(const microfacet_t *mf, double eta, const lobe_film_t *film,
                                vec3_t wo, vec3_t wi, int allowed);
bool lobe_dielectric_sample_film(const microfacet_t *mf, double eta, const lobe_film_t *film,
                                 bsdf_mode_t mode, vec3_t wo, double uc, double u1, double u2,
                                 int allowed, lobe_sample_t *out);

/* The smooth dielectric's refraction of wo (either side) with pbrt-v4's Refract: false under
 * total internal reflection; *etap is the relative index along wi. */
bool lobe_refract(vec3_t wo, vec3_t n, double eta, double *etap, vec3_t *wi);

/* The generalized half vector of Walter et al. 2007 (eq. 16), pbrt-v4 eq. 9.34, of a dielectric
 * of relative index eta: wm = normalize(etap wi + wo) facing +z, etap = 1 for reflection, eta
 * or 1/eta for refraction from outside or inside (*reflect: wo and wi on one side). False for
 * the configurations with no microfacet (in-plane directions, wm = 0, or wm back-facing
 * either direction). */
bool lobe_half(double eta, vec3_t wo, vec3_t wi, vec3_t *wm, double *etap, bool *reflect);

#endif
