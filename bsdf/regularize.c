#include "regularize.h"

#include <math.h>

static double roughen(double alpha)
{
    if (!isfinite(alpha) || alpha < 0.0)
        alpha = 0.0;
    if (alpha >= 0.3)
        return alpha;
    return fmin(fmax(2.0 * alpha, 0.1), 0.3);
}

microfacet_t regularize_microfacet(microfacet_t m)
{
    return (microfacet_t){roughen(m.alpha_x), roughen(m.alpha_y)};
}

void regularize_bsdf(bsdf_t *b)
{
    switch (b->kind) {
    case BSDF_CONDUCTOR:
    case BSDF_DIELECTRIC:
        b->mf = regularize_microfacet(b->mf);
        return;
    case BSDF_COATED_DIFFUSE:
        b->mf = regularize_microfacet(b->mf);
        return;
    case BSDF_COATED_CONDUCTOR:
        b->mf = regularize_microfacet(b->mf);
        b->mf_base = regularize_microfacet(b->mf_base);
        return;
    case BSDF_DIFFUSE:
    case BSDF_DIFFUSE_TRANSMISSION:
    case BSDF_THIN_DIELECTRIC:
    case BSDF_MEASURED: /* pbrt-v4's MeasuredBxDF::Regularize does nothing */
    case BSDF_HAIR:     /* pbrt-v4's HairBxDF::Regularize does nothing */
    case BSDF_SSS_EXIT: /* nor does its NormalizedFresnelBxDF's */
        return;
    }
}
