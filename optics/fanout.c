#include "fanout.h"

#include "fresnel.h"

#include <float.h>
#include <math.h>

int fanout_split(const double *lambda_nm, const double *energy, int count, double shift,
                 fanout_sample_t *out, err_t *err)
{
    if (count < 1 || !lambda_nm || !energy || !out)
        return err_set(err, "fan-out: %d buckets (need at least 1) or missing arrays", count);
    if (!(shift >= -0.5 && shift <= 0.5))
        return err_set(err, "fan-out: shift S = %g is outside [-0.5, 0.5]", shift);
    for (int i = 0; i < count; i++) {
        if (!isfinite(lambda_nm[i]) || (i > 0 && !(lambda_nm[i] > lambda_nm[i - 1])))
            return err_set(err,
                           "fan-out: bucket centre %d (%g nm) is not finite and above the "
                           "previous one",
                           i, lambda_nm[i]);
        if (!isfinite(energy[i]))
            return err_set(err, "fan-out: energy of bucket %d is not finite", i);
    }

    double frac = fabs(shift);
    int step = shift > 0.0 ? 1 : -1;
    for (int i = 0; i < count; i++) {
        fanout_sample_t *s = &out[i];
        int j = i + step;
        bool has_neighbour = shift != 0.0 && j >= 0 && j < count;
        /* Spacing towards the neighbour, or, at an end of the grid, the mirrored spacing to the
         * only neighbour there is (a uniform grid's bucket half-width), so lambda' stays inside
         * the end bucket. */
        double spacing = 0.0;
        if (has_neighbour)
            spacing = lambda_nm[j] - lambda_nm[i];
        else if (count > 1 && shift != 0.0)
            spacing = i == 0 ? lambda_nm[0] - lambda_nm[1] : lambda_nm[i] - lambda_nm[i - 1];
        s->lambda_nm = lambda_nm[i] + frac * spacing;
        s->bucket[0] = i;
        if (has_neighbour) {
            /* (P - |S| P) + |S| P: the two parts add back to P up to one rounding. */
            double moved = frac * energy[i];
            s->bucket[1] = j;
            s->energy[0] = energy[i] - moved;
            s->energy[1] = moved;
        } else {
            s->bucket[1] = i;
            s->energy[0] = energy[i];
            s->energy[1] = 0.0;
        }
    }
    return 0;
}

/* k t_i = T_P (N t_i / sum): N t_i / sum <= N, so no overflow even for a subnormal sum. */
static double scaled_term(double t_i, int count, double sum, double t_poly)
{
    if (!(sum > 0.0) || !isfinite(sum) || !(t_poly > 0.0) || !isfinite(t_poly) || !(t_i > 0.0) ||
        !isfinite(t_i))
        return 0.0;
    return t_poly * ((double)count * t_i / sum);
}

static double scale_factor(int count, double sum, double t_poly)
{
    if (!(sum > 0.0) || !isfinite(sum) || !(t_poly > 0.0) || !isfinite(t_poly))
        return 0.0;
    double k = (double)count * t_poly / sum;
    return isfinite(k) ? k : DBL_MAX;
}

double fanout_fresnel_scale(const double *t, int count, double t_poly, double *scaled)
{
    double sum = 0.0;
    for (int i = 0; i < count; i++)
        if (t[i] > 0.0 && isfinite(t[i]))
            sum += t[i];
    double k = scale_factor(count, sum, t_poly);
    for (int i = 0; i < count; i++)
        scaled[i] = scaled_term(t[i], count, sum, t_poly);
    return k;
}

int fanout_refract(const ior_model_t *outside, const ior_model_t *inside, vec3_t d, vec3_t n,
                   const double *lambda_nm, int count, fanout_ray_t *rays, fanout_poly_t *poly,
                   err_t *err)
{
    if (!outside || !inside || !lambda_nm || !rays || !poly || count < 1)
        return err_set(err, "fan-out: %d wavelengths (need at least 1) or missing arguments",
                       count);
    if (!(vec3_length(d) > 0.0) || !(vec3_length(n) > 0.0))
        return err_set(err, "fan-out: zero-length or non-finite direction or normal");
    d = vec3_normalize(d);
    n = vec3_normalize(n);
    /* Fresnel's cos_theta_i is measured from the direction the light comes from (-d). */
    double cos_i = -vec3_dot(d, n);
    vec3_t mirror = fresnel_reflect(d, n);

    double sum_out = 0.0, sum_in = 0.0, sum_t = 0.0;
    for (int i = 0; i < count; i++) {
        fanout_ray_t *r = &rays[i];
        double n_out = ior_eval(outside, lambda_nm[i]);
        double n_in = ior_eval(inside, lambda_nm[i]);
        sum_out += n_out;
        sum_in += n_in;
        fresnel_terms_t f = fresnel_dielectric_terms(cos_i, n_out, n_in);
        r->lambda_nm = lambda_nm[i];
        r->n_incident = f.n1;
        r->n_transmitted = f.n2;
        bool refracted = fresnel_refract(d, n, f.n1 / f.n2, &r->dir);
        r->tir = f.tir || !refracted;
        if (r->tir) {
            r->dir = mirror;
            r->transmittance = 0.0;
        } else {
            r->transmittance = f.transmittance;
        }
        sum_t += r->transmittance;
    }

    fresnel_terms_t fp = fresnel_dielectric_terms(cos_i, sum_out / count, sum_in / count);
    poly->n_incident = fp.n1;
    poly->n_transmitted = fp.n2;
    poly->reflect_dir = mirror;
    bool refracted = fresnel_refract(d, n, fp.n1 / fp.n2, &poly->refract_dir);
    poly->tir = fp.tir || !refracted;
    if (poly->tir)
        poly->refract_dir = vec3_make(0.0, 0.0, 0.0);
    if (poly->tir || !(sum_t > 0.0)) {
        /* No monochrome ray gets through, so neither may the polychrome one: R_P = 1 keeps
         * R_P + mean(k t_i) = 1. */
        poly->reflectance = 1.0;
        poly->transmittance = 0.0;
    } else {
        poly->reflectance = fp.reflectance;
        poly->transmittance = fp.transmittance;
    }
    poly->scale = scale_factor(count, sum_t, poly->transmittance);
    for (int i = 0; i < count; i++)
        rays[i].transmittance =
            scaled_term(rays[i].transmittance, count, sum_t, poly->transmittance);
    return 0;
}
