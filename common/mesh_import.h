/* mesh_import: reads triangle meshes from PLY files (ascii and binary) through assimp,
 * triangulating polygons (a quad v0 v1 v2 v3 becomes v0 v1 v2 and v0 v2 v3, keeping the
 * winding) and keeping shared vertices, normals and texture coordinates as the file has them.
 * Every index is checked against the vertex count; positions must be finite. */
#ifndef PRISMFARM_MESH_IMPORT_H
#define PRISMFARM_MESH_IMPORT_H

#include "err.h"

#include <stddef.h>
#include <stdint.h>

typedef struct mesh_data {
    size_t nvertices;
    double *P;  /* 3 per vertex */
    double *N;  /* 3 per vertex, or NULL when the file has no normals */
    double *uv; /* 2 per vertex, or NULL when the file has no texture coordinates */
    size_t ntriangles;
    uint32_t *indices; /* 3 per triangle */
} mesh_data_t;

/* Loads path into out (malloc'ed arrays; release with mesh_data_free). Fails with the path
 * and the reason when the file is missing, is not PLY, has no faces, or is malformed. */
int mesh_import_ply(const char *path, mesh_data_t *out, err_t *err);
void mesh_data_free(mesh_data_t *mesh);

#endif
