#include "error_estimate.h"

#include <float.h>
#include <math.h>

double error_estimate_variance_of_mean(uint64_t n, double s1, double s2)
{
    if (n < 2 || !isfinite(s1) || !isfinite(s2))
        return -1.0;
    double dn = (double)n;
    double mean = s1 / dn;
    if (s2 >= DBL_MAX || !isfinite(s1 * mean))
        return DBL_MAX;
    /* Sum of squared deviations, sum (Y - mean)^2 = s2 - s1 * mean; the one-pass form loses
     * digits when the mean is large against the spread, which only ever matters for nearly
     * constant pixels, whose true variance is about 0: hence the clamp. */
    double ss = s2 - s1 * mean;
    if (!(ss > 0))
        ss = 0;
    return ss / (dn - 1.0) / dn; /* finite: 0 <= ss <= s2 < DBL_MAX, and n >= 2 */
}

/* Relative RMSE of the image (the definition, docs/farm.md "Accuracy"):
 *
 *   V_p  = s_p^2 / n_p                  variance of pixel p's mean luminance (Student 1908)
 *   rmse = sqrt( (1/N) sum_p V_p )      N: pixels with n_p >= 2
 *   mean = (1/N) sum_p (S1_p / n_p)
 *   rel  = rmse / mean
 *
 * For independent samples V_p = sigma_p^2 / n_p, so rel falls as 1/sqrt(spp). Normalising by
 * the image's mean (not pixel by pixel) keeps dark pixels from dominating and makes the figure
 * independent of exposure. Pixels with fewer than 2 samples carry no variance estimate and are
 * left out of both sums, so numerator and denominator describe the same pixels. */
error_estimate_t error_estimate_image(const tilebuf_t *image)
{
    error_estimate_t e = {.valid = false};
    const uint64_t *counts = tilebuf_counts(image);
    const double *lum = tilebuf_luminance_sums(image), *lum_sq = tilebuf_luminance_sq_sums(image);
    size_t npix = (size_t)tilebuf_width(image) * (size_t)tilebuf_height(image);
    double sum_var = 0, sum_mean = 0;
    for (size_t p = 0; p < npix; p++) {
        double v = error_estimate_variance_of_mean(counts[p], lum[p], lum_sq[p]);
        if (v < 0) {
            e.skipped++;
            continue;
        }
        if (v == DBL_MAX) {
            e.saturated++;
            continue;
        }
        sum_var += v;
        sum_mean += lum[p] / (double)counts[p];
        e.pixels++;
    }
    if (e.pixels == 0 || e.saturated > 0)
        return e;
    e.rmse = sqrt(sum_var / (double)e.pixels);
    e.mean = sum_mean / (double)e.pixels;
    if (sum_var == 0)
        e.rel_rmse = 0; /* not one sample differs from its pixel's others: nothing left to gain */
    else if (e.mean > 0)
        e.rel_rmse = e.rmse / e.mean;
    else
        return e; /* a noisy image of mean <= 0 has no relative error */
    e.valid = isfinite(e.rmse) && isfinite(e.mean) && isfinite(e.rel_rmse);
    if (!e.valid)
        e.rel_rmse = e.rmse = e.mean = 0;
    return e;
}

const char *error_estimate_note(double rel)
{
    return rel > 1.0 ? " (above 1: the noise still exceeds the image's mean)" : "";
}
