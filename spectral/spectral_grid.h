/* spectral_grid: the framebuffer's wavelength axis, N equal buckets over [lambda_min,
 * lambda_max] nm, and the energy-conserving splat of a continuous-wavelength Monte-Carlo
 * sample into them. A bucket holds spectral radiance averaged over its width. Pure functions
 * on a plain value type. */
#ifndef PRISMFARM_SPECTRAL_GRID_H
#define PRISMFARM_SPECTRAL_GRID_H

#include "err.h"

typedef struct spectral_grid {
    int n;             /* number of buckets, 1..SPECTRAL_GRID_MAX_BUCKETS */
    double lambda_min; /* nm, > 0 */
    double lambda_max; /* nm, > lambda_min */
} spectral_grid_t;

#define SPECTRAL_GRID_MAX_BUCKETS 1024
#define SPECTRAL_GRID_DEFAULT_N 16
#define SPECTRAL_GRID_DEFAULT_MIN 380.0
#define SPECTRAL_GRID_DEFAULT_MAX 720.0

/* How a sample is shared between buckets (both conserve sum(bucket) * width = v / p).
 * BOX: all of it goes to the bucket that contains lambda, so the expected bucket value is
 *   exactly the spectrum's average over the bucket (no blur between buckets).
 * TENT: split linearly between the two nearest bucket centres (weights 1 - f and f, f the
 *   fractional distance from the lower centre); below the first centre or above the last
 *   everything goes to the end bucket, so nothing leaves the grid. The expected value is the
 *   spectrum filtered by a triangle of half-width one bucket: smoother, slightly blurred. */
typedef enum spectral_splat {
    SPECTRAL_SPLAT_BOX,
    SPECTRAL_SPLAT_TENT,
} spectral_splat_t;

/* The default grid: 16 buckets over 380-720 nm. */
spectral_grid_t spectral_grid_default(void);

/* Checks n in [1, SPECTRAL_GRID_MAX_BUCKETS] and 0 < lambda_min < lambda_max, both finite;
 * returns 0, or -1 with a message naming the field. */
int spectral_grid_validate(spectral_grid_t grid, err_t *err);

/* Fills *grid after validation; returns 0 or -1 (then *grid is untouched). */
int spectral_grid_init(spectral_grid_t *grid, int n, double lambda_min, double lambda_max,
                       err_t *err);

/* Bucket width (nm) and centre of bucket i (nm); i is not range-checked. */
double spectral_grid_width(spectral_grid_t grid);
double spectral_grid_centre(spectral_grid_t grid, int i);
double spectral_grid_bucket_min(spectral_grid_t grid, int i);
double spectral_grid_bucket_max(spectral_grid_t grid, int i);

/* Index of the bucket containing lambda_nm: buckets are [lo, hi) except the last, which also
 * holds lambda_max. -1 outside [lambda_min, lambda_max] or for a non-finite lambda. */
int spectral_grid_index(spectral_grid_t grid, double lambda_nm);

/* Deposits one Monte-Carlo sample: spectral radiance `value` at lambda_nm drawn with density
 * pdf (1/nm). The sample estimates the integral of the spectrum over the grid as value/pdf;
 * it is added to buckets[] as value / (pdf * width), shared as `mode` says, so that after N
 * samples buckets[i] / N estimates the spectrum's average over bucket i (BOX, unbiased) and
 * sum(buckets) * width / N estimates its integral over [lambda_min, lambda_max] (both modes).
 * A lambda outside the grid deposits nothing and returns 0 (its energy is outside the range
 * the grid estimates). Returns -1 and deposits nothing for a non-finite value or lambda, or a
 * pdf that is not finite and > 0 (so no NaN or Inf reaches the buckets); callers count these. */
int spectral_grid_splat(spectral_grid_t grid, double *buckets, double lambda_nm, double value,
                        double pdf, spectral_splat_t mode);

/* A grid with its bucket boundaries and width computed once, for the renderer's inner loop:
 * spectral_table_index and spectral_table_splat give exactly (bit for bit) what
 * spectral_grid_index and spectral_grid_splat give for the grid, with two divisions instead of
 * five and no call to floor. Immutable after spectral_table_new; may be shared by threads. */
typedef struct spectral_table spectral_table_t;

/* NULL with a message for an invalid grid (spectral_grid_validate) or no memory. */
spectral_table_t *spectral_table_new(spectral_grid_t grid, err_t *err);
void spectral_table_destroy(spectral_table_t **self_p);
int spectral_table_index(const spectral_table_t *self, double lambda_nm);
int spectral_table_splat(const spectral_table_t *self, double *buckets, double lambda_nm,
                         double value, double pdf, spectral_splat_t mode);

#endif
