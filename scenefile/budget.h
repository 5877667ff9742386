/* budget: how much one scene may make the master build, and for how long (issue 16, item 4: a
 * 20 MB bundle of Shape "sphere" lines took the master to 2.2 GB; a 32768x32768 one-bucket
 * film reserved 33.9 GB; issue 26, finding 2: a 1.17 MB .ply.gz claiming 10^8 vertices cost
 * 9.8 GB, 400 Includes of one 4 MB file held the loader 145 s). Every figure is charged where
 * it is declared, before the thing it counts is allocated or decoded: shapes and object
 * instances as the parser reads them, a PLY's vertices and faces from its header (of a .ply.gz,
 * only the header is inflated first), scene text as each file is read (an Include of the same
 * file 400 times is charged 400 times), texels from an image's header, the merged image's
 * bytes from the film before any geometry loads, triangles as meshes are made. A refusal names
 * the file, the figure and the master's option that sets it. 0 in a field means no bound.
 * Configurable on the master (docs/security.md, "Budgets", gives the memory each bounds). */
#ifndef PRISMFARM_BUDGET_H
#define PRISMFARM_BUDGET_H

#include "err.h"
#include "mesh_import.h"

#include <stddef.h>
#include <stdint.h>

typedef struct scene_budget {
    uint64_t shapes;      /* Shape directives and ObjectInstances (--max-shapes) */
    uint64_t triangles;   /* mesh triangles, bilinear patches and PLY faces after
                           * subdivision and tessellation (--max-triangles) */
    uint64_t texels;      /* image texture and environment map pixels (--max-texels) */
    uint64_t image_bytes; /* the merged image: xres * yres * (buckets + 4) * 8 bytes
                           * (--max-image-mb) */
    uint64_t vertices;    /* PLY vertices, all files together (--max-vertices) */
    uint64_t text_bytes;  /* scene text read, main file and every Include/Import each
                           * time it is read, after inflating (--max-text-mb) */
    uint64_t ply_bytes;   /* the bytes PLY headers declare their bodies to hold: vertex
                           * properties, faces (--max-ply-mb) */
    double load_seconds;  /* the longest a load may take (--max-load-seconds) */
    double deadline;      /* clock_now_s() time the load must end by, set by
                           * scene_budget_start; 0: none */
} scene_budget_t;

/* What one load has charged so far (the parser's, a plain value). */
typedef struct scene_budget_use {
    uint64_t vertices, text_bytes, ply_bytes;
} scene_budget_use_t;

/* 1 000 000 shapes, 100 000 000 triangles, 268 435 456 texels (a 16384² map), 4 GiB of
 * merged image, 33 554 432 PLY vertices, 256 MiB of scene text, 1 GiB of PLY bodies, 60 s of
 * parse: room for every corpus scene. No deadline until scene_budget_start. */
scene_budget_t scene_budget_default(void);

/* The merged image's bytes for a film (saturating). */
uint64_t scene_budget_image_bytes(uint64_t xres, uint64_t yres, uint64_t buckets);

/* Starts the load clock: the deadline is now + load_seconds (none when load_seconds is 0). */
void scene_budget_start(scene_budget_t *b, double now);

/* -1 with a message naming the budget when the load has passed its deadline (b NULL: never). */
int scene_budget_check_time(const scene_budget_t *b, err_t *err);

/* Charges text of the file `name` (bytes, as parsed: inflated) to the text budget, and checks
 * the deadline. -1 with a message naming the file and the option. */
int scene_budget_charge_text(const scene_budget_t *b, scene_budget_use_t *u, uint64_t bytes,
                             const char *name, err_t *err);

/* The most a file may inflate to that the text budget still allows (at most limit), so that
 * a .pbrt.gz over it is refused while it is counted, before it is inflated. */
uint64_t scene_budget_text_left(const scene_budget_t *b, const scene_budget_use_t *u,
                                uint64_t limit);

/* Charges the vertices and body bytes a PLY's header declares (mesh_import.h), and refuses a
 * file declaring more faces than the whole triangle budget (each face makes at least one
 * triangle), before any of it is inflated or decoded; checks the deadline. -1 with a message
 * naming the file and the option. */
int scene_budget_charge_ply(const scene_budget_t *b, scene_budget_use_t *u,
                            const mesh_ply_counts_t *c, const char *name, err_t *err);

/* The same for a PLY file in memory (data[0..len), gzip'ed or not): its header read with
 * mesh_import_ply_counts, nothing else of it inflated (b NULL: nothing read, 0). */
int scene_budget_charge_ply_file(const scene_budget_t *b, scene_budget_use_t *u, const void *data,
                                 size_t len, const char *name, err_t *err);

#endif
