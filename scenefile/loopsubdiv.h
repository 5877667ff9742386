/* loopsubdiv: pbrt-v4's "loopsubdiv" shape as a triangle mesh. Loop's subdivision scheme
 * (Loop 1987; pbrt-v4 util/loopsubdiv.cpp, the 3rd edition's §4 online chapter), with
 * Loop's boundary rules, applied `levels` times, then every vertex moved to its limit
 * position and given the normal of its limit tangents, so the mesh has the vertices,
 * triangles and normals pbrt-v4 renders. The control mesh must be a manifold of consistently
 * oriented triangles in which every vertex is used (pbrt-v4 assumes so and crashes
 * otherwise); anything else is refused with the triangle or vertex at fault. */
#ifndef PRISMFARM_LOOPSUBDIV_H
#define PRISMFARM_LOOPSUBDIV_H

#include "err.h"
#include "mesh_import.h"

#include <stddef.h>
#include <stdint.h>

/* The most triangles a subdivision may make (4^levels times the control triangles). */
#define LOOPSUBDIV_TRIANGLES_MAX ((size_t)1 << 26)

/* Subdivides the control mesh (nv points P, 3 per point; nt triangles, 3 indices each, every
 * index < nv) `levels` times (0 only moves it to the limit surface) into out (malloc'ed;
 * release with mesh_data_free): positions, normals (not normalised), triangles. */
int loopsubdiv_mesh(const double *P, size_t nv, const uint32_t *indices, size_t nt, int levels,
                    mesh_data_t *out, err_t *err);

#endif
