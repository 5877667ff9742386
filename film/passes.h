/* passes: the cut of a pixel's samples into progressive passes, 0, 1, 2, 4, 8, ... spp -- one
 * cut for the farm's scheduler (master/sched.c) and for `prismfarm render --direct`
 * (render/local_render.c), so that both sum the same per-pass tile sums in the same order and
 * their images agree bit for bit (docs/farm.md, "Same pixels"). */
#ifndef PRISMFARM_PASSES_H
#define PRISMFARM_PASSES_H

#include <stdint.h>

/* Bounds enough for any int spp: at most 1 + ceil(log2 spp) <= 32 passes, plus one. */
#define PASSES_MAX_BOUNDS 33

/* Writes bounds 0, 1, 2, 4, 8, ... spp into bounds[0..n] (when bounds is not NULL) and returns n,
 * the number of passes: pass p covers sample indices [bounds[p], bounds[p+1]). 0 for spp < 1. */
int passes_bounds(int spp, uint32_t *bounds);

/* Pass pass's sample range [*begin, *end) of the same cut; an empty range at spp past the
 * last pass. */
void passes_range(int spp, uint64_t pass, uint32_t *begin, uint32_t *end);

#endif
