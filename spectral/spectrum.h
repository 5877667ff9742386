/* spectrum: spectral distributions evaluable at any wavelength (nm): tabulated, blackbody,
 * CIE illuminants D65 and A, constant, and RGB uplifted to smooth spectra (Jakob & Hanika
 * 2019). Objects are immutable after spectrum_new_*; spectrum_eval only reads, so one
 * spectrum may be evaluated from many threads at once. Evaluation never returns NaN or Inf. */
#ifndef PRISMFARM_SPECTRUM_H
#define PRISMFARM_SPECTRUM_H

#include "colour.h"
#include "err.h"

#include <stdbool.h>
#include <stddef.h>

typedef struct spectrum spectrum_t;

typedef enum spectrum_kind {
    SPECTRUM_CONSTANT,
    SPECTRUM_TABULATED,
    SPECTRUM_BLACKBODY,
    SPECTRUM_CIE_D65,
    SPECTRUM_CIE_A,
    SPECTRUM_RGB_REFLECTANCE,
    SPECTRUM_RGB_ILLUMINANT,
} spectrum_kind_t;

/* value everywhere; value must be finite. */
spectrum_t *spectrum_new_constant(double value, err_t *err);

/* n >= 1 (lambda, value) pairs, lambda strictly increasing, all finite; copied. Linear
 * interpolation inside, the end values held outside (a single pair is a constant); the
 * error names the first bad pair. */
spectrum_t *spectrum_new_tabulated(const double *lambda_nm, const double *value, size_t n,
                                   err_t *err);

/* The same, but 0 outside [lambda_nm[0], lambda_nm[n-1]] (pbrt-v4 PiecewiseLinearSpectrum),
 * for the named illuminant tables, which pbrt-v4 defines only over their range. */
spectrum_t *spectrum_new_tabulated_zero_outside(const double *lambda_nm, const double *value,
                                                size_t n, err_t *err);

/* Planck's law B(lambda, T) = 2 h c^2 / lambda^5 / (exp(h c / (lambda k T)) - 1), in
 * W m^-2 sr^-1 nm^-1 (CODATA 2018 constants), kelvin finite and > 0. With normalise, divided
 * by its value at the Wien peak lambda_max = 2.897771955e-3 m K / T so the peak is 1
 * (pbrt-v4 BlackbodySpectrum). */
spectrum_t *spectrum_new_blackbody(double kelvin, int normalise, err_t *err);

/* The normalised blackbody above at one wavelength, without a spectrum object (a medium's
 * temperature varies from point to point); 0 for a kelvin that is not finite and > 0. */
double spectrum_blackbody_eval(double lambda_nm, double kelvin);

/* CIE standard illuminant D65 (tabulated 300-830 nm at 5 nm, linear between, 0 outside) and
 * illuminant A (CIE 15:2004 eq. for a 2848 K Planckian with c2 = 1.435e-2 m K:
 * S_A = 100 (560/lambda)^5 (exp(1.435e7/(2848*560)) - 1) / (exp(1.435e7/(2848 lambda)) - 1),
 * lambda in nm, valid at any lambda > 0). Both relative, S(560) = 100. */
spectrum_t *spectrum_new_cie_d65(err_t *err);
spectrum_t *spectrum_new_cie_a(err_t *err);

/* A deep copy of src multiplied by factor (finite). */
spectrum_t *spectrum_new_scaled(const spectrum_t *src, double factor, err_t *err);

/* RGB reflectance (linear sRGB) uplifted to s(lambda) = sigmoid(c0 lambda^2 + c1 lambda + c2)
 * in (0, 1) by spectrum_sigmoid_fit. Components must be finite; they are clamped to [0, 1].
 * r = g = b gives exactly the constant spectrum of that value (0 and 1 included). */
spectrum_t *spectrum_new_rgb_reflectance(rgb_t rgb, err_t *err);

/* RGB emission (pbrt-v4 RGBIlluminantSpectrum): with m = 2 max(r, g, b), the spectrum is
 * m * uplift(rgb / m) * D65n, D65n being D65 scaled so that its Y is 1. Its XYZ is then the
 * XYZ of linear sRGB rgb (to the uplift's residual): rgb (1, 1, 1) is D65 with Y = 1.
 * Components must be finite and >= 0 (unbounded above). */
spectrum_t *spectrum_new_rgb_illuminant(rgb_t rgb, err_t *err);

void spectrum_destroy(spectrum_t **self_p);

/* A tabulated spectrum's own pairs (unscaled), alive as long as the spectrum: true and *n,
 * *lambda_nm, *value filled for SPECTRUM_TABULATED, false for any other kind. */
bool spectrum_tabulated_pairs(const spectrum_t *self, size_t *n, const double **lambda_nm,
                              const double **value);

/* The spectrum at lambda_nm; 0 for a non-finite lambda. */
double spectrum_eval(const spectrum_t *self, double lambda_nm);

spectrum_kind_t spectrum_kind(const spectrum_t *self);

/* Integral of s(lambda) y-bar(lambda) over 360-830 nm (1 nm sum, the same sum as
 * CIE_Y_INTEGRAL, so a constant 1 gives CIE_Y_INTEGRAL). */
double spectrum_photometric(const spectrum_t *self);

/* XYZ = sum over lambda = 360, 361, ..., 830 nm of s(lambda) * cmf(lambda) * 1 nm, divided
 * by CIE_Y_INTEGRAL. spectrum_eval is called 471 times. */
xyz_t spectrum_to_xyz(const spectrum_t *s);

/* pbrt-v4's SpectrumToPhotometric, by which lights divide their spectrum: the same as
 * spectrum_photometric except that for an RGB illuminant only its D65 part counts (times any
 * spectrum_new_scaled factor), so an rgb "L" keeps its colour's own brightness. */
double spectrum_photometric_light(const spectrum_t *self);

/* Jakob & Hanika 2019 uplift of one reflectance.
 * The residual: the sigmoid lies strictly inside (0, 1), so a target that needs a reflectance
 * of exactly 0 or 1 over a band is approached but not met, and the best fit within the step
 * budget is returned with its residual (not an error). Measured: every corner of the sRGB cube
 * ((1,0,0), (1,1,0), ...) and colours such as (0, 0, 1e-4) are reached to below 1e-11, because
 * they lie inside the D65 object-colour solid; the unreachable ones are targets within ~1e-3
 * of white with two components at 1, since the 4-decimal sRGB matrix maps the constant 1 to
 * (0.99999, 1.00002, 0.99982), not (1, 1, 1): (1, 1, 0.9999) keeps 7e-5, (1, 0.9999, 1) 1.6e-4,
 * and the uplift of white itself is the constant 1 (off by 1.8e-4). A consequence: a grey is
 * exactly flat, while a colour 1e-7 away from it is fitted exactly by a spectrum that departs
 * from flat by up to ~1e-3 (both are within 2e-4 in RGB).
 * Cost (gcc -O2, one 2-core EPYC): about 60 us for a typical colour (6 Gauss-Newton steps over
 * 471 wavelengths), 4 ms for the unreachable near-whites that exhaust the 100-step budget. */
typedef struct spectrum_sigmoid {
    double c[3];     /* s(lambda) = sigmoid(c[0] lambda^2 + c[1] lambda + c[2]), lambda in nm */
    rgb_t target;    /* the clamped target */
    rgb_t rgb;       /* linear sRGB of the fitted spectrum under D65 */
    double residual; /* max over channels of |rgb - target| */
    int iterations;  /* Gauss-Newton steps taken, all continuation stages together */
} spectrum_sigmoid_t;

/* sigmoid(x) = 0.5 + x / (2 sqrt(1 + x^2)); exact 0 and 1 only for infinite-like |x|. */
double spectrum_sigmoid(double x);

/* Solves for the coefficients whose spectrum, lit by D65 and seen through the CMFs and the
 * sRGB matrix (RGB = M * sum(s D65 cmf) / sum(D65 y-bar), 1 nm), gives target (components
 * clamped to [0, 1]). Gauss-Newton on that RGB residual in normalised wavelength
 * (lambda - 360) / 470, with a backtracking line search, started from the grey of equal
 * luminance and, if the direct solve does not reach 1e-9, by continuation from that grey toward
 * the target in 8, then 64 stages, each started from the previous solution (as Jakob &
 * Hanika's table builder seeds each cell with its neighbour's solution), 100 steps at most.
 * r = g = b gives c = (0, 0, sigmoid^-1(r)) (+-DBL_MAX for 0 and 1). Returns 0 (even with a
 * residual, see above) or -1 for a non-finite component. Deterministic; no shared state. */
int spectrum_sigmoid_fit(rgb_t target, spectrum_sigmoid_t *fit, err_t *err);

#endif
