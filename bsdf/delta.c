#include "delta.h"

#include "fresnel.h"
#include "polar_frame.h"
#include "polar_fresnel.h"
#include "thinfilm.h"

#include <complex.h>
#include <math.h>

double delta_eta_ratio(double n, bool entering)
{
    /* n_i / n_t with the outside's index 1: written as the quotient of the two sides' indices
     * (1 / n or n / 1, both exact forms of the same numbers). */
    double n_i = entering ? 1.0 : n, n_t = entering ? n : 1.0;
    return n_i / n_t;
}

void delta_dielectric_make(vec3_t dir, vec3_t nrm, bool entering, const double *n, int count,
                           bsdf_mode_t mode, delta_dielectric_t *e)
{
    if (count < 1)
        count = 1;
    if (count > BSDF_MAX_LANES)
        count = BSDF_MAX_LANES;
    /* Fresnel's cos_theta_i is measured from the direction the light comes from (-dir) against
     * the normal; its sign says from which side (fresnel_dielectric_terms swaps the indices). */
    const double cos_i = -vec3_dot(dir, nrm);
    e->mode = mode;
    e->nr = count;
    e->coated = false;
    e->reflect = fresnel_reflect(dir, nrm);
    e->ratio = delta_eta_ratio(n[0], entering);
    e->refracts = fresnel_refract(dir, nrm, e->ratio, &e->refract);
    for (int j = 0; j < count; j++)
        e->reflectance[j] = fresnel_dielectric(cos_i, 1.0, n[j]);
    /* Snell and Fresnel agree on total reflection but for rounding at the critical angle:
     * where no refracted direction exists the event reflects with probability 1. */
    e->prob_reflect = e->refracts ? e->reflectance[0] : 1.0;
}

double delta_dielectric_weight(const delta_dielectric_t *e, bool reflect, double scale)
{
    if (reflect)
        return e->prob_reflect * scale;
    /* Radiance across an interface scales by (n_t / n_i)^2; a camera path carries light the
     * other way, so its importance takes (n_i / n_t)^2 along its own direction; flux takes T
     * alone (docs/physics.md §3.4). */
    if (e->mode == BSDF_RADIANCE)
        return (1.0 - e->prob_reflect) * scale * e->ratio * e->ratio;
    return (1.0 - e->prob_reflect) * scale;
}

double delta_dielectric_transmit_lane(const delta_dielectric_t *e, int j, double scale)
{
    if (!e->coated)
        return delta_dielectric_weight(e, false, scale);
    if (j < 0 || j >= e->nr)
        return 0.0;
    if (e->mode == BSDF_RADIANCE)
        return e->transmittance[j] * scale * e->ratio * e->ratio;
    return e->transmittance[j] * scale;
}

void delta_dielectric_coat(delta_dielectric_t *e, vec3_t dir, vec3_t nrm, bool entering,
                           const double *n, const double *lambda, const delta_film_t *film)
{
    const double cos_i = fabs(vec3_dot(dir, nrm));
    double sum = 0.0;
    for (int j = 0; j < e->nr; j++) {
        const double nf = ior_eval(film->ior, lambda[j]);
        const thinfilm_t f =
            entering ? thinfilm_eval(cos_i, 1.0, nf, film->thickness_nm, n[j], lambda[j])
                     : thinfilm_eval(cos_i, n[j], nf, film->thickness_nm, 1.0, lambda[j]);
        e->reflectance[j] = thinfilm_reflectance(&f);
        e->transmittance[j] = 1.0 - e->reflectance[j];
        sum += e->reflectance[j];
    }
    e->coated = true;
    e->prob_reflect = e->refracts ? sum / e->nr : 1.0;
}

double delta_dielectric_reflect_lane(const delta_dielectric_t *e, int j, bool chosen)
{
    if (j < 0 || j >= e->nr)
        return 0.0;
    if (!chosen)
        return e->reflectance[j];
    return e->prob_reflect > 0.0 ? e->reflectance[j] / e->prob_reflect : 0.0;
}

double delta_dielectric_choose(const delta_dielectric_t *e, double u, bool *reflect, vec3_t *dir)
{
    *reflect = u < e->prob_reflect;
    *dir = *reflect ? e->reflect : e->refract;
    /* R / R and T / T are 1: written as 1, so that no rounding enters a photon's power. */
    if (*reflect || e->mode == BSDF_IMPORTANCE)
        return 1.0;
    return e->ratio * e->ratio;
}

int delta_fan_make(vec3_t dir, vec3_t nrm, const ior_model_t *inside, const double *lambda,
                   int count, bsdf_mode_t mode, delta_fan_t *fan)
{
    if (count < 1 || count > BSDF_MAX_LANES)
        return -1;
    /* nrm is outward, so air is always the outside medium. */
    const ior_model_t air = ior_constant(1.0);
    fan->mode = mode;
    fan->count = count;
    fan->reflect = fresnel_reflect(dir, nrm);
    return fanout_refract(&air, inside, dir, nrm, lambda, count, fan->rays, &fan->poly, NULL);
}

double delta_fan_weight(const delta_fan_t *fan, int i, double scale, double pick)
{
    if (i < 0 || i >= fan->count)
        return 0.0;
    const fanout_ray_t *r = &fan->rays[i];
    if (r->tir || !(r->transmittance > 0.0))
        return 0.0;
    if (fan->mode == BSDF_RADIANCE) {
        double ratio = r->n_incident / r->n_transmitted;
        return r->transmittance * scale * pick * ratio * ratio;
    }
    return r->transmittance * scale * pick;
}

delta_conductor_t delta_conductor_make(vec3_t dir, vec3_t nrm)
{
    const vec3_t wo = vec3_neg(dir);
    const vec3_t n = vec3_dot(nrm, wo) >= 0.0 ? nrm : vec3_neg(nrm);
    return (delta_conductor_t){.reflect = fresnel_reflect(dir, n), .cos_i = vec3_dot(wo, n)};
}

double delta_conductor_weight(const delta_conductor_t *e, double eta, double k)
{
    return fresnel_conductor(e->cos_i, eta, k);
}

double delta_conductor_coated_weight(const delta_conductor_t *e, double eta, double k,
                                     double lambda, const delta_film_t *film)
{
    const double nf = ior_eval(film->ior, lambda);
    const thinfilm_t f =
        thinfilm_eval(fabs(e->cos_i), 1.0, nf, film->thickness_nm, eta + I * k, lambda);
    return thinfilm_reflectance(&f);
}

mueller_t delta_dielectric_mueller(vec3_t out, vec3_t nrm, bool entering, double n, double lambda,
                                   const delta_film_t *film, bool reflect)
{
    /* The light's side: the path's on reflection, the other on refraction. */
    const bool light_outside = reflect ? entering : !entering;
    const double n_i = light_outside ? 1.0 : n, n_t = light_outside ? n : 1.0;
    const double cos_i = fmin(1.0, fabs(vec3_dot(out, nrm)));
    mueller_t m;
    if (film) {
        const double nf = ior_eval(film->ior, lambda);
        const thinfilm_t f = thinfilm_eval(cos_i, n_i, nf, film->thickness_nm, n_t, lambda);
        m = reflect ? thinfilm_reflection(&f) : thinfilm_transmission(&f);
    } else {
        const polar_fresnel_t f = polar_fresnel_eval(cos_i, n_i, n_t);
        m = reflect ? polar_fresnel_reflection(&f) : polar_fresnel_transmission(&f);
    }
    return mueller_normalised(&m);
}

mueller_t delta_conductor_mueller(const delta_conductor_t *e, double eta, double k, double lambda,
                                  const delta_film_t *film)
{
    mueller_t m;
    if (film) {
        const double nf = ior_eval(film->ior, lambda);
        const thinfilm_t f =
            thinfilm_eval(fabs(e->cos_i), 1.0, nf, film->thickness_nm, eta + I * k, lambda);
        m = thinfilm_reflection(&f);
    } else {
        const polar_fresnel_t f = polar_fresnel_conductor(fabs(e->cos_i), eta, k);
        m = polar_fresnel_reflection(&f);
    }
    return mueller_normalised(&m);
}
