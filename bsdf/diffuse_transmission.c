/* pbrt-v4's DiffuseTransmissionBxDF: Lambertian reflection of reflectance[j] on wo's side and
 * Lambertian transmission of transmittance[j] to the other, sampled in proportion r / (r + t)
 * with the lane's own values rather than the spectrum's maxima. */
#include "bsdf_model.h"

#include "sample.h"

static double lane_f(double r, double t, vec3_t wo, vec3_t wi)
{
    if (wo.z == 0.0 || wi.z == 0.0)
        return 0.0;
    return (wo.z * wi.z > 0.0 ? lobe_finite(r) : lobe_finite(t)) / PF_PI;
}

static double lane_pdf(double r, double t, vec3_t wo, vec3_t wi)
{
    r = lobe_finite(r);
    t = lobe_finite(t);
    if (r + t == 0.0 || wo.z == 0.0 || wi.z == 0.0)
        return 0.0;
    double p = wo.z * wi.z > 0.0 ? r / (r + t) : t / (r + t);
    return p * sample_cosine_hemisphere_pdf(fabs(wi.z));
}

static void eval(const bsdf_t *b, int n, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *f)
{
    (void)rng;
    for (int j = 0; j < n; j++)
        f[j] = lane_f(b->reflectance[j], b->transmittance[j], wo, wi);
}

static void pdf(const bsdf_t *b, int n, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *pdf)
{
    (void)rng;
    for (int j = 0; j < n; j++)
        pdf[j] = lane_pdf(b->reflectance[j], b->transmittance[j], wo, wi);
}

static bsdf_sampled_t sample(const bsdf_t *b, int n, vec3_t wo, int hero, double uc, double u1,
                             double u2, rng_stream_t *rng, bsdf_sample_t *out)
{
    (void)n;
    (void)rng;
    double r = lobe_finite(b->reflectance[hero]), t = lobe_finite(b->transmittance[hero]);
    if (r + t == 0.0)
        return BSDF_SAMPLED_NONE;
    vec3_t wi = sample_cosine_hemisphere(u1, u2);
    bool reflect = uc < r / (r + t);
    /* Reflection stays on wo's side, transmission crosses to the other. */
    if ((wo.z < 0.0) == reflect)
        wi.z = -wi.z;
    if (wi.z == 0.0)
        return BSDF_SAMPLED_NONE;
    out->wi = wi;
    out->flags = reflect ? BSDF_REFLECTION : BSDF_TRANSMISSION;
    out->f[hero] = lane_f(r, t, wo, wi);
    out->pdf[hero] = lane_pdf(r, t, wo, wi);
    return out->pdf[hero] > 0.0 ? BSDF_SAMPLED_HERO : BSDF_SAMPLED_NONE;
}

const bsdf_model_t bsdf_model_diffuse_transmission = {.eval = eval, .pdf = pdf, .sample = sample};
