#include "measured.h"

#include "bsdf_model.h"
#include "plinear2d.h"
#include "tensor_file.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct measured {
    plinear2d_t *ndf, *sigma;      /* evaluated over (theta2u, phi2u) of wm and of wo */
    plinear2d_t *vndf, *luminance; /* sampling warps conditioned on (phi_o, theta_o) */
    plinear2d_t *spectra;          /* R over the luminance warp's domain, (phi, theta, lambda) */
    bool isotropic;                /* phi_i has at most 2 values: wm's phi is relative to wo's */
    double lambda_lo, lambda_hi;
    char description[256];
};

void measured_destroy(measured_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    measured_t *m = *self_p;
    plinear2d_destroy(&m->ndf);
    plinear2d_destroy(&m->sigma);
    plinear2d_destroy(&m->vndf);
    plinear2d_destroy(&m->luminance);
    plinear2d_destroy(&m->spectra);
    free(m);
    *self_p = NULL;
}

/* The paper's parameterisation of a direction (pbrt-v4's theta2u, phi2u and inverses):
 * theta's square root spreads the grazing angles' samples less. */
static double theta2u(double theta)
{
    return sqrt(fmax(0.0, theta) * (2.0 / PF_PI));
}
static double phi2u(double phi)
{
    return phi * (0.5 / PF_PI) + 0.5;
}
static double u2theta(double u)
{
    return u * u * (0.5 * PF_PI);
}
static double u2phi(double u)
{
    return (2.0 * u - 1.0) * PF_PI;
}

static double theta_of(vec3_t w)
{
    return acos(fmin(fmax(w.z, -1.0), 1.0));
}

/* A float field's values in a buffer of their own (aligned, host order). */
static float *floats_of(const tensor_field_t *f, const char *name, err_t *err)
{
    float *v = malloc((f->count ? f->count : 1) * sizeof *v);
    if (!v) {
        err_set(err, "%s: out of memory for field \"%s\"", name, f->name);
        return NULL;
    }
    for (uint64_t i = 0; i < f->count; i++)
        v[i] = tensor_field_f32(f, i);
    return v;
}

static plinear2d_t *warp(const tensor_field_t *f, const char *name, int nparams, const int *res,
                         const float *const *values, bool sampling, err_t *err)
{
    float *data = floats_of(f, name, err);
    if (!data)
        return NULL;
    char what[256];
    snprintf(what, sizeof what, "%s: field \"%s\"", name, f->name);
    const int nx = (int)f->shape[f->ndim - 1], ny = (int)f->shape[f->ndim - 2];
    plinear2d_t *p = plinear2d_new(data, nx, ny, nparams, res, values, sampling, what, err);
    free(data);
    return p;
}

/* The extents pbrt-v4's MeasuredBxDFData::Create requires of the fields, with a message
 * naming the first that differs. */
static int check_shapes(const char *name, const tensor_field_t *theta, const tensor_field_t *phi,
                        const tensor_field_t *wl, const tensor_field_t *ndf,
                        const tensor_field_t *sigma, const tensor_field_t *vndf,
                        const tensor_field_t *lum, const tensor_field_t *spec,
                        const tensor_field_t *jac, err_t *err)
{
    const uint64_t np = phi->shape[0], nt = theta->shape[0], nl = wl->shape[0];
    if (np < 1 || nt < 1 || nl < 1)
        return err_set(err,
                       "%s: phi_i, theta_i and wavelengths need at least one value each "
                       "(have %llu, %llu, %llu)",
                       name, (unsigned long long)np, (unsigned long long)nt,
                       (unsigned long long)nl);
    if (jac->shape[0] != 1)
        return err_set(err, "%s: field \"jacobian\" has %llu values (expected 1)", name,
                       (unsigned long long)jac->shape[0]);
    const tensor_field_t *grids[] = {ndf, sigma, vndf, lum, spec};
    for (size_t i = 0; i < sizeof grids / sizeof *grids; i++) {
        const tensor_field_t *g = grids[i];
        uint64_t nx = g->shape[g->ndim - 1], ny = g->shape[g->ndim - 2];
        if (nx < 2 || ny < 2 || nx > 1u << 20 || ny > 1u << 20)
            return err_set(err, "%s: field \"%s\" is a %llu x %llu grid (expected at least 2 x 2)",
                           name, g->name, (unsigned long long)ny, (unsigned long long)nx);
    }
    const tensor_field_t *cond[] = {vndf, lum, spec};
    for (size_t i = 0; i < 3; i++)
        if (cond[i]->shape[0] != np || cond[i]->shape[1] != nt)
            return err_set(err,
                           "%s: field \"%s\" starts %llu x %llu (expected phi_i x theta_i, "
                           "%llu x %llu)",
                           name, cond[i]->name, (unsigned long long)cond[i]->shape[0],
                           (unsigned long long)cond[i]->shape[1], (unsigned long long)np,
                           (unsigned long long)nt);
    if (spec->shape[2] != nl)
        return err_set(err,
                       "%s: field \"spectra\" has %llu wavelengths (expected %llu, as "
                       "\"wavelengths\")",
                       name, (unsigned long long)spec->shape[2], (unsigned long long)nl);
    if (lum->shape[2] != spec->shape[3] || lum->shape[3] != spec->shape[4])
        return err_set(err,
                       "%s: \"luminance\" is a %llu x %llu grid and \"spectra\" %llu x %llu "
                       "(expected the same)",
                       name, (unsigned long long)lum->shape[2], (unsigned long long)lum->shape[3],
                       (unsigned long long)spec->shape[3], (unsigned long long)spec->shape[4]);
    return 0;
}

static int build(measured_t *m, const tensor_file_t *t, const char *name, err_t *err)
{
    const tensor_field_t *desc, *theta, *phi, *wl, *ndf, *sigma, *vndf, *lum, *spec, *jac;
    if (!tensor_file_find(t, "spectra") && tensor_file_find(t, "rgb"))
        return err_set(err,
                       "%s: an RGB measured BSDF (field \"rgb\"); prismfarm, like pbrt-v4, "
                       "reads RGL's spectral files (field \"spectra\")",
                       name);
    if (!(desc = tensor_file_expect(t, "description", TENSOR_UINT8, 1, err)) ||
        !(theta = tensor_file_expect(t, "theta_i", TENSOR_FLOAT32, 1, err)) ||
        !(phi = tensor_file_expect(t, "phi_i", TENSOR_FLOAT32, 1, err)) ||
        !(wl = tensor_file_expect(t, "wavelengths", TENSOR_FLOAT32, 1, err)) ||
        !(ndf = tensor_file_expect(t, "ndf", TENSOR_FLOAT32, 2, err)) ||
        !(sigma = tensor_file_expect(t, "sigma", TENSOR_FLOAT32, 2, err)) ||
        !(vndf = tensor_file_expect(t, "vndf", TENSOR_FLOAT32, 4, err)) ||
        !(lum = tensor_file_expect(t, "luminance", TENSOR_FLOAT32, 4, err)) ||
        !(spec = tensor_file_expect(t, "spectra", TENSOR_FLOAT32, 5, err)) ||
        !(jac = tensor_file_expect(t, "jacobian", TENSOR_UINT8, 1, err)))
        return -1;
    if (check_shapes(name, theta, phi, wl, ndf, sigma, vndf, lum, spec, jac, err) != 0)
        return -1;
    size_t dn =
        desc->count < sizeof m->description ? (size_t)desc->count : sizeof m->description - 1;
    memcpy(m->description, desc->data, dn);
    m->description[dn] = 0;
    for (size_t i = 0; i < dn; i++)
        if (m->description[i] < 32 && m->description[i] != 0)
            m->description[i] = ' ';
    float *th = floats_of(theta, name, err), *ph = th ? floats_of(phi, name, err) : NULL,
          *la = ph ? floats_of(wl, name, err) : NULL;
    int rc = -1;
    if (!la)
        goto done;
    const int np = (int)phi->shape[0], nt = (int)theta->shape[0], nl = (int)wl->shape[0];
    m->isotropic = np <= 2;
    if (!m->isotropic) {
        /* pbrt-v4 reads only files whose phi_i spans the full circle (no symmetry folded). */
        double span = (double)ph[np - 1] - ph[0];
        double reduction = span > 0.0 ? rint(2.0 * PF_PI / span) : 0.0;
        if (reduction != 1.0) {
            rc = err_set(err,
                         "%s: phi_i spans %g radians (expected the full circle, 2 pi: "
                         "files with a folded symmetry are not read, as in pbrt-v4)",
                         name, span);
            goto done;
        }
    }
    m->lambda_lo = la[0];
    m->lambda_hi = la[nl - 1];
    const int res2[2] = {np, nt}, res3[3] = {np, nt, nl};
    const float *vals[3] = {ph, th, la};
    if (!(m->ndf = warp(ndf, name, 0, NULL, NULL, false, err)) ||
        !(m->sigma = warp(sigma, name, 0, NULL, NULL, false, err)) ||
        !(m->vndf = warp(vndf, name, 2, res2, vals, true, err)) ||
        !(m->luminance = warp(lum, name, 2, res2, vals, true, err)) ||
        !(m->spectra = warp(spec, name, 3, res3, vals, false, err)))
        goto done;
    rc = 0;
done:
    free(th);
    free(ph);
    free(la);
    return rc;
}

measured_t *measured_new(const uint8_t *buf, size_t len, const char *name, err_t *err)
{
    tensor_file_t *t = tensor_file_parse(buf, len, name, err);
    if (!t)
        return NULL;
    measured_t *m = calloc(1, sizeof *m);
    if (!m)
        err_set(err, "%s: out of memory", name);
    else if (build(m, t, name, err) != 0)
        measured_destroy(&m);
    tensor_file_destroy(&t);
    return m;
}

/* wo's place in the paper's parameterisation: (phi_o, theta_o) condition the warps, u_wo is
 * where sigma is read. */
typedef struct outgoing {
    double params[3]; /* phi_o, theta_o, lambda */
    double u_wo[2];
} outgoing_t;

static outgoing_t outgoing_of(vec3_t wo)
{
    outgoing_t o;
    o.params[0] = atan2(wo.y, wo.x);
    o.params[1] = theta_of(wo);
    o.params[2] = 0.0;
    o.u_wo[0] = theta2u(o.params[1]);
    o.u_wo[1] = phi2u(o.params[0]);
    return o;
}

/* wm's coordinates over the vndf warp's square. */
static void u_of_wm(const measured_t *m, const outgoing_t *o, vec3_t wm, double u[2])
{
    double phi_m = atan2(wm.y, wm.x);
    u[0] = theta2u(theta_of(wm));
    u[1] = phi2u(m->isotropic ? phi_m - o->params[0] : phi_m);
    u[1] -= floor(u[1]);
}

static double finite0(double x)
{
    return isfinite(x) && x > 0.0 ? x : 0.0;
}

void measured_eval(const measured_t *m, vec3_t wo, vec3_t wi, const double *lambda, int n,
                   double *f)
{
    for (int j = 0; j < n; j++)
        f[j] = 0.0;
    if (!(wo.z * wi.z > 0.0))
        return;
    if (wo.z < 0.0) {
        wo = vec3_neg(wo);
        wi = vec3_neg(wi);
    }
    vec3_t h = vec3_add(wo, wi);
    if (!(vec3_dot(h, h) > 0.0))
        return;
    vec3_t wm = vec3_normalize(h);
    outgoing_t o = outgoing_of(wo);
    double u_wm[2], ui[2], vpdf;
    u_of_wm(m, &o, wm, u_wm);
    plinear2d_invert(m->vndf, u_wm[0], u_wm[1], o.params, ui, &vpdf);
    const double scale = plinear2d_eval(m->ndf, u_wm[0], u_wm[1], NULL) /
                         (4.0 * plinear2d_eval(m->sigma, o.u_wo[0], o.u_wo[1], NULL) * wi.z);
    if (!(scale > 0.0) || !isfinite(scale))
        return;
    for (int j = 0; j < n; j++) {
        o.params[2] = lambda[j];
        f[j] = finite0(plinear2d_eval(m->spectra, ui[0], ui[1], o.params) * scale);
    }
}

/* The density of wm's vndf-square coordinates -> the solid angle of wi (pbrt-v4's
 * MeasuredBxDF): d(omega_m) = 2 pi^2 u sin(theta_m) du dv, and the reflection's 4 (wo . wm);
 * the floor keeps the pole finite. */
static double jacobian(double u_theta, double sin_m, double wo_dot_wm)
{
    return 4.0 * wo_dot_wm * fmax(2.0 * PF_PI * PF_PI * u_theta * sin_m, 1e-6);
}

double measured_pdf(const measured_t *m, vec3_t wo, vec3_t wi)
{
    if (!(wo.z * wi.z > 0.0))
        return 0.0;
    if (wo.z < 0.0) {
        wo = vec3_neg(wo);
        wi = vec3_neg(wi);
    }
    vec3_t h = vec3_add(wo, wi);
    if (!(vec3_dot(h, h) > 0.0))
        return 0.0;
    vec3_t wm = vec3_normalize(h);
    const double cos_om = vec3_dot(wo, wm);
    if (!(cos_om > 0.0))
        return 0.0;
    outgoing_t o = outgoing_of(wo);
    double u_wm[2], ui[2], vpdf;
    u_of_wm(m, &o, wm, u_wm);
    plinear2d_invert(m->vndf, u_wm[0], u_wm[1], o.params, ui, &vpdf);
    const double lpdf = plinear2d_eval(m->luminance, ui[0], ui[1], o.params);
    const double sin_m = sqrt(wm.x * wm.x + wm.y * wm.y);
    return finite0(vpdf * lpdf / jacobian(u_wm[0], sin_m, cos_om));
}

bool measured_sample(const measured_t *m, vec3_t wo, double u1, double u2, const double *lambda,
                     int n, vec3_t *wi, double *f, double *pdf)
{
    const bool flip = wo.z < 0.0;
    if (!(wo.z != 0.0))
        return false;
    if (flip)
        wo = vec3_neg(wo);
    outgoing_t o = outgoing_of(wo);
    double ul[2], um[2], p;
    plinear2d_sample(m->luminance, u1, u2, o.params, ul, &p);
    plinear2d_sample(m->vndf, ul[0], ul[1], o.params, um, &p);
    double phi_m = u2phi(um[1]), theta_m = u2theta(um[0]);
    if (m->isotropic)
        phi_m += o.params[0];
    const double s = sin(theta_m);
    vec3_t wm = vec3_make(s * cos(phi_m), s * sin(phi_m), cos(theta_m));
    vec3_t w = vec3_sub(vec3_scale(wm, 2.0 * vec3_dot(wo, wm)), wo);
    if (!(w.z > 0.0))
        return false;
    w = vec3_normalize(w);
    /* f and pdf from eval and pdf, so that they agree bit for bit with what light sampling's
     * MIS asks of the same direction. */
    measured_eval(m, wo, w, lambda, n, f);
    *pdf = measured_pdf(m, wo, w);
    *wi = flip ? vec3_neg(w) : w;
    return *pdf > 0.0;
}

const char *measured_description(const measured_t *m)
{
    return m->description;
}

void measured_lambda_range(const measured_t *m, double *lo, double *hi)
{
    *lo = m->lambda_lo;
    *hi = m->lambda_hi;
}

bool measured_isotropic(const measured_t *m)
{
    return m->isotropic;
}

size_t measured_bytes(const measured_t *m)
{
    return sizeof *m + plinear2d_bytes(m->ndf) + plinear2d_bytes(m->sigma) +
           plinear2d_bytes(m->vndf) + plinear2d_bytes(m->luminance) + plinear2d_bytes(m->spectra);
}

/* ---- The model (BSDF_MEASURED): the scene's data read at each lane's wavelength ---- */

static void eval(const bsdf_t *b, int n, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *f)
{
    (void)rng;
    measured_eval(b->measured, wo, wi, b->lambda, n, f);
}

/* One density for every lane: the warps do not depend on the wavelength. */
static void pdf(const bsdf_t *b, int n, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *pdf)
{
    (void)rng;
    double p = measured_pdf(b->measured, wo, wi);
    for (int j = 0; j < n; j++)
        pdf[j] = p;
}

static bsdf_sampled_t sample(const bsdf_t *b, int n, vec3_t wo, int hero, double uc, double u1,
                             double u2, rng_stream_t *rng, bsdf_sample_t *out)
{
    (void)hero;
    (void)uc;
    (void)rng;
    double p;
    if (!measured_sample(b->measured, wo, u1, u2, b->lambda, n, &out->wi, out->f, &p))
        return BSDF_SAMPLED_NONE;
    out->flags = BSDF_REFLECTION;
    for (int j = 0; j < n; j++)
        out->pdf[j] = p;
    return BSDF_SAMPLED_ALL;
}

const bsdf_model_t bsdf_model_measured = {.eval = eval, .pdf = pdf, .sample = sample};
