/* pbrt-v4's ConductorBxDF: microfacet reflection (a mirror when mf is smooth) with each lane's
 * Fresnel term of the complex index cond_eta[j] + i cond_k[j], or its thin film's Airy
 * reflectance; reflects on both sides (the lobes are lobe.h's). */
#include "bsdf_model.h"

#include "regularize.h"

static void eval(const bsdf_t *b, int n, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *f)
{
    (void)rng;
    lobe_film_t film;
    for (int j = 0; j < n; j++)
        f[j] = lobe_conductor_f_film(&b->mf, b->cond_eta[j], b->cond_k[j],
                                     bsdf_lane_film(b, j, &film), wo, wi);
}

static void pdf(const bsdf_t *b, int n, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *pdf)
{
    (void)rng;
    for (int j = 0; j < n; j++)
        pdf[j] = lobe_conductor_pdf(&b->mf, wo, wi, LOBE_ALL);
}

static bsdf_sampled_t sample(const bsdf_t *b, int n, vec3_t wo, int hero, double uc, double u1,
                             double u2, rng_stream_t *rng, bsdf_sample_t *out)
{
    (void)uc;
    (void)rng;
    lobe_sample_t s;
    lobe_film_t film;
    if (!lobe_conductor_sample_film(&b->mf, b->cond_eta[hero], b->cond_k[hero],
                                    bsdf_lane_film(b, hero, &film), wo, u1, u2, LOBE_ALL, &s))
        return BSDF_SAMPLED_NONE;
    out->wi = s.wi;
    out->flags = s.flags;
    if (!(s.flags & BSDF_SPECULAR)) {
        out->f[hero] = s.f;
        out->pdf[hero] = s.pdf;
        return BSDF_SAMPLED_HERO;
    }
    /* The mirror direction is every lane's, each weighted by its own Fresnel. */
    double c = fabs(s.wi.z);
    for (int j = 0; j < n; j++) {
        out->f[j] = lobe_finite(
            lobe_fresnel_conductor(c, b->cond_eta[j], b->cond_k[j], bsdf_lane_film(b, j, &film)) /
            c);
        out->pdf[j] = 1.0;
    }
    return BSDF_SAMPLED_ALL;
}

static bool is_specular(const bsdf_t *b, int n)
{
    (void)n;
    return microfacet_smooth(&b->mf);
}

/* The half vector's Fresnel matrix (bsdf.h's bsdf_mueller). */
static bool mueller(const bsdf_t *b, int j, vec3_t wo, vec3_t wi, mueller_t *m, vec3_t *wm)
{
    vec3_t h = vec3_add(wo, wi);
    if (wo.z * wi.z < 0.0 || vec3_dot(h, h) == 0.0)
        return false;
    *wm = vec3_normalize(h);
    *m = bsdf_interface_mueller(b, j, fabs(vec3_dot(wi, *wm)), 1.0,
                                b->cond_eta[j] + I * b->cond_k[j], true);
    return true;
}

const bsdf_model_t bsdf_model_conductor = {.eval = eval,
                                           .pdf = pdf,
                                           .sample = sample,
                                           .is_specular = is_specular,
                                           .mueller = mueller,
                                           .regularize = regularize_interface};
