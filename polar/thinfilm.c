#include "thinfilm.h"

#include "polar_fresnel.h"

#include <math.h>

#define PF_TWO_PI 6.28318530717958647692

/* cos theta in a medium of index n from Snell's invariant n_0 sin theta_0 (given squared as
 * (n_0 sin theta_0)^2): the root whose wave n cos theta propagates or decays away from the
 * interface (Im(n cos) >= 0; Born & Wolf §14.2). */
static double complex layer_cos(double complex n, double complex invariant2)
{
    double complex c = csqrt(1.0 - invariant2 / (n * n));
    if (cimag(n * c) < 0.0 || (cimag(n * c) == 0.0 && creal(n * c) < 0.0))
        c = -c;
    return c;
}

static double clamp01(double v)
{
    return isfinite(v) ? fmin(1.0, fmax(0.0, v)) : 0.0;
}

thinfilm_t thinfilm_eval(double cos_0, double complex n0, double complex n1, double thickness_nm,
                         double complex n2, double lambda_nm)
{
    thinfilm_t f = {.rs = -1.0, .rp = -1.0, .Rs = 1.0, .Rp = 1.0};
    cos_0 = fmin(1.0, fabs(cos_0));
    if (!(cos_0 >= 0.0))
        cos_0 = 0.0;
    if (!(creal(n0) > 0.0) || !(creal(n1) > 0.0) || !(creal(n2) >= 0.0) || !(cabs(n2) > 0.0) ||
        !(lambda_nm > 0.0) || !(thickness_nm >= 0.0) || !isfinite(thickness_nm) ||
        !isfinite(creal(n0) + cimag(n0) + creal(n1) + cimag(n1) + creal(n2) + cimag(n2)))
        return f;
    const double sin2_0 = fmax(0.0, 1.0 - cos_0 * cos_0);
    const double complex inv2 = n0 * n0 * sin2_0;
    const double complex c0 = cos_0, c1 = layer_cos(n1, inv2), c2 = layer_cos(n2, inv2);
    double complex r01s, r01p, t01s, t01p, r12s, r12p, t12s, t12p;
    polar_fresnel_amplitudes(n0, c0, n1, c1, &r01s, &r01p, &t01s, &t01p);
    polar_fresnel_amplitudes(n1, c1, n2, c2, &r12s, &r12p, &t12s, &t12p);
    /* The phase the wave gains crossing the film once; Im(beta) >= 0 (layer_cos), so the
     * exponentials below never overflow: an absorbing film's round trip only decays. */
    const double complex beta = PF_TWO_PI * n1 * c1 * thickness_nm / lambda_nm;
    const double complex e1 = cexp(I * beta), e2 = e1 * e1;
    const double complex ds = 1.0 + r01s * r12s * e2, dp = 1.0 + r01p * r12p * e2;
    if (!(cabs(ds) > 0.0) || !(cabs(dp) > 0.0))
        return f;
    f.rs = (r01s + r12s * e2) / ds;
    f.rp = (r01p + r12p * e2) / dp;
    f.ts = t01s * t12s * e1 / ds;
    f.tp = t01p * t12p * e1 / dp;
    const double in = creal(n0 * c0), out = creal(n2 * c2);
    f.eta_t = in > 0.0 && out > 0.0 && isfinite(out / in) ? out / in : 0.0;
    f.Rs = clamp01(creal(f.rs * conj(f.rs)));
    f.Rp = clamp01(creal(f.rp * conj(f.rp)));
    f.Ts = clamp01(f.eta_t * creal(f.ts * conj(f.ts)));
    f.Tp = clamp01(f.eta_t * creal(f.tp * conj(f.tp)));
    return f;
}

double thinfilm_reflectance(const thinfilm_t *f)
{
    return 0.5 * (f->Rs + f->Rp);
}

double thinfilm_transmittance(const thinfilm_t *f)
{
    return 0.5 * (f->Ts + f->Tp);
}

mueller_t thinfilm_reflection(const thinfilm_t *f)
{
    return mueller_jones_diagonal(creal(f->rs), cimag(f->rs), creal(f->rp), cimag(f->rp));
}

mueller_t thinfilm_transmission(const thinfilm_t *f)
{
    const double s = sqrt(f->eta_t);
    const double complex ts = f->ts * s, tp = f->tp * s;
    return mueller_jones_diagonal(creal(ts), cimag(ts), creal(tp), cimag(tp));
}
