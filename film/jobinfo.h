/* jobinfo: the text of the EXR's "prismfarm" attribute, the record a rendered image carries of
 * how it was made (docs/farm.md, "Accuracy"). One writer for the master and `render --direct`:
 * "key=value;" pairs in a fixed order, then the pass history, always last:
 *   [job=ID;name=NAME;]scene=..;spp=..;xres=..;yres=..;seed=..;integrator=..;dispersion=..;
 *   samples=..;[rays=..;]nonfinite=..;photons=..;seconds=..;spp_done=..;rel_rmse=E|none;
 *   stop=none|target|time;target_error=..;time_limit=..;
 *   [adaptive=on;tile=..;tiles=XxY;spp_mean=..;tile_spp=16*40,32,...;]history=PASS:SPP:SECONDS:REL,...
 * with "-" for a pass without an estimate; the adaptive keys only for a job whose tiles were
 * decided one by one (film/adaptive.h), tile_spp in run-length form (adaptive_format_tile_spp). The text is cut at size - 1 bytes, never overrun. */
#ifndef PRISMFARM_JOBINFO_H
#define PRISMFARM_JOBINFO_H

#include "err.h"
#include "stopping.h"
#include "tilegrid.h"

#include <stddef.h>
#include <stdint.h>

typedef struct jobinfo {
    uint64_t job;     /* the farm's job id; 0 for a render without a master (no job= or name=) */
    const char *name; /* the job's name (with a job id) */
    const char *scene;
    int spp, xres, yres;
    uint64_t seed;
    const char *integrator, *dispersion; /* what the scene ran with */
    uint64_t samples, nonfinite, photons;
    int64_t rays; /* < 0: not counted (the master does not see rays) */
    double seconds;
    int spp_done;
    stopping_why_t stop;
    stopping_rule_t rule;
    const pass_record_t *history;
    int nhistory;
    /* Adaptive sampling (film/adaptive.h): tile_spp[t] the samples per pixel of each tile of
     * grid; NULL for a job without it (no adaptive keys). */
    const int *tile_spp;
    tilegrid_t grid;
} jobinfo_t;

/* Writes the text into out[0..size) and returns its length (as snprintf would, uncut). */
size_t jobinfo_format(const jobinfo_t *info, char *out, size_t size);

/* The adaptive keys of such a text back (xres, yres, tile, tiles, tile_spp): *grid and
 * *tile_spp (malloc'ed, one per tile of the grid). Returns 1 with them, 0 when the text has no
 * adaptive keys, -1 with err when they do not describe a grid's tiles. */
int jobinfo_tile_spp(const char *info, tilegrid_t *grid, int **tile_spp, err_t *err);

#endif
