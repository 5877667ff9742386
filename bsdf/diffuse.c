/* pbrt-v4's DiffuseBxDF, Lambertian reflection of each lane's reflectance[j] on wo's side (the
 * lobe is lobe.h's). */
#include "diffuse.h"

static void eval(const bsdf_t *b, int n, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *f)
{
    (void)rng;
    for (int j = 0; j < n; j++)
        f[j] = lobe_diffuse_f(b->reflectance[j], wo, wi);
}

void diffuse_pdf(const bsdf_t *b, int n, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *pdf)
{
    (void)b;
    (void)rng;
    for (int j = 0; j < n; j++)
        pdf[j] = lobe_diffuse_pdf(wo, wi, LOBE_ALL);
}

static bsdf_sampled_t sample(const bsdf_t *b, int n, vec3_t wo, int hero, double uc, double u1,
                             double u2, rng_stream_t *rng, bsdf_sample_t *out)
{
    (void)n;
    (void)uc;
    (void)rng;
    lobe_sample_t s;
    if (!lobe_diffuse_sample(b->reflectance[hero], wo, u1, u2, LOBE_ALL, &s))
        return BSDF_SAMPLED_NONE;
    out->wi = s.wi;
    out->flags = s.flags;
    out->f[hero] = s.f;
    out->pdf[hero] = s.pdf;
    return BSDF_SAMPLED_HERO;
}

const bsdf_model_t bsdf_model_diffuse = {.eval = eval, .pdf = diffuse_pdf, .sample = sample};
