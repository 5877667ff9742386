#include "photon_store.h"

#include "lightmap.h"

#include "le_bytes.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

struct photon_store {
    const scene_t *scene;
    photon_store_kind_t kind;
    photon_map_t *map;     /* PHOTON_STORE_PHOTONMAP */
    lightmap_t *lightmap;  /* PHOTON_STORE_LIGHTMAP */
    photon_map_t *volume;  /* the volume photons (photon_store_has_volume), or NULL */
    int finished;
};

/* A decoded light map may hold at most this much memory whatever its payload claims. */
#define LIGHTMAP_DECODE_MAX ((size_t)4 << 30)

static photon_store_t *store_alloc(const scene_t *scene, err_t *err)
{
    photon_store_t *self = calloc(1, sizeof *self);
    if (!self) {
        err_set(err, "out of memory");
        return NULL;
    }
    self->scene = scene;
    self->kind = scene->settings.photon.store;
    return self;
}

/* Whether stores of this scene carry volume photons: decided by the scene alone, so that the
 * master and every worker agree on the wire form. */
static int scene_wants_volume(const scene_t *scene)
{
    return scene->settings.media && scene->nmedia > 0;
}

double photon_gather_radius(const scene_t *scene)
{
    double r = scene->settings.photon.radius;
    return r > 0.0 ? r : 0.01 * scene->scene_radius;
}

/* The white photons' spectra (photon_map.h): for each light, scale x its spectrum integrated
 * over each bucket -- what a photon of a uniformly drawn wavelength adds to that bucket's sum
 * on average, so that a white photon's estimate has the coloured one's expectation. Midpoint
 * rule on WHITE_STEPS points a bucket (a smooth spectrum's error is below 1e-4; a tabulated
 * one's kinks and lines move a bucket by at most a step's share). A scene of more lights
 * than a photon's field can name gets no spectra: its photons stay coloured (photon.c). */
#define WHITE_STEPS 64
static int set_white_spectra(photon_map_t *map, const scene_t *scene, err_t *err)
{
    const spectral_grid_t g = scene->settings.grid;
    if (scene->nlights == 0 || scene->nlights > PHOTON_MAP_MAX_SPECTRA)
        return 0;
    double *c = malloc(scene->nlights * (size_t)g.n * sizeof *c);
    if (!c)
        return err_set(err, "out of memory");
    const double width = spectral_grid_width(g);
    for (size_t l = 0; l < scene->nlights; l++) {
        const light_t *li = &scene->lights[l];
        for (int b = 0; b < g.n; b++) {
            double sum = 0.0;
            for (int k = 0; k < WHITE_STEPS && li->spectrum; k++)
                sum += spectrum_eval(li->spectrum,
                                     g.lambda_min + width * (b + (k + 0.5) / WHITE_STEPS));
            const double v = li->scale * sum * width / WHITE_STEPS;
            c[l * (size_t)g.n + (size_t)b] = v > 0.0 && v <= DBL_MAX ? v : 0.0;
        }
    }
    const int r = photon_map_set_spectra(map, (int)scene->nlights, c, err);
    free(c);
    return r;
}

int photon_store_white(const photon_store_t *self)
{
    return self->map && photon_map_spectrum(self->map, 0) != NULL;
}

const double *photon_store_white_spectrum(const photon_store_t *self, int bucket)
{
    return self->map ? photon_map_spectrum(self->map, PHOTON_MAP_WHITE_SPECTRUM(bucket)) : NULL;
}

int photon_store_deposit_white(photon_store_t *self, vec3_t p, vec3_t dir, vec3_t n, int light,
                               double power, err_t *err)
{
    if (self->finished)
        return err_set(err, "photon store: deposit after it was finished");
    if (!self->map)
        return err_set(err, "photon store: white photons need a photon map");
    return photon_map_deposit_white(self->map, p, dir, n, light, power, err);
}

photon_store_t *photon_store_new(const scene_t *scene, err_t *err)
{
    photon_store_t *self = store_alloc(scene, err);
    if (!self)
        return NULL;
    switch (self->kind) {
    case PHOTON_STORE_PHOTONMAP:
        self->map = photon_map_new(scene->settings.grid, err);
        if (self->map && set_white_spectra(self->map, scene, err))
            photon_map_destroy(&self->map);
        break;
    case PHOTON_STORE_LIGHTMAP:
        self->lightmap = lightmap_new(scene, scene->settings.photon.lightmap_density,
                                      scene->settings.grid, err);
        break;
    }
    if (!self->map && !self->lightmap) {
        free(self);
        return NULL;
    }
    if (scene_wants_volume(scene) && !(self->volume = photon_map_new(scene->settings.grid, err)))
        photon_store_destroy(&self);
    return self;
}

void photon_store_destroy(photon_store_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    photon_map_destroy(&(*self_p)->map);
    lightmap_destroy(&(*self_p)->lightmap);
    photon_map_destroy(&(*self_p)->volume);
    free(*self_p);
    *self_p = NULL;
}

photon_store_kind_t photon_store_kind(const photon_store_t *self)
{
    return self->kind;
}

int photon_store_deposit(photon_store_t *self, const hit_t *h, vec3_t p, vec3_t dir, vec3_t n,
                         double lambda, double power, err_t *err)
{
    if (self->finished)
        return err_set(err, "photon store: deposit after it was finished");
    if (self->lightmap)
        return lightmap_deposit(self->lightmap, h, n, lambda, power, err);
    return photon_map_deposit(self->map, p, dir, n, lambda, power, err);
}

void photon_store_add_emitted(photon_store_t *self, uint64_t n)
{
    if (self->volume)
        photon_map_add_emitted(self->volume, n);
    if (self->lightmap)
        lightmap_add_emitted(self->lightmap, n);
    else
        photon_map_add_emitted(self->map, n);
}

uint64_t photon_store_emitted(const photon_store_t *self)
{
    return self->lightmap ? lightmap_emitted(self->lightmap) : photon_map_emitted(self->map);
}

int photon_store_merge(photon_store_t *dst, const photon_store_t *src, err_t *err)
{
    if (dst->kind != src->kind)
        return err_set(err, "photon store: cannot merge a %s into a %s",
                       src->kind == PHOTON_STORE_LIGHTMAP ? "light map" : "photon map",
                       dst->kind == PHOTON_STORE_LIGHTMAP ? "light map" : "photon map");
    if (dst->finished || src->finished)
        return err_set(err, "photon store: only unfinished stores merge");
    if (!dst->volume != !src->volume)
        return err_set(err, "photon store: cannot merge a store with volume photons and one without");
    if (dst->volume && photon_map_append(dst->volume, src->volume, err))
        return -1;
    if (dst->lightmap)
        return lightmap_merge(dst->lightmap, src->lightmap, err);
    return photon_map_append(dst->map, src->map, err);
}

int photon_store_finish(photon_store_t *self, err_t *err)
{
    if (self->finished)
        return 0;
    /* A light map needs nothing more: its texels are read as they are. */
    if (self->map && photon_map_build(self->map, err))
        return -1;
    if (self->volume && photon_map_build(self->volume, err))
        return -1;
    self->finished = 1;
    return 0;
}

int photon_store_finished(const photon_store_t *self)
{
    return self->finished;
}

static int encode_surface(const photon_store_t *self, uint8_t **out, size_t *out_len, err_t *err)
{
    if (self->lightmap)
        return lightmap_encode(self->lightmap, out, out_len, err);
    return photon_map_encode(self->map, out, out_len, err);
}

/* The volume map's wire form first (its header says its length: 32 + 24 n bytes), then the
 * surface store's. */
static int encode_with_volume(const photon_store_t *self, uint8_t **out, size_t *out_len,
                              err_t *err)
{
    uint8_t *v = NULL, *sfc = NULL;
    size_t vn = 0, sn = 0;
    *out = NULL;
    *out_len = 0;
    if (photon_map_encode(self->volume, &v, &vn, err) || encode_surface(self, &sfc, &sn, err)) {
        free(v);
        return -1;
    }
    uint8_t *b = vn + sn >= vn ? malloc(vn + sn) : NULL;
    if (!b) {
        free(v);
        free(sfc);
        return err_set(err, "out of memory encoding the photon store");
    }
    memcpy(b, v, vn);
    memcpy(b + vn, sfc, sn);
    free(v);
    free(sfc);
    *out = b;
    *out_len = vn + sn;
    return 0;
}

int photon_store_encode(const photon_store_t *self, uint8_t **out, size_t *out_len, err_t *err)
{
    if (self->finished)
        return err_set(err, "photon store: only an unfinished store can be encoded");
    if (self->volume)
        return encode_with_volume(self, out, out_len, err);
    return encode_surface(self, out, out_len, err);
}

photon_store_t *photon_store_decode(const scene_t *scene, const uint8_t *data, size_t len,
                                    err_t *err)
{
    photon_store_t *self = store_alloc(scene, err);
    if (!self)
        return NULL;
    if (scene_wants_volume(scene)) {
        /* The volume part's length from its header (photon_map.c's wire form: the photon count
         * at byte 16, 24 bytes a photon after 32); its decoder checks everything else. */
        const uint64_t n = len >= 24 ? le_get_u64(data + 16) : UINT64_MAX;
        if (len < 32 || n > (len - 32) / 24) {
            err_set(err, "photon store data: the scene's media call for volume photons, and "
                         "%zu bytes hold no volume part",
                    len);
            free(self);
            return NULL;
        }
        const size_t vlen = 32 + (size_t)n * 24;
        if (!(self->volume = photon_map_decode(scene->settings.grid, data, vlen, err))) {
            err_prefix(err, "volume photons: ");
            free(self);
            return NULL;
        }
        data += vlen;
        len -= vlen;
    }
    switch (self->kind) {
    case PHOTON_STORE_PHOTONMAP:
        self->map = photon_map_decode(scene->settings.grid, data, len, err);
        if (self->map && set_white_spectra(self->map, scene, err))
            photon_map_destroy(&self->map);
        break;
    case PHOTON_STORE_LIGHTMAP:
        self->lightmap = lightmap_decode(scene, scene->settings.photon.lightmap_density,
                                         scene->settings.grid, data, len, LIGHTMAP_DECODE_MAX, err);
        break;
    }
    if (!self->map && !self->lightmap) {
        photon_map_destroy(&self->volume);
        free(self);
        return NULL;
    }
    return self;
}

int photon_store_irradiance(const photon_store_t *self, const hit_t *h, vec3_t p, vec3_t n,
                            double *E)
{
    if (self->lightmap)
        return lightmap_irradiance(self->lightmap, h, n, E);
    return photon_map_irradiance(self->map, p, n, photon_gather_radius(self->scene),
                                 self->scene->settings.photon.k, E) > 0;
}

int photon_store_directional(const photon_store_t *self)
{
    return self->map != NULL;
}

int photon_store_gather(const photon_store_t *self, vec3_t p, vec3_t n, photon_map_visit_fn fn,
                        void *user, double *scale)
{
    *scale = 0.0;
    if (!self->map)
        return 0;
    return photon_map_gather(self->map, p, n, photon_gather_radius(self->scene),
                             self->scene->settings.photon.k, fn, user, scale);
}

double photon_store_power_sum(const photon_store_t *self)
{
    return self->lightmap ? lightmap_power_sum(self->lightmap) : photon_map_power_sum(self->map);
}

size_t photon_store_count(const photon_store_t *self)
{
    return self->lightmap ? lightmap_texels_used(self->lightmap) : photon_map_count(self->map);
}

size_t photon_store_memory_bytes(const photon_store_t *self)
{
    return sizeof *self +
           (self->lightmap ? lightmap_memory_bytes(self->lightmap)
                           : photon_map_memory_bytes(self->map)) +
           (self->volume ? photon_map_memory_bytes(self->volume) : 0);
}

int photon_store_has_volume(const photon_store_t *self)
{
    return self->volume != NULL;
}

int photon_store_deposit_volume(photon_store_t *self, vec3_t p, vec3_t dir, double lambda,
                                double power, err_t *err)
{
    if (self->finished)
        return err_set(err, "photon store: deposit after it was finished");
    if (!self->volume)
        return err_set(err, "photon store: a volume photon in a store without media");
    /* The normal is unused (photon_store_volume_gather queries with the same one, two-sided). */
    return photon_map_deposit(self->volume, p, dir, vec3_make(0.0, 0.0, 1.0), lambda, power, err);
}

int photon_store_volume_gather(const photon_store_t *self, vec3_t p, photon_map_visit_fn fn,
                               void *user, double *scale)
{
    *scale = 0.0;
    if (!self->volume)
        return 0;
    /* The k nearest within R: photon_map_gather's disk scale 1 / (N w pi r^2) gives back the
     * radius r it used (the k-th photon's distance, or R), and times pi r^2 / (4/3 pi r^3) it is
     * the sphere's. Every photon's normal is +z, so the two-sided normal test passes them all. */
    const double R = PHOTON_VOLUME_RADIUS_SCALE * photon_gather_radius(self->scene);
    const int used = photon_map_gather(self->volume, p, vec3_make(0.0, 0.0, 1.0), R,
                                       PHOTON_VOLUME_K, fn, user, scale);
    if (used == 0 || !(*scale > 0.0))
        return used;
    const spectral_grid_t g = photon_map_grid(self->volume);
    const double r = sqrt(1.0 / ((double)photon_map_emitted(self->volume) *
                                 spectral_grid_width(g) * PF_PI * *scale));
    *scale *= 0.75 / r;
    return used;
}

const photon_map_t *photon_store_volume_map(const photon_store_t *self)
{
    return self->volume;
}

const lightmap_t *photon_store_lightmap(const photon_store_t *self)
{
    return self->lightmap;
}

const photon_map_t *photon_store_map(const photon_store_t *self)
{
    return self->map;
}
