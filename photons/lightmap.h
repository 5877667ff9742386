/* lightmap: the light-map store of the photon integrator (thesis 5.5 and 6.3; docs/physics.md
 * §5.1): per-surface texel grids of a given density (texels per unit area) on every
 * triangle, sphere and disk of a scene, each texel holding the raw spectral power that photons
 * deposited on it, per framebuffer bucket. Storage is sparse (only 4x4-texel tiles, and within
 * them only the buckets, that received power are allocated). Each texel's sum is a binned
 * fixed-point sum (lightmap.c): exact down to 2^-72 of its largest deposit, and a function of the
 * deposits alone -- not of their order, nor of how they were split between maps before merging --
 * so a merged map, its wire form and every irradiance read from it are the same bytes whatever
 * the batches and threads. Read-only use (irradiance, encode) is safe from many threads.
 *
 * Texels. Every surface has its own equal-area parameterisation, so that every texel of a
 * surface has the same area (uniform texel power means uniform irradiance):
 * - a triangle (mesh prim; quads and bilinear patches are triangles here; UVs are not used) is
 *   cut into m*m equal sub-triangles in barycentric space, m = max(1, ceil(sqrt(A d))), A its
 *   world-space area and d the density; every texel has area A / m^2, exactly for any affine
 *   instance transform;
 * - a disk maps to an n*n grid through the inverse of Shirley and Chiu's concentric map (1997),
 *   which preserves area, n = max(1, ceil(sqrt(A d)));
 * - a sphere is an nphi*nz grid in (phi, z) on the object-space sphere (Archimedes: equal steps
 *   of z cut equal areas), nz = round(sqrt(T / pi)), nphi = ceil(T / nz), T = ceil(A d), so
 *   texels are square at the equator.
 * Areas are world-space areas. A disk is planar, so its texels' world area is exact under any
 * affine map. A sphere under a non-uniform scale (an ellipsoid) is not equal-area in world space:
 * each texel's area is its object-space area times the map's area factor at the texel centre
 * (Nanson's formula, |det L| |L^-T n|), the midpoint rule, exact for similarity transforms, and
 * T uses A = 4 pi r^2 |det L|^(2/3). Grids are capped at LIGHTMAP_MAX_SIDE texels a side.
 * Texels are keyed by (instance, shape, prim, side): the same object placed twice has texels of
 * its own per placement, and a surface's two sides (the side a photon arrives on, against the
 * hit's geometric normal) are separate, so light behind a thin screen does not show in front.
 *
 * Irradiance (the thesis's light-map lookup): E_b = P_b / (N_emitted * A_texel * width_b), W m^-2
 * nm^-1 averaged over bucket b, where P_b is the texel's raw power (W/nm, photon.h).
 *
 * Size: 33 bytes per texel and bucket with power (in chunks of 16 texels of one bucket) plus
 * 160 bytes per 4x4 tile at 16 buckets. Measured (tests/unit/test_lightmap.c): a dispersed caustic of
 * 1e6 photons on a 10x10 screen at 1600 texels per unit area (160178 texels) touches 7216 texels
 * and holds 1.05 MB (about 1 byte per photon); it encodes to 0.16 MB, against 20.5 MB for the
 * screen's texels as dense doubles. */
#ifndef PRISMFARM_LIGHTMAP_H
#define PRISMFARM_LIGHTMAP_H

#include "err.h"
#include "geometry.h"
#include "scene.h"
#include "spectral_grid.h"
#include "vec3.h"

#include <stddef.h>
#include <stdint.h>

typedef struct lightmap lightmap_t;

/* Texels a grid may have along a side (so a surface has at most 2^48 texels). */
#define LIGHTMAP_MAX_SIDE (1u << 24)
/* Texel density allowed, texels per unit area. */
#define LIGHTMAP_MAX_DENSITY 1e9

/* A texel: the surface (instance or GEOMETRY_NO_INSTANCE, shape, triangle or 0, side 0 on the
 * geometric normal's side or 1 behind it) and its index in that surface's grid. */
typedef struct lightmap_texel {
    uint32_t instance, shape, prim;
    int side;
    uint64_t index;
} lightmap_texel_t;

/* An empty map of `density` texels per unit area (finite, in (0, LIGHTMAP_MAX_DENSITY]) for the
 * framebuffer's grid. The scene must be finished and outlive the map. */
lightmap_t *lightmap_new(const scene_t *scene, double density, spectral_grid_t grid, err_t *err);
void lightmap_destroy(lightmap_t **self_p);

/* A photon of raw spectral power `power` (W/nm, like photon_map_deposit) at wavelength lambda
 * landed at `hit` (from geometry_intersect on the map's scene), arriving on the side of the
 * normal n (any vector on that side of hit->ng). A lambda outside the grid, or a power of 0,
 * deposits nothing and returns 0. A non-finite lambda, a power that is not finite, negative
 * or above FLT_MAX, a hit that names no surface of the scene, more than 2^40 deposits in one
 * texel, or running out of memory returns -1. */
int lightmap_deposit(lightmap_t *self, const hit_t *hit, vec3_t n, double lambda, double power,
                     err_t *err);

/* Photons emitted into the map: the N of every irradiance. */
void lightmap_add_emitted(lightmap_t *self, uint64_t n);
uint64_t lightmap_emitted(const lightmap_t *self);

/* Adds src's texels and emitted count into dst (same scene, density and grid; src != dst).
 * Sums are exact per texel, so merging is associative and commutative: merge(a, b) is bit for
 * bit the map that took a's and b's deposits itself, in any order. On failure (memory, or a
 * texel past 2^40 deposits) dst holds part of src: discard it. */
int lightmap_merge(lightmap_t *dst, const lightmap_t *src, err_t *err);

/* The wire form (malloc'ed into *out): only texels with power, in key order, deflated with
 * zlib; the same map gives the same bytes whatever order its deposits came in. Format (all
 * little endian):
 *   "PFLM", u32 version (LIGHTMAP_WIRE_VERSION), u64 raw length L, then a zlib stream of L bytes:
 *   u32 buckets, u32 0, f64 lambda_min, f64 lambda_max, f64 density, u64 emitted, u64 surfaces;
 *   per surface, in increasing (instance, shape, prim, side): u32 instance, u32 shape, u32 prim,
 *     u32 side, u64 tiles;
 *   per tile, in increasing index: u64 tile index (tiles of 4x4 texels, row-major over the
 *     grid's tile columns), then a bucket mask (ceil(buckets / 8) bytes, bit b % 8 of byte b / 8);
 *   per bucket in the mask: u16 texel mask (bit y * 4 + x for texel (x, y) of the tile), then
 *     per texel in the mask: i8 top, u64 acc[4] -- its exact sum: the sum over k of
 *     acc[k] * 2^(24 (top - k)), acc[0] > 0. */
#define LIGHTMAP_WIRE_VERSION 1
int lightmap_encode(const lightmap_t *self, uint8_t **out, size_t *out_len, err_t *err);
/* Decodes untrusted bytes for the same scene, density and grid. Everything is checked: magic,
 * version, grid and density equal to the caller's, the inflated size (at most max_bytes and
 * equal to the header's), every count against the bytes left, keys in strictly increasing order
 * naming a surface of this scene (instance, shape of that instance's object, triangle, side),
 * tiles and texels inside the surface's grid, sums canonical and finite, no trailing bytes, and
 * the decoded map's memory at most max_bytes (which should be well above the payload: memory
 * comes in slabs of up to 1 MB). Payloads inflate to at most 4 GiB. An error names what is
 * wrong; never a crash. */
lightmap_t *lightmap_decode(const scene_t *scene, double density, spectral_grid_t grid,
                            const uint8_t *data, size_t len, size_t max_bytes, err_t *err);

/* Spectral irradiance per bucket at a hit seen from the side of n, written to
 * E[0 .. grid.n - 1]: the texel's power over (photons emitted * texel area * bucket width).
 * Returns 1 when the texel holds power, else 0 with E zeroed (also for no photons emitted, a
 * zero-area texel or a hit naming no surface). Safe from concurrent readers. */
int lightmap_irradiance(const lightmap_t *self, const hit_t *hit, vec3_t n, double *E);

/* The texel a hit on the side of n falls in. */
int lightmap_locate(const lightmap_t *self, const hit_t *hit, vec3_t n, lightmap_texel_t *out,
                    err_t *err);
/* Texels of a surface's grid (on each side); -1 when the key names no surface. */
int lightmap_surface_texels(const lightmap_t *self, uint32_t instance, uint32_t shape,
                            uint32_t prim, uint64_t *count, err_t *err);
/* World-space area of a texel; 0 for a texel that does not exist. */
double lightmap_texel_area(const lightmap_t *self, lightmap_texel_t t);
/* A texel's raw power per bucket (W/nm, power[0 .. grid.n - 1]); returns 1 if any is > 0. */
int lightmap_texel_power(const lightmap_t *self, lightmap_texel_t t, double *power);

/* Texels holding power (any bucket). */
size_t lightmap_texels_used(const lightmap_t *self);
/* Bytes held: tiles, accumulators, the hash table and the map itself. */
size_t lightmap_memory_bytes(const lightmap_t *self);
/* Sum of the raw power of every texel and bucket (as photon_map_power_sum): divided by the
 * photons emitted and multiplied by the bucket width it is the flux the map holds, in W. */
double lightmap_power_sum(const lightmap_t *self);
spectral_grid_t lightmap_grid(const lightmap_t *self);
double lightmap_density(const lightmap_t *self);

#endif
