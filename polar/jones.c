#include "jones.h"

#include <math.h>

jones_t jones_identity(void)
{
    return (jones_t){{{1.0, 0.0}, {0.0, 1.0}}};
}

jones_t jones_mul(const jones_t *a, const jones_t *b)
{
    jones_t r;
    for (int i = 0; i < 2; i++)
        for (int k = 0; k < 2; k++)
            r.m[i][k] = a->m[i][0] * b->m[0][k] + a->m[i][1] * b->m[1][k];
    return r;
}

mueller_t jones_mueller(const jones_t *j)
{
    double d[2][2][2];
    for (int r = 0; r < 2; r++)
        for (int c = 0; c < 2; c++) {
            d[r][c][0] = creal(j->m[r][c]);
            d[r][c][1] = cimag(j->m[r][c]);
        }
    return mueller_jones(d);
}

jones_t jones_elliptical(double phi_a, double phi_b, double psi)
{
    const double delta = phi_a - phi_b, g = sqrt(0.25 * delta * delta + psi * psi);
    /* sin g / g by its series where g is tiny (the ratio's rounding). */
    const double sg = g > 1e-4 ? sin(g) / g : 1.0 - g * g / 6.0, cg = cos(g);
    const double complex ph = cexp(I * 0.5 * (phi_a + phi_b));
    jones_t r;
    r.m[0][0] = ph * (cg + I * sg * 0.5 * delta);
    r.m[1][1] = ph * (cg - I * sg * 0.5 * delta);
    r.m[0][1] = -ph * sg * psi;
    r.m[1][0] = ph * sg * psi;
    return r;
}

/* The real unit field of a propagating wave (the solver's E is real then). */
static vec3_t field(const uniaxial_fresnel_wave_t *w)
{
    return vec3_make(creal(w->E[0]), creal(w->E[1]), creal(w->E[2]));
}

/* The power-normalised amplitude of outgoing wave o for unit power in incident wave i:
 * amp sqrt(|flux_o| / |flux_i|), zero unless both propagate. */
static double complex scaled(const uniaxial_fresnel_t *f, int i, int o)
{
    const uniaxial_fresnel_wave_t *wi = &f->in[i], *wo = &f->out[o];
    const double fi = fabs(wi->flux), fo = fabs(wo->flux);
    if (!f->ok || !wi->propagating || !wo->propagating || !(fi > 0.0))
        return 0.0;
    const double complex a = f->amp[i][o] * sqrt(fo / fi);
    return isfinite(creal(a)) && isfinite(cimag(a)) ? a : 0.0;
}

jones_t jones_uniaxial_exit(const uniaxial_fresnel_t *f, vec3_t k_out, vec3_t x_out)
{
    const vec3_t y_out = vec3_cross(k_out, x_out);
    const vec3_t es = field(&f->out[UF_S]), ep = field(&f->out[UF_P]);
    jones_t r = {{{0}}};
    for (int c = 0; c < 2; c++) {
        const int w = c ? UF_E : UF_O;
        const double complex as = scaled(f, w, UF_S), ap = scaled(f, w, UF_P);
        r.m[0][c] = as * vec3_dot(es, x_out) + ap * vec3_dot(ep, x_out);
        r.m[1][c] = as * vec3_dot(es, y_out) + ap * vec3_dot(ep, y_out);
    }
    return r;
}

jones_t jones_uniaxial_enter(const uniaxial_fresnel_t *f, vec3_t k_in, vec3_t x_in)
{
    const vec3_t y_in = vec3_cross(k_in, x_in);
    const vec3_t es = field(&f->in[UF_S]), ep = field(&f->in[UF_P]);
    jones_t r = {{{0}}};
    for (int row = 0; row < 2; row++) {
        const int w = row ? UF_E : UF_O;
        const double complex as = scaled(f, UF_S, w), ap = scaled(f, UF_P, w);
        /* The arriving field's s and p components, per unit field along x_in and y_in. */
        r.m[row][0] = as * vec3_dot(es, x_in) + ap * vec3_dot(ep, x_in);
        r.m[row][1] = as * vec3_dot(es, y_in) + ap * vec3_dot(ep, y_in);
    }
    return r;
}

jones_t jones_uniaxial_reflect(const uniaxial_fresnel_t *f)
{
    jones_t r;
    for (int row = 0; row < 2; row++)
        for (int c = 0; c < 2; c++)
            r.m[row][c] = scaled(f, c ? UF_E : UF_O, row ? UF_E : UF_O);
    return r;
}
