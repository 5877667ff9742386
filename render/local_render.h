/* local_render: renders a whole image on this machine's cores -- the engine behind
 * `prismfarm render --direct`. The image is cut into tiles handed to threads from a shared
 * counter; each tile is rendered pass by pass (film/passes.h), each pass's sums rounded by
 * tilebuf_round_sums and added in pass order, which is the farm's arithmetic: the image is
 * bit-identical to the farm's (any worker count, thread count or tile size), by construction. */
#ifndef PRISMFARM_LOCAL_RENDER_H
#define PRISMFARM_LOCAL_RENDER_H

#include "render.h"

/* Called from one thread at a time, after each finished tile. */
typedef void (*local_render_progress_fn)(void *user, uint64_t samples_done, uint64_t samples_total,
                                         double elapsed_s);

typedef struct local_render_opts {
    int threads;   /* 0: all cores */
    int tile_size; /* 0: 32 */
    local_render_progress_fn progress;
    void *user;
} local_render_opts_t;

/* Renders samples [0, scene->settings.spp) of every pixel into image, which must cover the
 * whole image with the film's bucket count. */
int local_render(const scene_t *scene, const local_render_opts_t *opts, tilebuf_t *image,
                 render_stats_t *stats, err_t *err);

/* Cores available to this process. */
int local_render_cores(void);

#endif
