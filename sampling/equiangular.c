#include "equiangular.h"

#include <float.h>
#include <math.h>

int equiangular_make(vec3_t org, vec3_t dir, double tmax, vec3_t c, equiangular_t *out)
{
    if (!(tmax > 0.0))
        return 0;
    const vec3_t oc = vec3_sub(c, org);
    const double delta = vec3_dot(oc, dir);
    const vec3_t foot = vec3_sub(oc, vec3_scale(dir, delta));
    double D = vec3_length(foot);
    const double scale = vec3_length(oc) + (isfinite(tmax) ? tmax : 0.0);
    if (!isfinite(delta) || !isfinite(D) || !isfinite(scale) || !(scale > 0.0))
        return 0;
    const double floor = EQUIANGULAR_D_MIN * scale;
    if (!(D >= floor))
        D = floor;
    if (!(D > 1e-290))
        return 0;
    const double a = -delta / D;
    double dtheta;
    if (isinf(tmax)) {
        /* pi/2 - atan(a) */
        dtheta = atan2(1.0, a);
    } else {
        /* atan(b) - atan(a) = atan2(b - a, 1 + a b) for b > a: both lie in (0, pi) with the same
         * tangent, and no difference of two angles near pi/2 loses the digits. */
        const double b = (tmax - delta) / D;
        dtheta = atan2(b - a, 1.0 + a * b);
    }
    if (!(dtheta > 0.0) || !isfinite(dtheta))
        return 0;
    out->delta = delta;
    out->D = D;
    out->a = a;
    out->dtheta = dtheta;
    out->tmax = tmax;
    return 1;
}

double equiangular_sample(const equiangular_t *e, double u)
{
    /* tan(theta_a + phi) = (a + tan phi) / (1 - a tan phi), phi = u dtheta in [0, dtheta). */
    const double tp = tan(u * e->dtheta);
    const double den = 1.0 - e->a * tp;
    /* den < 0 is a valid ratio (phi past pi/2); only den = 0 (theta = pi/2, the unbounded
     * segment's end) has no t. */
    double t = den != 0.0 ? e->delta + e->D * ((e->a + tp) / den) : INFINITY;
    if (!(t >= 0.0))
        t = 0.0;
    if (!(t < e->tmax))
        t = isfinite(e->tmax) ? nextafter(e->tmax, 0.0) : DBL_MAX;
    return t;
}

double equiangular_pdf(const equiangular_t *e, double t)
{
    if (!(t >= 0.0) || !(t < e->tmax))
        return 0.0;
    const double x = (t - e->delta) / e->D;
    /* D / (dtheta ((t - delta)^2 + D^2)) = 1 / (dtheta D (x^2 + 1)); x^2 overflows to inf
     * (density 0) only for t beyond any double the sampler returns in practice. */
    return 1.0 / (e->dtheta * e->D * (x * x + 1.0));
}
