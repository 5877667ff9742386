#include "medium_file.h"

#include "files.h"
#include "nanovdb.h"
#include "pbrt_limits.h"

#include <stdlib.h>

/* What nanovdb_read may take (0 there means no bound: a spent budget leaves 1). */
static uint64_t left(uint64_t budget, uint64_t used)
{
    if (!budget)
        return 0;
    return budget > used ? budget - used : 1;
}

medium_t *medium_file_load_nanovdb(const scene_medium_t *dm, const medium_params_t *p,
                                   uint64_t voxel_budget, uint64_t *voxels_used, err_t *err)
{
    uint8_t *bytes;
    size_t len;
    if (files_read(dm->filename, PBRT_FILE_BYTES_MAX, &bytes, &len, err) != 0)
        return NULL;
    nanovdb_grid_t *density = NULL, *temperature = NULL;
    uint64_t took = 0;
    int rc = 0;
    if (nanovdb_read(bytes, len, dm->gridname, left(voxel_budget, *voxels_used), &density, &took,
                     err) != 0)
        rc = -1;
    *voxels_used += took;
    if (rc == 0 && !density)
        rc =
            err_set(err, "the file holds no grid named \"%s\" (\"string gridname\")", dm->gridname);
    took = 0;
    if (rc == 0 && nanovdb_read(bytes, len, dm->temperaturename, left(voxel_budget, *voxels_used),
                                &temperature, &took, err) != 0)
        rc = -1;
    *voxels_used += took;
    free(bytes);
    if (rc) {
        nanovdb_destroy(&density);
        err_prefix(err, "\"%s\": ", dm->filename);
        return NULL;
    }
    medium_t *m = medium_new_nanovdb(p, &density, &temperature, dm->temperature_offset,
                                     dm->temperature_scale, &dm->to_world, err);
    if (!m)
        err_prefix(err, "\"%s\": ", dm->filename);
    return m;
}
