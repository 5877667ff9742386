/* medium_file: a "nanovdb" medium made from its file (pbrt-v4 NanoVDBMedium::Create): the
 * file read whole (at most PBRT_FILE_BYTES_MAX bytes), its density grid (required) and
 * temperature grid (optional) decoded by nanovdb.h within the voxel budget, the medium built.
 * Errors name the file, the grid and the byte at fault; the caller prefixes file:line. */
#ifndef PRISMFARM_MEDIUM_FILE_H
#define PRISMFARM_MEDIUM_FILE_H

#include "medium.h"
#include "scene_desc.h"

#include <stdint.h>

/* p: the coefficients (borrowed as medium_new_* borrows them). voxel_budget: the voxels the
 * scene may still hold (0: no bound); *voxels_used grows by what the grids took. */
medium_t *medium_file_load_nanovdb(const scene_medium_t *dm, const medium_params_t *p,
                                   uint64_t voxel_budget, uint64_t *voxels_used, err_t *err);

#endif
