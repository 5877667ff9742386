/* wavelength: continuous wavelength sampling for light transport, uniform over a range or
 * importance-sampled to the eye's response (pbrt-v4's visible-wavelength pdf), each sample
 * returned with its pdf (1/nm); and hero-wavelength tuples (Wilkie et al. 2014): one sampled
 * wavelength and three more rotated by equal spacing. Pure functions; u is in [0, 1). */
#ifndef PRISMFARM_WAVELENGTH_H
#define PRISMFARM_WAVELENGTH_H

#define WAVELENGTH_HERO_COUNT 4

/* Range of the visible-importance pdf (the CIE table's range). */
#define WAVELENGTH_VISIBLE_MIN 360.0
#define WAVELENGTH_VISIBLE_MAX 830.0

typedef struct wavelength_sample {
    double lambda; /* nm */
    double pdf;    /* 1/nm, > 0 for a valid sample */
} wavelength_sample_t;

/* lambda[0] is the hero; pdf[j] is the marginal density of lambda[j] (each lambda[j] alone is
 * distributed with that pdf). The estimator of a spectral integral is
 * (1/WAVELENGTH_HERO_COUNT) * sum_j f(lambda[j]) / pdf[j], skipping terms with pdf[j] = 0. */
typedef struct wavelength_hero {
    double lambda[WAVELENGTH_HERO_COUNT];
    double pdf[WAVELENGTH_HERO_COUNT];
} wavelength_hero_t;

/* Uniform over [lambda_min, lambda_max] (lambda_min < lambda_max, finite): pdf 1/range.
 * u outside [0, 1) is clamped into it; a non-finite u gives the range's start. */
wavelength_sample_t wavelength_sample_uniform(double u, double lambda_min, double lambda_max);
double wavelength_pdf_uniform(double lambda_nm, double lambda_min, double lambda_max);

/* Visible importance (pbrt-v4 SampleVisibleWavelengths): over [360, 830] nm,
 *   p(lambda) = A / cosh^2(0.0072 (lambda - 538)),  A = 0.0072 / (tanh(0.0072*292) +
 * tanh(0.0072*178)), normalised here from the formula (A = 0.00393980, as pbrt-v4's 0.0039398042),
 * and sampled by its exact inverse CDF lambda = 538 + atanh(t0 + u (t1 - t0)) / 0.0072 with t0 =
 * tanh(0.0072 (360 - 538)), t1 = tanh(0.0072 (830 - 538)). The pdf is 0 outside. */
wavelength_sample_t wavelength_sample_visible(double u);
double wavelength_pdf_visible(double lambda_nm);

/* Hero tuples. Uniform: lambda[j] = lambda_min + frac(u + j/4) * range, i.e. the hero rotated
 * by j/4 of the range (lambda_j = lambda_min + frac((lambda_0 - lambda_min)/range + j/4) range).
 * Visible: u is rotated (u_j = frac(u + j/4)) and each u_j mapped by the inverse CDF, as
 * pbrt-v4's SampledWavelengths::SampleVisible does, which stratifies the CDF. */
wavelength_hero_t wavelength_hero_uniform(double u, double lambda_min, double lambda_max);
wavelength_hero_t wavelength_hero_visible(double u);

/* At a dispersive interface only the hero survives (pbrt-v4 TerminateSecondary): pdf[1..3]
 * become 0 and pdf[0] is divided by WAVELENGTH_HERO_COUNT, so that the estimator above stays
 * unbiased with one term. Calling it twice does nothing more. */
void wavelength_hero_terminate_secondary(wavelength_hero_t *hero);

/* True when only the hero is left (after wavelength_hero_terminate_secondary). */
int wavelength_hero_is_terminated(const wavelength_hero_t *hero);

#endif
