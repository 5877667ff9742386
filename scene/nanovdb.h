/* nanovdb: float grids read from NanoVDB files (.nvdb: the layout of OpenVDB's
 * nanovdb/NanoVDB.h and nanovdb/util/IO.h, major version 32), as pbrt-v4's NanoVDBMedium reads
 * them: one grid found by name, its values trilinear between the voxels' integer index
 * coordinates, the background value outside the tree. Only the voxels a lookup inside the
 * grid's bounding box can reach are kept (a brick of margin around it): beyond, every value
 * reads as the background (pbrt-v4 never looks there), so a tree whose tiles span 4096^3
 * voxels costs no more than its bounds. The file may be uncompressed or use the
 * ZIP (zlib) or BLOSC codec (BLOSC only in builds with Debian's libblosc; refused by name
 * otherwise).
 *
 * Guarantees, for any bytes (the file may be a hostile upload): every offset and count is
 * checked against the bytes it points into before it is followed; each node of the tree is
 * reached at most once (a tree that shares or loops a node is refused), so the work is linear in
 * the grid's size; every value is finite; memory is charged to the caller's voxel budget before
 * it is allocated (the decompressed grid as its size / 4 voxels, then the brick table); errors
 * name the byte offset at fault. The grid is immutable once read: safe to read from many
 * threads. */
#ifndef PRISMFARM_NANOVDB_H
#define PRISMFARM_NANOVDB_H

#include "err.h"
#include "transform.h"
#include "vec3.h"

#include <stddef.h>
#include <stdint.h>

typedef struct nanovdb_grid nanovdb_grid_t;

/* The most a grid may decompress to (the file itself is bounded by PBRT_FILE_BYTES_MAX). */
#define NANOVDB_GRID_BYTES_MAX ((uint64_t)2 << 30)

/* Reads the first grid named `name` from the file's bytes. voxels_left: the budget left (0: no
 * bound); *voxels_charged is what this grid took of it. 0 with *out set when read; 0 with *out
 * NULL when the file holds no grid of that name; -1 with a message otherwise (a damaged file,
 * a grid that is not of floats, a codec this build cannot read, a grid over the budget: the
 * message names the budget as "voxels"). */
int nanovdb_read(const uint8_t *data, size_t len, const char *name, uint64_t voxels_left,
                 nanovdb_grid_t **out, uint64_t *voxels_charged, err_t *err);

void nanovdb_destroy(nanovdb_grid_t **self_p);

/* The grid's box in its medium space (NanoVDB's "world" bounding box, as pbrt-v4 uses it). */
void nanovdb_bounds(const nanovdb_grid_t *self, vec3_t *lo, vec3_t *hi);

/* Medium space to the grid's index space (the inverse of the file's index-to-world map). */
transform_t nanovdb_medium_to_index(const nanovdb_grid_t *self);

/* The value at medium-space point p: trilinear between the voxels (pbrt-v4's
 * SampleFromVoxels<1>, index coordinates of the voxels' integer points). */
double nanovdb_sample(const nanovdb_grid_t *self, vec3_t p);

/* The largest value of any voxel in the inclusive index box [lo, hi] (the background
 * included where the box reaches past the stored voxels); an upper bound, by whole 8^3 bricks. */
double nanovdb_max_in(const nanovdb_grid_t *self, const int64_t lo[3], const int64_t hi[3]);

/* The least value of the grid, the background included. */
double nanovdb_min(const nanovdb_grid_t *self);

/* The number of 8^3 leaves and of stored voxel values (for reports). */
size_t nanovdb_leaf_count(const nanovdb_grid_t *self);

#endif
