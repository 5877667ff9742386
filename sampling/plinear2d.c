#include "plinear2d.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

struct plinear2d {
    int nx, ny, nparams;
    int res[PLINEAR2D_MAX_PARAMS];
    size_t stride[PLINEAR2D_MAX_PARAMS]; /* slices between neighbouring values of parameter k */
    float *values[PLINEAR2D_MAX_PARAMS];
    size_t nslices;
    bool sampling;
    float *data;     /* nslices * nx * ny values (normalised per slice when sampling) */
    float *cond;     /* sampling: per slice and row, the running integral over x (nx each) */
    float *marginal; /* sampling: per slice, the running integral over rows (ny each) */
};

/* The slices a parameter point blends and their weights: 2^k corners for the k parameters
 * with more than one grid value. */
typedef struct corners {
    int n;
    size_t slice[1 << PLINEAR2D_MAX_PARAMS];
    double w[1 << PLINEAR2D_MAX_PARAMS];
} corners_t;

void plinear2d_destroy(plinear2d_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    plinear2d_t *p = *self_p;
    for (int k = 0; k < PLINEAR2D_MAX_PARAMS; k++)
        free(p->values[k]);
    free(p->data);
    free(p->cond);
    free(p->marginal);
    free(p);
    *self_p = NULL;
}

static double clamp01(double x)
{
    return fmin(fmax(x, 0.0), 1.0); /* NaN: 0 */
}

/* Builds one slice's running integrals (trapezoids over grid cells), normalised so that the
 * last marginal entry is 1; a slice of total 0 becomes uniform first. */
static void slice_tables(plinear2d_t *p, float *d, float *cond, float *marg)
{
    const int nx = p->nx, ny = p->ny;
    for (int pass = 0; pass < 2; pass++) {
        for (int y = 0; y < ny; y++) {
            double sum = 0.0;
            cond[(size_t)y * nx] = 0.0f;
            for (int x = 0; x + 1 < nx; x++) {
                sum += 0.5 * ((double)d[(size_t)y * nx + x] + (double)d[(size_t)y * nx + x + 1]);
                cond[(size_t)y * nx + x + 1] = (float)sum;
            }
        }
        double sum = 0.0;
        marg[0] = 0.0f;
        for (int y = 0; y + 1 < ny; y++) {
            sum += 0.5 * ((double)cond[(size_t)(y + 1) * nx - 1] +
                          (double)cond[(size_t)(y + 2) * nx - 1]);
            marg[y + 1] = (float)sum;
        }
        if (sum > 0.0 && isfinite(sum)) {
            const double inv = 1.0 / sum;
            for (size_t i = 0; i < (size_t)nx * ny; i++) {
                cond[i] = (float)(cond[i] * inv);
                d[i] = (float)(d[i] * inv);
            }
            for (int y = 0; y < ny; y++)
                marg[y] = (float)(marg[y] * inv);
            return;
        }
        for (size_t i = 0; i < (size_t)nx * ny; i++)
            d[i] = 1.0f;
    }
}

plinear2d_t *plinear2d_new(const float *data, int nx, int ny, int nparams, const int *param_res,
                           const float *const *param_values, bool sampling, const char *what,
                           err_t *err)
{
    if (nx < 2 || ny < 2 || nparams < 0 || nparams > PLINEAR2D_MAX_PARAMS) {
        err_set(err, "%s: a %d x %d grid with %d parameters (needs at least 2 x 2, at most %d)",
                what, nx, ny, nparams, PLINEAR2D_MAX_PARAMS);
        return NULL;
    }
    plinear2d_t *p = calloc(1, sizeof *p);
    if (!p) {
        err_set(err, "%s: out of memory", what);
        return NULL;
    }
    p->nx = nx;
    p->ny = ny;
    p->nparams = nparams;
    p->sampling = sampling;
    size_t slices = 1;
    for (int k = nparams - 1; k >= 0; k--) {
        const int r = param_res[k];
        if (r < 1 || slices > SIZE_MAX / (size_t)r) {
            err_set(err, "%s: parameter %d has %d values", what, k + 1, r);
            goto fail;
        }
        p->res[k] = r;
        p->stride[k] = slices;
        slices *= (size_t)r;
        p->values[k] = malloc((size_t)r * sizeof(float));
        if (!p->values[k]) {
            err_set(err, "%s: out of memory", what);
            goto fail;
        }
        for (int i = 0; i < r; i++) {
            const float v = param_values[k][i];
            if (!isfinite(v) || (i > 0 && !(v > param_values[k][i - 1]))) {
                err_set(err,
                        "%s: parameter %d's values must be finite and increasing (value %d is "
                        "%g)",
                        what, k + 1, i + 1, (double)v);
                goto fail;
            }
            p->values[k][i] = v;
        }
    }
    p->nslices = slices;
    const size_t slice_size = (size_t)nx * (size_t)ny;
    if (slices > SIZE_MAX / sizeof(float) / slice_size) {
        err_set(err, "%s: too many values", what);
        goto fail;
    }
    const size_t n = slices * slice_size;
    p->data = malloc(n * sizeof(float));
    if (sampling) {
        p->cond = malloc(n * sizeof(float));
        p->marginal = malloc(slices * (size_t)ny * sizeof(float));
    }
    if (!p->data || (sampling && (!p->cond || !p->marginal))) {
        err_set(err, "%s: out of memory for %zu values", what, n);
        goto fail;
    }
    for (size_t i = 0; i < n; i++) {
        if (!isfinite(data[i]) || (sampling && data[i] < 0.0f)) {
            err_set(err, "%s: value %zu is %g (must be finite%s)", what, i + 1, (double)data[i],
                    sampling ? " and not negative" : "");
            goto fail;
        }
        p->data[i] = data[i];
    }
    if (sampling)
        for (size_t s = 0; s < slices; s++)
            slice_tables(p, p->data + s * slice_size, p->cond + s * slice_size,
                         p->marginal + s * (size_t)ny);
    return p;
fail:
    plinear2d_destroy(&p);
    return NULL;
}

size_t plinear2d_bytes(const plinear2d_t *p)
{
    size_t n = p->nslices * (size_t)p->nx * (size_t)p->ny;
    return sizeof *p + n * sizeof(float) * (p->sampling ? 2 : 1) +
           (p->sampling ? p->nslices * (size_t)p->ny * sizeof(float) : 0);
}

/* The largest i in [0, n - 2] with v[i] <= x (0 when none): the grid cell of x. */
static int cell_of(const float *v, int n, double x)
{
    int lo = 0, hi = n - 2;
    while (lo < hi) {
        int mid = (lo + hi + 1) / 2;
        if (v[mid] <= x)
            lo = mid;
        else
            hi = mid - 1;
    }
    return lo;
}

static void corners_make(const plinear2d_t *p, const double *params, corners_t *c)
{
    c->n = 1;
    c->slice[0] = 0;
    c->w[0] = 1.0;
    for (int k = 0; k < p->nparams; k++) {
        const int r = p->res[k];
        if (r == 1)
            continue;
        const float *v = p->values[k];
        const double x = params[k];
        const int i = cell_of(v, r, x);
        const double t = clamp01((x - v[i]) / ((double)v[i + 1] - v[i]));
        const int m = c->n;
        for (int j = 0; j < m; j++) {
            c->slice[j + m] = c->slice[j] + p->stride[k] * (size_t)(i + 1);
            c->w[j + m] = c->w[j] * t;
            c->slice[j] += p->stride[k] * (size_t)i;
            c->w[j] *= 1.0 - t;
        }
        c->n = 2 * m;
    }
}

/* arr's entry idx of the blended slice (slices of `size` entries). */
static double at(const float *arr, size_t size, const corners_t *c, size_t idx)
{
    double s = 0.0;
    for (int j = 0; j < c->n; j++)
        s += c->w[j] * (double)arr[c->slice[j] * size + idx];
    return s;
}

double plinear2d_eval(const plinear2d_t *p, double x, double y, const double *params)
{
    corners_t c;
    corners_make(p, params, &c);
    const int nx = p->nx, ny = p->ny;
    x = clamp01(x) * (nx - 1);
    y = clamp01(y) * (ny - 1);
    const int col = x < nx - 2 ? (int)x : nx - 2, row = y < ny - 2 ? (int)y : ny - 2;
    const double fx = x - col, fy = y - row;
    const size_t size = (size_t)nx * ny, i = (size_t)row * nx + col;
    const double v00 = at(p->data, size, &c, i), v10 = at(p->data, size, &c, i + 1),
                 v01 = at(p->data, size, &c, i + nx), v11 = at(p->data, size, &c, i + nx + 1);
    double v = (1.0 - fy) * ((1.0 - fx) * v00 + fx * v10) + fy * ((1.0 - fx) * v01 + fx * v11);
    if (p->sampling)
        v *= (double)(nx - 1) * (ny - 1);
    return isfinite(v) ? v : 0.0;
}

/* The t in [0, 1] where a density linear from a (at 0) to b (at 1) has integrated to u. */
static double solve_linear(double a, double b, double u)
{
    double t;
    if (fabs(a - b) <= 1e-9 * (a + b))
        t = a + b > 0.0 ? 2.0 * u / (a + b) : 0.0;
    else
        t = (a - sqrt(fmax(0.0, a * a + 2.0 * u * (b - a)))) / (a - b);
    return clamp01(t);
}

void plinear2d_sample(const plinear2d_t *p, double u0, double u1, const double *params,
                      double out[2], double *pdf)
{
    const double eps = 1e-12;
    u0 = fmin(fmax(u0, eps), 1.0 - eps);
    u1 = fmin(fmax(u1, eps), 1.0 - eps);
    corners_t c;
    corners_make(p, params, &c);
    const int nx = p->nx, ny = p->ny;
    const size_t size = (size_t)nx * ny;
    /* The row: the last whose running marginal is below u1. */
    int lo = 0, hi = ny - 2;
    while (lo < hi) {
        int mid = (lo + hi + 1) / 2;
        if (at(p->marginal, (size_t)ny, &c, (size_t)mid) < u1)
            lo = mid;
        else
            hi = mid - 1;
    }
    const int row = lo;
    u1 -= at(p->marginal, (size_t)ny, &c, (size_t)row);
    const size_t r = (size_t)row * nx;
    const double r0 = at(p->cond, size, &c, r + nx - 1), r1 = at(p->cond, size, &c, r + 2 * nx - 1);
    const double t = solve_linear(r0, r1, u1);
    /* The column, in the row blended at t. */
    u0 *= (1.0 - t) * r0 + t * r1;
    lo = 0;
    hi = nx - 2;
    while (lo < hi) {
        int mid = (lo + hi + 1) / 2;
        double cm =
            (1.0 - t) * at(p->cond, size, &c, r + mid) + t * at(p->cond, size, &c, r + nx + mid);
        if (cm < u0)
            lo = mid;
        else
            hi = mid - 1;
    }
    const int col = lo;
    u0 -= (1.0 - t) * at(p->cond, size, &c, r + col) + t * at(p->cond, size, &c, r + nx + col);
    const size_t i = r + col;
    const double v00 = at(p->data, size, &c, i), v10 = at(p->data, size, &c, i + 1),
                 v01 = at(p->data, size, &c, i + nx), v11 = at(p->data, size, &c, i + nx + 1);
    const double c0 = (1.0 - t) * v00 + t * v01, c1 = (1.0 - t) * v10 + t * v11;
    const double s = solve_linear(c0, c1, u0);
    out[0] = clamp01((col + s) / (nx - 1));
    out[1] = clamp01((row + t) / (ny - 1));
    const double d = ((1.0 - s) * c0 + s * c1) * (double)(nx - 1) * (ny - 1);
    *pdf = isfinite(d) && d > 0.0 ? d : 0.0;
}

void plinear2d_invert(const plinear2d_t *p, double x, double y, const double *params, double out[2],
                      double *pdf)
{
    corners_t c;
    corners_make(p, params, &c);
    const int nx = p->nx, ny = p->ny;
    const size_t size = (size_t)nx * ny;
    x = clamp01(x) * (nx - 1);
    y = clamp01(y) * (ny - 1);
    const int col = x < nx - 2 ? (int)x : nx - 2, row = y < ny - 2 ? (int)y : ny - 2;
    const double sx = x - col, sy = y - row;
    const size_t r = (size_t)row * nx, i = r + col;
    const double v00 = at(p->data, size, &c, i), v10 = at(p->data, size, &c, i + 1),
                 v01 = at(p->data, size, &c, i + nx), v11 = at(p->data, size, &c, i + nx + 1);
    const double c0 = (1.0 - sy) * v00 + sy * v01, c1 = (1.0 - sy) * v10 + sy * v11;
    const double d = ((1.0 - sx) * c0 + sx * c1) * (double)(nx - 1) * (ny - 1);
    /* x: the running integral of the row blended at sy up to x, over the row's total. */
    double ux = sx * (c0 + 0.5 * sx * (c1 - c0)) + (1.0 - sy) * at(p->cond, size, &c, i) +
                sy * at(p->cond, size, &c, i + nx);
    const double r0 = at(p->cond, size, &c, r + nx - 1), r1 = at(p->cond, size, &c, r + 2 * nx - 1);
    const double total = (1.0 - sy) * r0 + sy * r1;
    ux = total > 0.0 ? ux / total : 0.0;
    const double uy =
        sy * (r0 + 0.5 * sy * (r1 - r0)) + at(p->marginal, (size_t)ny, &c, (size_t)row);
    out[0] = clamp01(ux);
    out[1] = clamp01(uy);
    *pdf = isfinite(d) && d > 0.0 ? d : 0.0;
}
