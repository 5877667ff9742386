#include "lobe.h"

#include "fresnel.h"
#include "sample.h"
#include "thinfilm.h"

#include <math.h>
#include <stddef.h>

static bool same_hemisphere(vec3_t a, vec3_t b)
{
    return a.z * b.z > 0.0;
}

/* pbrt-v4's FrDielectric(cos_i, eta) with eta = n_inside / n_outside: optics' cosine form
 * with n_outside = 1. */
static double fr_dielectric(double cos_i, double eta)
{
    return fresnel_dielectric(cos_i, 1.0, eta);
}

/* The Fresnel reflectance at a microfacet under a thin film (film not NULL): the film's
 * unpolarised Airy reflectance (R_s + R_p) / 2 for light on the side cos_i says (> 0: outside,
 * index 1; < 0: inside, index eta), which for a lossless film is the same from either side, so
 * that 1 - R is its transmittance both ways (bsdf/delta.h's delta_dielectric_coat does the same
 * on smooth glass). */
static double fr_dielectric_film(double cos_i, double eta, const lobe_film_t *film)
{
    if (!film)
        return fr_dielectric(cos_i, eta);
    const double c = fmin(1.0, fabs(cos_i));
    const thinfilm_t f =
        cos_i > 0.0 ? thinfilm_eval(c, 1.0, film->n, film->thickness_nm, eta, film->lambda)
                    : thinfilm_eval(c, eta, film->n, film->thickness_nm, 1.0, film->lambda);
    return thinfilm_reflectance(&f);
}

double lobe_fresnel_conductor(double cos_i, double eta, double k, const lobe_film_t *film)
{
    if (!film)
        return fresnel_conductor(cos_i, eta, k);
    const thinfilm_t f = thinfilm_eval(fmin(1.0, fabs(cos_i)), 1.0, film->n, film->thickness_nm,
                                       eta + I * k, film->lambda);
    return thinfilm_reflectance(&f);
}

/* ---- Lambertian ---- */

double lobe_diffuse_f(double r, vec3_t wo, vec3_t wi)
{
    return same_hemisphere(wo, wi) ? lobe_finite(r) / PF_PI : 0.0;
}

double lobe_diffuse_pdf(vec3_t wo, vec3_t wi, int allowed)
{
    if (!(allowed & LOBE_R) || !same_hemisphere(wo, wi))
        return 0.0;
    return sample_cosine_hemisphere_pdf(fabs(wi.z));
}

bool lobe_diffuse_sample(double r, vec3_t wo, double u1, double u2, int allowed,
                         lobe_sample_t *out)
{
    if (!(allowed & LOBE_R) || wo.z == 0.0)
        return false;
    vec3_t wi = sample_cosine_hemisphere(u1, u2);
    if (wo.z < 0.0)
        wi.z = -wi.z;
    *out = (lobe_sample_t){wi, lobe_diffuse_f(r, wo, wi), lobe_diffuse_pdf(wo, wi, LOBE_R),
                           BSDF_REFLECTION, 1.0};
    return out->pdf > 0.0;
}

/* ---- Conductor ---- */

bool lobe_conductor_specular(const microfacet_t *mf)
{
    return microfacet_smooth(mf);
}

/* Torrance-Sparrow (pbrt-v4 eq. 9.33): f = D(wm) F(wo.wm) G(wo, wi) / (4 |cos_o| |cos_i|),
 * wm the half vector. */
double lobe_conductor_f_film(const microfacet_t *mf, double eta, double k, const lobe_film_t *film,
                             vec3_t wo, vec3_t wi)
{
    if (!same_hemisphere(wo, wi) || microfacet_smooth(mf))
        return 0.0;
    double co = fabs(wo.z), ci = fabs(wi.z);
    vec3_t wm = vec3_add(wo, wi);
    if (co == 0.0 || ci == 0.0 || vec3_dot(wm, wm) == 0.0)
        return 0.0;
    wm = vec3_normalize(wm);
    double fr = lobe_fresnel_conductor(fabs(vec3_dot(wo, wm)), eta, k, film);
    return lobe_finite(microfacet_d(mf, wm) * fr * microfacet_g(mf, wo, wi) / (4.0 * co * ci));
}

/* The half-vector Jacobian dwm/dwi = 1 / (4 |wo.wm|) (Walter et al. 2007 eq. 14). */
double lobe_conductor_pdf(const microfacet_t *mf, vec3_t wo, vec3_t wi, int allowed)
{
    if (!(allowed & LOBE_R) || !same_hemisphere(wo, wi) || microfacet_smooth(mf))
        return 0.0;
    vec3_t wm = vec3_add(wo, wi);
    if (vec3_dot(wm, wm) == 0.0)
        return 0.0;
    wm = vec3_normalize(wm);
    if (wm.z < 0.0)
        wm = vec3_neg(wm);
    double d = fabs(vec3_dot(wo, wm));
    return d > 0.0 ? lobe_finite(microfacet_pdf(mf, wo, wm) / (4.0 * d)) : 0.0;
}

bool lobe_conductor_sample_film(const microfacet_t *mf, double eta, double k,
                                const lobe_film_t *film, vec3_t wo, double u1, double u2,
                                int allowed, lobe_sample_t *out)
{
    if (!(allowed & LOBE_R) || wo.z == 0.0)
        return false;
    if (microfacet_smooth(mf)) {
        vec3_t wi = vec3_make(-wo.x, -wo.y, wo.z);
        double c = fabs(wi.z);
        *out = (lobe_sample_t){wi, lobe_finite(lobe_fresnel_conductor(c, eta, k, film) / c), 1.0,
                               BSDF_REFLECTION | BSDF_SPECULAR, 1.0};
        return true;
    }
    vec3_t wm = microfacet_sample_wm(mf, wo, u1, u2);
    vec3_t wi = fresnel_reflect(vec3_neg(wo), wm);
    if (!same_hemisphere(wo, wi))
        return false;
    double d = fabs(vec3_dot(wo, wm));
    double co = fabs(wo.z), ci = fabs(wi.z);
    if (d == 0.0 || ci == 0.0)
        return false;
    double pdf = lobe_finite(microfacet_pdf(mf, wo, wm) / (4.0 * d));
    double fr = lobe_fresnel_conductor(d, eta, k, film);
    double f = lobe_finite(microfacet_d(mf, wm) * fr * microfacet_g(mf, wo, wi) / (4.0 * co * ci));
    *out = (lobe_sample_t){wi, f, pdf, BSDF_REFLECTION, 1.0};
    return pdf > 0.0;
}

/* ---- Dielectric ---- */

bool lobe_dielectric_specular(const microfacet_t *mf, double eta)
{
    return eta == 1.0 || microfacet_smooth(mf);
}

/* Snell's law in vector form (Heckbert & Hanrahan 1984; pbrt-v4 Refract, the 4th edition's
 * sec. 9.3): wi = -wo / eta + (cos_i / eta - cos_t) n, with n turned to wo's side
 * and eta inverted for light leaving the inside. */
bool lobe_refract(vec3_t wo, vec3_t n, double eta, double *etap, vec3_t *wi)
{
    double cos_i = vec3_dot(n, wo);
    if (cos_i < 0.0) {
        eta = 1.0 / eta;
        cos_i = -cos_i;
        n = vec3_neg(n);
    }
    double sin2_i = fmax(0.0, 1.0 - cos_i * cos_i);
    double sin2_t = sin2_i / (eta * eta);
    if (!(sin2_t < 1.0))
        return false;
    double cos_t = sqrt(1.0 - sin2_t);
    *wi = vec3_add(vec3_scale(wo, -1.0 / eta), vec3_scale(n, cos_i / eta - cos_t));
    *etap = eta;
    return true;
}

/* Walter et al. 2007 eq. 16 (lobe.h). */
bool lobe_half(double eta, vec3_t wo, vec3_t wi, vec3_t *wm, double *etap, bool *reflect)
{
    double co = wo.z, ci = wi.z;
    *reflect = co * ci > 0.0;
    *etap = 1.0;
    if (!*reflect)
        *etap = co > 0.0 ? eta : 1.0 / eta;
    vec3_t h = vec3_add(vec3_scale(wi, *etap), wo);
    if (ci == 0.0 || co == 0.0 || vec3_dot(h, h) == 0.0)
        return false;
    h = vec3_normalize(h);
    if (h.z < 0.0)
        h = vec3_neg(h);
    if (vec3_dot(h, wi) * ci < 0.0 || vec3_dot(h, wo) * co < 0.0)
        return false;
    *wm = h;
    return true;
}

/* The probabilities of choosing reflection and transmission, restricted to `allowed`. */
static void lobe_choice(double r, int allowed, double *pr, double *pt)
{
    *pr = allowed & LOBE_R ? r : 0.0;
    *pt = allowed & LOBE_T ? 1.0 - r : 0.0;
}

/* The rough dielectric's microfacet wm joining wo and wi (lobe_half) and the Fresnel term fr
 * (bare or filmed) at it: what f and pdf both start from. False when the interface is smooth
 * (delta lobes only: f = pdf = 0 off them) or no microfacet joins the two. */
static bool rough_facet(const microfacet_t *mf, double eta, const lobe_film_t *film, vec3_t wo,
                        vec3_t wi, vec3_t *wm, double *etap, bool *reflect, double *fr)
{
    if (lobe_dielectric_specular(mf, eta) || !lobe_half(eta, wo, wi, wm, etap, reflect))
        return false;
    *fr = fr_dielectric_film(vec3_dot(wo, *wm), eta, film);
    return true;
}

/* Walter et al. 2007 eq. 21 (pbrt-v4 eq. 9.40) for transmission:
 *   f_t = T D G |wi.wm| |wo.wm| / (|cos_i| |cos_o| (wi.wm + wo.wm / etap)^2),
 * divided by etap^2 for radiance (non-symmetric scattering, Veach 1997 sec. 5.2); eq. 20 for
 * reflection: D G R / (4 |cos_i| |cos_o|). */
double lobe_dielectric_f_film(const microfacet_t *mf, double eta, const lobe_film_t *film,
                              bsdf_mode_t mode, vec3_t wo, vec3_t wi)
{
    vec3_t wm;
    double etap, fr;
    bool reflect;
    if (!rough_facet(mf, eta, film, wo, wi, &wm, &etap, &reflect, &fr))
        return 0.0;
    double co = wo.z, ci = wi.z;
    if (reflect)
        return lobe_finite(microfacet_d(mf, wm) * microfacet_g(mf, wo, wi) * fr /
                           fabs(4.0 * ci * co));
    double a = vec3_dot(wi, wm) + vec3_dot(wo, wm) / etap;
    double denom = a * a * ci * co;
    double ft = microfacet_d(mf, wm) * (1.0 - fr) * microfacet_g(mf, wo, wi) *
                fabs(vec3_dot(wi, wm) * vec3_dot(wo, wm) / denom);
    if (mode == BSDF_RADIANCE)
        ft /= etap * etap;
    return lobe_finite(ft);
}

/* The visible-normal pdf times the Jacobian of wm -> wi: 1 / (4 |wo.wm|) for reflection,
 * |wi.wm| / (wi.wm + wo.wm / etap)^2 for refraction (Walter et al. 2007 eq. 17), times the
 * probability of the lobe chosen at wm. */
double lobe_dielectric_pdf_film(const microfacet_t *mf, double eta, const lobe_film_t *film,
                                vec3_t wo, vec3_t wi, int allowed)
{
    vec3_t wm;
    double etap, fr;
    bool reflect;
    if (!rough_facet(mf, eta, film, wo, wi, &wm, &etap, &reflect, &fr))
        return 0.0;
    double pr, pt;
    lobe_choice(fr, allowed, &pr, &pt);
    if (pr == 0.0 && pt == 0.0)
        return 0.0;
    double pdf;
    if (reflect) {
        pdf = microfacet_pdf(mf, wo, wm) / (4.0 * fabs(vec3_dot(wo, wm))) * pr / (pr + pt);
    } else {
        double a = vec3_dot(wi, wm) + vec3_dot(wo, wm) / etap;
        pdf = microfacet_pdf(mf, wo, wm) * fabs(vec3_dot(wi, wm)) / (a * a) * pt / (pr + pt);
    }
    return lobe_finite(pdf);
}

bool lobe_dielectric_sample_film(const microfacet_t *mf, double eta, const lobe_film_t *film,
                                 bsdf_mode_t mode, vec3_t wo, double uc, double u1, double u2,
                                 int allowed, lobe_sample_t *out)
{
    if (wo.z == 0.0)
        return false;
    if (lobe_dielectric_specular(mf, eta)) {
        /* pbrt-v4 DielectricBxDF::Sample_f, specular branch: reflect with R / (R + T). */
        double r = fr_dielectric_film(wo.z, eta, film), pr, pt;
        lobe_choice(r, allowed, &pr, &pt);
        if (pr == 0.0 && pt == 0.0)
            return false;
        if (uc < pr / (pr + pt)) {
            vec3_t wi = vec3_make(-wo.x, -wo.y, wo.z);
            *out = (lobe_sample_t){wi, lobe_finite(r / fabs(wi.z)), pr / (pr + pt),
                                   BSDF_REFLECTION | BSDF_SPECULAR, 1.0};
            return true;
        }
        vec3_t wi;
        double etap;
        if (!lobe_refract(wo, vec3_make(0.0, 0.0, 1.0), eta, &etap, &wi) || wi.z == 0.0)
            return false;
        double ft = (1.0 - r) / fabs(wi.z);
        if (mode == BSDF_RADIANCE)
            ft /= etap * etap;
        *out = (lobe_sample_t){wi, lobe_finite(ft), pt / (pr + pt),
                               BSDF_TRANSMISSION | BSDF_SPECULAR, etap};
        return true;
    }
    vec3_t wm = microfacet_sample_wm(mf, wo, u1, u2);
    double dwm = vec3_dot(wo, wm);
    double r = fr_dielectric_film(dwm, eta, film), pr, pt;
    lobe_choice(r, allowed, &pr, &pt);
    if (pr == 0.0 && pt == 0.0)
        return false;
    double co = wo.z;
    if (uc < pr / (pr + pt)) {
        vec3_t wi = fresnel_reflect(vec3_neg(wo), wm);
        if (!same_hemisphere(wo, wi) || fabs(dwm) == 0.0)
            return false;
        double pdf = microfacet_pdf(mf, wo, wm) / (4.0 * fabs(dwm)) * pr / (pr + pt);
        double f = microfacet_d(mf, wm) * microfacet_g(mf, wo, wi) * r / fabs(4.0 * wi.z * co);
        *out = (lobe_sample_t){wi, lobe_finite(f), lobe_finite(pdf), BSDF_REFLECTION, 1.0};
        return out->pdf > 0.0;
    }
    vec3_t wi;
    double etap;
    if (!lobe_refract(wo, wm, eta, &etap, &wi) || same_hemisphere(wo, wi) || wi.z == 0.0)
        return false;
    double a = vec3_dot(wi, wm) + dwm / etap;
    double pdf = microfacet_pdf(mf, wo, wm) * fabs(vec3_dot(wi, wm)) / (a * a) * pt / (pr + pt);
    double ft = (1.0 - r) * microfacet_d(mf, wm) * microfacet_g(mf, wo, wi) *
                fabs(vec3_dot(wi, wm) * dwm / (wi.z * co * a * a));
    if (mode == BSDF_RADIANCE)
        ft /= etap * etap;
    *out = (lobe_sample_t){wi, lobe_finite(ft), lobe_finite(pdf), BSDF_TRANSMISSION, etap};
    return out->pdf > 0.0;
}

double lobe_conductor_f(const microfacet_t *mf, double eta, double k, vec3_t wo, vec3_t wi)
{
    return lobe_conductor_f_film(mf, eta, k, NULL, wo, wi);
}

bool lobe_conductor_sample(const microfacet_t *mf, double eta, double k, vec3_t wo, double u1,
                           double u2, int allowed, lobe_sample_t *out)
{
    return lobe_conductor_sample_film(mf, eta, k, NULL, wo, u1, u2, allowed, out);
}

double lobe_dielectric_f(const microfacet_t *mf, double eta, bsdf_mode_t mode, vec3_t wo, vec3_t wi)
{
    return lobe_dielectric_f_film(mf, eta, NULL, mode, wo, wi);
}

double lobe_dielectric_pdf(const microfacet_t *mf, double eta, vec3_t wo, vec3_t wi, int allowed)
{
    return lobe_dielectric_pdf_film(mf, eta, NULL, wo, wi, allowed);
}

bool lobe_dielectric_sample(const microfacet_t *mf, double eta, bsdf_mode_t mode, vec3_t wo,
                            double uc, double u1, double u2, int allowed, lobe_sample_t *out)
{
    return lobe_dielectric_sample_film(mf, eta, NULL, mode, wo, uc, u1, u2, allowed, out);
}
