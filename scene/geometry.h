/* geometry: the scene's surfaces in Embree, and ray queries against them.
 * Triangles go to Embree as they are; spheres and disks are analytic user geometries
 * intersected in double precision in their own object space, so any affine transform works
 * (an ellipsoid is a scaled sphere). Objects hold shapes once, in their own space, and
 * instances place them as Embree instances, so a thousand instances cost one copy of the
 * shapes. Every hit comes back in world space. Queries are thread-safe once committed. */
#ifndef PRISMFARM_GEOMETRY_H
#define PRISMFARM_GEOMETRY_H

#include "err.h"
#include "transform.h"
#include "vec3.h"

#include <stddef.h>
#include <stdint.h>

typedef struct geometry geometry_t;

/* hit.instance of a shape that is not instanced. */
#define GEOMETRY_NO_INSTANCE UINT32_MAX
/* The object argument that means "the world" rather than an instanced object. */
#define GEOMETRY_WORLD (-1)

typedef struct hit {
    double t;
    vec3_t p;          /* world-space hit point */
    vec3_t ng;         /* unit geometric normal in world space, outward per the shape's orientation */
    double u, v;       /* barycentrics (triangles: p = (1-u-v) p0 + u p1 + v p2) or the surface
                        * parameters (u, v) of pbrt-v4's sphere and disk */
    uint32_t shape;    /* the caller's id given when the shape was added */
    uint32_t prim;     /* triangle index within its mesh; 0 for analytic shapes */
    uint32_t instance; /* the caller's id of the instance hit, or GEOMETRY_NO_INSTANCE */
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

/* Curves: nseg cubic Bezier segments, 4 control points each (cp: 12 numbers per segment) with
 * the radius at each control point (radii: 4 per segment; equal steps make the radius linear
 * in u), intersected by Embree as flat ribbons that face the ray (pbrt-v4's "flat" curve).
 * A hit reports u along its segment (prim), v = (h + 1) / 2 where h in [-1, 1] is the offset
 * from the centre line across the ribbon in units of the radius, positive along
 * dir x dp/du (pbrt-v4's v), and ng facing the ray (perpendicular to the curve). A ray
 * never hits a curve closer than 2.5 radii to its origin: a ray leaving a fibre would
 * otherwise find the ribbon that faces it through its own origin (pbrt-v4 moves such a
 * ray's origin off by the width for the same reason).
 * With normals (6 per segment: unit normals at its two ends), a segment is pbrt-v4's "ribbon"
 * instead: a flat strip across n x dp/du, n turning along the great arc from the first normal
 * to the second (Embree's normal-oriented curve), seen narrowed by |n . dir| from aside; its
 * hit's ng is the slerped normal made perpendicular to the curve (flipped when flip is set),
 * h as pbrt-v4 computes it, over the narrowed width.
 * Embree intersects each segment as straight pieces, as many as bring them within a tenth of
 * the radius of the curve (pbrt-v4's refinement tolerance); a segment that wants more than
 * Embree 3's 16 goes to it as up to 16 sub-segments at equal steps of u (the same curve,
 * radii and slerped normals), whose hits still report the segment and u along it. */
int geometry_object_add_curves(geometry_t *self, int object, const double *cp, const double *radii,
                               const double *normals, size_t nseg, uint32_t shape, int flip,
                               err_t *err);
/* A cubic Bezier segment (4 control points, 12 numbers) at u: its point and derivative. */
void geometry_bezier(const double *cp, double u, vec3_t *p, vec3_t *dpdu);

/* A new, empty object (its own Embree scene); returns its id (>= 0) or -1. */
int geometry_object_new(geometry_t *self, err_t *err);
/* The same shapes added to an object (or to the world with GEOMETRY_WORLD), in the object's
 * space. An object accepts shapes until its first instance is added. */
int geometry_object_add_mesh(geometry_t *self, int object, const double *positions, size_t nverts,
                             const uint32_t *indices, size_t ntris, uint32_t shape, int flip,
                             err_t *err);
int geometry_object_add_sphere(geometry_t *self, int object, const transform_t *to_world,
                               double radius, uint32_t shape, int flip, err_t *err);
int geometry_object_add_disk(geometry_t *self, int object, const transform_t *to_world,
                             double radius, double height, uint32_t shape, int flip, err_t *err);
/* Places a non-empty object in the world with to_world (affine, invertible, finite); the object
 * is committed here, before its instance. Hits on it report `instance`. Normals follow what
 * the flattened placement (every shape's transform composed with to_world) would give:
 * triangles keep their orientation, spheres and disks flip under a to_world that swaps
 * handedness, as pbrt-v4 flips a quadric whose own transform swaps it (shapes.h). */
int geometry_add_instance(geometry_t *self, int object, const transform_t *to_world,
                          uint32_t instance, err_t *err);

/* Builds the acceleration structure; no shape or instance may be added afterwards. */
int geometry_commit(geometry_t *self, err_t *err);

/* Nearest hit along org + t*dir with t in (tmin, tmax); returns 1 on a hit, 0 on a miss.
 * A triangle counts only if org lies strictly on one side of its plane and dir points to the
 * other (decided in double, so a ray leaving a triangle never hits it again whatever the
 * triangle's size or distance); the hit point is rebuilt from barycentrics in double. */
int geometry_intersect(const geometry_t *self, vec3_t org, vec3_t dir, double tmin, double tmax,
                       hit_t *out);
/* 1 when anything blocks org + t*dir for t in (tmin, tmax). */
int geometry_occluded(const geometry_t *self, vec3_t org, vec3_t dir, double tmin, double tmax);

/* One query as Embree receives it: the float ray geometry_intersect or geometry_occluded
 * builds from its arguments. */
typedef struct geometry_query {
    float org[3], tnear, dir[3], tfar;
    int occluded; /* 1: geometry_occluded, 0: geometry_intersect */
} geometry_query_t;
typedef void (*geometry_query_fn)(void *user, const geometry_query_t *q);

/* For benchmarks that replay a render's rays on Embree alone (bench/throughput.c): from now
 * on fn(user, query) is called before every query, from the querying thread; NULL (the
 * default) turns it off, leaving one pointer test per query. Set it only while no query is
 * in flight. */
void geometry_set_query_hook(geometry_t *self, geometry_query_fn fn, void *user);
/* The world's Embree scene (an RTCScene) once committed, NULL before. */
struct RTCSceneTy *geometry_embree_scene(const geometry_t *self);

/* Bounding box of everything in the world, instances included (valid after commit). */
void geometry_bounds(const geometry_t *self, vec3_t *lo, vec3_t *hi);

/* Bytes Embree holds for this geometry right now (buffers, BVHs, instances), as its memory
 * monitor callback reports them. */
size_t geometry_memory_bytes(const geometry_t *self);

/* Offsets a ray origin off a surface along its normal, to dir's side, by 4e-6 of the point's
 * largest coordinate (34 float ulps: Embree traces in float32). Purely relative, so a scene
 * scaled by 1e-3 or 1e5 takes the same paths. Hit points are exact to double rounding and
 * triangle hits are checked in double against the side a ray starts on, so no more is needed
 * (tests/unit/test_numeric_hard.c). */
vec3_t geometry_offset(vec3_t p, vec3_t ng, vec3_t dir);

#endif
