/* budget: how much one scene may make the master build (issue 16, item 4: a 20 MB bundle of
 * Shape "sphere" lines took the master to 2.2 GB; a 32768x32768 one-bucket film reserved
 * 33.9 GB). Each figure is checked where it is counted, before the thing it counts is built
 * where that can be known: shapes and object instances as the parser reads them, triangles as
 * meshes are read (a loopsubdiv's before it is subdivided), texels from an image's header
 * before it is decoded, the merged image's bytes from the film before any geometry loads.
 * A refusal names the file, the line and the master's option that sets the figure. 0 in a
 * field means no bound. Configurable on the master (docs/security.md, "Budgets"). */
#ifndef PRISMFARM_BUDGET_H
#define PRISMFARM_BUDGET_H

#include <stdint.h>

typedef struct scene_budget {
    uint64_t shapes;            /* Shape directives and ObjectInstances (--max-shapes) */
    uint64_t triangles;         /* mesh triangles, bilinear patches and PLY faces after
                                 * subdivision and tessellation (--max-triangles) */
    uint64_t texels;            /* image texture and environment map pixels (--max-texels) */
    uint64_t image_bytes;       /* the merged image: xres * yres * (buckets + 4) * 8 bytes
                                 * (--max-image-mb) */
} scene_budget_t;

/* 1 000 000 shapes, 100 000 000 triangles, 268 435 456 texels (a 16384² map), 4 GiB of
 * merged image: a few gigabytes at most for the master, room for every corpus scene. */
scene_budget_t scene_budget_default(void);

/* The merged image's bytes for a film (saturating). */
uint64_t scene_budget_image_bytes(uint64_t xres, uint64_t yres, uint64_t buckets);

#endif
