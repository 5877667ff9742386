#include "spectrum.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

struct spectrum {
    spectrum_kind_t kind;
    double scale; /* every kind is multiplied by it (spectrum_new_scaled) */

    double constant; /* CONSTANT */

    size_t n; /* TABULATED: n pairs, lambda strictly increasing */
    double *lambda;
    double *value;
    int zero_outside; /* TABULATED: 0 outside [lambda[0], lambda[n-1]], not the end values */

    double kelvin; /* BLACKBODY */
    double bb_norm;

    /* RGB_REFLECTANCE and RGB_ILLUMINANT: sigmoid coefficients in nm, or a flat value. */
    double coeff[3];
    int flat;
    double flat_value;
    double rgb_scale; /* RGB_ILLUMINANT: m = 2 max(r, g, b) */
    double d65_norm;  /* RGB_ILLUMINANT: makes the D65 factor's Y equal 1 */
};

/* CODATA 2018 exact SI constants and Wien's displacement constant. */
#define PLANCK_H 6.62607015e-34
#define LIGHT_C 299792458.0
#define BOLTZMANN_K 1.380649e-23
#define WIEN_B 2.897771955e-3 /* m K */

static spectrum_t *spectrum_alloc(spectrum_kind_t kind, err_t *err)
{
    spectrum_t *s = calloc(1, sizeof *s);
    if (!s) {
        err_set(err, "spectrum: out of memory");
        return NULL;
    }
    s->kind = kind;
    s->scale = 1.0;
    return s;
}

void spectrum_destroy(spectrum_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    free((*self_p)->lambda);
    free((*self_p)->value);
    free(*self_p);
    *self_p = NULL;
}

spectrum_kind_t spectrum_kind(const spectrum_t *self)
{
    return self->kind;
}

spectrum_t *spectrum_new_constant(double value, err_t *err)
{
    if (!isfinite(value)) {
        err_set(err, "constant spectrum: value %g is not finite", value);
        return NULL;
    }
    spectrum_t *s = spectrum_alloc(SPECTRUM_CONSTANT, err);
    if (s)
        s->constant = value;
    return s;
}

static spectrum_t *tabulated(const double *lambda_nm, const double *value, size_t n,
                             int zero_outside, err_t *err)
{
    if (n == 0 || !lambda_nm || !value) {
        err_set(err, "tabulated spectrum: needs at least one (lambda, value) pair, got %zu", n);
        return NULL;
    }
    for (size_t i = 0; i < n; i++) {
        if (!isfinite(lambda_nm[i]) || !isfinite(value[i])) {
            err_set(err,
                    "tabulated spectrum: pair %zu of %zu (lambda %g nm, value %g) is not finite",
                    i + 1, n, lambda_nm[i], value[i]);
            return NULL;
        }
        if (i > 0 && !(lambda_nm[i] > lambda_nm[i - 1])) {
            err_set(err,
                    "tabulated spectrum: pair %zu of %zu (lambda %g nm) does not follow pair %zu "
                    "(lambda %g nm): "
                    "wavelengths must increase strictly",
                    i + 1, n, lambda_nm[i], i, lambda_nm[i - 1]);
            return NULL;
        }
    }
    spectrum_t *s = spectrum_alloc(SPECTRUM_TABULATED, err);
    if (!s)
        return NULL;
    s->n = n;
    s->lambda = malloc(n * sizeof *s->lambda);
    s->value = malloc(n * sizeof *s->value);
    if (!s->lambda || !s->value) {
        spectrum_destroy(&s);
        err_set(err, "tabulated spectrum: out of memory for %zu pairs", n);
        return NULL;
    }
    memcpy(s->lambda, lambda_nm, n * sizeof *s->lambda);
    memcpy(s->value, value, n * sizeof *s->value);
    s->zero_outside = zero_outside;
    return s;
}

spectrum_t *spectrum_new_tabulated(const double *lambda_nm, const double *value, size_t n,
                                   err_t *err)
{
    return tabulated(lambda_nm, value, n, 0, err);
}

spectrum_t *spectrum_new_tabulated_zero_outside(const double *lambda_nm, const double *value,
                                                size_t n, err_t *err)
{
    return tabulated(lambda_nm, value, n, 1, err);
}

bool spectrum_tabulated_pairs(const spectrum_t *self, size_t *n, const double **lambda_nm,
                              const double **value)
{
    if (!self || self->kind != SPECTRUM_TABULATED)
        return false;
    *n = self->n;
    *lambda_nm = self->lambda;
    *value = self->value;
    return true;
}

/* Planck's law per nm of wavelength; expm1 keeps the Rayleigh-Jeans end accurate and an
 * overflowing exponent gives +Inf in the denominator, hence 0, not NaN. */
static double planck(double lambda_nm, double kelvin)
{
    if (!(lambda_nm > 0.0))
        return 0.0;
    double l = lambda_nm * 1e-9;
    double e = expm1(PLANCK_H * LIGHT_C / (l * BOLTZMANN_K * kelvin));
    double l5 = l * l * l * l * l;
    double b = 2.0 * PLANCK_H * LIGHT_C * LIGHT_C / (l5 * e); /* W m^-2 sr^-1 m^-1 */
    return isfinite(b) ? b * 1e-9 : 0.0;
}

double spectrum_blackbody_eval(double lambda_nm, double kelvin)
{
    if (!isfinite(kelvin) || !(kelvin > 0.0))
        return 0.0;
    double peak = planck(WIEN_B / kelvin * 1e9, kelvin);
    double v = peak > 0.0 ? planck(lambda_nm, kelvin) / peak : 0.0;
    return isfinite(v) ? v : 0.0;
}

spectrum_t *spectrum_new_blackbody(double kelvin, int normalise, err_t *err)
{
    if (!isfinite(kelvin) || kelvin <= 0.0) {
        err_set(err, "blackbody spectrum: temperature %g K must be finite and > 0", kelvin);
        return NULL;
    }
    double norm = 1.0;
    if (normalise) {
        double peak = planck(WIEN_B / kelvin * 1e9, kelvin);
        if (!(peak > 0.0) || !isfinite(1.0 / peak)) {
            err_set(err,
                    "blackbody spectrum: temperature %g K: peak radiance %g cannot be normalised",
                    kelvin, peak);
            return NULL;
        }
        norm = 1.0 / peak;
    }
    spectrum_t *s = spectrum_alloc(SPECTRUM_BLACKBODY, err);
    if (s) {
        s->kelvin = kelvin;
        s->bb_norm = norm;
    }
    return s;
}

spectrum_t *spectrum_new_cie_d65(err_t *err)
{
    return spectrum_alloc(SPECTRUM_CIE_D65, err);
}

spectrum_t *spectrum_new_cie_a(err_t *err)
{
    return spectrum_alloc(SPECTRUM_CIE_A, err);
}

/* CIE 15:2004 illuminant A: a Planckian radiator at 2848 K with the c2 = 1.435e-2 m K of the
 * 1931 definition (hence "2856 K" with today's c2), normalised to 100 at 560 nm. */
static double illuminant_a(double lambda_nm)
{
    if (!(lambda_nm > 0.0))
        return 0.0;
    const double c2 = 1.435e7; /* nm K */
    double num = expm1(c2 / (2848.0 * 560.0));
    double den = expm1(c2 / (2848.0 * lambda_nm));
    double r = 560.0 / lambda_nm;
    double v = 100.0 * r * r * r * r * r * num / den;
    return isfinite(v) ? v : 0.0;
}

spectrum_t *spectrum_new_scaled(const spectrum_t *src, double factor, err_t *err)
{
    if (!isfinite(factor)) {
        err_set(err, "scaled spectrum: factor %g is not finite", factor);
        return NULL;
    }
    spectrum_t *s = spectrum_alloc(src->kind, err);
    if (!s)
        return NULL;
    *s = *src;
    s->lambda = NULL;
    s->value = NULL;
    if (src->kind == SPECTRUM_TABULATED) {
        s->lambda = malloc(src->n * sizeof *s->lambda);
        s->value = malloc(src->n * sizeof *s->value);
        if (!s->lambda || !s->value) {
            spectrum_destroy(&s);
            err_set(err, "scaled spectrum: out of memory for %zu pairs", src->n);
            return NULL;
        }
        memcpy(s->lambda, src->lambda, src->n * sizeof *s->lambda);
        memcpy(s->value, src->value, src->n * sizeof *s->value);
    }
    s->scale = src->scale * factor;
    return s;
}

double spectrum_sigmoid(double x)
{
    /* Beyond |x| = 1e8 the distance to 0 or 1 (about 1/(4 x^2)) is below double precision at
     * 1, and x^2 would overflow for |x| > 1e154. */
    if (x > 1e8)
        return 1.0;
    if (x < -1e8)
        return 0.0;
    if (isnan(x))
        return 0.5;
    return 0.5 + x / (2.0 * sqrt(1.0 + x * x));
}

static double tabulated_eval(const spectrum_t *s, double lambda)
{
    size_t n = s->n;
    if (s->zero_outside && (lambda < s->lambda[0] || lambda > s->lambda[n - 1]))
        return 0.0;
    if (lambda <= s->lambda[0])
        return s->value[0];
    if (lambda >= s->lambda[n - 1])
        return s->value[n - 1];
    size_t lo = 0, hi = n - 1; /* lambda[lo] < lambda < lambda[hi] */
    while (hi - lo > 1) {
        size_t mid = lo + (hi - lo) / 2;
        if (s->lambda[mid] <= lambda)
            lo = mid;
        else
            hi = mid;
    }
    double f = (lambda - s->lambda[lo]) / (s->lambda[hi] - s->lambda[lo]);
    return s->value[lo] + f * (s->value[hi] - s->value[lo]);
}

static double rgb_reflectance_eval(const spectrum_t *s, double lambda)
{
    if (s->flat)
        return s->flat_value;
    return spectrum_sigmoid((s->coeff[0] * lambda + s->coeff[1]) * lambda + s->coeff[2]);
}

double spectrum_eval(const spectrum_t *self, double lambda_nm)
{
    if (!isfinite(lambda_nm))
        return 0.0;
    double v = 0.0;
    switch (self->kind) {
    case SPECTRUM_CONSTANT:
        v = self->constant;
        break;
    case SPECTRUM_TABULATED:
        v = tabulated_eval(self, lambda_nm);
        break;
    case SPECTRUM_BLACKBODY:
        v = planck(lambda_nm, self->kelvin) * self->bb_norm;
        break;
    case SPECTRUM_CIE_D65:
        v = cie_d65_eval(lambda_nm);
        break;
    case SPECTRUM_CIE_A:
        v = illuminant_a(lambda_nm);
        break;
    case SPECTRUM_RGB_REFLECTANCE:
        v = rgb_reflectance_eval(self, lambda_nm);
        break;
    case SPECTRUM_RGB_ILLUMINANT:
        v = self->rgb_scale * rgb_reflectance_eval(self, lambda_nm) * self->d65_norm *
            cie_d65_eval(lambda_nm);
        break;
    }
    v *= self->scale;
    return isfinite(v) ? v : 0.0;
}

/* sum over lambda = 360..830 nm of D65 * y-bar (about 10567.8). */
static double d65_y_sum(void)
{
    double sum = 0.0;
    for (int i = 0; i < CIE_SAMPLE_COUNT; i++)
        sum += cie_d65_eval(CIE_LAMBDA_MIN + (double)i) * cie_y_table[i];
    return sum;
}

double spectrum_photometric(const spectrum_t *self)
{
    double sum = 0.0;
    for (int i = 0; i < CIE_SAMPLE_COUNT; i++)
        sum += spectrum_eval(self, CIE_LAMBDA_MIN + (double)i) * cie_y_table[i];
    return sum;
}

double spectrum_photometric_light(const spectrum_t *self)
{
    if (self->kind == SPECTRUM_RGB_ILLUMINANT)
        return self->scale * self->d65_norm * d65_y_sum();
    return spectrum_photometric(self);
}

/* ---- Jakob & Hanika 2019 uplift ----------------------------------------------------------
 *
 * The model: s(t) = sigmoid(a t^2 + b t + c), t = (lambda - 360) / 470 (the paper normalises
 * wavelength the same way to keep the 3x3 system well conditioned). Its linear sRGB under D65
 *   RGB(a, b, c) = sum_k s(t_k) W_k,  W_k = M cmf(lambda_k) D65(lambda_k) / sum_j D65 y-bar,
 * over lambda_k = 360..830 nm, is smooth in (a, b, c) with Jacobian
 *   dRGB/d(a, b, c) = sum_k sigmoid'(x_k) (t_k^2, t_k, 1) W_k,  sigmoid'(x) = (1 + x^2)^(-3/2) / 2.
 * Gauss-Newton solves RGB(a, b, c) = target; a backtracking line search keeps each step
 * decreasing |residual|. Saturated targets need large coefficients that a step from grey
 * overshoots, so, as in the paper's table builder (which walks each row of its table from a
 * mid-brightness start, seeding each cell with its neighbour's solution), the target is
 * approached by continuation from the grey of equal luminance. */

#define JH_N CIE_SAMPLE_COUNT
#define JH_TOL 1e-10      /* converged: max |residual| below this */
#define JH_ACCEPT 1e-9    /* a solve reaching this needs no (more) continuation */
#define JH_STAGE_TOL 1e-7 /* intermediate continuation stages stop here */
#define JH_MAX_ITER 60    /* Gauss-Newton steps per stage */
/* Steps over all attempts together. A target just outside what a [0, 1] reflectance can reach
 * (e.g. (1, 1, 0.9999): sRGB white is 1e-4 off the D65 the matrices assume) only creeps
 * toward the boundary; the budget bounds the time spent there (a few ms) and the best
 * solution found is kept. Reachable targets converge in under 25 steps. */
#define JH_BUDGET 100

typedef struct jh_system {
    double t[JH_N];
    double w[JH_N][3];
} jh_system_t;

static void jh_system_init(jh_system_t *sys)
{
    double norm = d65_y_sum();
    for (int k = 0; k < JH_N; k++) {
        double lambda = CIE_LAMBDA_MIN + (double)k;
        double d = cie_d65_eval(lambda) / norm;
        rgb_t w = colour_xyz_to_linear_srgb(
            (xyz_t){cie_x_table[k] * d, cie_y_table[k] * d, cie_z_table[k] * d});
        sys->t[k] = (double)k / (double)(JH_N - 1);
        sys->w[k][0] = w.r;
        sys->w[k][1] = w.g;
        sys->w[k][2] = w.b;
    }
}

/* RGB of coefficients c and, if jac is not NULL, its Jacobian jac[channel][coefficient]. */
static void jh_eval(const jh_system_t *sys, const double c[3], double rgb[3], double jac[3][3])
{
    rgb[0] = rgb[1] = rgb[2] = 0.0;
    if (jac)
        memset(jac, 0, 9 * sizeof jac[0][0]);
    for (int k = 0; k < JH_N; k++) {
        double t = sys->t[k];
        double x = (c[0] * t + c[1]) * t + c[2];
        double s = spectrum_sigmoid(x);
        for (int i = 0; i < 3; i++)
            rgb[i] += s * sys->w[k][i];
        if (jac && fabs(x) < 1e8) {
            double q = 1.0 + x * x;
            double ds = 0.5 / (q * sqrt(q));
            double basis[3] = {t * t, t, 1.0};
            for (int i = 0; i < 3; i++)
                for (int j = 0; j < 3; j++)
                    jac[i][j] += ds * basis[j] * sys->w[k][i];
        }
    }
}

static double max_abs3(const double v[3])
{
    double m = fabs(v[0]);
    if (fabs(v[1]) > m)
        m = fabs(v[1]);
    if (fabs(v[2]) > m)
        m = fabs(v[2]);
    return m;
}

/* Solves A x = b (3x3) by Gaussian elimination with partial pivoting; -1 if singular. */
static int solve3(double a[3][3], double b[3], double x[3])
{
    for (int col = 0; col < 3; col++) {
        int piv = col;
        for (int r = col + 1; r < 3; r++)
            if (fabs(a[r][col]) > fabs(a[piv][col]))
                piv = r;
        if (!(fabs(a[piv][col]) > 1e-300))
            return -1;
        if (piv != col) {
            for (int j = 0; j < 3; j++) {
                double t = a[col][j];
                a[col][j] = a[piv][j];
                a[piv][j] = t;
            }
            double t = b[col];
            b[col] = b[piv];
            b[piv] = t;
        }
        for (int r = col + 1; r < 3; r++) {
            double f = a[r][col] / a[col][col];
            for (int j = col; j < 3; j++)
                a[r][j] -= f * a[col][j];
            b[r] -= f * b[col];
        }
    }
    for (int r = 2; r >= 0; r--) {
        double sum = b[r];
        for (int j = r + 1; j < 3; j++)
            sum -= a[r][j] * x[j];
        x[r] = sum / a[r][r];
    }
    return isfinite(x[0]) && isfinite(x[1]) && isfinite(x[2]) ? 0 : -1;
}

/* Gauss-Newton from c toward target; updates c, returns the final max |residual|. */
static double jh_newton(const jh_system_t *sys, double c[3], const double target[3], double tol,
                        int *iterations)
{
    double rgb[3], jac[3][3], r[3];
    jh_eval(sys, c, rgb, jac);
    for (int i = 0; i < 3; i++)
        r[i] = rgb[i] - target[i];
    double err = max_abs3(r);
    double norm2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
    for (int it = 0; it < JH_MAX_ITER && err > tol && *iterations < JH_BUDGET; it++) {
        double a[3][3], b[3], dc[3];
        memcpy(a, jac, sizeof a);
        for (int i = 0; i < 3; i++)
            b[i] = -r[i];
        if (solve3(a, b, dc) != 0) {
            /* Singular Jacobian (saturated sigmoid): fall back to the normal equations with a
             * Levenberg term, which always has a solution. */
            double n[3][3], g[3];
            for (int i = 0; i < 3; i++) {
                g[i] = 0.0;
                for (int j = 0; j < 3; j++) {
                    n[i][j] = 0.0;
                    for (int k = 0; k < 3; k++)
                        n[i][j] += jac[k][i] * jac[k][j];
                }
                for (int k = 0; k < 3; k++)
                    g[i] -= jac[k][i] * r[k];
            }
            double mu = 1e-9 * (n[0][0] + n[1][1] + n[2][2]) + 1e-300;
            for (int i = 0; i < 3; i++)
                n[i][i] += mu;
            if (solve3(n, g, dc) != 0)
                break;
        }
        (*iterations)++;
        /* Backtracking: halve the step until the squared residual decreases. */
        double step = 1.0, cn[3], rgbn[3], rn[3], norm2n = norm2;
        int improved = 0;
        for (int ls = 0; ls < 20; ls++) {
            for (int i = 0; i < 3; i++)
                cn[i] = c[i] + step * dc[i];
            jh_eval(sys, cn, rgbn, NULL);
            for (int i = 0; i < 3; i++)
                rn[i] = rgbn[i] - target[i];
            norm2n = rn[0] * rn[0] + rn[1] * rn[1] + rn[2] * rn[2];
            if (norm2n < norm2) {
                improved = 1;
                break;
            }
            step *= 0.5;
        }
        if (!improved)
            break;
        memcpy(c, cn, sizeof cn);
        jh_eval(sys, c, rgb, jac);
        for (int i = 0; i < 3; i++)
            r[i] = rgb[i] - target[i];
        err = max_abs3(r);
        norm2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
    }
    return err;
}

/* Inverse of the sigmoid for 0 < g < 1: with u = 2g - 1, x = u / sqrt(1 - u^2). */
static double sigmoid_inverse(double g)
{
    double u = 2.0 * g - 1.0;
    return u / (2.0 * sqrt(g * (1.0 - g)));
}

/* Continuation in `stages` equal steps from the grey of luminance y to target. */
static double jh_continuation(const jh_system_t *sys, double c[3], const double target[3], double y,
                              int stages, int *iterations)
{
    c[0] = 0.0;
    c[1] = 0.0;
    c[2] = sigmoid_inverse(y);
    double err = 0.0;
    for (int s = 1; s <= stages; s++) {
        double f = (double)s / (double)stages, goal[3];
        for (int i = 0; i < 3; i++)
            goal[i] = y + f * (target[i] - y);
        err = jh_newton(sys, c, goal, s == stages ? JH_TOL : JH_STAGE_TOL, iterations);
    }
    return err;
}

static double clamp_unit(double v)
{
    return v < 0.0 ? 0.0 : v > 1.0 ? 1.0 : v;
}

int spectrum_sigmoid_fit(rgb_t target, spectrum_sigmoid_t *fit, err_t *err)
{
    if (!isfinite(target.r) || !isfinite(target.g) || !isfinite(target.b))
        return err_set(err, "rgb reflectance (%g, %g, %g): components must be finite", target.r,
                       target.g, target.b);
    rgb_t t = {clamp_unit(target.r), clamp_unit(target.g), clamp_unit(target.b)};
    memset(fit, 0, sizeof *fit);
    fit->target = t;
    jh_system_t sys;
    jh_system_init(&sys);

    if (t.r == t.g && t.g == t.b) {
        /* Exactly flat; for 0 and 1 the coefficient is the largest finite double, which
         * spectrum_sigmoid maps to exactly 0 or 1. */
        fit->c[2] = t.r <= 0.0 ? -DBL_MAX : t.r >= 1.0 ? DBL_MAX : sigmoid_inverse(t.r);
        double c[3] = {0.0, 0.0, fit->c[2]}, rgb[3];
        jh_eval(&sys, c, rgb, NULL);
        fit->rgb = (rgb_t){rgb[0], rgb[1], rgb[2]};
        fit->residual = fmax(fabs(rgb[0] - t.r), fmax(fabs(rgb[1] - t.g), fabs(rgb[2] - t.b)));
        return 0;
    }

    double goal[3] = {t.r, t.g, t.b};
    double y = colour_luminance(t);
    /* Keep the starting grey strictly inside (0, 1) where the sigmoid can be inverted. */
    if (y < 1e-6)
        y = 1e-6;
    if (y > 1.0 - 1e-6)
        y = 1.0 - 1e-6;

    static const int STAGES[] = {1, 8, 64};
    double best_c[3] = {0.0, 0.0, 0.0}, best = INFINITY;
    for (size_t a = 0; a < sizeof STAGES / sizeof STAGES[0] && best > JH_ACCEPT; a++) {
        double c[3];
        double e = jh_continuation(&sys, c, goal, y, STAGES[a], &fit->iterations);
        if (e < best) {
            best = e;
            memcpy(best_c, c, sizeof c);
        }
    }

    double rgb[3];
    jh_eval(&sys, best_c, rgb, NULL);
    fit->rgb = (rgb_t){rgb[0], rgb[1], rgb[2]};
    fit->residual = fmax(fabs(rgb[0] - t.r), fmax(fabs(rgb[1] - t.g), fabs(rgb[2] - t.b)));

    /* From t = (lambda - L0) / W to lambda in nm:
     * a t^2 + b t + c = (a/W^2) lambda^2 + (b/W - 2 a L0/W^2) lambda + (a L0^2/W^2 - b L0/W + c).
     */
    const double l0 = CIE_LAMBDA_MIN, w = CIE_LAMBDA_MAX - CIE_LAMBDA_MIN;
    double a = best_c[0], b = best_c[1], c = best_c[2];
    fit->c[0] = a / (w * w);
    fit->c[1] = b / w - 2.0 * a * l0 / (w * w);
    fit->c[2] = a * l0 * l0 / (w * w) - b * l0 / w + c;
    return 0;
}

static int rgb_spectrum_init(spectrum_t *s, rgb_t rgb, err_t *err)
{
    spectrum_sigmoid_t fit;
    if (spectrum_sigmoid_fit(rgb, &fit, err) != 0)
        return -1;
    if (fit.target.r == fit.target.g && fit.target.g == fit.target.b) {
        s->flat = 1;
        s->flat_value = fit.target.r;
    }
    memcpy(s->coeff, fit.c, sizeof s->coeff);
    return 0;
}

spectrum_t *spectrum_new_rgb_reflectance(rgb_t rgb, err_t *err)
{
    spectrum_t *s = spectrum_alloc(SPECTRUM_RGB_REFLECTANCE, err);
    if (!s)
        return NULL;
    if (rgb_spectrum_init(s, rgb, err) != 0) {
        spectrum_destroy(&s);
        return NULL;
    }
    return s;
}

spectrum_t *spectrum_new_rgb_illuminant(rgb_t rgb, err_t *err)
{
    if (!isfinite(rgb.r) || !isfinite(rgb.g) || !isfinite(rgb.b) || rgb.r < 0.0 || rgb.g < 0.0 ||
        rgb.b < 0.0) {
        err_set(err, "rgb illuminant (%g, %g, %g): components must be finite and >= 0", rgb.r,
                rgb.g, rgb.b);
        return NULL;
    }
    spectrum_t *s = spectrum_alloc(SPECTRUM_RGB_ILLUMINANT, err);
    if (!s)
        return NULL;
    double m = 2.0 * fmax(rgb.r, fmax(rgb.g, rgb.b));
    if (!isfinite(m)) {
        spectrum_destroy(&s);
        err_set(err, "rgb illuminant (%g, %g, %g): components too large", rgb.r, rgb.g, rgb.b);
        return NULL;
    }
    s->rgb_scale = m;
    s->d65_norm = CIE_Y_INTEGRAL / d65_y_sum();
    rgb_t unit = m > 0.0 ? (rgb_t){rgb.r / m, rgb.g / m, rgb.b / m} : (rgb_t){0.0, 0.0, 0.0};
    if (rgb_spectrum_init(s, unit, err) != 0) {
        spectrum_destroy(&s);
        return NULL;
    }
    return s;
}

xyz_t spectrum_to_xyz(const spectrum_t *s)
{
    double x = 0.0, y = 0.0, z = 0.0;
    for (int i = 0; i < CIE_SAMPLE_COUNT; i++) {
        double v = spectrum_eval(s, CIE_LAMBDA_MIN + (double)i);
        x += v * cie_x_table[i];
        y += v * cie_y_table[i];
        z += v * cie_z_table[i];
    }
    return (xyz_t){x / CIE_Y_INTEGRAL, y / CIE_Y_INTEGRAL, z / CIE_Y_INTEGRAL};
}
