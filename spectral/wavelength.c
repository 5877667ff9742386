#include "wavelength.h"

#include <math.h>

/* pbrt-v4's visible-wavelength pdf parameters (Physically Based Rendering 4th ed., §4.6.5):
 * p(lambda) proportional to sech^2(VIS_B (lambda - VIS_C)). */
#define VIS_B 0.0072
#define VIS_C 538.0

static double clamp_unit(double u)
{
    if (!(u >= 0.0)) /* also catches NaN */
        return 0.0;
    if (u >= 1.0)
        return nextafter(1.0, 0.0);
    return u;
}

static double frac(double x)
{
    double f = x - floor(x);
    return f >= 1.0 ? 0.0 : f;
}

wavelength_sample_t wavelength_sample_uniform(double u, double lambda_min, double lambda_max)
{
    double range = lambda_max - lambda_min;
    if (!(range > 0.0) || !isfinite(range))
        return (wavelength_sample_t){lambda_min, 0.0};
    double lambda = lambda_min + clamp_unit(u) * range;
    if (lambda > lambda_max)
        lambda = lambda_max;
    return (wavelength_sample_t){lambda, 1.0 / range};
}

double wavelength_pdf_uniform(double lambda_nm, double lambda_min, double lambda_max)
{
    double range = lambda_max - lambda_min;
    if (!(range > 0.0) || !isfinite(range) || !(lambda_nm >= lambda_min && lambda_nm <= lambda_max))
        return 0.0;
    return 1.0 / range;
}

/* tanh at the two ends of the visible range, from which the normalisation and the inverse CDF
 * follow: the CDF of sech^2(B(x - c)) is tanh(B(x - c)) / B. */
static double vis_t0(void)
{
    return tanh(VIS_B * (WAVELENGTH_VISIBLE_MIN - VIS_C));
}
static double vis_t1(void)
{
    return tanh(VIS_B * (WAVELENGTH_VISIBLE_MAX - VIS_C));
}

double wavelength_pdf_visible(double lambda_nm)
{
    if (!(lambda_nm >= WAVELENGTH_VISIBLE_MIN && lambda_nm <= WAVELENGTH_VISIBLE_MAX))
        return 0.0;
    double a = VIS_B / (vis_t1() - vis_t0());
    double ch = cosh(VIS_B * (lambda_nm - VIS_C));
    return a / (ch * ch);
}

wavelength_sample_t wavelength_sample_visible(double u)
{
    double t0 = vis_t0(), t1 = vis_t1();
    double lambda = VIS_C + atanh(t0 + clamp_unit(u) * (t1 - t0)) / VIS_B;
    /* atanh near the ends can round a hair outside the range. */
    if (lambda < WAVELENGTH_VISIBLE_MIN)
        lambda = WAVELENGTH_VISIBLE_MIN;
    if (lambda > WAVELENGTH_VISIBLE_MAX)
        lambda = WAVELENGTH_VISIBLE_MAX;
    return (wavelength_sample_t){lambda, wavelength_pdf_visible(lambda)};
}

wavelength_hero_t wavelength_hero_uniform(double u, double lambda_min, double lambda_max)
{
    wavelength_hero_t h;
    u = clamp_unit(u);
    for (int j = 0; j < WAVELENGTH_HERO_COUNT; j++) {
        wavelength_sample_t s = wavelength_sample_uniform(
            frac(u + (double)j / WAVELENGTH_HERO_COUNT), lambda_min, lambda_max);
        h.lambda[j] = s.lambda;
        h.pdf[j] = s.pdf;
    }
    return h;
}

wavelength_hero_t wavelength_hero_visible(double u)
{
    wavelength_hero_t h;
    u = clamp_unit(u);
    for (int j = 0; j < WAVELENGTH_HERO_COUNT; j++) {
        wavelength_sample_t s =
            wavelength_sample_visible(frac(u + (double)j / WAVELENGTH_HERO_COUNT));
        h.lambda[j] = s.lambda;
        h.pdf[j] = s.pdf;
    }
    return h;
}

int wavelength_hero_is_terminated(const wavelength_hero_t *hero)
{
    for (int j = 1; j < WAVELENGTH_HERO_COUNT; j++)
        if (hero->pdf[j] != 0.0)
            return 0;
    return 1;
}

void wavelength_hero_terminate_secondary(wavelength_hero_t *hero)
{
    if (wavelength_hero_is_terminated(hero))
        return;
    for (int j = 1; j < WAVELENGTH_HERO_COUNT; j++)
        hero->pdf[j] = 0.0;
    hero->pdf[0] /= (double)WAVELENGTH_HERO_COUNT;
}
