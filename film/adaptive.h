/* adaptive: which tiles of a progressive image still need samples to reach the job's target
 * error (docs/rendering.md, "Adaptive sampling"). One rule for the farm's scheduler
 * (master/sched.c) and for `prismfarm render --direct` (render/local_render.c): at a pass
 * boundary, from the merged image alone, a tile whose own share of the image's squared error is
 * within its share of target^2 stops; the others go on. The decision depends only on the
 * image's bytes, the tiles still running and the rule, so the image is the same bytes for any
 * number of workers, threads, kills and restarts. Also the record of what each tile got: the
 * summary a render prints and the run-length list the EXR carries. */
#ifndef PRISMFARM_ADAPTIVE_H
#define PRISMFARM_ADAPTIVE_H

#include "error_estimate.h"
#include "tilegrid.h"

#include <stdbool.h>
#include <stddef.h>

/* A tile may stop only at a boundary where it holds at least this many samples per pixel: 16
 * samples of each of a tile's pixels (16 384 for a 32x32 tile) make an estimate that a handful
 * of lucky samples cannot fake, and a job of fewer spp has nothing to save. */
#define ADAPTIVE_MIN_SPP 16

/* A tile darker than the image is judged against its own mean luminance, but never against
 * less than this fraction of the image's (adaptive_decide). */
#define ADAPTIVE_DARK_FLOOR 0.25

/* The decision at the pass boundary where the running tiles hold spp_done samples per pixel and
 * the image's estimate is e (error_estimate_image of image): clears active[t] of each running
 * tile t of grid that stops here (tiles whose active[t] is false stopped before and are left
 * alone). Nothing stops unless target > 0, e is valid with a mean > 0 and above the target (a
 * job at its target ends as a whole), and spp_done >= ADAPTIVE_MIN_SPP. A tile stops when
 *
 *   sum over its pixels p of V_p  <=  (its pixels) x (target x ref)^2,
 *   ref = min(mean, max(tile mean, ADAPTIVE_DARK_FLOOR x mean))
 *
 * with V_p the variance of pixel p's mean luminance (error_estimate_variance_of_mean), mean the
 * image's mean luminance and tile mean the tile's: were every tile there, the image's estimate
 * would be at most the target, and a tile darker than the image is within the target relative
 * to its own light too (down to the floor).
 * A tile with a pixel of fewer than 2 samples or beyond range never stops; a tile without
 * light (every sample 0) has V = 0 and stops at the first boundary allowed. When every running
 * tile would stop while the image is still above its target (the tiles that stopped earlier
 * were judged against an image mean that moved since), none stops: the job goes on until the
 * image's own estimate reaches the target. Returns how many tiles stopped here. */
int adaptive_decide(const tilebuf_t *image, const tilegrid_t *grid, double target, int spp_done,
                    const error_estimate_t *e, bool *active);

/* What the tiles got, from tile_spp[t] the samples per pixel of each tile of grid. */
typedef struct adaptive_summary {
    int tiles;       /* tiles in the grid */
    int max_spp;     /* the most any tile got */
    int min_spp;     /* the least */
    int stopped;     /* tiles below max_spp: stopped early */
    int at_min;      /* tiles at min_spp */
    double mean_spp; /* samples per pixel over the image (pixels weighted) */
} adaptive_summary_t;

adaptive_summary_t adaptive_summarize(const tilegrid_t *grid, const int *tile_spp);

/* The one-line summary a render prints, into out[0..size):
 * "adaptive: 38 % of tiles stopped at 16 spp, 61 % before 64 spp; mean 27 spp". */
void adaptive_summary_line(const adaptive_summary_t *s, char *out, size_t size);

/* tile_spp as the EXR's record keeps it: run-length, row-major tiles, "16*40,32,64*3" (a count
 * after '*' repeats the value). Writes within size (cut, NUL-terminated) and returns the
 * uncut length, as snprintf. */
size_t adaptive_format_tile_spp(const int *tile_spp, int n, char *out, size_t size);

#endif
