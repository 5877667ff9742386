#include "filter.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define FILTER_PI 3.14159265358979323846

static const char *const NAMES[] = {[FILTER_BOX] = "box",
                                    [FILTER_GAUSSIAN] = "gaussian",
                                    [FILTER_MITCHELL] = "mitchell",
                                    [FILTER_SINC] = "sinc",
                                    [FILTER_TRIANGLE] = "triangle"};

filter_params_t filter_params_default(filter_kind_t kind)
{
    filter_params_t f = {.kind = kind, .sigma = 0.5, .b = 1.0 / 3.0, .c = 1.0 / 3.0, .tau = 3.0};
    switch (kind) {
    case FILTER_BOX: f.xradius = f.yradius = 0.5; break;
    case FILTER_GAUSSIAN: f.xradius = f.yradius = 1.5; break;
    case FILTER_SINC: f.xradius = f.yradius = 4.0; break;
    case FILTER_MITCHELL:
    case FILTER_TRIANGLE: f.xradius = f.yradius = 2.0; break;
    }
    return f;
}

int filter_kind_find(const char *name)
{
    for (int k = FILTER_BOX; name && k <= FILTER_TRIANGLE; k++)
        if (!strcmp(NAMES[k], name))
            return k;
    return -1;
}

const char *filter_kind_name(filter_kind_t kind)
{
    return kind >= FILTER_BOX && kind <= FILTER_TRIANGLE ? NAMES[kind] : "?";
}

static double gaussian(double x, double sigma)
{
    return exp(-x * x / (2.0 * sigma * sigma)) / sqrt(2.0 * FILTER_PI * sigma * sigma);
}

/* Mitchell & Netravali 1988, on [-2, 2] (pbrt-v4's Mitchell1D). */
static double mitchell1d(double x, double b, double c)
{
    x = fabs(x);
    if (x <= 1.0)
        return ((12 - 9 * b - 6 * c) * x * x * x + (-18 + 12 * b + 6 * c) * x * x + (6 - 2 * b)) / 6.0;
    if (x <= 2.0)
        return ((-b - 6 * c) * x * x * x + (6 * b + 30 * c) * x * x + (-12 * b - 48 * c) * x +
                (8 * b + 24 * c)) /
               6.0;
    return 0.0;
}

static double sinc(double x)
{
    return fabs(x) < 1e-5 ? 1.0 - FILTER_PI * FILTER_PI * x * x / 6.0 : sin(FILTER_PI * x) / (FILTER_PI * x);
}

/* pbrt-v4 WindowedSinc: sinc(x) times the Lanczos window sinc(x / tau), zero beyond radius. */
static double windowed_sinc(double x, double radius, double tau)
{
    return fabs(x) > radius ? 0.0 : sinc(x) * sinc(x / tau);
}

double filter_eval(const filter_params_t *f, double x, double y)
{
    switch (f->kind) {
    case FILTER_BOX: return fabs(x) <= f->xradius && fabs(y) <= f->yradius ? 1.0 : 0.0;
    case FILTER_GAUSSIAN:
        return fmax(0.0, gaussian(x, f->sigma) - gaussian(f->xradius, f->sigma)) *
               fmax(0.0, gaussian(y, f->sigma) - gaussian(f->yradius, f->sigma));
    case FILTER_MITCHELL:
        return mitchell1d(2.0 * x / f->xradius, f->b, f->c) * mitchell1d(2.0 * y / f->yradius, f->b, f->c);
    case FILTER_SINC: return windowed_sinc(x, f->xradius, f->tau) * windowed_sinc(y, f->yradius, f->tau);
    case FILTER_TRIANGLE: return fmax(0.0, f->xradius - fabs(x)) * fmax(0.0, f->yradius - fabs(y));
    }
    return 0.0;
}

struct filter_sampler {
    filter_params_t p;
    int nx, ny;
    double *f;       /* [ny][nx] the filter at cell centres */
    double *row_cdf; /* [ny + 1] marginal CDF of the rows' sums of |f| */
    double *col_cdf; /* [ny][nx + 1] each row's conditional CDF */
    double weight;   /* integral of |f| / integral of f over the table */
    /* Guide tables (distrib2d.c's cutpoint method): for u in [g / FGUIDE, (g + 1) / FGUIDE),
     * the cell cdf_search finds for u = g / FGUIDE, a lower bound of u's cell. */
    int *row_guide; /* [FGUIDE] */
    int *col_guide; /* [ny][FGUIDE] */
};

enum { FGUIDE = 32 };

/* The last cell i in [0, n) with c[i] <= u * c[n] (c nondecreasing, c[0] = 0). */
static int cdf_search(const double *c, int n, double u)
{
    double t = u * c[n];
    int lo = 0, hi = n - 1;
    while (lo < hi) { /* the last i with c[i] <= t */
        int mid = (lo + hi + 1) / 2;
        if (c[mid] <= t)
            lo = mid;
        else
            hi = mid - 1;
    }
    return lo;
}

static void guide_fill(const double *c, int n, int *guide)
{
    for (int g = 0; g < FGUIDE; g++)
        guide[g] = cdf_search(c, n, (double)g / FGUIDE);
}

void filter_sampler_destroy(filter_sampler_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    free((*self_p)->f);
    free((*self_p)->row_cdf);
    free((*self_p)->col_cdf);
    free((*self_p)->row_guide);
    free((*self_p)->col_guide);
    free(*self_p);
    *self_p = NULL;
}

filter_sampler_t *filter_sampler_new(const filter_params_t *params, err_t *err)
{
    const filter_params_t *p = params;
    if (!(p->xradius > 0.0 && p->xradius <= 64.0 && p->yradius > 0.0 && p->yradius <= 64.0)) {
        err_set(err, "filter radius %g x %g must lie in (0, 64]", p->xradius, p->yradius);
        return NULL;
    }
    if ((p->kind == FILTER_GAUSSIAN && !(p->sigma > 0.0 && isfinite(p->sigma))) ||
        (p->kind == FILTER_SINC && !(p->tau > 0.0 && isfinite(p->tau))) ||
        (p->kind == FILTER_MITCHELL && !(isfinite(p->b) && isfinite(p->c)))) {
        err_set(err, "filter \"%s\": sigma and tau must be positive, B and C finite", filter_kind_name(p->kind));
        return NULL;
    }
    filter_sampler_t *self = calloc(1, sizeof *self);
    if (!self) {
        err_set(err, "out of memory");
        return NULL;
    }
    self->p = *p;
    self->weight = 1.0;
    if (p->kind == FILTER_BOX || p->kind == FILTER_TRIANGLE)
        return self;
    /* pbrt-v4 FilterSampler: int(32 * radius) cells per axis. */
    self->nx = (int)(32.0 * p->xradius) > 0 ? (int)(32.0 * p->xradius) : 1;
    self->ny = (int)(32.0 * p->yradius) > 0 ? (int)(32.0 * p->yradius) : 1;
    size_t nx = (size_t)self->nx, ny = (size_t)self->ny;
    self->f = malloc(nx * ny * sizeof *self->f);
    self->row_cdf = malloc((ny + 1) * sizeof *self->row_cdf);
    self->col_cdf = malloc(ny * (nx + 1) * sizeof *self->col_cdf);
    if (!self->f || !self->row_cdf || !self->col_cdf) {
        filter_sampler_destroy(&self);
        err_set(err, "out of memory");
        return NULL;
    }
    double sum_abs = 0.0, sum = 0.0;
    self->row_cdf[0] = 0.0;
    for (size_t y = 0; y < ny; y++) {
        double *cdf = self->col_cdf + y * (nx + 1);
        cdf[0] = 0.0;
        double py = -p->yradius + 2.0 * p->yradius * ((double)y + 0.5) / (double)ny;
        for (size_t x = 0; x < nx; x++) {
            double px = -p->xradius + 2.0 * p->xradius * ((double)x + 0.5) / (double)nx;
            double v = filter_eval(p, px, py);
            self->f[y * nx + x] = v;
            cdf[x + 1] = cdf[x] + fabs(v);
            sum += v;
        }
        self->row_cdf[y + 1] = self->row_cdf[y] + cdf[nx];
        sum_abs += cdf[nx];
    }
    if (!(sum > 0.0) || !isfinite(sum_abs)) {
        filter_sampler_destroy(&self);
        err_set(err, "filter \"%s\" integrates to %g: it cannot weight a pixel", filter_kind_name(p->kind), sum);
        return NULL;
    }
    self->weight = sum_abs / sum;
    self->row_guide = malloc(FGUIDE * sizeof *self->row_guide);
    self->col_guide = malloc(ny * FGUIDE * sizeof *self->col_guide);
    if (!self->row_guide || !self->col_guide) {
        filter_sampler_destroy(&self);
        err_set(err, "out of memory for a filter table");
        return NULL;
    }
    guide_fill(self->row_cdf, (int)ny, self->row_guide);
    for (size_t y = 0; y < ny; y++)
        guide_fill(self->col_cdf + y * (nx + 1), (int)nx, self->col_guide + y * FGUIDE);
    return self;
}

/* The cell i of a CDF c[0..n] (c[0] = 0) with c[i] <= u * c[n] < c[i + 1], and the position of
 * u inside it in [0, 1). Cells of zero width are never chosen. */
static int cdf_find(const double *c, const int *guide, int n, double u, double *frac)
{
    double t = u * c[n];
    /* cdf_search's cell: from the guide's lower bound (g / FGUIDE <= u, so its t is <= this
     * t), forward while the next cell still starts at or below t. */
    int g = (int)(u * FGUIDE);
    int lo = guide[g < FGUIDE ? g : FGUIDE - 1];
    while (lo < n - 1 && c[lo + 1] <= t)
        lo++;
    while (lo > 0 && !(c[lo + 1] > c[lo]))
        lo--;
    double w = c[lo + 1] - c[lo];
    double f = w > 0.0 ? (t - c[lo]) / w : 0.5;
    *frac = f < 0.0 ? 0.0 : f >= 1.0 ? nextafter(1.0, 0.0) : f;
    return lo;
}

/* pbrt-v4 SampleTent as an inverse CDF (monotonic, so strata are kept). */
static double sample_tent(double u, double r)
{
    return u < 0.5 ? -r + r * sqrt(2.0 * u) : r - r * sqrt(2.0 * (1.0 - u));
}

filter_sample_t filter_sampler_sample(const filter_sampler_t *self, double u1, double u2)
{
    const filter_params_t *p = &self->p;
    if (p->kind == FILTER_BOX)
        return (filter_sample_t){-p->xradius + 2.0 * p->xradius * u1, -p->yradius + 2.0 * p->yradius * u2, 1.0};
    if (p->kind == FILTER_TRIANGLE)
        return (filter_sample_t){sample_tent(u1, p->xradius), sample_tent(u2, p->yradius), 1.0};
    double fy, fx;
    int y = cdf_find(self->row_cdf, self->row_guide, self->ny, u2, &fy);
    int x = cdf_find(self->col_cdf + (size_t)y * (size_t)(self->nx + 1),
                     self->col_guide + (size_t)y * FGUIDE, self->nx, u1, &fx);
    double v = self->f[(size_t)y * (size_t)self->nx + (size_t)x];
    return (filter_sample_t){
        .dx = -p->xradius + 2.0 * p->xradius * ((double)x + fx) / self->nx,
        .dy = -p->yradius + 2.0 * p->yradius * ((double)y + fy) / self->ny,
        .weight = v < 0.0 ? -self->weight : self->weight,
    };
}

const filter_params_t *filter_sampler_params(const filter_sampler_t *self) { return &self->p; }
