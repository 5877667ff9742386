/* shape_tess: pbrt-v4's curved quadrics and bilinear patches as triangle meshes, fine enough
 * that the difference does not show: "cylinder", a "sphere" cut by zmin/zmax/phimax, and
 * "bilinearmesh" patches (a planar patch is exactly two triangles; a twisted one, which
 * pbrt-v4's BilinearPatch renders curved, a grid whose size follows its twist). Each mesh
 * carries the exact surface normal at its vertices and pbrt-v4's (u, v), and its triangles
 * face the way pbrt-v4's normal does (outwards for the quadrics, cross(dp/du, dp/dv) for a
 * patch). */
#ifndef PRISMFARM_SHAPE_TESS_H
#define PRISMFARM_SHAPE_TESS_H

#include "err.h"
#include "mesh_import.h"

#include <stddef.h>
#include <stdint.h>

/* Segments around a full turn: the polygon's area is sin(2 pi / n) n / (2 pi) of the circle's,
 * 1 - 2.5e-5 at 512, and its silhouette lies within 1.9e-5 radii of the circle. */
#define SHAPE_TESS_TURN_SEGMENTS 512

/* pbrt-v4 Cylinder: radius r about the z axis from zmin to zmax, phi from 0 to phimax
 * (degrees, in (0, 360]); u = phi / phimax, v = (z - zmin) / (zmax - zmin). */
int shape_tess_cylinder(double r, double zmin, double zmax, double phimax_deg, mesh_data_t *out,
                        err_t *err);

/* pbrt-v4 Sphere: radius r, cut to zmin <= z <= zmax (clamped to [-r, r]) and phi in [0,
 * phimax]; u = phi / phimax, v = (theta - theta(zmin)) / (theta(zmax) - theta(zmin)). */
int shape_tess_sphere(double r, double zmin, double zmax, double phimax_deg, mesh_data_t *out,
                      err_t *err);

/* pbrt-v4 BilinearPatchMesh: patch i has corners P[idx[4i..4i+3]] = p00 p10 p01 p11 and
 * p(u, v) = (1-u)(1-v) p00 + u(1-v) p10 + (1-u) v p01 + u v p11. uv (2 per point) and N (3
 * per point) are interpolated the same way when given; without uv a patch's (u, v) are its
 * own. Every patch gets its own vertices (patches that share a corner may disagree on its uv). */
int shape_tess_bilinear(const double *P, size_t nv, const uint32_t *idx, size_t npatches,
                        const double *uv, const double *N, mesh_data_t *out, err_t *err);

#endif
