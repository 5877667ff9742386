#include "scene.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

render_settings_t render_settings_default(void)
{
    return (render_settings_t){
        .integrator = INTEGRATOR_PATH,
        .dispersion = DISPERSION_HERO,
        .maxdepth = 5,
        .spp = 16,
        .seed = 1,
        .xres = 1280,
        .yres = 720,
        .grid = spectral_grid_default(),
        .visible_sampling = 1,
        .filename = "",
        .film_spectral = 1,
    };
}

scene_t *scene_new(err_t *err)
{
    scene_t *self = calloc(1, sizeof *self);
    if (!self) {
        err_set(err, "out of memory");
        return NULL;
    }
    self->geometry = geometry_new(0, err);
    if (!self->geometry) {
        free(self);
        return NULL;
    }
    self->settings = render_settings_default();
    self->camera = (camera_t){.camera_to_world = transform_identity(), .fov_deg = 90.0,
                              .lens_radius = 0.0, .focal_distance = 1e6};
    return self;
}

void scene_destroy(scene_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    scene_t *self = *self_p;
    geometry_destroy(&self->geometry);
    for (size_t i = 0; i < self->nshapes; i++) {
        shape_t *s = &self->shapes[i];
        free(s->positions);
        free(s->indices);
        free(s->normals);
        free(s->uvs);
        alias_destroy(&s->triangles);
    }
    free(self->shapes);
    free(self->materials);
    free(self->lights);
    alias_destroy(&self->light_power);
    /* Textures may reference earlier textures: destroy in reverse order of creation. */
    for (size_t i = self->ntextures; i-- > 0;)
        texture_destroy(&self->textures[i]);
    free(self->textures);
    for (size_t i = 0; i < self->nspectra; i++)
        spectrum_destroy(&self->spectra[i]);
    free(self->spectra);
    free(self);
    *self_p = NULL;
}

/* Appends one element to a growable array; returns its index or -1. */
static long grow(void **array, size_t *count, size_t elem, err_t *err)
{
    size_t n = *count;
    /* Capacity doubles at powers of two, so growing one at a time stays amortised O(1). */
    if ((n & (n - 1)) == 0) {
        size_t cap = n ? 2 * n : 4;
        void *p = realloc(*array, cap * elem);
        if (!p) {
            err_set(err, "out of memory");
            return -1;
        }
        *array = p;
    }
    memset((char *)*array + n * elem, 0, elem);
    *count = n + 1;
    return (long)n;
}

int scene_own_texture(scene_t *self, texture_t *tex, err_t *err)
{
    long i = grow((void **)&self->textures, &self->ntextures, sizeof *self->textures, err);
    if (i < 0) {
        texture_destroy(&tex);
        return -1;
    }
    self->textures[i] = tex;
    return 0;
}

int scene_own_spectrum(scene_t *self, spectrum_t *s, err_t *err)
{
    long i = grow((void **)&self->spectra, &self->nspectra, sizeof *self->spectra, err);
    if (i < 0) {
        spectrum_destroy(&s);
        return -1;
    }
    self->spectra[i] = s;
    return 0;
}

int scene_add_material(scene_t *self, const material_t *m, err_t *err)
{
    long i = grow((void **)&self->materials, &self->nmaterials, sizeof *self->materials, err);
    if (i < 0)
        return -1;
    self->materials[i] = *m;
    return (int)i;
}

int scene_add_light(scene_t *self, const light_t *l, err_t *err)
{
    if (!l->spectrum)
        return err_set(err, "light %zu has no spectrum", self->nlights);
    if (!isfinite(l->scale) || l->scale < 0)
        return err_set(err, "light %zu: scale must be finite and >= 0, got %g", self->nlights, l->scale);
    long i = grow((void **)&self->lights, &self->nlights, sizeof *self->lights, err);
    if (i < 0)
        return -1;
    self->lights[i] = *l;
    self->lights[i].shape = -1;
    return (int)i;
}

static int check_refs(const scene_t *self, int material, int area_light, err_t *err)
{
    if (material < 0 || (size_t)material >= self->nmaterials)
        return err_set(err, "shape refers to material %d of %zu", material, self->nmaterials);
    if (area_light >= 0) {
        if ((size_t)area_light >= self->nlights)
            return err_set(err, "shape refers to light %d of %zu", area_light, self->nlights);
        const light_t *l = &self->lights[area_light];
        if (l->kind != LIGHT_AREA && l->kind != LIGHT_COLLIMATED)
            return err_set(err, "light %d is not an area light", area_light);
        if (l->shape >= 0)
            return err_set(err, "area light %d is already attached to shape %d", area_light, l->shape);
    }
    return 0;
}

static shape_t *new_shape(scene_t *self, int material, int area_light, int flip, err_t *err)
{
    long i = grow((void **)&self->shapes, &self->nshapes, sizeof *self->shapes, err);
    if (i < 0)
        return NULL;
    shape_t *s = &self->shapes[i];
    s->material = material;
    s->light = area_light;
    s->flip = flip;
    s->to_world = transform_identity();
    return s;
}

static void *copy_array(const void *src, size_t bytes, int *failed)
{
    if (!src)
        return NULL;
    void *p = malloc(bytes);
    if (!p)
        *failed = 1;
    else
        memcpy(p, src, bytes);
    return p;
}

int scene_add_mesh(scene_t *self, const double *positions, size_t nverts, const uint32_t *indices,
                   size_t ntris, const double *normals, const double *uvs, int material,
                   int area_light, int flip, err_t *err)
{
    if (check_refs(self, material, area_light, err))
        return -1;
    uint32_t id = (uint32_t)self->nshapes;
    if (geometry_add_mesh(self->geometry, positions, nverts, indices, ntris, id, flip, err))
        return -1;
    shape_t *s = new_shape(self, material, area_light, flip, err);
    if (!s)
        return -1;
    s->kind = SHAPE_MESH;
    int failed = 0;
    s->positions = copy_array(positions, 3 * nverts * sizeof(double), &failed);
    s->indices = copy_array(indices, 3 * ntris * sizeof(uint32_t), &failed);
    s->normals = copy_array(normals, 3 * nverts * sizeof(double), &failed);
    s->uvs = copy_array(uvs, 2 * nverts * sizeof(double), &failed);
    s->nverts = nverts;
    s->ntris = ntris;
    if (failed)
        return err_set(err, "out of memory copying a mesh of %zu triangles", ntris);
    if (area_light >= 0) {
        double *areas = malloc(ntris * sizeof *areas);
        if (!areas)
            return err_set(err, "out of memory");
        double total = 0;
        for (size_t t = 0; t < ntris; t++) {
            const double *p0 = positions + 3 * indices[3 * t];
            const double *p1 = positions + 3 * indices[3 * t + 1];
            const double *p2 = positions + 3 * indices[3 * t + 2];
            vec3_t e1 = vec3_make(p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]);
            vec3_t e2 = vec3_make(p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]);
            areas[t] = 0.5 * vec3_length(vec3_cross(e1, e2));
            total += areas[t];
        }
        s->area = total;
        if (total > 0)
            s->triangles = alias_new(areas, ntris, err);
        free(areas);
        if (total > 0 && !s->triangles)
            return -1;
        self->lights[area_light].shape = (int)id;
    }
    return (int)id;
}

/* Area of a unit-parameter patch under the transform's linear part: |M a x M b|. */
static double mapped_area_factor(const transform_t *t, vec3_t a, vec3_t b)
{
    return vec3_length(vec3_cross(transform_vector(t, a), transform_vector(t, b)));
}

static int add_analytic(scene_t *self, shape_kind_t kind, const transform_t *to_world,
                        double radius, double height, int material, int area_light, int flip,
                        err_t *err)
{
    if (check_refs(self, material, area_light, err))
        return -1;
    uint32_t id = (uint32_t)self->nshapes;
    int r = kind == SHAPE_SPHERE
                ? geometry_add_sphere(self->geometry, to_world, radius, id, flip, err)
                : geometry_add_disk(self->geometry, to_world, radius, height, id, flip, err);
    if (r)
        return -1;
    double area;
    if (kind == SHAPE_SPHERE) {
        /* A sphere keeps uniform area sampling only under a similarity transform; an area light
         * on an ellipsoid would need a non-uniform pdf, so it is refused. */
        double sx = vec3_length(transform_vector(to_world, vec3_make(1, 0, 0)));
        double sy = vec3_length(transform_vector(to_world, vec3_make(0, 1, 0)));
        double sz = vec3_length(transform_vector(to_world, vec3_make(0, 0, 1)));
        double sxy = mapped_area_factor(to_world, vec3_make(1, 0, 0), vec3_make(0, 1, 0));
        int similar = fabs(sx - sy) <= 1e-9 * sx && fabs(sx - sz) <= 1e-9 * sx &&
                      fabs(sxy - sx * sy) <= 1e-9 * sxy;
        if (area_light >= 0 && !similar)
            return err_set(err, "an area light on a non-uniformly scaled sphere is not supported");
        area = 4.0 * PF_PI * radius * radius * sx * sx;
    } else {
        area = PF_PI * radius * radius *
               mapped_area_factor(to_world, vec3_make(1, 0, 0), vec3_make(0, 1, 0));
    }
    shape_t *s = new_shape(self, material, area_light, flip, err);
    if (!s)
        return -1;
    s->kind = kind;
    s->to_world = *to_world;
    s->radius = radius;
    s->height = height;
    s->area = area;
    if (area_light >= 0)
        self->lights[area_light].shape = (int)id;
    return (int)id;
}

int scene_add_sphere(scene_t *self, const transform_t *to_world, double radius, int material,
                     int area_light, int flip, err_t *err)
{
    return add_analytic(self, SHAPE_SPHERE, to_world, radius, 0.0, material, area_light, flip, err);
}

int scene_add_disk(scene_t *self, const transform_t *to_world, double radius, double height,
                   int material, int area_light, int flip, err_t *err)
{
    return add_analytic(self, SHAPE_DISK, to_world, radius, height, material, area_light, flip, err);
}

double scene_light_power(const scene_t *self, const light_t *l)
{
    /* Power up to constant factors common to all lights, at the luminance-weighted mean:
     * the spectra are normalised to luminance, so scale alone carries brightness. */
    double r = self->scene_radius;
    switch (l->kind) {
    case LIGHT_AREA:
        return l->scale * PF_PI * self->shapes[l->shape].area * (l->twosided ? 2.0 : 1.0);
    case LIGHT_COLLIMATED:
        return l->scale * self->shapes[l->shape].area;
    case LIGHT_POINT:
        return l->scale * 4.0 * PF_PI;
    case LIGHT_SPOT:
        return l->scale * 2.0 * PF_PI * (1.0 - 0.5 * (l->cos_falloff_start + l->cos_total_width));
    case LIGHT_DISTANT:
        return l->scale * PF_PI * r * r;
    case LIGHT_INFINITE:
        return l->scale * 4.0 * PF_PI * PF_PI * r * r;
    }
    return 0.0;
}

int scene_finish(scene_t *self, err_t *err)
{
    if (geometry_commit(self->geometry, err))
        return -1;
    geometry_bounds(self->geometry, &self->bounds_lo, &self->bounds_hi);
    if (!(self->bounds_lo.x <= self->bounds_hi.x)) {
        self->bounds_lo = vec3_make(0, 0, 0);
        self->bounds_hi = vec3_make(0, 0, 0);
    }
    self->scene_radius = 0.5 * vec3_length(vec3_sub(self->bounds_hi, self->bounds_lo));
    if (!(self->scene_radius > 0))
        self->scene_radius = 1.0;
    spectral_grid_t g = self->settings.grid;
    self->has_dispersion = 0;
    for (size_t i = 0; i < self->nmaterials; i++) {
        material_t *m = &self->materials[i];
        if (m->kind != MATERIAL_DIELECTRIC)
            continue;
        if (ior_validate(&m->ior, m->name, g.lambda_min, g.lambda_max, err))
            return -1;
        m->dispersive = ior_is_dispersive(&m->ior, g.lambda_min, g.lambda_max);
        self->has_dispersion |= m->dispersive;
    }
    for (size_t i = 0; i < self->nlights; i++) {
        light_t *l = &self->lights[i];
        if ((l->kind == LIGHT_AREA || l->kind == LIGHT_COLLIMATED) && l->shape < 0)
            return err_set(err, "area light %zu is attached to no shape", i);
    }
    alias_destroy(&self->light_power);
    if (self->nlights > 0) {
        double *w = malloc(self->nlights * sizeof *w);
        if (!w)
            return err_set(err, "out of memory");
        double total = 0;
        for (size_t i = 0; i < self->nlights; i++)
            total += w[i] = scene_light_power(self, &self->lights[i]);
        /* All-black lights: fall back to uniform choice so that sampling stays defined. */
        if (!(total > 0))
            for (size_t i = 0; i < self->nlights; i++)
                w[i] = 1.0;
        self->light_power = alias_new(w, self->nlights, err);
        free(w);
        if (!self->light_power)
            return -1;
    }
    return 0;
}
