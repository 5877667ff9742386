/* geometry: the scene's surfaces in Embree, and ray queries against them.
 * Triangles go to Embree as they are; spheres and disks are analytic user geometries
 * intersected in double precision in their own object space, so any affine transform works
 * (an ellipsoid is a scaled sphere). Queries are thread-safe once committed. */
#ifndef PRISMFARM_GEOMETRY_H
#define PRISMFARM_GEOMETRY_H

#include "err.h"
#include "transform.h"
#include "vec3.h"

#include <stddef.h>
#include <stdint.h>

typedef struct geometry geometry_t;

typedef struct hit {
    double t;
    vec3_t p;         /* world-space hit point */
    vec3_t ng;        /* unit geometric normal in world space, outward per the shape's orientation */
    double u, v;      /* barycentrics (triangles) or surface parameters (sphere, disk) */
    uint32_t shape;   /* the caller's id given when the shape was added */
    uint32_t prim;    /* triangle index within its mesh; 0 for analytic shapes */
} hit_t;

/* nthreads is a hint for Embree's BVH build (0: all cores). */
geometry_t *geometry_new(int nthreads, err_t *err);
void geometry_destroy(geometry_t **self_p);

/* A triangle mesh in world space: positions xyz, 3 indices per triangle. flip reverses the
 * geometric normal (pbrt's ReverseOrientation / handedness swap). */
int geometry_add_mesh(geometry_t *self, const double *positions, size_t nverts,
                      const uint32_t *indices, size_t ntris, uint32_t shape, int flip, err_t *err);
/* A sphere of the given radius at the object-space origin; to_world must be affine and
 * invertible. */
int geometry_add_sphere(geometry_t *self, const transform_t *to_world, double radius, uint32_t shape,
                        int flip, err_t *err);
/* A disk of the given radius at object-space z = height with normal +z. */
int geometry_add_disk(geometry_t *self, const transform_t *to_world, double radius, double height,
                      uint32_t shape, int flip, err_t *err);

/* Builds the acceleration structure; no shape may be added afterwards. */
int geometry_commit(geometry_t *self, err_t *err);

/* Nearest hit along org + t*dir with t in (tmin, tmax); returns 1 on a hit, 0 on a miss. */
int geometry_intersect(const geometry_t *self, vec3_t org, vec3_t dir, double tmin, double tmax,
                       hit_t *out);
/* 1 when anything blocks org + t*dir for t in (tmin, tmax). */
int geometry_occluded(const geometry_t *self, vec3_t org, vec3_t dir, double tmin, double tmax);

/* Bounding box of everything added (valid after commit). */
void geometry_bounds(const geometry_t *self, vec3_t *lo, vec3_t *hi);

/* Offsets a ray origin off a surface along its normal, far enough for float32 Embree
 * intersection at the point's magnitude (scenes span 1e-3 to 1e5). */
vec3_t geometry_offset(vec3_t p, vec3_t ng, vec3_t dir);

#endif
