#include "regularize.h"

#include "bsdf_model.h"

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

void regularize_interface(bsdf_t *b)
{
    b->mf = regularize_microfacet(b->mf);
}

void regularize_bsdf(bsdf_t *b)
{
    const bsdf_model_t *m = bsdf_model_of(b);
    if (m && m->regularize)
        m->regularize(b);
}
