/* pbrt-v4's ThinDielectricBxDF: a thin slab of each lane's index eta[j], reflecting on wo's side
 * and transmitting straight through; only delta lobes (no eval: f = pdf = 0 off them), the two
 * directions every lane's, each lane weighted by its own slab reflectance. */
#include "bsdf_model.h"

#include "fresnel.h"

/* pbrt-v4 4th ed. sec. 9.5.3: the slab's inter-reflections summed as a geometric series,
 * R' = R + T^2 R / (1 - R^2), T' = 1 - R'. */
static double slab_reflectance(double cos_o, double eta)
{
    double r = fresnel_dielectric(fabs(cos_o), 1.0, eta), t = 1.0 - r;
    if (r < 1.0)
        r += t * t * r / (1.0 - r * r);
    return fmin(1.0, fmax(0.0, r));
}

static bsdf_sampled_t sample(const bsdf_t *b, int n, vec3_t wo, int hero, double uc, double u1,
                             double u2, rng_stream_t *rng, bsdf_sample_t *out)
{
    (void)u1;
    (void)u2;
    (void)rng;
    double rh = slab_reflectance(wo.z, b->eta[hero]);
    bool reflect = uc < rh;
    if (!reflect && rh >= 1.0)
        return BSDF_SAMPLED_NONE;
    out->wi = reflect ? vec3_make(-wo.x, -wo.y, wo.z) : vec3_neg(wo);
    out->flags = (reflect ? BSDF_REFLECTION : BSDF_TRANSMISSION) | BSDF_SPECULAR;
    double c = fabs(wo.z);
    for (int j = 0; j < n; j++) {
        double r = slab_reflectance(wo.z, b->eta[j]);
        double w = reflect ? r : 1.0 - r;
        out->f[j] = lobe_finite(w / c);
        out->pdf[j] = w;
    }
    return BSDF_SAMPLED_ALL;
}

const bsdf_model_t bsdf_model_thin_dielectric = {.sample = sample};
