/* pbrt-v4's DielectricBxDF: an interface of each lane's relative index eta[j] (inside over
 * outside, +z outside), smooth (delta reflection and refraction) when mf is smooth or eta is 1,
 * else the rough dielectric of Walter et al. 2007; with a thin film on the outside, its Airy
 * reflectance for the Fresnel term (the lobes are lobe.h's). The lanes' lobes disperse when
 * their indices differ (bsdf.h: delta lobes per lane). */
#include "bsdf_model.h"

#include "regularize.h"

static void eval(const bsdf_t *b, int n, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *f)
{
    (void)rng;
    lobe_film_t film;
    for (int j = 0; j < n; j++)
        f[j] =
            lobe_dielectric_f_film(&b->mf, b->eta[j], bsdf_lane_film(b, j, &film), b->mode, wo, wi);
}

static void pdf(const bsdf_t *b, int n, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *pdf)
{
    (void)rng;
    lobe_film_t film;
    for (int j = 0; j < n; j++)
        pdf[j] = lobe_dielectric_pdf_film(&b->mf, b->eta[j], bsdf_lane_film(b, j, &film), wo, wi,
                                          LOBE_ALL);
}

static bsdf_sampled_t sample(const bsdf_t *b, int n, vec3_t wo, int hero, double uc, double u1,
                             double u2, rng_stream_t *rng, bsdf_sample_t *out)
{
    (void)rng;
    lobe_sample_t s;
    lobe_film_t film;
    if (!lobe_dielectric_sample_film(&b->mf, b->eta[hero], bsdf_lane_film(b, hero, &film), b->mode,
                                     wo, uc, u1, u2, LOBE_ALL, &s))
        return BSDF_SAMPLED_NONE;
    out->wi = s.wi;
    out->flags = s.flags;
    out->eta = s.eta;
    out->f[hero] = s.f;
    out->pdf[hero] = s.pdf;
    if (!(s.flags & BSDF_SPECULAR))
        return BSDF_SAMPLED_HERO;
    /* A delta lobe: the mirror direction is every lane's, each weighted by its own
     * Fresnel; the refracted direction is only the lanes' of the hero's index. */
    for (int j = 0; j < n; j++) {
        if (j == hero)
            continue;
        lobe_sample_t sj;
        out->f[j] = out->pdf[j] = 0.0;
        if (!lobe_dielectric_specular(&b->mf, b->eta[j]))
            continue;
        if (s.flags & BSDF_REFLECTION) {
            /* uc = 0 picks reflection whenever lane j reflects at all. */
            if (lobe_dielectric_sample_film(&b->mf, b->eta[j], bsdf_lane_film(b, j, &film), b->mode,
                                            wo, 0.0, u1, u2, LOBE_ALL, &sj) &&
                (sj.flags & BSDF_REFLECTION)) {
                out->f[j] = sj.f;
                out->pdf[j] = sj.pdf;
            }
        } else if (bsdf_eta_same(b->eta[j], b->eta[hero])) {
            if (lobe_dielectric_sample_film(&b->mf, b->eta[j], bsdf_lane_film(b, j, &film), b->mode,
                                            wo, 1.0, u1, u2, LOBE_ALL, &sj) &&
                (sj.flags & BSDF_TRANSMISSION)) {
                out->f[j] = sj.f;
                out->pdf[j] = sj.pdf;
            }
        }
    }
    return BSDF_SAMPLED_ALL;
}

static bool is_specular(const bsdf_t *b, int n)
{
    for (int j = 0; j < n; j++)
        if (!lobe_dielectric_specular(&b->mf, b->eta[j]))
            return false;
    return true;
}

/* The (generalized) half vector's Fresnel matrix (bsdf.h's bsdf_mueller). */
static bool mueller(const bsdf_t *b, int j, vec3_t wo, vec3_t wi, mueller_t *m, vec3_t *wm)
{
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
    *m = bsdf_interface_mueller(b, j, fabs(vec3_dot(wi, *wm)), n_i, n_t, reflect);
    return true;
}

const bsdf_model_t bsdf_model_dielectric = {.eval = eval,
                                            .pdf = pdf,
                                            .sample = sample,
                                            .is_specular = is_specular,
                                            .mueller = mueller,
                                            .regularize = regularize_interface,
                                            .flags = BSDF_MODEL_DISPERSIVE};
