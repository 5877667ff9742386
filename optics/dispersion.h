/* dispersion: index-of-refraction models n(lambda) for dielectrics -- constant, Cauchy,
 * Sellmeier (any number of terms, optional constant term) and tabulated (lambda, n) pairs --
 * as plain values that may be copied freely (a tabulated model borrows its arrays). ior_eval never
 * returns NaN or Inf; ior_validate proves a model physical (no pole, n^2 > 0) over a range. */
#ifndef PRISMFARM_DISPERSION_H
#define PRISMFARM_DISPERSION_H

#include "err.h"

#include <stdbool.h>
#include <stddef.h>

/* Fraunhofer lines used by glass catalogues (nm in air): d (helium), F and C (hydrogen),
 * e (mercury). Abbe number v_d = (n_d - 1) / (n_F - n_C). */
#define IOR_LAMBDA_D_NM 587.5618
#define IOR_LAMBDA_F_NM 486.1327
#define IOR_LAMBDA_C_NM 656.2725
#define IOR_LAMBDA_E_NM 546.0740

/* Water's Daimon-Masumura fit needs 4 terms; 6 leaves room for other published fits. */
#define IOR_SELLMEIER_MAX_TERMS 6

/* A model whose n varies by less than this over a range is treated as non-dispersive: the
 * direction spread it would cause at refraction is below 1e-6 rad, under what a float32
 * ray can resolve, so spectral fan-out would only cost time. */
#define IOR_DISPERSIVE_EPSILON 1e-6

typedef enum ior_kind {
    IOR_CONSTANT,
    IOR_CAUCHY,
    IOR_SELLMEIER,
    IOR_TABULATED,
} ior_kind_t;

/* n^2 = 1 + a0 + sum_i b[i] L^2 / (L^2 - c_um2[i]), L = lambda in um, c_um2 in um^2
 * (Sellmeier 1871; the constant term a0 is the form Li 1980 uses for CaF2). */
typedef struct ior_sellmeier_coefs {
    double a0;
    int terms; /* 0..IOR_SELLMEIER_MAX_TERMS */
    double b[IOR_SELLMEIER_MAX_TERMS];
    double c_um2[IOR_SELLMEIER_MAX_TERMS];
} ior_sellmeier_coefs_t;

/* n = a + b_um2 / L^2, L in um: B in um^2, the usage of pbrt and most optics tables
 * (a B quoted in nm^2 is 1e6 times larger). */
typedef struct ior_cauchy_coefs {
    double a;
    double b_um2;
} ior_cauchy_coefs_t;

/* n(lambda) piecewise linear between (lambda_nm[i], n[i]), the end values held outside
 * (pbrt-v4's tabulated eta is a PiecewiseLinearSpectrum; see ior_tabulated for the ends).
 * Lifetime: the model does not own the arrays. They must stay unchanged and alive for as long
 * as any copy of the model is used: a scene keeps them in memory it owns (scene_own_*) and
 * frees them with itself; pbrt-v4's named glass tables are static. */
typedef struct ior_table {
    size_t count; /* >= 1 */
    const double *lambda_nm;
    const double *n;
} ior_table_t;

typedef struct ior_model {
    ior_kind_t kind;
    union {
        double constant;
        ior_cauchy_coefs_t cauchy;
        ior_sellmeier_coefs_t sellmeier;
        ior_table_t table;
    };
} ior_model_t;

ior_model_t ior_constant(double n);
ior_model_t ior_cauchy(double a, double b_um2);

/* Builds a Sellmeier model; fails (-1, *out untouched) when terms is outside
 * 0..IOR_SELLMEIER_MAX_TERMS or a coefficient is not finite. b and c_um2 may be NULL when
 * terms is 0. */
int ior_sellmeier(ior_model_t *out, double a0, const double *b, const double *c_um2, int terms,
                  err_t *err);

/* Builds a tabulated model over count >= 1 pairs (borrowed, see ior_table_t): lambda_nm
 * finite, > 0 and strictly increasing, n finite. Fails (-1, *out untouched) naming the first
 * bad pair. pbrt-v4 evaluates such a table as 0 outside its range and its dielectric then uses
 * n = 1; prismfarm holds the end values instead, as it does for every tabulated spectrum. */
int ior_tabulated(ior_model_t *out, const double *lambda_nm, const double *n, size_t count,
                  err_t *err);

/* n at lambda_nm (vacuum or air wavelength, as the model's source defines). Where the model
 * has no real positive index (n^2 <= 0, a pole, a non-finite argument) it returns 1.0, so
 * that nothing refracts rather than a NaN escaping; ior_validate rules this out over the
 * range a renderer samples. */
double ior_eval(const ior_model_t *model, double lambda_nm);

/* Proves the model physical over [lambda_min_nm, lambda_max_nm]: coefficients finite, no
 * Sellmeier pole (lambda^2 = C_i with B_i != 0) in the range, and n^2 > 0 at every sample
 * of a 0.5 nm grid (and the ends; for a table also at every tabulated wavelength inside the
 * range, which makes the check exact for it). On failure returns -1 with a message naming the
 * material, e.g. "material 'foo': Sellmeier pole at 452.1 nm lies inside the sampled range
 * 380-720 nm". material may be NULL ("(unnamed)"). */
int ior_validate(const ior_model_t *model, const char *material, double lambda_min_nm,
                 double lambda_max_nm, err_t *err);

/* True when n varies by more than IOR_DISPERSIVE_EPSILON over [lambda_min_nm, lambda_max_nm]
 * (checked at 65 evenly spaced wavelengths, and for a table also at its tabulated wavelengths
 * inside the range, where a piecewise linear n has its extremes; a constant model is never
 * dispersive, nor a table that is flat over the range). */
bool ior_is_dispersive(const ior_model_t *model, double lambda_min_nm, double lambda_max_nm);

/* Abbe number v_d = (n_d - 1) / (n_F - n_C). Returns false (and *vd = 0) for a model with
 * n_F == n_C, whose Abbe number is infinite. */
bool ior_abbe_number(const ior_model_t *model, double *vd);

/* "constant", "Cauchy", "Sellmeier" or "tabulated". */
const char *ior_kind_name(ior_kind_t kind);

#endif
