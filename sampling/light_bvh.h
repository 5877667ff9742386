/* light_bvh: choosing one of many bounded emitters as seen from a shading point, in proportion
 * to an importance that bounds what each group of emitters can send there (Conty Estevez &
 * Kulla 2018, "Importance Sampling of Many Lights with Adaptive Tree Splitting"; pbrt-v4's
 * BVHLightSampler, PBR 4th ed. §12.6.3). Each emitter is described by its light_bounds_t; a
 * binary tree over them is built once in O(n log n), and a draw walks it from the root,
 * choosing a child in proportion to the two children's importances, in O(depth) = O(log n) for
 * any reasonable scene (the depth never exceeds LIGHT_BVH_MAX_DEPTH). light_bvh_pmf walks the
 * same path to the emitter and multiplies the same ratios in the same order, so it returns
 * bit for bit the pmf that light_bvh_sample reported. An emitter's importance is 0 only where
 * its bounds prove it sends nothing (outside its emission cone, behind a one-sided emitter),
 * so the choice stays unbiased. Immutable once built: safe to share between threads. */
#ifndef PRISMFARM_LIGHT_BVH_H
#define PRISMFARM_LIGHT_BVH_H

#include "err.h"
#include "vec3.h"

#include <stddef.h>

/* Deepest leaf the build makes (the bit trail to a leaf fits a 64-bit word). */
#define LIGHT_BVH_MAX_DEPTH 60

/* What an emitter (or a group of them) can send, pbrt-v4's LightBounds: its points lie in the
 * box [lo, hi]; the normals of its emitting points lie within the cone of half-angle theta_o
 * about the unit axis w (cos_o = cos theta_o; -1: any direction); each point emits only
 * within theta_e of its normal (cos_e = cos theta_e: 0 for a cosine emitter, theta_e = pi/2);
 * twosided: each point emits about -normal as well. phi is its power (any unit common to all
 * emitters, >= 0; 0: never chosen). */
typedef struct light_bounds {
    vec3_t lo, hi;
    vec3_t w;
    double phi;
    double cos_o, cos_e;
    int twosided;
} light_bounds_t;

/* The importance of b at point p with unit normal n (the zero vector: a point in a medium,
 * which receives from every direction): phi cos(theta') / d^2 times, at a surface,
 * cos(theta_i'), where d is the distance from p to the box's centre (at least half its
 * diagonal), theta' the smallest angle any emitter in the box can make between its normal and
 * the direction to p (0 when that is inside the normal cone widened by the angle the box
 * subtends), and theta_i' likewise the smallest angle between n (either side) and a direction
 * into the box. 0 when theta' exceeds theta_e: no emitter in b can reach p. */
double light_bounds_importance(const light_bounds_t *b, vec3_t p, vec3_t n);

/* The bounds of two groups together: the union of the boxes, the smallest cone of pbrt-v4's
 * DirectionCone Union that holds both normal cones, the smaller cos_e, the summed power. A
 * group of zero power is left out. */
light_bounds_t light_bounds_union(const light_bounds_t *a, const light_bounds_t *b);

typedef struct light_bvh light_bvh_t;

/* Builds the tree over emitters items[0..n-1] (copied; the caller keeps its array). Emitters
 * of zero (or NaN) power are left out: never drawn, pmf 0. n = 0 or all left out gives an
 * empty tree (light_bvh_empty). NULL with err filled on n above 2^31 or no memory. */
light_bvh_t *light_bvh_new(const light_bounds_t *items, size_t n, err_t *err);
void light_bvh_destroy(light_bvh_t **self_p);

/* No emitter can be drawn. */
int light_bvh_empty(const light_bvh_t *self);

/* Draws an emitter for point p with normal n (as light_bounds_importance) with one uniform u in
 * [0, 1): 1 with its index in *item and its probability in *pmf, 0 when every emitter's
 * importance at p is 0 (or the tree is empty). */
int light_bvh_sample(const light_bvh_t *self, vec3_t p, vec3_t n, double u, size_t *item,
                     double *pmf);

/* The probability that light_bvh_sample draws item at (p, n): exactly the pmf it reports when
 * it does, 0 when it never can. */
double light_bvh_pmf(const light_bvh_t *self, size_t item, vec3_t p, vec3_t n);

/* The tree's depth (0: a single leaf or empty), for tests and benchmarks. */
int light_bvh_depth(const light_bvh_t *self);

#endif
