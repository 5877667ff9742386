/* render: the camera-pass kernel. Renders one tile -- a pixel rectangle times a range of sample
 * indices -- of a finished scene into a spectral tile buffer, with the integrator and the
 * dispersion strategy of scene->settings. It knows nothing of threads or sockets: every random
 * number depends only on (seed, pixel, sample index, dimension), so a tile renders to the same
 * bytes whoever renders it, and sample ranges can be split and merged freely. */
#ifndef PRISMFARM_RENDER_H
#define PRISMFARM_RENDER_H

#include "err.h"
#include "photon_store.h"
#include "scene.h"
#include "tilebuf.h"

#include <stdint.h>

typedef struct render_stats {
    uint64_t samples;    /* pixel samples taken */
    uint64_t rays;       /* intersection and shadow rays traced */
    uint64_t nonfinite;  /* samples dropped because a contribution was NaN or Inf */
    uint64_t dispersive; /* dispersive events (fan-outs or hero terminations) */
} render_stats_t;

/* Renders pixels [x0, x0+w) x [y0, y0+h) for sample indices [sample_begin, sample_end) into
 * out, which must cover that rectangle and have scene->settings.grid.n buckets. photons is the
 * finished caustic store of the scene's photon pass (photon_pass.h: photon_pass_run on this machine,
 * or the farm's merged store), required when settings.photon.enabled and ignored otherwise.
 * Adds to *stats (which may be NULL). */
int render_tile(const scene_t *scene, const photon_store_t *photons, int x0, int y0, int w, int h,
                uint32_t sample_begin, uint32_t sample_end, tilebuf_t *out, render_stats_t *stats,
                err_t *err);

/* The most lanes a path can carry: fan-out needs one per bucket. */
#define RENDER_MAX_BUCKETS 64

#endif
