#include "specular.h"

#include "fresnel.h"

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
