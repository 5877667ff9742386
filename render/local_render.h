/* local_render: renders a whole image on this machine's cores -- the engine behind
 * `prismfarm render --direct`, benchmarks and tests. The image is cut into tiles (film/tilegrid)
 * run on the thread pool (base/pool); each tile is rendered pass by pass (film/passes), each
 * pass's sums rounded by tilebuf_round_sums and added in pass order, which is the farm's
 * arithmetic: the image is bit-identical to the farm's (any worker count, thread count or tile
 * size), by construction. With a stopping rule (film/stopping) the passes run one after the
 * other over the whole image and the rule decides at each boundary, as the master does; with
 * adaptive sampling under a target error (film/adaptive) the same boundaries also stop tiles
 * one by one, by the master's rule, so the bytes are still the farm's. */
#ifndef PRISMFARM_LOCAL_RENDER_H
#define PRISMFARM_LOCAL_RENDER_H

#include "render.h"
#include "stopping.h"
#include "tilegrid.h"

/* Called from one thread at a time, after each finished tile. */
typedef void (*local_render_progress_fn)(void *user, uint64_t samples_done, uint64_t samples_total,
                                         double elapsed_s);

/* Called after each pass merged under a stopping rule, from the calling thread. */
typedef void (*local_render_pass_fn)(void *user, const pass_record_t *rec, uint64_t samples_done,
                                     uint64_t samples_total);

typedef struct local_render_opts {
    int threads;                     /* 0: all cores */
    int tile_size;                   /* 0: 32 */
    const photon_store_t *photons;   /* the photon pass's store (render_tile) for a scene with a
                                      * photon pass; NULL: local_render traces it first */
    stopping_rule_t stop;            /* none: every pass, tile by tile */
    bool adaptive;                   /* with stop.target_error: tiles stop one by one at pass
                                      * boundaries (film/adaptive.h), as the farm's master
                                      * decides them (--adaptive on); without a target it
                                      * changes nothing */
    double t0;                       /* clock_now_s() when the job started (its elapsed times and
                                      * time limit count from it); 0: at the call */
    local_render_progress_fn progress;
    local_render_pass_fn pass_done;
    void *user;
} local_render_opts_t;

typedef struct local_render_result {
    pass_record_t history[STOPPING_MAX_RECORDS]; /* one per pass under a stopping rule; else one
                                                  * record for all the passes at once */
    int nhistory;
    stopping_why_t why; /* why it ended before the last pass */
    /* Adaptive sampling: the grid of tiles and each tile's samples per pixel in the image
     * (tilegrid order); NULL without it. Freed by local_render_result_free. */
    tilegrid_t grid;
    int *tile_spp;
} local_render_result_t;

/* Frees what a result holds (tile_spp); the result may be used again. */
void local_render_result_free(local_render_result_t *result);

/* Renders samples [0, scene->settings.spp) of every pixel into image, which must be zero and
 * cover the whole image with the film's bucket count; under a stopping rule, the passes up to
 * the boundary where the rule stopped (a time limit drops the pass in flight, never the first).
 * Adds to *stats the work that is in the image; fills *result (both may be NULL). */
int local_render(const scene_t *scene, const local_render_opts_t *opts, tilebuf_t *image,
                 render_stats_t *stats, local_render_result_t *result, err_t *err);

#endif
