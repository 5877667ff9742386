/* photon_store: the caustic store of the photon integrator, whichever kind the job chose
 * (Integrator "photon" "string store"): a photon map (photon_map.h, density estimation over
 * a kd-tree) or light maps (lightmap.h, per-surface texel grids). The photon tracer deposits
 * into it, batches merge into it in batch order, the master ships it to workers in its wire
 * form, and the camera pass asks it for irradiance at a diffuse hit. Power is raw throughout;
 * both kinds divide by the photons emitted only when asked for irradiance, so merged batches,
 * a re-run batch or a later refinement all come out normalised by what was actually emitted
 * (docs/physics.md §5.2). A photon map also answers the radiance at a glossy receiver
 * (photon_store_gather), from the photons' directions. A scene whose media are simulated also
 * gets volume photons, kept in a photon map of their own (photon_store_has_volume). */
#ifndef PRISMFARM_PHOTON_STORE_H
#define PRISMFARM_PHOTON_STORE_H

#include "err.h"
#include "geometry.h"
#include "lightmap.h"
#include "photon_map.h"
#include "scene.h"

#include <stddef.h>
#include <stdint.h>

typedef struct photon_store photon_store_t;

/* An empty store of the kind scene->settings.photon.store names, for the scene's film grid.
 * The scene must outlive the store. */
photon_store_t *photon_store_new(const scene_t *scene, err_t *err);
void photon_store_destroy(photon_store_t **self_p);

photon_store_kind_t photon_store_kind(const photon_store_t *self);

/* A photon of raw spectral power `power` (W/nm) at wavelength lambda landed at hit h (point p,
 * travelling along dir, arriving on the side of unit normal n). Wavelengths outside the film
 * are ignored; a non-finite or negative power is an error. Not after photon_store_finish. */
int photon_store_deposit(photon_store_t *self, const hit_t *h, vec3_t p, vec3_t dir, vec3_t n,
                         double lambda, double power, err_t *err);

/* A white photon (photon_map.h) of light `light` (an index into scene->lights) with raw power
 * `power` per unit of the light's spectrum: only into a photon map whose spectra are set
 * (photon_store_white). */
int photon_store_deposit_white(photon_store_t *self, vec3_t p, vec3_t dir, vec3_t n, int light,
                               double power, err_t *err);
/* Whether the store takes white photons: a photon map, which gets every light's spectrum
 * integrated over the film's buckets when it is made or decoded. */
int photon_store_white(const photon_store_t *self);
/* For a bucket a visitor got (photon_store_gather) that is a white photon's,
 * PHOTON_MAP_WHITE(light): the light's row of grid.n bucket weights (the photon's power in
 * bucket b is its power times row[b]); NULL for any other bucket. */
const double *photon_store_white_spectrum(const photon_store_t *self, int bucket);

void photon_store_add_emitted(photon_store_t *self, uint64_t n);
/* Photons emitted into the store: the N of every estimate's 1/N. */
uint64_t photon_store_emitted(const photon_store_t *self);

/* Merges src into dst (same scene and kind, neither finished): dst's deposits then src's, and
 * the emitted counts added. Merging batches in index order gives the store one pass over all
 * of them would have given. */
int photon_store_merge(photon_store_t *dst, const photon_store_t *src, err_t *err);

/* Makes the store ready for queries (balances a photon map's kd-tree); read-only and safe for
 * concurrent readers afterwards. */
int photon_store_finish(photon_store_t *self, err_t *err);
int photon_store_finished(const photon_store_t *self);

/* The wire form of an unfinished store (malloc'ed into *out), and its strict decoder for
 * untrusted bytes: the kind must be the scene's, every count and value is checked. */
int photon_store_encode(const photon_store_t *self, uint8_t **out, size_t *out_len, err_t *err);
photon_store_t *photon_store_decode(const scene_t *scene, const uint8_t *data, size_t len,
                                    err_t *err);

/* Spectral irradiance per film bucket at a diffuse hit seen from the side of unit normal n
 * (E[0 .. grid.n - 1], W m^-2 nm^-1 averaged over each bucket): the photon map's density
 * estimate with the scene's gather radius and k, or the light map's texel. Returns 1 when
 * any power was found, else 0 with E zeroed. Only on a finished store. */
int photon_store_irradiance(const photon_store_t *self, const hit_t *h, vec3_t p, vec3_t n,
                            double *E);

/* Whether the store keeps each photon's direction, so that photons may be stored on glossy
 * receivers and gathered there (photon_store_gather): a photon map does, light maps (texel
 * irradiance) do not. */
int photon_store_directional(const photon_store_t *self);

/* The glossy receiver's estimate at hit point p with unit geometric normal n (either side):
 * photon_map_gather with the scene's gather radius and k. Returns the photons handed to fn
 * (0 with *scale 0 on a light map or when none is near). Only on a finished store. */
int photon_store_gather(const photon_store_t *self, vec3_t p, vec3_t n, photon_map_visit_fn fn,
                        void *user, double *scale);

/* Sum of the raw power held (as photon_map_power_sum). */
double photon_store_power_sum(const photon_store_t *self);
/* Photons held (photon map) or texels with power (light map). */
size_t photon_store_count(const photon_store_t *self);
size_t photon_store_memory_bytes(const photon_store_t *self);

/* The photon map's gather radius: settings.photon.radius, or when that is 0 a hundredth of
 * the radius of the scene's bounding sphere. */
double photon_gather_radius(const scene_t *scene);

/* The volume photons (docs/physics.md §12, "Media and the photon pass"): a store made for a
 * scene whose participating media are simulated (settings.media with media present) holds a
 * second photon map of photons stored where they scatter in a medium after a specular chain,
 * each with power Phi / sigma_s(lambda, x) (raw, W/nm per unit scattering coefficient), so
 * that the camera pass's point estimate needs no coefficient of its own. The volume map merges,
 * counts emitted photons and travels with the surface store: its wire form is the volume map's
 * (photon_map_encode) followed by the surface store's, only for such scenes (every other store's
 * bytes are unchanged); a store of such a scene without its volume part is refused. */
int photon_store_has_volume(const photon_store_t *self);
int photon_store_deposit_volume(photon_store_t *self, vec3_t p, vec3_t dir, double lambda,
                                double power, err_t *err);
/* The PHOTON_VOLUME_K volume photons nearest to p within R = PHOTON_VOLUME_RADIUS_SCALE times
 * the scene's gather radius (a sphere, no normal test) handed to fn; *scale = 1 / (N_emitted *
 * bucket width * 4/3 pi r^3), r the k-th photon's distance (R when fewer are found). A sphere
 * holds far fewer photons than a surface's disk of the same radius (they spread over a volume),
 * so it is wider, and the k nearest keep a focus sharp where photons crowd. Returns the photons
 * handed over (0, *scale 0, without a volume map). Only on a finished store. */
#define PHOTON_VOLUME_K 64
#define PHOTON_VOLUME_RADIUS_SCALE 4.0
int photon_store_volume_gather(const photon_store_t *self, vec3_t p, photon_map_visit_fn fn,
                               void *user, double *scale);
const photon_map_t *photon_store_volume_map(const photon_store_t *self);

/* The photon map or light map inside a store of that kind, else NULL (tests and statistics). */
const photon_map_t *photon_store_map(const photon_store_t *self);
const lightmap_t *photon_store_lightmap(const photon_store_t *self);

#endif
