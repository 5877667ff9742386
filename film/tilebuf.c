#include "tilebuf.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

struct tilebuf {
    int x0, y0, w, h, nb;
    double *sums;      /* [h][w][nb] */
    double *xyz;       /* [h][w][3] */
    uint64_t *counts;  /* [h][w] */
    double *lum;       /* [h][w] */
    double *lum_sq;    /* [h][w] */
    uint64_t nonfinite;
};

tilebuf_t *tilebuf_new(int x0, int y0, int w, int h, int nbuckets, err_t *err)
{
    if (w <= 0 || h <= 0 || nbuckets <= 0 || x0 < 0 || y0 < 0) {
        err_set(err, "tile %dx%d at (%d,%d) with %d buckets: sizes must be positive", w, h, x0,
                y0, nbuckets);
        return NULL;
    }
    size_t npix = (size_t)w * (size_t)h;
    if (npix > ((size_t)1 << 31) / (size_t)nbuckets) {
        err_set(err, "tile %dx%d with %d buckets is too large", w, h, nbuckets);
        return NULL;
    }
    tilebuf_t *self = calloc(1, sizeof *self);
    if (!self) {
        err_set(err, "out of memory for a %dx%d tile", w, h);
        return NULL;
    }
    *self = (tilebuf_t){.x0 = x0, .y0 = y0, .w = w, .h = h, .nb = nbuckets};
    self->sums = calloc(npix * (size_t)nbuckets, sizeof *self->sums);
    self->xyz = calloc(npix * TILEBUF_XYZ, sizeof *self->xyz);
    self->counts = calloc(npix, sizeof *self->counts);
    self->lum = calloc(npix, sizeof *self->lum);
    self->lum_sq = calloc(npix, sizeof *self->lum_sq);
    if (!self->sums || !self->xyz || !self->counts || !self->lum || !self->lum_sq) {
        tilebuf_destroy(&self);
        err_set(err, "out of memory for a %dx%d tile with %d buckets", w, h, nbuckets);
        return NULL;
    }
    return self;
}

void tilebuf_destroy(tilebuf_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    tilebuf_t *self = *self_p;
    free(self->sums);
    free(self->xyz);
    free(self->counts);
    free(self->lum);
    free(self->lum_sq);
    free(self);
    *self_p = NULL;
}

int tilebuf_x0(const tilebuf_t *self) { return self->x0; }
int tilebuf_y0(const tilebuf_t *self) { return self->y0; }
int tilebuf_width(const tilebuf_t *self) { return self->w; }
int tilebuf_height(const tilebuf_t *self) { return self->h; }
int tilebuf_nbuckets(const tilebuf_t *self) { return self->nb; }
uint64_t tilebuf_nonfinite(const tilebuf_t *self) { return self->nonfinite; }
const double *tilebuf_sums(const tilebuf_t *self) { return self->sums; }
const double *tilebuf_xyz_sums(const tilebuf_t *self) { return self->xyz; }
const uint64_t *tilebuf_counts(const tilebuf_t *self) { return self->counts; }
const double *tilebuf_luminance_sums(const tilebuf_t *self) { return self->lum; }
const double *tilebuf_luminance_sq_sums(const tilebuf_t *self) { return self->lum_sq; }

static int all_finite(const double *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

tilebuf_t *tilebuf_new_from(int x0, int y0, int w, int h, int nbuckets, const double *sums,
                            const double *xyz, const uint64_t *counts, const double *lum, const double *lum_sq,
                            uint64_t nonfinite, err_t *err)
{
    tilebuf_t *self = tilebuf_new(x0, y0, w, h, nbuckets, err);
    if (!self)
        return NULL;
    size_t npix = (size_t)w * (size_t)h;
    if (!all_finite(sums, npix * (size_t)nbuckets) || !all_finite(xyz, npix * TILEBUF_XYZ) ||
        !all_finite(lum, npix) ||
        !all_finite(lum_sq, npix)) {
        tilebuf_destroy(&self);
        err_set(err, "tile %dx%d at (%d,%d) holds a non-finite sum", w, h, x0, y0);
        return NULL;
    }
    memcpy(self->sums, sums, npix * (size_t)nbuckets * sizeof *sums);
    memcpy(self->xyz, xyz, npix * TILEBUF_XYZ * sizeof *xyz);
    memcpy(self->counts, counts, npix * sizeof *counts);
    memcpy(self->lum, lum, npix * sizeof *lum);
    memcpy(self->lum_sq, lum_sq, npix * sizeof *lum_sq);
    self->nonfinite = nonfinite;
    return self;
}

static size_t pixel_index(const tilebuf_t *self, int x, int y)
{
    return (size_t)(y - self->y0) * (size_t)self->w + (size_t)(x - self->x0);
}

int tilebuf_add_sample(tilebuf_t *self, int x, int y, const double *buckets, const double *xyz)
{
    size_t p = pixel_index(self, x, y);
    double *s = self->sums + p * (size_t)self->nb;
    double *c = self->xyz + p * TILEBUF_XYZ;
    const double luminance = xyz[1];
    /* Finite values can still overflow a sum (two samples near DBL_MAX): such a sample is
     * dropped like a non-finite one, so that the sums stay finite (tilebuf_new_from refuses
     * anything else). */
    int finite = isfinite(luminance) && isfinite(self->lum[p] + luminance);
    for (int b = 0; b < self->nb && finite; b++)
        finite = isfinite(buckets[b]) && isfinite(s[b] + buckets[b]);
    for (int k = 0; k < TILEBUF_XYZ && finite; k++)
        finite = isfinite(xyz[k]) && isfinite(c[k] + xyz[k]);
    self->counts[p]++;
    if (!finite) {
        /* The sample still counts as taken: dropping it from the count too would bias the
         * pixel toward the remaining (typically brighter) samples. */
        self->nonfinite++;
        return -1;
    }
    for (int b = 0; b < self->nb; b++)
        s[b] += buckets[b];
    for (int k = 0; k < TILEBUF_XYZ; k++)
        c[k] += xyz[k];
    self->lum[p] += luminance;
    /* Only error estimates read the squares: a luminance above 1.3e154, whose square is Inf,
     * saturates them at DBL_MAX (an unbounded error) rather than losing its light. */
    self->lum_sq[p] = fmin(self->lum_sq[p] + luminance * luminance, DBL_MAX);
    return 0;
}

double tilebuf_sum(const tilebuf_t *self, int x, int y, int bucket)
{
    return self->sums[pixel_index(self, x, y) * (size_t)self->nb + (size_t)bucket];
}

uint64_t tilebuf_count(const tilebuf_t *self, int x, int y)
{
    return self->counts[pixel_index(self, x, y)];
}

double tilebuf_luminance_sum(const tilebuf_t *self, int x, int y)
{
    return self->lum[pixel_index(self, x, y)];
}

double tilebuf_luminance_sq_sum(const tilebuf_t *self, int x, int y)
{
    return self->lum_sq[pixel_index(self, x, y)];
}

double tilebuf_xyz_sum(const tilebuf_t *self, int x, int y, int k)
{
    return self->xyz[pixel_index(self, x, y) * TILEBUF_XYZ + (size_t)k];
}

void tilebuf_xyz_mean(const tilebuf_t *self, int x, int y, double out[3])
{
    size_t p = pixel_index(self, x, y);
    uint64_t n = self->counts[p];
    for (int k = 0; k < TILEBUF_XYZ; k++)
        out[k] = n ? self->xyz[p * TILEBUF_XYZ + (size_t)k] / (double)n : 0.0;
}

void tilebuf_mean(const tilebuf_t *self, int x, int y, double *out)
{
    size_t p = pixel_index(self, x, y);
    uint64_t n = self->counts[p];
    const double *s = self->sums + p * (size_t)self->nb;
    for (int b = 0; b < self->nb; b++)
        out[b] = n ? s[b] / (double)n : 0.0;
}

int tilebuf_merge(tilebuf_t *dst, const tilebuf_t *src, err_t *err)
{
    if (src->nb != dst->nb)
        return err_set(err, "cannot merge a tile with %d buckets into a buffer with %d", src->nb,
                       dst->nb);
    if (src->x0 < dst->x0 || src->y0 < dst->y0 || src->x0 + src->w > dst->x0 + dst->w ||
        src->y0 + src->h > dst->y0 + dst->h)
        return err_set(err, "tile %dx%d at (%d,%d) lies outside the %dx%d buffer at (%d,%d)",
                       src->w, src->h, src->x0, src->y0, dst->w, dst->h, dst->x0, dst->y0);
    for (int y = 0; y < src->h; y++) {
        for (int x = 0; x < src->w; x++) {
            size_t ps = (size_t)y * (size_t)src->w + (size_t)x;
            size_t pd = pixel_index(dst, src->x0 + x, src->y0 + y);
            for (int b = 0; b < src->nb; b++)
                dst->sums[pd * (size_t)dst->nb + (size_t)b] += src->sums[ps * (size_t)src->nb + (size_t)b];
            for (int k = 0; k < TILEBUF_XYZ; k++)
                dst->xyz[pd * TILEBUF_XYZ + (size_t)k] += src->xyz[ps * TILEBUF_XYZ + (size_t)k];
            dst->counts[pd] += src->counts[ps];
            dst->lum[pd] += src->lum[ps];
            dst->lum_sq[pd] += src->lum_sq[ps];
        }
    }
    dst->nonfinite += src->nonfinite;
    return 0;
}

void tilebuf_clear(tilebuf_t *self)
{
    size_t npix = (size_t)self->w * (size_t)self->h;
    memset(self->sums, 0, npix * (size_t)self->nb * sizeof *self->sums);
    memset(self->xyz, 0, npix * TILEBUF_XYZ * sizeof *self->xyz);
    memset(self->counts, 0, npix * sizeof *self->counts);
    memset(self->lum, 0, npix * sizeof *self->lum);
    memset(self->lum_sq, 0, npix * sizeof *self->lum_sq);
    self->nonfinite = 0;
}

/* |s| as bits: for non-negative doubles the unsigned order of the bits is the numeric order,
 * and integer compares are not touched by denormals-are-zero (an SSE compare of a subnormal
 * double against 0 would say "equal" there). */
static uint64_t abs_bits(double s)
{
    uint64_t b;
    memcpy(&b, &s, sizeof b);
    return b & ~((uint64_t)1 << 63);
}

static uint64_t bits_of(double v)
{
    uint64_t b;
    memcpy(&b, &v, sizeof b);
    return b;
}

double tilebuf_round_value(double s)
{
    /* FLT_MIN - 2^-150: the midpoint between FLT_MIN and the largest subnormal float, which
     * rounds to FLT_MIN (its mantissa is even). FLT_MAX + 2^103: the midpoint between FLT_MAX and
     * 2^128, which rounds to Inf (FLT_MAX's mantissa is odd). Both are exact doubles. */
    const uint64_t lo = bits_of((double)FLT_MIN - 0x1p-150), min = bits_of((double)FLT_MIN),
                   hi = bits_of((double)FLT_MAX + 0x1p103);
    uint64_t a = abs_bits(s);
    /* Below FLT_MIN the conversion is tiny before rounding, and flush-to-zero (x86 decides
     * tininess before rounding for it) would give 0 where round to nearest gives FLT_MIN. */
    if (a >= lo && a < min)
        return copysign((double)FLT_MIN, s);
    /* From FLT_MIN on, s and its float are normal: FTZ and DAZ cannot touch the conversion. */
    if (a >= min && a < hi)
        return (double)(float)s;
    return s; /* zero (a float already), beyond float range, or too small to be a normal float */
}

bool tilebuf_is_float_value(double s)
{
    uint64_t a = abs_bits(s);
    if (a == 0)
        return true;
    /* A normal float: biased double exponent 1023-126 .. 1023+127, and no mantissa bits below
     * float's 23 (the low 52 - 23 = 29). */
    uint64_t e = a >> 52;
    return e >= 1023 - 126 && e <= 1023 + 127 && (a & (((uint64_t)1 << 29) - 1)) == 0;
}

size_t tilebuf_round_sums(tilebuf_t *self)
{
    size_t n = (size_t)self->w * (size_t)self->h * (size_t)self->nb, wide = 0;
    for (size_t i = 0; i < n; i++) {
        self->sums[i] = tilebuf_round_value(self->sums[i]);
        wide += !tilebuf_is_float_value(self->sums[i]);
    }
    size_t nx = (size_t)self->w * (size_t)self->h * TILEBUF_XYZ;
    for (size_t i = 0; i < nx; i++) {
        self->xyz[i] = tilebuf_round_value(self->xyz[i]);
        wide += !tilebuf_is_float_value(self->xyz[i]);
    }
    return wide;
}
