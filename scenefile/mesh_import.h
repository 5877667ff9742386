/* mesh_import: reads triangle meshes from PLY files (ascii and binary) through assimp,
 * triangulating polygons (a quad v0 v1 v2 v3 becomes v0 v1 v2 and v0 v2 v3, keeping the
 * winding) and keeping shared vertices, normals and texture coordinates as the file has them.
 * Every index is checked against the vertex count; positions must be finite. Before assimp
 * sees a file, its header and body are checked against each other: assimp allocates an
 * element's storage from the header's count and a list's from its length field, so every count
 * and length must be backed by bytes of the file, and a small file cannot make it allocate
 * gigabytes or loop for minutes. */
#ifndef PRISMFARM_MESH_IMPORT_H
#define PRISMFARM_MESH_IMPORT_H

#include "err.h"

#include <stddef.h>
#include <stdint.h>

/* The largest PLY file read: assimp takes a buffer's length as an unsigned int, and 2 GiB is
 * far beyond any mesh that one render could hold. */
#define MESH_PLY_BYTES_MAX ((size_t)2 << 30)

/* The longest PLY header accepted (a header is a few hundred bytes; a Gaussian-splat file's,
 * with 60-odd properties, about 2 KiB). */
#define MESH_PLY_HEADER_BYTES_MAX ((size_t)64 << 10)

typedef struct mesh_data {
    size_t nvertices;
    double *P;  /* 3 per vertex */
    double *N;  /* 3 per vertex, or NULL when the file has no normals */
    double *uv; /* 2 per vertex, or NULL when the file has no texture coordinates */
    size_t ntriangles;
    uint32_t *indices; /* 3 per triangle */
} mesh_data_t;

/* Loads path into out (malloc'ed arrays; release with mesh_data_free). Fails with the path
 * and the reason when the file is missing, is not PLY, has no faces, is malformed, or its
 * counts are not backed by its bytes. */
int mesh_import_ply(const char *path, mesh_data_t *out, err_t *err);

/* The same for a PLY file already in memory (data[0..len), which the caller keeps); name is
 * the file's name in messages. The parser uses it for files it opened itself. */
int mesh_import_ply_memory(const void *data, size_t len, const char *name, mesh_data_t *out,
                           err_t *err);

void mesh_data_free(mesh_data_t *mesh);

#endif
