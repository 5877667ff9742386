#include "distrib2d.h"

#include <math.h>
#include <stdlib.h>

struct distrib2d {
    int nu, nv;
    double *f;        /* nu * nv cell weights (uniform 1 when all were 0) */
    double *cdf;      /* per row: nu + 1 cumulative sums of f, normalised to end at 1 */
    double *row;      /* nv row sums */
    double *marginal; /* nv + 1 cumulative row sums, normalised */
    double mean;      /* mean of f: the density is f / mean */
    /* Guide tables (the cutpoint method: Chen and Asau 1974, "On generating random variates
     * from an empirical distribution", AIIE Transactions 6(2)): for u in [g / G, (g + 1) / G),
     * guide[g] is invert's bin for u = g / G, a lower bound of u's bin, from which a short
     * forward scan finds exactly the bin the binary search finds. GUIDE entries per row (in
     * row_guide, nv * GUIDE) and for the marginal. */
    int *row_guide;
    int *marginal_guide;
};

enum { GUIDE = 64 };

void distrib2d_destroy(distrib2d_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    distrib2d_t *d = *self_p;
    free(d->f);
    free(d->cdf);
    free(d->row);
    free(d->marginal);
    free(d->row_guide);
    free(d->marginal_guide);
    free(d);
    *self_p = NULL;
}

static int invert_search(const double *cdf, int n, double u);
static void guide_fill(const double *cdf, int n, int *guide)
{
    for (int g = 0; g < GUIDE; g++)
        guide[g] = invert_search(cdf, n, (double)g / GUIDE);
}

distrib2d_t *distrib2d_new(const double *f, int nu, int nv, err_t *err)
{
    if (!f || nu < 1 || nv < 1 || (size_t)nu * (size_t)nv > ((size_t)1 << 30)) {
        err_set(err, "distribution of %dx%d cells is empty or too large", nu, nv);
        return NULL;
    }
    size_t n = (size_t)nu * (size_t)nv;
    distrib2d_t *d = calloc(1, sizeof *d);
    if (!d || !(d->f = malloc(n * sizeof *d->f)) ||
        !(d->cdf = malloc((size_t)nv * (size_t)(nu + 1) * sizeof *d->cdf)) ||
        !(d->row = malloc((size_t)nv * sizeof *d->row)) ||
        !(d->marginal = malloc((size_t)(nv + 1) * sizeof *d->marginal)) ||
        !(d->row_guide = malloc((size_t)nv * GUIDE * sizeof *d->row_guide)) ||
        !(d->marginal_guide = malloc(GUIDE * sizeof *d->marginal_guide))) {
        distrib2d_destroy(&d);
        err_set(err, "out of memory for a %dx%d distribution", nu, nv);
        return NULL;
    }
    d->nu = nu;
    d->nv = nv;
    double total = 0.0;
    for (size_t i = 0; i < n; i++) {
        if (!(f[i] >= 0.0) || !isfinite(f[i])) {
            err_set(err, "distribution weight %zu is %g (must be finite and >= 0)", i, f[i]);
            distrib2d_destroy(&d);
            return NULL;
        }
        d->f[i] = f[i];
        total += f[i];
    }
    if (!(total > 0.0) || !isfinite(total)) {
        for (size_t i = 0; i < n; i++)
            d->f[i] = 1.0;
        total = (double)n;
    }
    d->mean = total / (double)n;
    d->marginal[0] = 0.0;
    for (int iv = 0; iv < nv; iv++) {
        const double *fr = d->f + (size_t)iv * (size_t)nu;
        double *c = d->cdf + (size_t)iv * (size_t)(nu + 1);
        c[0] = 0.0;
        for (int iu = 0; iu < nu; iu++)
            c[iu + 1] = c[iu] + fr[iu];
        d->row[iv] = c[nu];
        if (c[nu] > 0.0)
            for (int iu = 1; iu <= nu; iu++)
                c[iu] /= c[nu];
        else
            for (int iu = 1; iu <= nu; iu++)
                c[iu] = (double)iu / nu;
        d->marginal[iv + 1] = d->marginal[iv] + d->row[iv];
    }
    for (int iv = 1; iv <= nv; iv++)
        d->marginal[iv] /= d->marginal[nv];
    for (int iv = 0; iv < nv; iv++)
        guide_fill(d->cdf + (size_t)iv * (size_t)(nu + 1), nu, d->row_guide + (size_t)iv * GUIDE);
    guide_fill(d->marginal, nv, d->marginal_guide);
    return d;
}

/* The index i in [0, n) with cdf[i] <= u < cdf[i + 1] (u in [0, 1), cdf[0] = 0, cdf[n] = 1). */
static int invert_search(const double *cdf, int n, double u)
{
    int lo = 0, hi = n; /* cdf[lo] <= u < cdf[hi] */
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (cdf[mid] <= u)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

/* invert_search's index from the guide's lower bound, then empty bins skipped, and u's place
 * in the bin. */
static int invert(const double *cdf, const int *guide, int n, double u, double *frac)
{
    int g = (int)(u * GUIDE);
    int lo = guide[g < GUIDE ? g : GUIDE - 1];
    while (lo < n - 1 && cdf[lo + 1] <= u)
        lo++;
    while (lo < n - 1 && !(cdf[lo + 1] > cdf[lo]))
        lo++;
    while (lo > 0 && !(cdf[lo + 1] > cdf[lo]))
        lo--;
    double w = cdf[lo + 1] - cdf[lo];
    double t = w > 0.0 ? (u - cdf[lo]) / w : 0.5;
    *frac = t < 0.0 ? 0.0 : (t >= 1.0 ? 0x1.fffffffffffffp-1 : t);
    return lo;
}

static double clamp_u(double u)
{
    return u > 0.0 ? (u < 1.0 ? u : 0x1.fffffffffffffp-1) : 0.0;
}

void distrib2d_sample(const distrib2d_t *d, double u0, double u1, double *u, double *v, double *pdf)
{
    double fv, fu;
    int iv = invert(d->marginal, d->marginal_guide, d->nv, clamp_u(u1), &fv);
    int iu = invert(d->cdf + (size_t)iv * (size_t)(d->nu + 1), d->row_guide + (size_t)iv * GUIDE,
                    d->nu, clamp_u(u0), &fu);
    *u = (iu + fu) / d->nu;
    *v = (iv + fv) / d->nv;
    *pdf = d->f[(size_t)iv * (size_t)d->nu + (size_t)iu] / d->mean;
}

double distrib2d_pdf(const distrib2d_t *d, double u, double v)
{
    int iu = (int)(clamp_u(u) * d->nu), iv = (int)(clamp_u(v) * d->nv);
    if (iu >= d->nu)
        iu = d->nu - 1;
    if (iv >= d->nv)
        iv = d->nv - 1;
    return d->f[(size_t)iv * (size_t)d->nu + (size_t)iu] / d->mean;
}
