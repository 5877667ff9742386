/* photon_map: the photon store of the photon integrator (Jensen 2001, "Realistic Image
 * Synthesis Using Photon Mapping", ch. 6-7). Deposits (position, incoming direction, surface
 * normal, wavelength, raw power) are appended in a fixed order, then balanced once into a
 * kd-tree that answers density estimates: spectral irradiance per framebuffer bucket at a
 * point, from every photon within a radius or from the k nearest.
 * Power is stored raw (unnormalised, see photon.h); a map also counts the photons emitted to
 * make it, and the estimate divides by that count, so maps traced in separate batches merge by
 * concatenation and are rescaled once, by the photons actually emitted (docs/physics.md
 * §5.2). 24 bytes per photon, the direction included (what a glossy receiver's estimate,
 * photon_map_gather, needs); building and queries are deterministic. */
#ifndef PRISMFARM_PHOTON_MAP_H
#define PRISMFARM_PHOTON_MAP_H

#include "err.h"
#include "spectral_grid.h"
#include "vec3.h"

#include <stddef.h>
#include <stdint.h>

typedef struct photon_map photon_map_t;

/* A stored photon, decoded. Directions are stored with 8 bits per octahedral coordinate
 * (about 1 degree) and the wavelength to (lambda_max - lambda_min) / 65535. */
typedef struct photon_info {
    vec3_t p;      /* where it landed (float precision) */
    vec3_t dir;    /* unit direction it was travelling in */
    vec3_t normal; /* unit geometric normal on the side it arrived from */
    double lambda; /* nm */
    int bucket;    /* framebuffer bucket of lambda; a white photon: PHOTON_MAP_WHITE(spectrum)
                    * (and lambda 0) */
    double power;  /* raw spectral power, W/nm before division by the photons emitted */
} photon_info_t;

/* An empty, unbuilt map for the framebuffer's wavelength grid. */
photon_map_t *photon_map_new(spectral_grid_t grid, err_t *err);
void photon_map_destroy(photon_map_t **self_p);

/* Appends a deposit (not after photon_map_build). lambda outside the grid is ignored (its
 * energy lies outside what the framebuffer holds) and returns 0; a non-finite or negative
 * power or position, or running out of memory, returns -1. */
int photon_map_deposit(photon_map_t *self, vec3_t p, vec3_t dir, vec3_t normal, double lambda,
                       double power, err_t *err);

/* White photons: a photon whose path did not depend on the wavelength (photon.c) counts in
 * every bucket at once, with power `power` x shape[b] in bucket b, shape the row `spectrum` of
 * the map's spectra (photon_map_set_spectra: for a light, its power integrated over each
 * bucket). It stands for the photons of every wavelength that took its path, so each bucket's
 * estimate has every such photon instead of 1/n of them (docs/rendering.md, "White
 * photons"). Stored in the same 24 bytes, the bucket field marking it and the wavelength field
 * holding the spectrum. A visitor (photon_map_gather) gets bucket PHOTON_MAP_WHITE(spectrum),
 * a negative number. The spectra must be set before any white deposit, merge or build and be
 * the same in every map that merges (they come from the scene). */
#define PHOTON_MAP_MAX_SPECTRA 65535
#define PHOTON_MAP_WHITE(spectrum) (-1 - (int)(spectrum))
#define PHOTON_MAP_WHITE_SPECTRUM(bucket) (-1 - (bucket))
int photon_map_set_spectra(photon_map_t *self, int n, const double *shape, err_t *err);
/* Row `spectrum` of the spectra (grid.n doubles), or NULL when there is no such row. */
const double *photon_map_spectrum(const photon_map_t *self, int spectrum);
int photon_map_deposit_white(photon_map_t *self, vec3_t p, vec3_t dir, vec3_t normal, int spectrum,
                             double power, err_t *err);

/* Counts photons emitted into the map (the N that normalises every estimate). */
void photon_map_add_emitted(photon_map_t *self, uint64_t n);
uint64_t photon_map_emitted(const photon_map_t *self);

/* The merge of partial stores: appends src's deposits after dst's (in that order) and adds its
 * emitted count. Both unbuilt, on the same grid. */
int photon_map_append(photon_map_t *dst, const photon_map_t *src, err_t *err);

/* The compact wire form of an unbuilt map (a batch's partial store, or the merged store the
 * master sends to workers): 24 bytes per photon plus a 32-byte header holding the emitted
 * count, little endian whatever the host. *out is malloc'ed. */
int photon_map_encode(const photon_map_t *self, uint8_t **out, size_t *out_len, err_t *err);
/* Decodes untrusted bytes for a film of the given grid into an unbuilt map: every length,
 * count, position, power and bucket is checked, and anything wrong is an error naming it. */
photon_map_t *photon_map_decode(spectral_grid_t grid, const uint8_t *data, size_t len,
                                err_t *err);

/* Balances the kd-tree (median splits on the widest axis; O(n log n)). The map is read-only
 * afterwards and safe to query from many threads. The result depends only on the deposits
 * and their order. */
int photon_map_build(photon_map_t *self, err_t *err);
int photon_map_built(const photon_map_t *self);

size_t photon_map_count(const photon_map_t *self);
/* Photon i in storage order (deposit order before the build, tree order after). */
photon_info_t photon_map_photon(const photon_map_t *self, size_t i);
/* Sum of the raw power of every photon over the grid, (W/nm) summed: divided by the photons
 * emitted and multiplied by the bucket width it estimates the flux the map holds, in W. */
double photon_map_power_sum(const photon_map_t *self);
spectral_grid_t photon_map_grid(const photon_map_t *self);

/* Bytes held: the photons (capacity) and the map itself. */
size_t photon_map_memory_bytes(const photon_map_t *self);
/* Bytes per stored photon. */
size_t photon_map_photon_bytes(void);

/* Density estimate (Jensen 2001, eq. 7.6, for irradiance): spectral irradiance at p averaged
 * over each bucket,
 *   E_b = sum over photons of bucket b of power / (N_emitted * bucket width * pi r^2),
 * written to E[0 .. grid.n - 1]. Photons count only when their normal lies within 60 degrees
 * of n (the unit normal on the side being looked at), so a wall's back and the other face
 * of a corner do not leak in. With k <= 0 every photon within `radius` counts (a box kernel,
 * r = radius); with 0 < k <= PHOTON_MAP_MAX_K the k nearest within `radius` count and r is the
 * distance to the k-th (radius when fewer are found). Returns the number of photons used; 0 (and E
 * all zero) on an unbuilt or empty map or a radius that is not finite and > 0. */
#define PHOTON_MAP_MAX_K 1024
int photon_map_irradiance(const photon_map_t *self, vec3_t p, vec3_t n, double radius, int k,
                          double *E);

/* A photon found by photon_map_gather: the unit direction it was travelling in (decoded from
 * its 8-bit octahedral code), its bucket and its raw power. */
typedef void (*photon_map_visit_fn)(void *user, vec3_t dir, int bucket, double power);

/* The density estimate of radiance at a glossy receiver (Jensen 2001, eq. 7.6 with the BSDF
 * inside the sum): L_b = sum over photons of bucket b of f(wo, -dir) power / (N_emitted *
 * bucket width * pi r^2). The map hands each photon it selects, as photon_map_irradiance
 * selects them (same radius and k) except that photons on either side of n count (the
 * receiver's BSDF says whether light from the other side is transmitted or is nothing), to fn,
 * in an order that depends only on the map and the query; *scale is the
 * 1 / (N_emitted * bucket width * pi r^2) to multiply fn's sums by (0 when none was found).
 * Returns the number of photons handed over. */
int photon_map_gather(const photon_map_t *self, vec3_t p, vec3_t n, double radius, int k,
                      photon_map_visit_fn fn, void *user, double *scale);

#endif
