/* mesh_import: reads triangle meshes from PLY files (ascii, binary little- and big-endian;
 * plain or gzip-compressed) with its own reader, taking what pbrt-v4 takes (positions,
 * normals, texture coordinates, face index lists) and triangulating polygons (a quad v0 v1 v2
 * v3 becomes v0 v1 v2 and v0 v2 v3, keeping the winding). Every index is checked against the
 * vertex count and kept values must be finite; every count and list length must be backed by
 * bytes of the file before anything is allocated for it, so a small file cannot make it
 * allocate gigabytes or loop for minutes. A bad file's message names it and what is wrong
 * (a header line by its number, an ascii body line, a face, a truncation). */
#ifndef PRISMFARM_MESH_IMPORT_H
#define PRISMFARM_MESH_IMPORT_H

#include "err.h"

#include <stddef.h>
#include <stdint.h>

/* The largest PLY file read (and the most a .ply.gz may inflate to): 2 GiB is far beyond any
 * mesh that one render could hold. */
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

/* The same for a file in memory that may be gzip-compressed (inflated first, to at most
 * MESH_PLY_BYTES_MAX bytes). */
int mesh_import_ply_any(const void *data, size_t len, const char *name, mesh_data_t *out,
                        err_t *err);

/* What the header of a PLY in memory declares (data may be gzip-compressed: then only the
 * header's bytes are inflated): its vertices, its faces, and the fewest bytes its body can hold
 * (each element's count times the least an instance takes, as mesh_import_ply_memory checks
 * it: every property and list length, a separator after each in ascii; saturating), so that a
 * caller charges them to its budget (budget.h) before the file is inflated or decoded. Fails
 * with the file's name when the header is malformed or lacks what mesh_import_ply_memory
 * needs. */
typedef struct mesh_ply_counts {
    uint64_t vertices, faces, body_bytes;
} mesh_ply_counts_t;
int mesh_import_ply_counts(const void *data, size_t len, const char *name, mesh_ply_counts_t *out,
                           err_t *err);

void mesh_data_free(mesh_data_t *mesh);

#endif
