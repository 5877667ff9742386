#include "dispersion.h"

#include <math.h>

/* ior_validate samples n^2 on this grid; between samples n^2 is smooth (no pole, proven
 * first), so a sign change narrower than 0.5 nm would need coefficients no glass has. */
#define VALIDATE_STEP_NM 0.5
#define VALIDATE_MAX_SAMPLES 100000
#define DISPERSIVE_SAMPLES 65

ior_model_t ior_constant(double n)
{
    return (ior_model_t){.kind = IOR_CONSTANT, .constant = n};
}

ior_model_t ior_cauchy(double a, double b_um2)
{
    return (ior_model_t){.kind = IOR_CAUCHY, .cauchy = {.a = a, .b_um2 = b_um2}};
}

int ior_sellmeier(ior_model_t *out, double a0, const double *b, const double *c_um2, int terms,
                  err_t *err)
{
    if (terms < 0 || terms > IOR_SELLMEIER_MAX_TERMS)
        return err_set(err, "Sellmeier model: %d terms, expected 0 to %d", terms,
                       IOR_SELLMEIER_MAX_TERMS);
    if (terms > 0 && (!b || !c_um2))
        return err_set(err, "Sellmeier model: %d terms but no coefficient arrays", terms);
    if (!isfinite(a0))
        return err_set(err, "Sellmeier model: constant term A0 is not finite");
    ior_model_t m = {.kind = IOR_SELLMEIER, .sellmeier = {.a0 = a0, .terms = terms}};
    for (int i = 0; i < terms; i++) {
        if (!isfinite(b[i]) || !isfinite(c_um2[i]))
            return err_set(err, "Sellmeier model: term %d (B%d, C%d) is not finite", i + 1, i + 1,
                           i + 1);
        m.sellmeier.b[i] = b[i];
        m.sellmeier.c_um2[i] = c_um2[i];
    }
    *out = m;
    return 0;
}

int ior_tabulated(ior_model_t *out, const double *lambda_nm, const double *n, size_t count,
                  err_t *err)
{
    if (count == 0 || !lambda_nm || !n)
        return err_set(err, "tabulated index: needs at least one (wavelength, n) pair");
    for (size_t i = 0; i < count; i++) {
        if (!isfinite(lambda_nm[i]) || !(lambda_nm[i] > 0.0) || !isfinite(n[i]))
            return err_set(err,
                           "tabulated index: pair %zu (%g nm, n %g) is not a finite positive "
                           "wavelength with a finite index",
                           i + 1, lambda_nm[i], n[i]);
        if (i > 0 && !(lambda_nm[i] > lambda_nm[i - 1]))
            return err_set(err,
                           "tabulated index: wavelengths must increase, but pair %zu has %g nm "
                           "after %g nm",
                           i + 1, lambda_nm[i], lambda_nm[i - 1]);
    }
    *out = (ior_model_t){.kind = IOR_TABULATED,
                         .table = {.count = count, .lambda_nm = lambda_nm, .n = n}};
    return 0;
}

/* Piecewise linear between the pairs, the end values held outside. */
static double table_eval(const ior_table_t *t, double lambda)
{
    size_t count = t->count;
    if (lambda <= t->lambda_nm[0])
        return t->n[0];
    if (lambda >= t->lambda_nm[count - 1])
        return t->n[count - 1];
    size_t lo = 0, hi = count - 1; /* lambda_nm[lo] < lambda < lambda_nm[hi] */
    while (hi - lo > 1) {
        size_t mid = lo + (hi - lo) / 2;
        if (t->lambda_nm[mid] <= lambda)
            lo = mid;
        else
            hi = mid;
    }
    double f = (lambda - t->lambda_nm[lo]) / (t->lambda_nm[hi] - t->lambda_nm[lo]);
    return t->n[lo] + f * (t->n[hi] - t->n[lo]);
}

/* The unguarded index: n^2 for Sellmeier, n itself for the other kinds (where n^2 would hide
 * a negative n). May be negative, infinite or NaN; ior_eval and ior_validate guard it. */
static double eval_raw(const ior_model_t *m, double lambda_nm)
{
    double l_um = lambda_nm * 1e-3;
    double l2 = l_um * l_um;
    switch (m->kind) {
    case IOR_CONSTANT:
        return m->constant;
    case IOR_CAUCHY:
        return m->cauchy.a + m->cauchy.b_um2 / l2;
    case IOR_SELLMEIER: {
        double n2 = 1.0 + m->sellmeier.a0;
        /* A term with B = 0 contributes nothing, even at its C where it would be 0/0. */
        for (int i = 0; i < m->sellmeier.terms; i++)
            if (m->sellmeier.b[i] != 0.0)
                n2 += m->sellmeier.b[i] * l2 / (l2 - m->sellmeier.c_um2[i]);
        return n2;
    }
    case IOR_TABULATED:
        return table_eval(&m->table, lambda_nm);
    }
    return NAN;
}

double ior_eval(const ior_model_t *model, double lambda_nm)
{
    if (!(lambda_nm > 0.0) || !isfinite(lambda_nm))
        return 1.0;
    double v = eval_raw(model, lambda_nm);
    if (!(v > 0.0) || !isfinite(v))
        return 1.0;
    return model->kind == IOR_SELLMEIER ? sqrt(v) : v;
}

static bool coefs_finite(const ior_model_t *m)
{
    switch (m->kind) {
    case IOR_CONSTANT:
        return isfinite(m->constant);
    case IOR_CAUCHY:
        return isfinite(m->cauchy.a) && isfinite(m->cauchy.b_um2);
    case IOR_SELLMEIER:
        if (!isfinite(m->sellmeier.a0) || m->sellmeier.terms < 0 ||
            m->sellmeier.terms > IOR_SELLMEIER_MAX_TERMS)
            return false;
        for (int i = 0; i < m->sellmeier.terms; i++)
            if (!isfinite(m->sellmeier.b[i]) || !isfinite(m->sellmeier.c_um2[i]))
                return false;
        return true;
    case IOR_TABULATED:
        if (m->table.count == 0 || !m->table.lambda_nm || !m->table.n)
            return false;
        for (size_t i = 0; i < m->table.count; i++)
            if (!isfinite(m->table.lambda_nm[i]) || !isfinite(m->table.n[i]))
                return false;
        return true;
    }
    return false;
}

int ior_validate(const ior_model_t *model, const char *material, double lambda_min_nm,
                 double lambda_max_nm, err_t *err)
{
    const char *name = material ? material : "(unnamed)";
    if (!(lambda_min_nm > 0.0) || !isfinite(lambda_max_nm) || !(lambda_max_nm >= lambda_min_nm))
        return err_set(err, "material '%s': sampled range %g-%g nm is not a wavelength range", name,
                       lambda_min_nm, lambda_max_nm);
    if (!coefs_finite(model))
        return err_set(err, "material '%s': %s coefficients are not finite numbers", name,
                       ior_kind_name(model->kind));

    /* A pole lambda^2 = C_i sends n^2 to +-infinity: n is meaningless around it. */
    if (model->kind == IOR_SELLMEIER) {
        for (int i = 0; i < model->sellmeier.terms; i++) {
            double c = model->sellmeier.c_um2[i];
            if (model->sellmeier.b[i] == 0.0 || !(c > 0.0))
                continue;
            double pole_nm = 1e3 * sqrt(c);
            if (pole_nm >= lambda_min_nm && pole_nm <= lambda_max_nm)
                return err_set(err,
                               "material '%s': Sellmeier pole at %.1f nm lies inside the sampled "
                               "range %g-%g nm",
                               name, pole_nm, lambda_min_nm, lambda_max_nm);
        }
    }

    /* A piecewise linear n is positive over the range when it is at the ends and at the
     * tabulated wavelengths between them (the grid below checks the ends). */
    if (model->kind == IOR_TABULATED)
        for (size_t i = 0; i < model->table.count; i++) {
            double lambda = model->table.lambda_nm[i];
            if (lambda > lambda_min_nm && lambda < lambda_max_nm && !(model->table.n[i] > 0.0))
                return err_set(err,
                               "material '%s': tabulated n = %.6g at %.1f nm: no real "
                               "refractive index there (sampled range %g-%g nm)",
                               name, model->table.n[i], lambda, lambda_min_nm, lambda_max_nm);
        }

    double span = lambda_max_nm - lambda_min_nm;
    long samples = (long)ceil(span / VALIDATE_STEP_NM) + 1;
    if (samples > VALIDATE_MAX_SAMPLES)
        samples = VALIDATE_MAX_SAMPLES;
    for (long k = 0; k < samples; k++) {
        double lambda =
            samples == 1 ? lambda_min_nm : lambda_min_nm + span * (double)k / (double)(samples - 1);
        double v = eval_raw(model, lambda);
        if (!(v > 0.0) || !isfinite(v))
            return err_set(err,
                           "material '%s': %s = %.6g at %.1f nm: no real refractive index "
                           "there (sampled range %g-%g nm)",
                           name, model->kind == IOR_SELLMEIER ? "n^2" : "n", v, lambda,
                           lambda_min_nm, lambda_max_nm);
    }
    return 0;
}

bool ior_is_dispersive(const ior_model_t *model, double lambda_min_nm, double lambda_max_nm)
{
    if (model->kind == IOR_CONSTANT || !(lambda_max_nm > lambda_min_nm))
        return false;
    double lo = INFINITY, hi = -INFINITY;
    for (int k = 0; k < DISPERSIVE_SAMPLES; k++) {
        double lambda = lambda_min_nm + (lambda_max_nm - lambda_min_nm) * (double)k /
                                            (double)(DISPERSIVE_SAMPLES - 1);
        double n = ior_eval(model, lambda);
        lo = fmin(lo, n);
        hi = fmax(hi, n);
    }
    if (model->kind == IOR_TABULATED)
        for (size_t i = 0; i < model->table.count; i++) {
            double lambda = model->table.lambda_nm[i];
            if (lambda > lambda_min_nm && lambda < lambda_max_nm) {
                double n = ior_eval(model, lambda);
                lo = fmin(lo, n);
                hi = fmax(hi, n);
            }
        }
    return hi - lo > IOR_DISPERSIVE_EPSILON;
}

bool ior_abbe_number(const ior_model_t *model, double *vd)
{
    double nd = ior_eval(model, IOR_LAMBDA_D_NM);
    double dn = ior_eval(model, IOR_LAMBDA_F_NM) - ior_eval(model, IOR_LAMBDA_C_NM);
    double v = dn != 0.0 ? (nd - 1.0) / dn : 0.0;
    if (dn == 0.0 || !isfinite(v)) {
        *vd = 0.0;
        return false;
    }
    *vd = v;
    return true;
}

const char *ior_kind_name(ior_kind_t kind)
{
    switch (kind) {
    case IOR_CONSTANT:
        return "constant";
    case IOR_CAUCHY:
        return "Cauchy";
    case IOR_SELLMEIER:
        return "Sellmeier";
    case IOR_TABULATED:
        return "tabulated";
    }
    return "unknown";
}
