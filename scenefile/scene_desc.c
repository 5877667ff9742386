#include "scene_desc.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static int grow(void **array, size_t *count, size_t *cap, size_t elem, err_t *err)
{
    if (*count == *cap) {
        size_t ncap = *cap ? *cap * 2 : 8;
        if (ncap > (size_t)INT32_MAX)
            return err_set(err, "scene has too many elements");
        void *p = realloc(*array, ncap * elem);
        if (!p)
            return err_set(err, "out of memory while building the scene");
        *array = p;
        *cap = ncap;
    }
    memset((char *)*array + *count * elem, 0, elem);
    return (int)(*count)++;
}

#define ADD(self, field, cap_field, err)                                                           \
    grow((void **)&(self)->field, &(self)->n##field, &(self)->cap_field, sizeof *(self)->field, err)

int scene_desc_add_material(scene_desc_t *self, err_t *err)
{
    return ADD(self, materials, cap_materials, err);
}
int scene_desc_add_texture(scene_desc_t *self, err_t *err)
{
    return ADD(self, textures, cap_textures, err);
}
int scene_desc_add_light(scene_desc_t *self, err_t *err)
{
    return ADD(self, lights, cap_lights, err);
}
int scene_desc_add_area_light(scene_desc_t *self, err_t *err)
{
    return ADD(self, area_lights, cap_area_lights, err);
}
int scene_desc_add_shape(scene_desc_t *self, bool in_object, err_t *err)
{
    int i = in_object ? ADD(self, object_shapes, cap_object_shapes, err) : ADD(self, shapes, cap_shapes, err);
    if (i >= 0) {
        scene_shape_t *s = in_object ? &self->object_shapes[i] : &self->shapes[i];
        s->inside_medium = s->outside_medium = -1;
    }
    return i;
}
int scene_desc_add_medium(scene_desc_t *self, err_t *err)
{
    return ADD(self, media, cap_media, err);
}
int scene_desc_find_medium(const scene_desc_t *self, const char *name)
{
    for (size_t i = 0; name && i < self->nmedia; i++)
        if (!strcmp(self->media[i].name, name))
            return (int)i;
    return -1;
}
int scene_desc_add_object(scene_desc_t *self, err_t *err)
{
    return ADD(self, objects, cap_objects, err);
}
int scene_desc_add_instance(scene_desc_t *self, err_t *err)
{
    return ADD(self, instances, cap_instances, err);
}

int scene_desc_add_file(scene_desc_t *self, err_t *err)
{
    return ADD(self, files, cap_files, err);
}

int scene_desc_adopt(scene_desc_t *self, void *ptr, err_t *err)
{
    if (!ptr)
        return 0;
    if (self->nowned == self->cap_owned) {
        size_t ncap = self->cap_owned ? self->cap_owned * 2 : 64;
        void **p = realloc(self->owned, ncap * sizeof *p);
        if (!p) {
            free(ptr);
            return err_set(err, "out of memory while building the scene");
        }
        self->owned = p;
        self->cap_owned = ncap;
    }
    self->owned[self->nowned++] = ptr;
    return 0;
}

void *scene_desc_alloc(scene_desc_t *self, size_t size, err_t *err)
{
    void *p = calloc(1, size ? size : 1);
    if (!p) {
        err_set(err, "out of memory (%zu bytes) while building the scene", size);
        return NULL;
    }
    if (scene_desc_adopt(self, p, err) != 0)
        return NULL;
    return p;
}

const char *scene_desc_strdup(scene_desc_t *self, const char *s, err_t *err)
{
    size_t n = strlen(s);
    char *p = scene_desc_alloc(self, n + 1, err);
    if (p)
        memcpy(p, s, n + 1);
    return p;
}

scene_desc_t *scene_desc_new(err_t *err)
{
    scene_desc_t *self = calloc(1, sizeof *self);
    if (!self) {
        err_set(err, "out of memory for a scene");
        return NULL;
    }
    if (!(self->warnings = warnings_new(err))) {
        free(self);
        return NULL;
    }
    self->camera.type = "perspective";
    self->camera.fov = 90.0;
    self->camera.lensradius = 0.0;
    self->camera.focaldistance = 1e6;
    self->camera.camera_from_world = transform_identity();

    self->film.type = SCENE_FILM_RGB;
    self->film.xres = SCENE_FILM_XRES_DEFAULT;
    self->film.yres = SCENE_FILM_YRES_DEFAULT;
    self->film.filename = "pbrt.exr";
    self->film.nbuckets = SCENE_RGB_NBUCKETS_DEFAULT;
    self->film.lambda_min = SCENE_RGB_LAMBDA_MIN_DEFAULT;
    self->film.lambda_max = SCENE_RGB_LAMBDA_MAX_DEFAULT;
    self->film.iso = 100.0;
    self->film.exposuretime = 1.0;
    self->film.sensor = "cie1931";
    self->film.diagonal = 35.0;
    self->film.maxcomponentvalue = INFINITY;
    /* pbrt-v4 scene.cpp: a scene without PixelFilter gets the gaussian filter's defaults. */
    self->filter = (scene_filter_t){.type = "gaussian", .xradius = 1.5, .yradius = 1.5,
                                    .sigma = 0.5, .b = 1.0 / 3.0, .c = 1.0 / 3.0, .tau = 3.0};

    self->camera.medium = -1;
    self->sampler.type = "zsobol";
    self->sampler.pixelsamples = 16;

    self->integrator.type = "auto";
    self->integrator.params = params_new("Integrator \"auto\"", err);
    if (!self->integrator.params) {
        free(self);
        return NULL;
    }

    /* pbrt-v4 starts every scene with an anonymous "diffuse" material of reflectance 0.5. */
    int m = scene_desc_add_material(self, err);
    if (m < 0) {
        scene_desc_destroy(&self);
        return NULL;
    }
    self->materials[m].type = "diffuse"; /* no parameters: its class's defaults */
    return self;
}

void scene_desc_destroy(scene_desc_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    scene_desc_t *self = *self_p;
    params_destroy(&self->integrator.params);
    for (size_t i = 0; i < self->nmaterials; i++)
        params_destroy(&self->materials[i].params);
    for (size_t i = 0; i < self->nowned; i++)
        free(self->owned[i]);
    free(self->owned);
    free(self->materials);
    free(self->textures);
    free(self->lights);
    free(self->area_lights);
    free(self->media);
    free(self->shapes);
    free(self->objects);
    free(self->object_shapes);
    free(self->instances);
    free(self->files);
    warnings_destroy(&self->warnings);
    free(self);
    *self_p = NULL;
}

int scene_desc_find_texture(const scene_desc_t *self, const char *name, scene_texture_type_t type)
{
    for (size_t i = 0; i < self->ntextures; i++)
        if (self->textures[i].type == type && !strcmp(self->textures[i].name, name))
            return (int)i;
    return -1;
}

int scene_desc_find_material(const scene_desc_t *self, const char *name)
{
    for (size_t i = 0; i < self->nmaterials; i++)
        if (self->materials[i].name && !strcmp(self->materials[i].name, name))
            return (int)i;
    return -1;
}

int scene_desc_find_object(const scene_desc_t *self, const char *name)
{
    for (size_t i = 0; i < self->nobjects; i++)
        if (!strcmp(self->objects[i].name, name))
            return (int)i;
    return -1;
}

int scene_desc_find_file(const scene_desc_t *self, const char *relative)
{
    for (size_t i = 0; i < self->nfiles; i++)
        if (!strcmp(self->files[i].relative, relative))
            return (int)i;
    return -1;
}

size_t scene_desc_triangle_count(const scene_desc_t *self)
{
    size_t n = 0;
    for (size_t i = 0; i < self->nshapes; i++)
        if (self->shapes[i].type == SCENE_SHAPE_MESH)
            n += self->shapes[i].mesh.ntriangles;
    for (size_t i = 0; i < self->ninstances; i++) {
        const scene_object_t *o = &self->objects[self->instances[i].object];
        for (size_t j = 0; j < o->nshapes; j++) {
            const scene_shape_t *s = &self->object_shapes[o->first_shape + j];
            if (s->type == SCENE_SHAPE_MESH)
                n += s->mesh.ntriangles;
        }
    }
    return n;
}
