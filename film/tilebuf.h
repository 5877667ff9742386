/* tilebuf: a spectral framebuffer for a pixel rectangle: per pixel and bucket the sum of
 * sample contributions (double), per pixel the sum of the samples' CIE XYZ (each computed at the
 * sample's own wavelengths, so its mean converges to the pixel's colour whatever the buckets:
 * docs/rendering.md, "Colour"), the number of samples taken and the sums of per-sample
 * luminance Y and of its square (for error estimates). Tiles merge into a larger buffer by plain sums, so
 * merging in a fixed order gives the same bytes whoever rendered the tiles. Non-finite
 * contributions never enter the sums; they are counted instead. A pass's sums are rounded to
 * float32 values by one rule (tilebuf_round_sums) before they are merged, by the farm and by
 * `render --direct` alike, which halves the bytes a tile travels and is kept in. */
#ifndef PRISMFARM_TILEBUF_H
#define PRISMFARM_TILEBUF_H

#include "err.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef struct tilebuf tilebuf_t;

/* Colour channels per pixel beside the buckets: X, Y, Z. */
#define TILEBUF_XYZ 3

/* A buffer for pixels [x0, x0+w) x [y0, y0+h) with nbuckets spectral buckets, all zero. */
tilebuf_t *tilebuf_new(int x0, int y0, int w, int h, int nbuckets, err_t *err);
void tilebuf_destroy(tilebuf_t **self_p);

int tilebuf_x0(const tilebuf_t *self);
int tilebuf_y0(const tilebuf_t *self);
int tilebuf_width(const tilebuf_t *self);
int tilebuf_height(const tilebuf_t *self);
int tilebuf_nbuckets(const tilebuf_t *self);

/* Adds one finished sample of pixel (x, y) (absolute image coordinates): its per-bucket
 * contributions and its CIE XYZ xyz[3] (whose Y is the luminance the error estimate uses). A
 * sample with any non-finite value is dropped whole and counted, so that one bad path never
 * darkens or brightens a pixel. Returns 0, or -1 when the sample was dropped. */
int tilebuf_add_sample(tilebuf_t *self, int x, int y, const double *buckets, const double *xyz);

/* Sum over samples of the contribution to (x, y, bucket); samples taken at (x, y). */
double tilebuf_sum(const tilebuf_t *self, int x, int y, int bucket);
/* Sum over samples of channel k (0 X, 1 Y, 2 Z) of (x, y). */
double tilebuf_xyz_sum(const tilebuf_t *self, int x, int y, int k);
uint64_t tilebuf_count(const tilebuf_t *self, int x, int y);
double tilebuf_luminance_sum(const tilebuf_t *self, int x, int y);
double tilebuf_luminance_sq_sum(const tilebuf_t *self, int x, int y);
uint64_t tilebuf_nonfinite(const tilebuf_t *self);

/* Mean per bucket of pixel (x, y) into out[nbuckets] (zeros when no sample was taken). */
void tilebuf_mean(const tilebuf_t *self, int x, int y, double *out);
/* Mean XYZ of pixel (x, y) (zeros when no sample was taken). */
void tilebuf_xyz_mean(const tilebuf_t *self, int x, int y, double out[3]);

/* Adds src's sums, counts and non-finite count into dst. src must lie inside dst and have the
 * same number of buckets. */
int tilebuf_merge(tilebuf_t *dst, const tilebuf_t *src, err_t *err);

/* Every value to zero (a scratch buffer reused for the next pass). */
void tilebuf_clear(tilebuf_t *self);

/* The rounding of a pass's sums before they travel or are merged (docs/farm.md, "Same pixels"):
 * s becomes (double)(float)s when that float is zero or normal and finite, i.e. when s == 0 or
 * FLT_MIN - 2^-150 <= |s| < FLT_MAX + 2^103 (round to nearest, ties to even: the bounds are the
 * midpoints below FLT_MIN and above FLT_MAX); otherwise s stays the double it is, so that a sum
 * beyond float's range (huge radiance) or in its subnormal range loses nothing. The rule acts
 * on each value alone, so the rounded values do not depend on the tile's size or shape. Decided
 * on the bits, so that flush-to-zero and denormals-are-zero modes (render threads) do not change
 * it. */
double tilebuf_round_value(double s);
/* Whether s is a value the rule leaves as a float32 (zero, or a normal finite float): such a
 * value is carried exactly by 4 bytes. */
bool tilebuf_is_float_value(double s);
/* Applies tilebuf_round_value to every bucket and XYZ sum (lum and lum_sq stay double: an error estimate's
 * lum_sq - lum^2/n cancels, float32 would leave noise). Returns how many sums stayed doubles:
 * 0 when the tile travels as float32. */
size_t tilebuf_round_sums(tilebuf_t *self);

/* Raw arrays, for encoding a tile into a message: sums are [h][w][nbuckets], xyz sums
 * [h][w][TILEBUF_XYZ], the others [h][w]. */
const double *tilebuf_sums(const tilebuf_t *self);
const double *tilebuf_xyz_sums(const tilebuf_t *self);
const uint64_t *tilebuf_counts(const tilebuf_t *self);
const double *tilebuf_luminance_sums(const tilebuf_t *self);
const double *tilebuf_luminance_sq_sums(const tilebuf_t *self);

/* A tile rebuilt from those arrays (copied), e.g. from a decoded message. Every value must be
 * finite (sums can only hold finite values); returns NULL with err otherwise. */
tilebuf_t *tilebuf_new_from(int x0, int y0, int w, int h, int nbuckets, const double *sums,
                            const double *xyz, const uint64_t *counts, const double *lum, const double *lum_sq,
                            uint64_t nonfinite, err_t *err);

#endif
