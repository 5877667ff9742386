#include "polar_fresnel.h"

#include <math.h>

static bool finite_c(double complex z)
{
    return isfinite(creal(z)) && isfinite(cimag(z));
}

void polar_fresnel_amplitudes(double complex n_i, double complex cos_i, double complex n_t,
                              double complex cos_t, double complex *rs, double complex *rp,
                              double complex *ts, double complex *tp)
{
    /* Born & Wolf §1.5.2 eq. 20-21 in the cosine form: never the tan/sin form, which is 0/0 at
     * normal incidence and infinite over infinite at Brewster's angle (docs/physics.md §3.2). */
    const double complex ds = n_i * cos_i + n_t * cos_t, dp = n_t * cos_i + n_i * cos_t;
    if (!(cabs(ds) > 0.0) || !(cabs(dp) > 0.0)) {
        /* Grazing incidence onto an interface with nothing transmitted: the limit r = -1. */
        *rs = *rp = -1.0;
        *ts = *tp = 0.0;
        return;
    }
    *rs = (n_i * cos_i - n_t * cos_t) / ds;
    *rp = (n_t * cos_i - n_i * cos_t) / dp;
    *ts = 2.0 * n_i * cos_i / ds;
    *tp = 2.0 * n_i * cos_i / dp;
    if (!finite_c(*rs) || !finite_c(*rp) || !finite_c(*ts) || !finite_c(*tp)) {
        /* Index ratios so extreme that n cos overflows (a cos_t of i * Inf far beyond the
         * critical angle): the limit is total reflection, r = -1. */
        *rs = *rp = -1.0;
        *ts = *tp = 0.0;
    }
}

polar_fresnel_t polar_fresnel_eval(double cos_i, double complex n_i, double complex n_t)
{
    polar_fresnel_t f = {.rs = -1.0, .rp = -1.0, .Rs = 1.0, .Rp = 1.0, .tir = true};
    if (!finite_c(n_i) || !finite_c(n_t) || !(creal(n_i) > 0.0) || !(creal(n_t) >= 0.0) ||
        !(cabs(n_t) > 0.0))
        return f; /* a mirror rather than a NaN, as optics/fresnel.h does */
    cos_i = fmin(1.0, fabs(cos_i));
    if (!(cos_i >= 0.0))
        cos_i = 0.0;
    const double sin2_i = fmax(0.0, 1.0 - cos_i * cos_i);
    const double complex ratio = n_i / n_t;
    /* At normal incidence cos_t is exactly 1, whatever the ratio (no overflow of ratio^2). */
    double complex cos_t = sin2_i > 0.0 ? csqrt(1.0 - ratio * ratio * sin2_i) : 1.0;
    if (cimag(n_t * cos_t) < 0.0)
        cos_t = -cos_t;
    f.cos_t = cos_t;
    polar_fresnel_amplitudes(n_i, cos_i, n_t, cos_t, &f.rs, &f.rp, &f.ts, &f.tp);
    const double in = creal(n_i * cos_i), out = creal(n_t * cos_t);
    /* A transmitted wave that does not propagate (beyond the critical angle) carries no power:
     * its n_t cos_t is purely imaginary. */
    f.tir = !(out > 1e-300) && cimag(n_t) == 0.0;
    f.eta_t = in > 0.0 && out > 0.0 ? out / in : 0.0;
    f.Rs = fmin(1.0, creal(f.rs * conj(f.rs)));
    f.Rp = fmin(1.0, creal(f.rp * conj(f.rp)));
    f.Ts = f.eta_t * creal(f.ts * conj(f.ts));
    f.Tp = f.eta_t * creal(f.tp * conj(f.tp));
    if (!isfinite(f.Ts) || !isfinite(f.Tp) || !isfinite(f.eta_t)) {
        f.Ts = f.Tp = f.eta_t = 0.0;
    }
    return f;
}

polar_fresnel_t polar_fresnel_dielectric(double cos_theta_i, double n_outside, double n_inside)
{
    if (cos_theta_i < 0.0)
        return polar_fresnel_eval(-cos_theta_i, n_inside, n_outside);
    return polar_fresnel_eval(cos_theta_i, n_outside, n_inside);
}

polar_fresnel_t polar_fresnel_conductor(double cos_i, double eta, double k)
{
    return polar_fresnel_eval(fabs(cos_i), 1.0, eta + I * k);
}

mueller_t polar_fresnel_reflection(const polar_fresnel_t *f)
{
    return mueller_jones_diagonal(creal(f->rs), cimag(f->rs), creal(f->rp), cimag(f->rp));
}

mueller_t polar_fresnel_transmission(const polar_fresnel_t *f)
{
    const double s = sqrt(f->eta_t);
    const double complex ts = f->ts * s, tp = f->tp * s;
    return mueller_jones_diagonal(creal(ts), cimag(ts), creal(tp), cimag(tp));
}
