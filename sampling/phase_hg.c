#include "phase_hg.h"

#include <math.h>

double phase_hg_clamp(double g)
{
    if (!(g == g))
        return 0.0;
    return g > PHASE_HG_G_MAX ? PHASE_HG_G_MAX : g < -PHASE_HG_G_MAX ? -PHASE_HG_G_MAX : g;
}

/* The density as a function of the cosine between wo and wi: 1 + g^2 + 2 g cos >= (1 - |g|)^2
 * > 0 for the clamped g, so the value is finite. */
static double hg_of_cos(double c, double g)
{
    double denom = 1.0 + g * g + 2.0 * g * c;
    if (!(denom > 0.0))
        denom = (1.0 - fabs(g)) * (1.0 - fabs(g));
    return (1.0 - g * g) / (4.0 * PF_PI * denom * sqrt(denom));
}

double phase_hg_eval(vec3_t wo, vec3_t wi, double g)
{
    g = phase_hg_clamp(g);
    double c = vec3_dot(wo, wi);
    c = c > 1.0 ? 1.0 : c < -1.0 ? -1.0 : c;
    return hg_of_cos(c, g);
}

/* The cumulative distribution of cos(wo, wi) is inverted in closed form (pbrt-v4 §11.3.1,
 * eq. 11.12 with its sign for the away-pointing convention):
 *   cos = -(1 + g^2 - ((1 - g^2) / (1 + g - 2 g u))^2) / (2 g),
 * and, for |g| < 1e-3 where that cancels badly, the isotropic 1 - 2u. */
vec3_t phase_hg_sample(vec3_t wo, double g, double u1, double u2, double *pdf)
{
    g = phase_hg_clamp(g);
    u1 = u1 > 0.0 ? (u1 < 1.0 ? u1 : 1.0) : 0.0;
    u2 = u2 > 0.0 ? (u2 < 1.0 ? u2 : 1.0) : 0.0;
    double c;
    if (fabs(g) < 1e-3) {
        c = 1.0 - 2.0 * u1;
    } else {
        double s = (1.0 - g * g) / (1.0 + g - 2.0 * g * u1);
        c = -(1.0 + g * g - s * s) / (2.0 * g);
    }
    c = c > 1.0 ? 1.0 : c < -1.0 ? -1.0 : c;
    double sn = sqrt(fmax(0.0, 1.0 - c * c)), phi = 2.0 * PF_PI * u2;
    vec3_t t, b;
    vec3_basis(wo, &t, &b);
    vec3_t wi = vec3_add(vec3_add(vec3_scale(t, sn * cos(phi)), vec3_scale(b, sn * sin(phi))),
                         vec3_scale(wo, c));
    wi = vec3_normalize(wi);
    *pdf = hg_of_cos(c, g);
    return wi;
}
