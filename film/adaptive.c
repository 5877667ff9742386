#include "adaptive.h"

#include "strbuf.h"

#include <float.h>
#include <stdio.h>
#include <stdlib.h>

/* Sum over the tile's pixels of V_p, or -1 when a pixel has no estimate (fewer than 2 samples,
 * a non-finite sum) or an unbounded one (saturated squares): such a tile cannot be judged.
 * *mean gets the tile's mean luminance. */
static double tile_variance_sum(const tilebuf_t *image, const tilegrid_t *grid, int t, int *npix,
                                double *mean)
{
    int x0, y0, w, h;
    tilegrid_rect(grid, t, &x0, &y0, &w, &h);
    const uint64_t *n = tilebuf_counts(image);
    const double *s1 = tilebuf_luminance_sums(image), *s2 = tilebuf_luminance_sq_sums(image);
    size_t stride = (size_t)tilebuf_width(image);
    double sum = 0, lum = 0;
    for (int y = y0; y < y0 + h; y++)
        for (int x = x0; x < x0 + w; x++) {
            size_t p = (size_t)y * stride + (size_t)x;
            double v = error_estimate_variance_of_mean(n[p], s1[p], s2[p]);
            if (v < 0 || v == DBL_MAX)
                return -1;
            sum += v;
            lum += s1[p] / (double)n[p];
        }
    *npix = w * h;
    *mean = lum / (double)(w * h);
    return sum;
}

/* The rule (adaptive.h). The image's estimate is rel = sqrt(sum_p V_p / N) / mean, so it is <=
 * target when sum_p V_p <= N (target mean)^2; giving each tile the share of that budget its
 * pixels are of the image, a tile within its share needs no more samples. Every tile judged
 * alike keeps the noise even over the image (what the image's estimate measures), where the
 * allocation that minimises samples for the sum alone (n_t ~ sigma_t) would leave the noisy
 * regions visibly noisier. A tile darker than the image is held to its own mean instead
 * (relative to what it shows, its noise is then the target too), down to a quarter of the
 * image's mean: against the image's mean alone a tile at a fifth of it stopped at 5x the target
 * relative to itself, grain the tone curve shows (the jewel's dark backdrop at 16 spp,
 * docs/rendering.md); the floor keeps tiles with little light from running for ever. Since
 * passes double the samples, a tile stops with between half its budget and its budget. */
/* Whether running tile t is within its budget (adaptive.h): n_t (target ref)^2 with ref the
 * image's mean, or the tile's own when darker, down to ADAPTIVE_DARK_FLOOR of the image's. */
static bool tile_stops(const tilebuf_t *image, const tilegrid_t *grid, int t, double target,
                       double mean)
{
    int npix = 0;
    double m_t = 0;
    double v = tile_variance_sum(image, grid, t, &npix, &m_t);
    double ref = m_t < mean ? m_t : mean;
    if (!(ref > ADAPTIVE_DARK_FLOOR * mean))
        ref = ADAPTIVE_DARK_FLOOR * mean;
    return v >= 0 && v <= (double)npix * (target * ref) * (target * ref);
}

int adaptive_decide(const tilebuf_t *image, const tilegrid_t *grid, double target, int spp_done,
                    const error_estimate_t *e, bool *active)
{
    if (!(target > 0) || !e->valid || !(e->mean > 0) || e->rel_rmse <= target ||
        spp_done < ADAPTIVE_MIN_SPP)
        return 0;
    int ntiles = tilegrid_count(grid);
    /* Two rounds over the tiles, the first counting, the second stopping: nothing to allocate,
     * so that no failure can make one run's decision differ from another's. */
    int running = 0, stopping = 0;
    for (int t = 0; t < ntiles; t++)
        running += active[t];
    for (int t = 0; t < ntiles; t++)
        stopping += active[t] && tile_stops(image, grid, t, target, e->mean);
    if (stopping == running)
        return 0; /* the last running tiles end with the job: adaptive.h */
    for (int t = 0; t < ntiles; t++)
        if (active[t] && tile_stops(image, grid, t, target, e->mean))
            active[t] = false;
    return stopping;
}

adaptive_summary_t adaptive_summarize(const tilegrid_t *grid, const int *tile_spp)
{
    adaptive_summary_t s = {.tiles = tilegrid_count(grid)};
    if (s.tiles < 1)
        return s;
    s.max_spp = s.min_spp = tile_spp[0];
    for (int t = 1; t < s.tiles; t++) {
        if (tile_spp[t] > s.max_spp)
            s.max_spp = tile_spp[t];
        if (tile_spp[t] < s.min_spp)
            s.min_spp = tile_spp[t];
    }
    double samples = 0;
    for (int t = 0; t < s.tiles; t++) {
        int x0, y0, w, h;
        tilegrid_rect(grid, t, &x0, &y0, &w, &h);
        samples += (double)w * (double)h * (double)tile_spp[t];
        s.stopped += tile_spp[t] < s.max_spp;
        s.at_min += tile_spp[t] == s.min_spp;
    }
    s.mean_spp = samples / ((double)grid->xres * (double)grid->yres);
    return s;
}

void adaptive_summary_line(const adaptive_summary_t *s, char *out, size_t size)
{
    if (s->tiles < 1 || s->stopped == 0) {
        snprintf(out, size, "adaptive: every tile got %d spp", s->max_spp);
        return;
    }
    double pct_min = 100.0 * s->at_min / s->tiles, pct = 100.0 * s->stopped / s->tiles;
    snprintf(out, size,
             "adaptive: %.0f %% of tiles stopped at %d spp, %.0f %% before %d spp; "
             "mean %.1f spp",
             pct_min, s->min_spp, pct, s->max_spp, s->mean_spp);
}

size_t adaptive_format_tile_spp(const int *tile_spp, int n, char *out, size_t size)
{
    size_t len = 0;
    if (size > 0)
        out[0] = 0;
    for (int t = 0; t < n;) {
        int run = 1;
        while (t + run < n && tile_spp[t + run] == tile_spp[t])
            run++;
        if (run > 1)
            strbuf_appendf(out, size, &len, "%s%d*%d", t ? "," : "", tile_spp[t], run);
        else
            strbuf_appendf(out, size, &len, "%s%d", t ? "," : "", tile_spp[t]);
        t += run;
    }
    return len;
}
