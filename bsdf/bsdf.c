#include "bsdf.h"

#include "bssrdf.h"
#include "fresnel.h"
#include "hair.h"
#include "layered.h"
#include "lobe.h"
#include "measured.h"
#include "polar_frame.h"
#include "polar_fresnel.h"
#include "sample.h"
#include "thinfilm.h"

#include <math.h>
#include <stddef.h>

/* Two lanes share a delta refraction when their indices agree to 1e-9 (relative): closer
 * than any dispersion the renderer models, far above rounding. */
static bool eta_same(double a, double b)
{
    return fabs(a - b) <= 1e-9 * fabs(b);
}

static int lanes(const bsdf_t *b)
{
    return b->n < 1 ? 0 : b->n > BSDF_MAX_LANES ? BSDF_MAX_LANES : b->n;
}

/* Lane j's thin film (in *tmp), or NULL without one. */
static const lobe_film_t *lane_film(const bsdf_t *b, int j, lobe_film_t *tmp)
{
    if (!(b->film_nm > 0.0))
        return NULL;
    *tmp = (lobe_film_t){b->film_nm, b->film_n[j], b->lambda[j]};
    return tmp;
}

static bool coated(const bsdf_t *b)
{
    return b->kind == BSDF_COATED_DIFFUSE || b->kind == BSDF_COATED_CONDUCTOR;
}

/* pbrt-v4 ThinDielectricBxDF (4th ed. sec. 9.5.3): the slab's inter-reflections summed as a
 * geometric series, R' = R + T^2 R / (1 - R^2), T' = 1 - R'. */
static double thin_reflectance(double cos_o, double eta)
{
    double r = fresnel_dielectric(fabs(cos_o), 1.0, eta), t = 1.0 - r;
    if (r < 1.0)
        r += t * t * r / (1.0 - r * r);
    return fmin(1.0, fmax(0.0, r));
}

/* Lambertian reflection and transmission chosen by r / (r + t) (pbrt-v4
 * DiffuseTransmissionBxDF, with the lane's own values rather than the spectrum's maxima). */
static double dt_pdf(double r, double t, vec3_t wo, vec3_t wi)
{
    r = lobe_finite(r);
    t = lobe_finite(t);
    if (r + t == 0.0 || wo.z == 0.0 || wi.z == 0.0)
        return 0.0;
    double p = wo.z * wi.z > 0.0 ? r / (r + t) : t / (r + t);
    return p * sample_cosine_hemisphere_pdf(fabs(wi.z));
}

/* pbrt-v4's NormalizedFresnelBxDF, the BSSRDF's directional factor S_w where light leaves:
 * the outside's Fresnel transmission (1 - F_r(cos wi)) normalised by its cosine-weighted
 * integral c pi, c = 1 - 2 M1(1 / eta) (bssrdf.h's moment of the outside), so that
 * int S_w cos = 1; in radiance mode times eta^2, which undoes the 1 / eta^2 of the refraction
 * that took the light in. Reflection only, on wo's side. */
static double sss_exit_f(double eta, bsdf_mode_t mode, vec3_t wo, vec3_t wi)
{
    if (!(wo.z * wi.z > 0.0) || !(eta > 0.0))
        return 0.0;
    const double c = 1.0 - 2.0 * bssrdf_fresnel_moment1(1.0 / eta);
    const double f = (1.0 - fresnel_dielectric(fabs(wi.z), 1.0, eta)) / (c * PF_PI);
    return lobe_finite(mode == BSDF_RADIANCE ? f * eta * eta : f);
}

static double dt_f(double r, double t, vec3_t wo, vec3_t wi)
{
    if (wo.z == 0.0 || wi.z == 0.0)
        return 0.0;
    return (wo.z * wi.z > 0.0 ? lobe_finite(r) : lobe_finite(t)) / PF_PI;
}

double bsdf_guide(const bsdf_t *b, vec3_t wo, vec3_t wi)
{
    return coated(b) ? layered_guide(b, wo, wi) : 1.0;
}

void bsdf_eval(const bsdf_t *b, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *f)
{
    int n = lanes(b);
    lobe_film_t film;
    if (coated(b)) {
        if (n > 0)
            layered_eval(b, wo, wi, rng, f);
        return;
    }
    if (b->kind == BSDF_MEASURED) {
        measured_eval(b->measured, wo, wi, b->lambda, n, f);
        return;
    }
    if (b->kind == BSDF_HAIR) {
        hair_eval(b, wo, wi, f);
        return;
    }
    for (int j = 0; j < n; j++) {
        switch (b->kind) {
        case BSDF_DIFFUSE:
            f[j] = lobe_diffuse_f(b->reflectance[j], wo, wi);
            break;
        case BSDF_DIFFUSE_TRANSMISSION:
            f[j] = dt_f(b->reflectance[j], b->transmittance[j], wo, wi);
            break;
        case BSDF_CONDUCTOR:
            f[j] = lobe_conductor_f_film(&b->mf, b->cond_eta[j], b->cond_k[j],
                                         lane_film(b, j, &film), wo, wi);
            break;
        case BSDF_DIELECTRIC:
            f[j] =
                lobe_dielectric_f_film(&b->mf, b->eta[j], lane_film(b, j, &film), b->mode, wo, wi);
            break;
        case BSDF_SSS_EXIT:
            f[j] = sss_exit_f(b->eta[j], b->mode, wo, wi);
            break;
        default:
            f[j] = 0.0;
            break;
        }
    }
}

void bsdf_pdf(const bsdf_t *b, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *pdf)
{
    int n = lanes(b);
    lobe_film_t film;
    if (coated(b)) {
        if (n > 0)
            layered_pdf(b, wo, wi, rng, pdf);
        return;
    }
    if (b->kind == BSDF_MEASURED) {
        double p = measured_pdf(b->measured, wo, wi);
        for (int j = 0; j < n; j++)
            pdf[j] = p;
        return;
    }
    if (b->kind == BSDF_HAIR) {
        hair_pdf(b, wo, wi, pdf);
        return;
    }
    for (int j = 0; j < n; j++) {
        switch (b->kind) {
        case BSDF_DIFFUSE:
        case BSDF_SSS_EXIT:
            pdf[j] = lobe_diffuse_pdf(wo, wi, LOBE_ALL);
            break;
        case BSDF_DIFFUSE_TRANSMISSION:
            pdf[j] = dt_pdf(b->reflectance[j], b->transmittance[j], wo, wi);
            break;
        case BSDF_CONDUCTOR:
            pdf[j] = lobe_conductor_pdf(&b->mf, wo, wi, LOBE_ALL);
            break;
        case BSDF_DIELECTRIC:
            pdf[j] = lobe_dielectric_pdf_film(&b->mf, b->eta[j], lane_film(b, j, &film), wo, wi,
                                              LOBE_ALL);
            break;
        default:
            pdf[j] = 0.0;
            break;
        }
    }
}

/* Every lane but the hero: its own f and pdf at the hero's (non-delta) direction. */
static void other_lanes(const bsdf_t *b, vec3_t wo, int hero, rng_stream_t *rng,
                        bsdf_sample_t *out)
{
    double f[BSDF_MAX_LANES], pdf[BSDF_MAX_LANES];
    bsdf_eval(b, wo, out->wi, rng, f);
    bsdf_pdf(b, wo, out->wi, rng, pdf);
    for (int j = 0; j < lanes(b); j++) {
        if (j == hero)
            continue;
        out->f[j] = f[j];
        out->pdf[j] = pdf[j];
    }
}

static bool sample_dielectric(const bsdf_t *b, vec3_t wo, int hero, double uc, double u1,
                              double u2, rng_stream_t *rng, bsdf_sample_t *out)
{
    int n = lanes(b);
    lobe_sample_t s;
    lobe_film_t film;
    if (!lobe_dielectric_sample_film(&b->mf, b->eta[hero], lane_film(b, hero, &film), b->mode, wo,
                                     uc, u1, u2, LOBE_ALL, &s))
        return false;
    out->wi = s.wi;
    out->flags = s.flags;
    out->eta = s.eta;
    if (!(s.flags & BSDF_SPECULAR)) {
        out->f[hero] = s.f;
        out->pdf[hero] = s.pdf;
        other_lanes(b, wo, hero, rng, out);
        return true;
    }
    /* A delta lobe: the mirror direction is every lane's, each weighted by its own
     * Fresnel; the refracted direction is only the lanes' of the hero's index. */
    for (int j = 0; j < n; j++) {
        lobe_sample_t sj;
        out->f[j] = out->pdf[j] = 0.0;
        bool delta_j = lobe_dielectric_specular(&b->mf, b->eta[j]);
        if (!delta_j)
            continue;
        if (s.flags & BSDF_REFLECTION) {
            /* uc = 0 picks reflection whenever lane j reflects at all. */
            if (lobe_dielectric_sample_film(&b->mf, b->eta[j], lane_film(b, j, &film), b->mode, wo,
                                            0.0, u1, u2, LOBE_ALL, &sj) &&
                (sj.flags & BSDF_REFLECTION)) {
                out->f[j] = sj.f;
                out->pdf[j] = sj.pdf;
            }
        } else if (eta_same(b->eta[j], b->eta[hero]) || j == hero) {
            if (lobe_dielectric_sample_film(&b->mf, b->eta[j], lane_film(b, j, &film), b->mode, wo,
                                            1.0, u1, u2, LOBE_ALL, &sj) &&
                (sj.flags & BSDF_TRANSMISSION)) {
                out->f[j] = sj.f;
                out->pdf[j] = sj.pdf;
            }
        }
    }
    out->f[hero] = s.f;
    out->pdf[hero] = s.pdf;
    return true;
}

bool bsdf_sample(const bsdf_t *b, vec3_t wo, int hero, double uc, double u1, double u2,
                 rng_stream_t *rng, bsdf_sample_t *out)
{
    int n = lanes(b);
    if (n == 0 || !(wo.z != 0.0) || !isfinite(wo.x + wo.y + wo.z))
        return false;
    if (hero < 0 || hero >= n)
        hero = 0;
    out->flags = 0;
    out->eta = 1.0;
    out->pdf_is_estimate = false;
    lobe_sample_t s;
    lobe_film_t film;
    switch (b->kind) {
    case BSDF_DIFFUSE:
        if (!lobe_diffuse_sample(b->reflectance[hero], wo, u1, u2, LOBE_ALL, &s))
            return false;
        out->wi = s.wi;
        out->flags = s.flags;
        out->f[hero] = s.f;
        out->pdf[hero] = s.pdf;
        other_lanes(b, wo, hero, rng, out);
        return true;
    case BSDF_DIFFUSE_TRANSMISSION: {
        double r = lobe_finite(b->reflectance[hero]), t = lobe_finite(b->transmittance[hero]);
        if (r + t == 0.0)
            return false;
        vec3_t wi = sample_cosine_hemisphere(u1, u2);
        bool reflect = uc < r / (r + t);
        /* Reflection stays on wo's side, transmission crosses to the other. */
        if ((wo.z < 0.0) == reflect)
            wi.z = -wi.z;
        if (wi.z == 0.0)
            return false;
        out->wi = wi;
        out->flags = reflect ? BSDF_REFLECTION : BSDF_TRANSMISSION;
        out->f[hero] = dt_f(r, t, wo, wi);
        out->pdf[hero] = dt_pdf(r, t, wo, wi);
        other_lanes(b, wo, hero, rng, out);
        return out->pdf[hero] > 0.0;
    }
    case BSDF_CONDUCTOR:
        if (!lobe_conductor_sample_film(&b->mf, b->cond_eta[hero], b->cond_k[hero],
                                        lane_film(b, hero, &film), wo, u1, u2, LOBE_ALL, &s))
            return false;
        out->wi = s.wi;
        out->flags = s.flags;
        if (s.flags & BSDF_SPECULAR) {
            double c = fabs(s.wi.z);
            for (int j = 0; j < n; j++) {
                out->f[j] = lobe_finite(lobe_fresnel_conductor(c, b->cond_eta[j], b->cond_k[j],
                                                               lane_film(b, j, &film)) /
                                        c);
                out->pdf[j] = 1.0;
            }
            return true;
        }
        out->f[hero] = s.f;
        out->pdf[hero] = s.pdf;
        other_lanes(b, wo, hero, rng, out);
        return true;
    case BSDF_DIELECTRIC:
        return sample_dielectric(b, wo, hero, uc, u1, u2, rng, out);
    case BSDF_THIN_DIELECTRIC: {
        double rh = thin_reflectance(wo.z, b->eta[hero]);
        bool reflect = uc < rh;
        if (!reflect && rh >= 1.0)
            return false;
        out->wi = reflect ? vec3_make(-wo.x, -wo.y, wo.z) : vec3_neg(wo);
        out->flags = (reflect ? BSDF_REFLECTION : BSDF_TRANSMISSION) | BSDF_SPECULAR;
        double c = fabs(wo.z);
        for (int j = 0; j < n; j++) {
            double r = thin_reflectance(wo.z, b->eta[j]);
            double w = reflect ? r : 1.0 - r;
            out->f[j] = lobe_finite(w / c);
            out->pdf[j] = w;
        }
        return true;
    }
    case BSDF_COATED_DIFFUSE:
    case BSDF_COATED_CONDUCTOR:
        return layered_sample(b, wo, hero, uc, u1, u2, rng, out);
    case BSDF_MEASURED: {
        double p;
        if (!measured_sample(b->measured, wo, u1, u2, b->lambda, n, &out->wi, out->f, &p))
            return false;
        out->flags = BSDF_REFLECTION;
        for (int j = 0; j < n; j++)
            out->pdf[j] = p;
        return true;
    }
    case BSDF_HAIR:
        return hair_sample(b, wo, hero, uc, u1, u2, out);
    case BSDF_SSS_EXIT: {
        vec3_t wi = sample_cosine_hemisphere(u1, u2);
        if (wo.z < 0.0)
            wi.z = -wi.z;
        if (wi.z == 0.0)
            return false;
        out->wi = wi;
        out->flags = BSDF_REFLECTION;
        for (int j = 0; j < n; j++) {
            out->f[j] = sss_exit_f(b->eta[j], b->mode, wo, wi);
            out->pdf[j] = sample_cosine_hemisphere_pdf(fabs(wi.z));
        }
        return out->pdf[hero] > 0.0;
    }
    }
    return false;
}

bool bsdf_is_specular(const bsdf_t *b)
{
    int n = lanes(b);
    switch (b->kind) {
    case BSDF_CONDUCTOR:
        return microfacet_smooth(&b->mf);
    case BSDF_DIELECTRIC:
        for (int j = 0; j < n; j++)
            if (!lobe_dielectric_specular(&b->mf, b->eta[j]))
                return false;
        return true;
    case BSDF_THIN_DIELECTRIC:
        return true;
    case BSDF_COATED_CONDUCTOR:
        return layered_is_specular(b);
    default:
        return false;
    }
}

bool bsdf_lanes_disperse(const bsdf_t *b)
{
    if (b->kind != BSDF_DIELECTRIC && !coated(b))
        return false;
    for (int j = 1; j < lanes(b); j++)
        if (!eta_same(b->eta[j], b->eta[0]))
            return true;
    return false;
}

/* The normalised Mueller matrix of lane j's interface for light in n_i meeting n_t at incidence
 * cosine cos_i: Fresnel's, or with a film (on the outside, index 1's side) the Airy sum's. */
static mueller_t interface_mueller(const bsdf_t *b, int j, double cos_i, double complex n_i,
                                   double complex n_t, bool reflect)
{
    cos_i = fmin(1.0, cos_i);
    mueller_t m;
    if (b->film_nm > 0.0) {
        const thinfilm_t f = thinfilm_eval(cos_i, n_i, b->film_n[j], b->film_nm, n_t, b->lambda[j]);
        m = reflect ? thinfilm_reflection(&f) : thinfilm_transmission(&f);
    } else {
        const polar_fresnel_t f = polar_fresnel_eval(cos_i, n_i, n_t);
        m = reflect ? polar_fresnel_reflection(&f) : polar_fresnel_transmission(&f);
    }
    return mueller_normalised(&m);
}

bool bsdf_mueller(const bsdf_t *b, int j, vec3_t wo, vec3_t wi, mueller_t *m, vec3_t *wm)
{
    if (j < 0 || j >= lanes(b) || wo.z == 0.0 || wi.z == 0.0)
        return false;
    if (b->kind == BSDF_CONDUCTOR) {
        vec3_t h = vec3_add(wo, wi);
        if (wo.z * wi.z < 0.0 || vec3_dot(h, h) == 0.0)
            return false;
        *wm = vec3_normalize(h);
        *m = interface_mueller(b, j, fabs(vec3_dot(wi, *wm)), 1.0,
                               b->cond_eta[j] + I * b->cond_k[j], true);
        return true;
    }
    if (b->kind != BSDF_DIELECTRIC)
        return false;
    const double eta = b->eta[j];
    if (eta == 1.0) { /* pbrt-v4's pass-through: nothing to polarise */
        *m = mueller_identity();
        *wm = vec3_make(0.0, 0.0, 1.0);
        return true;
    }
    double etap;
    bool reflect;
    if (!lobe_half(eta, wo, wi, wm, &etap, &reflect))
        return false;
    /* The light comes from wi's side: outside (+z) in index 1, or inside in eta. */
    const bool light_outside = wi.z > 0.0;
    const double n_i = light_outside ? 1.0 : eta, n_t = light_outside ? eta : 1.0;
    *m = interface_mueller(b, j, fabs(vec3_dot(wi, *wm)), n_i, n_t, reflect);
    return true;
}
