/* error_estimate: how far a progressive image is from converged, estimated from its own
 * samples: the relative RMSE of the per-pixel means of luminance, from the per-pixel sample
 * count, sum and sum of squares that every tilebuf keeps. O(pixels), no allocation, never NaN:
 * an image that allows no estimate says so (valid = false) instead. */
#ifndef PRISMFARM_ERROR_ESTIMATE_H
#define PRISMFARM_ERROR_ESTIMATE_H

#include "tilebuf.h"

#include <stdbool.h>
#include <stdint.h>

typedef struct error_estimate {
    bool valid;         /* false: no pixel has 2 samples, a pixel's squares saturated, or a noisy
                         * image whose mean is <= 0 */
    double rel_rmse;    /* rmse / mean: the figure reported and compared with --target-error */
    double rmse;        /* sqrt(mean over pixels of Var(mean luminance)), luminance units */
    double mean;        /* mean over pixels of the mean luminance */
    uint64_t pixels;    /* pixels with >= 2 samples: the ones averaged */
    uint64_t skipped;   /* pixels with < 2 samples: no variance can be estimated from one */
    uint64_t saturated; /* pixels whose sum of squares saturated (tilebuf.h): unbounded error */
} error_estimate_t;

/* The variance of pixel p's mean luminance from its n samples with sum s1 and sum of squares
 * s2: s^2 / n with s^2 = (s2 - s1^2 / n) / (n - 1), the unbiased sample variance, clamped at 0
 * (rounding can make a constant pixel's difference slightly negative). Returns -1 when n < 2
 * or an input is not finite; DBL_MAX, "unbounded", when the squares saturated (tilebuf keeps
 * s2 at DBL_MAX once a square overflows) or s1^2 / n overflows. */
double error_estimate_variance_of_mean(uint64_t n, double s1, double s2);

/* What to say after the figure rel (rel_rmse) so that a value above 1 is not read as a
 * percentage gone wrong: "" up to 1, else a note that the noise still exceeds the image's mean
 * (a few samples per pixel, a firefly not yet averaged out). The figure itself is not clamped:
 * it is what the stopping rule compares with a target. */
const char *error_estimate_note(double rel);

/* The estimate over every pixel of image (see error_estimate_t and docs/farm.md, "Accuracy").
 * One saturated pixel makes the image's error unbounded: no estimate (valid = false), so that
 * no target is ever reached on its account. */
error_estimate_t error_estimate_image(const tilebuf_t *image);

#endif
