#include "specular.h"

#include "fresnel.h"

#include <complex.h>
#include <math.h>

vec3_t specular_normal(const surface_t *sf, vec3_t dir, double eta_rel, int *shading)
{
    if (shading)
        *shading = 0;
    if (!sf->smooth)
        return sf->ng;
    double cg = vec3_dot(dir, sf->ng);
    if (cg * vec3_dot(dir, sf->ns) <= 0.0)
        return sf->ng;
    /* The mirror direction must leave on the incident side, the refracted one continue. */
    if (vec3_dot(fresnel_reflect(dir, sf->ns), sf->ng) * cg >= 0.0)
        return sf->ng;
    vec3_t t;
    if (eta_rel > 0.0 && fresnel_refract(dir, sf->ns, eta_rel, &t) &&
        vec3_dot(t, sf->ng) * cg <= 0.0)
        return sf->ng;
    if (shading)
        *shading = 1;
    return sf->ns;
}

double specular_fresnel_conductor(double cos_i, double eta, double k)
{
    cos_i = fmin(1.0, fmax(0.0, cos_i));
    double complex e = eta + I * k;
    double sin2_i = 1.0 - cos_i * cos_i;
    double complex sin2_t = sin2_i / (e * e);
    double complex cos_t = csqrt(1.0 - sin2_t);
    double complex r_parl = (e * cos_i - cos_t) / (e * cos_i + cos_t);
    double complex r_perp = (cos_i - e * cos_t) / (cos_i + e * cos_t);
    double r = 0.5 * (creal(r_parl * conj(r_parl)) + creal(r_perp * conj(r_perp)));
    return isfinite(r) ? fmin(1.0, fmax(0.0, r)) : 1.0;
}

double specular_conductor_reflectance(const material_t *m, const surface_t *sf, double cos_i,
                                      double lambda)
{
    if (m->eta && m->k)
        return specular_fresnel_conductor(cos_i, spectrum_eval(m->eta, lambda),
                                          spectrum_eval(m->k, lambda));
    if (m->reflectance)
        return texture_eval(m->reflectance, sf->u, sf->v, lambda);
    return 1.0;
}
