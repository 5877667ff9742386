#include "scene.h"

#include "cie.h"
#include "overrides.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

render_settings_t render_settings_default(void)
{
    return (render_settings_t){
        .integrator = INTEGRATOR_PATH,
        .dispersion = DISPERSION_HERO,
        .spectral_mis = 1,
        .split_depth = 1,
        .maxdepth = 5,
        .spp = 16,
        .seed = 1,
        .sampler = SAMPLER_ZSOBOL,
        .xres = 1280,
        .yres = 720,
        .grid = spectral_grid_default(),
        .visible_sampling = 1,
        .filename = "",
        .film_spectral = 1,
        .photon = {.enabled = 0,
                   .photons = 1000000,
                   .radius = 0.0,
                   .k = 0,
                   .maxdepth = 5,
                   .threshold = 0.01,
                   .monochromerays = 1,
                   .mindepth = 1,
                   .store = PHOTON_STORE_PHOTONMAP,
                   .lightmap_density = 400.0},
        .filter = filter_params_default(FILTER_BOX),
        .imaging_ratio = 1.0,
        .max_component = INFINITY,
        .medium_sampling = MEDIUM_SAMPLING_EQUIANGULAR,
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
    self->camera_medium = -1;
    atomic_init(&self->holders, 1);
    return self;
}

scene_t *scene_retain(scene_t *self)
{
    if (self)
        atomic_fetch_add(&self->holders, 1);
    return self;
}

void scene_destroy(scene_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    scene_t *self = *self_p;
    *self_p = NULL;
    /* Another holder keeps it. (A scene not made by scene_new counts 0: it has one holder.) */
    if (atomic_fetch_sub(&self->holders, 1) > 1)
        return;
    warnings_destroy(&self->warnings);
    filter_sampler_destroy(&self->filter);
    sensor_destroy(&self->sensor);
    lens_system_destroy(&self->camera.lens);
    geometry_destroy(&self->geometry);
    for (size_t i = 0; i < self->nshapes; i++) {
        shape_t *s = &self->shapes[i];
        free(s->positions);
        free(s->indices);
        free(s->normals);
        free(s->uvs);
        free(s->radii);
        alias_destroy(&s->triangles);
    }
    free(self->shapes);
    free(self->instances);
    for (size_t i = 0; i < self->nmaterials; i++)
        free((void *)self->materials[i].data);
    free(self->materials);
    free(self->lights);
    alias_destroy(&self->light_power);
    free(self->light_emitter0);
    free(self->infinite_lights);
    light_bvh_destroy(&self->light_bvh);
    /* Textures may reference earlier textures: destroy in reverse order of creation. */
    for (size_t i = self->ntextures; i-- > 0;)
        texture_destroy(&self->textures[i]);
    free(self->textures);
    for (size_t i = 0; i < self->nspectra; i++)
        spectrum_destroy(&self->spectra[i]);
    for (size_t i = 0; i < self->nenvmaps; i++)
        envmap_destroy(&self->envmaps[i]);
    free(self->envmaps);
    for (size_t i = 0; i < self->nprojmaps; i++)
        projmap_destroy(&self->projmaps[i]);
    free(self->projmaps);
    for (size_t i = 0; i < self->nmeasured; i++) {
        measured_destroy(&self->measured[i]);
        free(self->measured_paths[i]);
    }
    free(self->measured);
    free(self->measured_paths);
    for (size_t i = 0; i < self->nbssrdf; i++)
        bssrdf_table_destroy(&self->bssrdf[i]);
    free(self->bssrdf);
    for (size_t i = 0; i < self->nmedia; i++)
        medium_destroy(&self->media[i]);
    free(self->media);
    free(self->spectra);
    free(self);
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

int scene_own_envmap(scene_t *self, envmap_t *e, err_t *err)
{
    long i = grow((void **)&self->envmaps, &self->nenvmaps, sizeof *self->envmaps, err);
    if (i < 0) {
        envmap_destroy(&e);
        return -1;
    }
    self->envmaps[i] = e;
    return 0;
}

int scene_own_projmap(scene_t *self, projmap_t *m, err_t *err)
{
    long i = grow((void **)&self->projmaps, &self->nprojmaps, sizeof *self->projmaps, err);
    if (i < 0) {
        projmap_destroy(&m);
        return -1;
    }
    self->projmaps[i] = m;
    return 0;
}

int scene_own_measured(scene_t *self, measured_t *m, const char *path, err_t *err)
{
    const size_t len = strlen(path) + 1, n = self->nmeasured;
    char *copy = malloc(len);
    if (copy)
        memcpy(copy, path, len);
    char **paths = copy ? realloc(self->measured_paths, (n + 1) * sizeof *paths) : NULL;
    if (paths)
        self->measured_paths = paths;
    long i = paths ? grow((void **)&self->measured, &self->nmeasured, sizeof *self->measured, err)
                   : err_set(err, "out of memory");
    if (i < 0) {
        free(copy);
        measured_destroy(&m);
        return -1;
    }
    self->measured[i] = m;
    self->measured_paths[i] = copy;
    return 0;
}

const measured_t *scene_find_measured(const scene_t *self, const char *path)
{
    for (size_t i = 0; i < self->nmeasured; i++)
        if (!strcmp(self->measured_paths[i], path))
            return self->measured[i];
    return NULL;
}

int scene_own_bssrdf(scene_t *self, bssrdf_table_t *t, err_t *err)
{
    long i = grow((void **)&self->bssrdf, &self->nbssrdf, sizeof *self->bssrdf, err);
    if (i < 0) {
        bssrdf_table_destroy(&t);
        return -1;
    }
    self->bssrdf[i] = t;
    return 0;
}

int scene_add_medium(scene_t *self, medium_t *m, err_t *err)
{
    long i = grow((void **)&self->media, &self->nmedia, sizeof *self->media, err);
    if (i < 0) {
        medium_destroy(&m);
        return -1;
    }
    self->media[i] = m;
    return (int)i;
}

int scene_medium_after(const surface_t *sf, vec3_t w, int current)
{
    const shape_t *s = sf->shape;
    if (s->medium_inside == s->medium_outside)
        return current;
    return vec3_dot(w, sf->ng) > 0.0 ? s->medium_outside : s->medium_inside;
}

int scene_add_material(scene_t *self, const material_t *m, err_t *err)
{
    const size_t size = m->data ? material_kind_data_size(m->data_kind) : 0;
    if (m->data && !size)
        return err_set(err, "material \"%s\": kind %d keeps no record of its own", m->name,
                       (int)m->data_kind);
    void *data = size ? malloc(size) : NULL;
    if (size && !data)
        return err_set(err, "out of memory");
    long i = grow((void **)&self->materials, &self->nmaterials, sizeof *self->materials, err);
    if (i < 0) {
        free(data);
        return -1;
    }
    self->materials[i] = *m;
    if (data)
        self->materials[i].data = memcpy(data, m->data, size);
    return (int)i;
}

int scene_add_light(scene_t *self, const light_t *l, err_t *err)
{
    if (!l->spectrum)
        return err_set(err, "light %zu has no spectrum", self->nlights);
    if (!isfinite(l->scale) || l->scale < 0)
        return err_set(err, "light %zu: scale must be finite and >= 0, got %g", self->nlights, l->scale);
    if ((l->kind == LIGHT_GONIOMETRIC && !l->gonio) || (l->kind == LIGHT_PROJECTION && !l->projmap))
        return err_set(err, "light %zu: a goniometric or projection light needs its image", self->nlights);
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

static shape_t *new_shape(scene_t *self, int object, int material, int area_light, int flip,
                          err_t *err)
{
    long i = grow((void **)&self->shapes, &self->nshapes, sizeof *self->shapes, err);
    if (i < 0)
        return NULL;
    shape_t *s = &self->shapes[i];
    s->object = object;
    s->material = material;
    s->light = area_light;
    s->flip = flip;
    s->to_world = transform_identity();
    s->medium_inside = s->medium_outside = -1;
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

static int check_object(const scene_t *self, int object, err_t *err)
{
    if (object < -1 || (object >= 0 && (size_t)object >= self->nobjects))
        return err_set(err, "there is no object %d (the scene has %zu)", object, self->nobjects);
    return 0;
}

static int add_mesh(scene_t *self, int object, const double *positions, size_t nverts,
                    const uint32_t *indices, size_t ntris, const double *normals, const double *uvs,
                    int material, int area_light, int flip, err_t *err)
{
    if (check_object(self, object, err) || check_refs(self, material, area_light, err))
        return -1;
    if (normals)
        for (size_t i = 0; i < 3 * nverts; i++)
            if (!isfinite(normals[i]))
                return err_set(err, "vertex normal %zu is not finite", i / 3);
    if (uvs)
        for (size_t i = 0; i < 2 * nverts; i++)
            if (!isfinite(uvs[i]))
                return err_set(err, "texture coordinate %zu is not finite", i / 2);
    uint32_t id = (uint32_t)self->nshapes;
    if (geometry_object_add_mesh(self->geometry, object, positions, nverts, indices, ntris, id, flip,
                                 err))
        return -1;
    shape_t *s = new_shape(self, object, material, area_light, flip, err);
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

static int add_analytic(scene_t *self, int object, shape_kind_t kind, const transform_t *to_world,
                        double radius, double height, int material, int area_light, int flip,
                        err_t *err)
{
    if (check_object(self, object, err) || check_refs(self, material, area_light, err))
        return -1;
    uint32_t id = (uint32_t)self->nshapes;
    int r = kind == SHAPE_SPHERE
                ? geometry_object_add_sphere(self->geometry, object, to_world, radius, id, flip, err)
                : geometry_object_add_disk(self->geometry, object, to_world, radius, height, id,
                                           flip, err);
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
    shape_t *s = new_shape(self, object, material, area_light, flip, err);
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

int scene_add_mesh(scene_t *self, const double *positions, size_t nverts, const uint32_t *indices,
                   size_t ntris, const double *normals, const double *uvs, int material,
                   int area_light, int flip, err_t *err)
{
    return add_mesh(self, -1, positions, nverts, indices, ntris, normals, uvs, material, area_light,
                    flip, err);
}

int scene_add_sphere(scene_t *self, const transform_t *to_world, double radius, int material,
                     int area_light, int flip, err_t *err)
{
    return add_analytic(self, -1, SHAPE_SPHERE, to_world, radius, 0.0, material, area_light, flip,
                        err);
}

int scene_add_disk(scene_t *self, const transform_t *to_world, double radius, double height,
                   int material, int area_light, int flip, err_t *err)
{
    return add_analytic(self, -1, SHAPE_DISK, to_world, radius, height, material, area_light, flip,
                        err);
}

int scene_add_curves(scene_t *self, int object, const double *cp, const double *radii,
                     const double *normals, size_t nseg, int cylinder, int flip, int material,
                     err_t *err)
{
    if (check_object(self, object, err) || check_refs(self, material, -1, err))
        return -1;
    uint32_t id = (uint32_t)self->nshapes;
    if (geometry_object_add_curves(self->geometry, object, cp, radii, normals, nseg, id, flip,
                                   err))
        return -1;
    shape_t *s = new_shape(self, object, material, -1, 0, err);
    if (!s)
        return -1;
    s->kind = SHAPE_CURVE;
    s->cylinder = cylinder;
    int failed = 0;
    s->positions = copy_array(cp, 12 * nseg * sizeof(double), &failed);
    s->radii = copy_array(radii, 4 * nseg * sizeof(double), &failed);
    s->nverts = 4 * nseg;
    s->ntris = nseg;
    if (failed)
        return err_set(err, "out of memory copying a curve of %zu segments", nseg);
    return (int)id;
}

/* A curve hit (geometry.h): dp/du the centre line's tangent, dp/dv across the ribbon (its
 * width long, toward h = 1), and for pbrt-v4's "cylinder" type the shading normal turned
 * toward dp/dv by 90 h degrees, as a round fibre's normal turns across its width. */
static void curve_surface(const scene_t *self, const shape_t *s, const hit_t *h, surface_t *out)
{
    if (h->prim >= s->ntris)
        return;
    vec3_t c, t;
    double u = fmin(1.0, fmax(0.0, h->u));
    geometry_bezier(s->positions + 12 * (size_t)h->prim, u, &c, &t);
    const double *r = s->radii + 4 * (size_t)h->prim;
    double v = 1.0 - u;
    double radius =
        v * v * v * r[0] + 3.0 * v * v * u * r[1] + 3.0 * v * u * u * r[2] + u * u * u * r[3];
    if (h->instance != GEOMETRY_NO_INSTANCE && h->instance < self->ninstances)
        t = transform_vector(&self->instances[h->instance].to_world, t);
    vec3_t across = vec3_normalize(vec3_cross(out->ng, t)); /* = dir x t: toward h = 1 */
    if (!(vec3_dot(across, across) > 0.5))
        return;
    out->dpdu = t;
    out->dpdv = vec3_scale(across, 2.0 * radius);
    if (s->cylinder) {
        double a = (PF_PI / 2.0) * (2.0 * out->v - 1.0);
        out->ns = vec3_normalize(vec3_add(vec3_scale(out->ng, cos(a)), vec3_scale(across, sin(a))));
        out->smooth = 1;
    }
}

int scene_add_object(scene_t *self, err_t *err)
{
    int g = geometry_object_new(self->geometry, err);
    if (g < 0)
        return -1;
    /* Scene objects and geometry objects are numbered alike. */
    if ((size_t)g != self->nobjects)
        return err_set(err, "object numbering went out of step (%d, %zu)", g, self->nobjects);
    self->nobjects++;
    return g;
}

int scene_add_object_mesh(scene_t *self, int object, const double *positions, size_t nverts,
                          const uint32_t *indices, size_t ntris, const double *normals,
                          const double *uvs, int material, int flip, err_t *err)
{
    if (object < 0)
        return err_set(err, "scene_add_object_mesh needs an object, got %d", object);
    return add_mesh(self, object, positions, nverts, indices, ntris, normals, uvs, material, -1,
                    flip, err);
}

int scene_add_object_sphere(scene_t *self, int object, const transform_t *to_world, double radius,
                            int material, int flip, err_t *err)
{
    if (object < 0)
        return err_set(err, "scene_add_object_sphere needs an object, got %d", object);
    return add_analytic(self, object, SHAPE_SPHERE, to_world, radius, 0.0, material, -1, flip, err);
}

int scene_add_object_disk(scene_t *self, int object, const transform_t *to_world, double radius,
                          double height, int material, int flip, err_t *err)
{
    if (object < 0)
        return err_set(err, "scene_add_object_disk needs an object, got %d", object);
    return add_analytic(self, object, SHAPE_DISK, to_world, radius, height, material, -1, flip, err);
}

int scene_add_instance(scene_t *self, int object, const transform_t *to_world, err_t *err)
{
    if (object < 0 || (size_t)object >= self->nobjects)
        return err_set(err, "there is no object %d to instance (the scene has %zu)", object,
                       self->nobjects);
    uint32_t id = (uint32_t)self->ninstances;
    if (geometry_add_instance(self->geometry, object, to_world, id, err))
        return -1;
    long i = grow((void **)&self->instances, &self->ninstances, sizeof *self->instances, err);
    if (i < 0)
        return -1;
    self->instances[i] = (instance_t){.object = object, .to_world = *to_world};
    return (int)i;
}

vec3_t scene_mesh_normal(const shape_t *s, uint32_t prim, double b1, double b2)
{
    if (s->kind != SHAPE_MESH || !s->normals || prim >= s->ntris)
        return vec3_make(0, 0, 0);
    const uint32_t *ix = s->indices + 3 * (size_t)prim;
    const double *n0 = s->normals + 3 * (size_t)ix[0], *n1 = s->normals + 3 * (size_t)ix[1],
                 *n2 = s->normals + 3 * (size_t)ix[2];
    double b0 = 1.0 - b1 - b2;
    return vec3_make(b0 * n0[0] + b1 * n1[0] + b2 * n2[0], b0 * n0[1] + b1 * n1[1] + b2 * n2[1],
                     b0 * n0[2] + b1 * n1[2] + b2 * n2[2]);
}

void scene_surface(const scene_t *self, const hit_t *h, surface_t *out)
{
    const shape_t *s = &self->shapes[h->shape];
    out->shape = s;
    out->material = &self->materials[s->material];
    out->light = s->light;
    out->p = h->p;
    out->ng = h->ng;
    out->ns = h->ng;
    out->smooth = 0;
    out->u = h->u;
    out->v = h->v;
    out->dpdu = vec3_make(0, 0, 0);
    out->dpdv = vec3_make(0, 0, 0);
    const transform_t *inst = h->instance != GEOMETRY_NO_INSTANCE && h->instance < self->ninstances
                                  ? &self->instances[h->instance].to_world
                                  : NULL;
    if (s->kind == SHAPE_CURVE) {
        curve_surface(self, s, h, out);
        return;
    }
    if (s->kind != SHAPE_MESH) {
        /* pbrt-v4's full sphere and disk: u = phi / 2 pi with phi counterclockwise about the
         * shape's z axis, so dp/du = 2 pi (-y, x, 0) in its own space; a sphere's
         * v = (theta - pi) / (0 - pi), so dp/dv = -pi (z cos phi, z sin phi, -r sin theta); a
         * disk's v = (r - rho) / r, so dp/dv = -(x, y, 0) r / rho. */
        transform_t to_world = inst ? transform_compose(*inst, s->to_world) : s->to_world;
        if (!to_world.singular) {
            transform_t from_world = transform_inverse(to_world);
            vec3_t q = transform_point(&from_world, h->p);
            out->dpdu = transform_vector(&to_world, vec3_make(-2.0 * PF_PI * q.y, 2.0 * PF_PI * q.x, 0.0));
            double rho = sqrt(q.x * q.x + q.y * q.y);
            if (rho > 0.0) {
                vec3_t d = s->kind == SHAPE_SPHERE
                               ? vec3_make(-PF_PI * q.z * q.x / rho, -PF_PI * q.z * q.y / rho, PF_PI * rho)
                               : vec3_make(-q.x * s->radius / rho, -q.y * s->radius / rho, 0.0);
                out->dpdv = transform_vector(&to_world, d);
            }
        }
        return;
    }
    const uint32_t *ix = s->indices + 3 * (size_t)h->prim;
    double t[3][2] = {{0, 0}, {1, 0}, {1, 1}}; /* pbrt-v4 Triangle: the uvs without "uv" */
    if (s->uvs)
        for (int k = 0; k < 3; k++) {
            t[k][0] = s->uvs[2 * (size_t)ix[k]];
            t[k][1] = s->uvs[2 * (size_t)ix[k] + 1];
        }
    double b0 = 1.0 - h->u - h->v;
    out->u = b0 * t[0][0] + h->u * t[1][0] + h->v * t[2][0];
    out->v = b0 * t[0][1] + h->u * t[1][1] + h->v * t[2][1];
    {
        /* pbrt-v4 Triangle::InteractionFromIntersection: dp/du from the uv differences. */
        const double *p0 = s->positions + 3 * (size_t)ix[0], *p1 = s->positions + 3 * (size_t)ix[1],
                     *p2 = s->positions + 3 * (size_t)ix[2];
        double du02 = t[0][0] - t[2][0], dv02 = t[0][1] - t[2][1];
        double du12 = t[1][0] - t[2][0], dv12 = t[1][1] - t[2][1];
        double det = du02 * dv12 - dv02 * du12;
        if (fabs(det) > 1e-12) {
            vec3_t dp02 = vec3_make(p0[0] - p2[0], p0[1] - p2[1], p0[2] - p2[2]);
            vec3_t dp12 = vec3_make(p1[0] - p2[0], p1[1] - p2[1], p1[2] - p2[2]);
            vec3_t d = vec3_scale(vec3_sub(vec3_scale(dp02, dv12), vec3_scale(dp12, dv02)), 1.0 / det);
            vec3_t e = vec3_scale(vec3_sub(vec3_scale(dp12, du02), vec3_scale(dp02, du12)), 1.0 / det);
            out->dpdu = inst ? transform_vector(inst, d) : d;
            out->dpdv = inst ? transform_vector(inst, e) : e;
        }
    }
    if (!s->normals)
        return;
    vec3_t n = scene_mesh_normal(s, h->prim, h->u, h->v);
    if (h->instance != GEOMETRY_NO_INSTANCE && h->instance < self->ninstances)
        n = transform_normal(&self->instances[h->instance].to_world, n);
    n = vec3_normalize(n);
    if (!(vec3_dot(n, n) > 0.5))
        return; /* the vertex normals cancel here: keep the geometric normal */
    out->ns = n;
    out->smooth = 1;
    if (vec3_dot(out->ng, n) < 0.0)
        out->ng = vec3_neg(out->ng);
}

double scene_light_luminance(const light_t *l)
{
    return l->spectrum ? l->scale * spectrum_photometric(l->spectrum) / CIE_Y_INTEGRAL : l->scale;
}

/* Power of a light up to constant factors common to all lights (its geometric factor times
 * its luminance), before any guard. */
static double light_power_raw(const scene_t *self, const light_t *l)
{
    /* The luminance Y = scale * integral(L y-bar) / integral(y-bar). Not scale alone: the
     * loader normalises named, blackbody and tabulated spectra to Y = 1, but a "float L" is
     * not normalised and an rgb L keeps its colour's luminance (docs/scene-format.md), so a
     * "float L" 1e9 sun had the power of a "float L" 1 lamp, and next-event estimation sent
     * 96 % of its samples to a candle of 1e-3 beside it. */
    double y = scene_light_luminance(l);
    double r = self->scene_radius;
    switch (l->kind) {
    case LIGHT_AREA:
        return y * (l->area_image ? l->area_image_y : 1.0) * PF_PI * self->shapes[l->shape].area *
               (l->twosided ? 2.0 : 1.0);
    case LIGHT_COLLIMATED:
        return y * self->shapes[l->shape].area;
    case LIGHT_POINT:
        return y * 4.0 * PF_PI;
    case LIGHT_SPOT:
        return y * 2.0 * PF_PI * (1.0 - 0.5 * (l->cos_falloff_start + l->cos_total_width));
    case LIGHT_DISTANT:
        return y * PF_PI * r * r;
    case LIGHT_INFINITE:
        /* pbrt-v4 ImageInfiniteLight::Phi: the image's mean radiance over the sphere. */
        return y * (l->envmap ? envmap_mean_luminance(l->envmap) : 1.0) * 4.0 * PF_PI * PF_PI * r * r;
    case LIGHT_GONIOMETRIC:
        /* pbrt-v4 GoniometricLight::Phi: 4 pi times the image's mean. */
        return l->gonio ? y * 4.0 * PF_PI * envmap_mean_luminance(l->gonio) : 0.0;
    case LIGHT_PROJECTION:
        return l->projmap ? y * projmap_power(l->projmap) : 0.0;
    }
    return 0.0;
}

double scene_light_power(const scene_t *self, const light_t *l)
{
    double p = light_power_raw(self, l);
    if (!(p > 0.0))
        return 0.0; /* also a NaN from an unusable spectrum: such a light is never picked */
    /* A light so bright that its power overflows (a radiance near DBL_MAX) keeps the largest
     * power that all the scene's lights can still sum to (alias tables refuse an infinite
     * total), so it is still picked almost always, as its real power would have it. */
    return fmin(p, DBL_MAX / (double)(self->nlights + 1));
}

int render_settings_buckets(const render_settings_t *rs)
{
    return rs->stokes ? 4 * rs->grid.n : rs->grid.n;
}

int material_is_sheet(material_kind_t kind)
{
    return kind == MATERIAL_POLARISER || kind == MATERIAL_RETARDER;
}

int material_has_ior(material_kind_t kind)
{
    return kind == MATERIAL_DIELECTRIC || kind == MATERIAL_THIN_DIELECTRIC ||
           kind == MATERIAL_COATED_DIFFUSE || kind == MATERIAL_COATED_CONDUCTOR;
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
    self->has_interface = 0;
    self->has_medium_boundary = 0;
    self->polarising_sheets = 0;
    /* A medium that is not simulated (NULL) is vacuum: the index becomes -1, so that a shape
     * between it and vacuum is no boundary. */
    if (self->camera_medium >= (int)self->nmedia)
        return err_set(err, "the camera's medium %d does not exist", self->camera_medium);
    if (self->camera_medium >= 0 && !self->media[self->camera_medium])
        self->camera_medium = -1;
    for (size_t i = 0; i < self->nshapes; i++) {
        shape_t *sh = &self->shapes[i];
        const material_t *m = &self->materials[sh->material];
        self->has_interface |= m->kind == MATERIAL_INTERFACE;
        self->polarising_sheets += m->kind == MATERIAL_POLARISER || m->kind == MATERIAL_RETARDER;
        int *side[2] = {&sh->medium_inside, &sh->medium_outside};
        for (int k = 0; k < 2; k++) {
            if (*side[k] >= (int)self->nmedia)
                return err_set(err, "shape %zu names medium %d, which does not exist", i, *side[k]);
            if (*side[k] >= 0 && !self->media[*side[k]])
                *side[k] = -1;
        }
        self->has_medium_boundary |= sh->medium_inside != sh->medium_outside;
    }
    /* Polarisation is carried only where something in the scene tells polarisations apart
     * (issue 28: simulate only what the scene calls for); it is never turned off here, so
     * that a caller may ask for it (the energy tests). */
    self->polarised_lights = 0;
    for (size_t i = 0; i < self->nlights; i++)
        self->polarised_lights += self->lights[i].polarisation > 0.0;
    /* A coherent crystal's interference colours and optical activity live in the carrier
     * (render/crystal_coherent.h). */
    int coherent = 0;
    for (size_t i = 0; i < self->nmaterials; i++)
        coherent += self->materials[i].needs_polarisation;
    if (self->polarising_sheets > 0 || self->camera.analyser || self->polarised_lights > 0 ||
        coherent > 0)
        self->settings.polarised = 1;
    /* Forced off (--polarized off): sheets pass their unpolarised share, the analyser and
     * polarised lights are seen as intensities (the analyser passes all); a Stokes output
     * cannot be written so. */
    if (self->settings.polarised_setting == SCENE_POLARIZED_OFF) {
        if (self->settings.stokes)
            return err_set(err, "--polarized off: the film writes Stokes layers (Film \"bool "
                                "stokes\" true), which need polarised transport");
        self->settings.polarised = 0;
    }
    for (size_t i = 0; i < self->nmaterials; i++) {
        material_t *m = &self->materials[i];
        if (!material_has_ior(m->kind))
            continue;
        if (ior_validate(&m->ior, m->name, g.lambda_min, g.lambda_max, err))
            return -1;
        /* A thin slab transmits straight through at every wavelength: its index changes
         * weights, never directions, so it never splits a path's wavelengths. */
        m->dispersive = m->kind != MATERIAL_THIN_DIELECTRIC &&
                        ior_is_dispersive(&m->ior, g.lambda_min, g.lambda_max);
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
    return scene_emitters_build(self, err);
}
