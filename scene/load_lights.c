#include "load_lights.h"

#include "colour.h"
#include "load_images.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The name of a light's kind in messages: LightSource "...". */
static const char *light_kind_word(scene_light_type_t t)
{
    return t == SCENE_LIGHT_GONIOMETRIC  ? "goniometric"
           : t == SCENE_LIGHT_PROJECTION ? "projection"
                                         : "infinite";
}

static int read_light_image(loader_t *L, const scene_light_t *dl, float **rgb, int *w, int *h,
                            err_t *err)
{
    char what[64];
    snprintf(what, sizeof what, "LightSource \"%s\"", light_kind_word(dl->type));
    return load_images_read_at(L, dl->filename, dl->filename_loc, what, rgb, w, h, err);
}

/* A diffuse area light's image (pbrt-v4 DiffuseAreaLight with "filename") into a texture the
 * scene owns: per texel the RGB illuminant factor m s(lambda) (rgb_uplift, as image textures),
 * read bilinearly and clamped at the edges as pbrt-v4's Image::BilerpChannel does, at
 * pbrt-v4's (u, 1 - v); *mean_y is the mean of the texels' luminances. */
static const texture_t *load_area_image(loader_t *L, const scene_area_light_t *a, double *mean_y,
                                        err_t *err)
{
    float *rgb;
    int w, h;
    if (load_images_read_at(L, a->filename, a->filename_loc, "AreaLightSource \"diffuse\"", &rgb,
                            &w, &h, err))
        return NULL;
    double sum = 0.0;
    size_t n = (size_t)w * (size_t)h;
    if (envmap_check_texels(rgb, w, h, a->filename, err)) {
        char why[sizeof err->msg];
        snprintf(why, sizeof why, "%s", err->msg);
        pbrt_error(err, a->filename_loc, "AreaLightSource \"diffuse\": %s", why);
        free(rgb);
        return NULL;
    }
    for (size_t i = 0; i < n; i++)
        sum += colour_luminance((rgb_t){rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]});
    *mean_y = sum / (double)n;
    texture_image_opts_t o = texture_image_opts_default();
    o.wrap = TEXTURE_WRAP_CLAMP;
    o.filter = TEXTURE_FILTER_BILINEAR;
    texture_t *t = texture_new_image(rgb, w, h, &o, err);
    free(rgb);
    if (!t || scene_own_texture(L->sc, t, err)) {
        char why[sizeof err->msg];
        snprintf(why, sizeof why, "%s", err->msg);
        pbrt_error(err, a->filename_loc, "AreaLightSource \"diffuse\": %s", why);
        return NULL;
    }
    return t;
}

/* The message of err, prefixed with the light's "filename" location and kind; returns NULL. */
static void *light_image_error(const scene_light_t *dl, err_t *err)
{
    char why[sizeof err->msg];
    snprintf(why, sizeof why, "%s", err->msg);
    pbrt_error(err, dl->filename_loc, "LightSource \"%s\": %s", light_kind_word(dl->type), why);
    return NULL;
}

/* An "infinite" light's image into an envmap the scene owns. */
static const envmap_t *load_envmap(loader_t *L, const scene_light_t *dl, err_t *err)
{
    float *rgb;
    int w, h;
    if (read_light_image(L, dl, &rgb, &w, &h, err))
        return NULL;
    envmap_t *e = envmap_new(rgb, w, h, dl->filename, err);
    free(rgb);
    if (!e || scene_own_envmap(L->sc, e, err))
        return light_image_error(dl, err);
    return e;
}

/* A goniometric light's image (pbrt-v4 GoniometricLight::Create): square, in the equal-area
 * octahedral layout, each texel reduced to the average of its channels (pbrt-v4 keeps one "Y"
 * channel, the RGB average), held as a grey envmap so that its value is that average at
 * every wavelength and its sampling, lookup and mean are envmap's. */
static const envmap_t *load_gonio(loader_t *L, const scene_light_t *dl, err_t *err)
{
    float *rgb;
    int w, h;
    if (read_light_image(L, dl, &rgb, &w, &h, err))
        return NULL;
    envmap_t *e = NULL;
    if (w != h) {
        err_set(err,
                "%s: image is %dx%d, not square: a goniometric light's image is an equal-area "
                "octahedral map (pbrt-v4 refuses it too)",
                dl->filename, w, h);
    } else {
        for (size_t i = 0; i < (size_t)w * (size_t)h; i++) {
            float *p = rgb + 3 * i;
            /* In double: three channels near FLT_MAX sum past it, their average does not. */
            float avg = (float)(((double)p[0] + p[1] + p[2]) / 3.0);
            /* A negative, NaN or infinite channel is kept, for envmap_new to refuse by name. */
            for (int c = 0; c < 3; c++)
                if (!(p[c] >= 0.0f) || !isfinite(p[c]))
                    avg = p[c];
            p[0] = p[1] = p[2] = avg;
        }
        e = envmap_new(rgb, w, h, dl->filename, err);
    }
    free(rgb);
    if (!e || scene_own_envmap(L->sc, e, err))
        return light_image_error(dl, err);
    return e;
}

/* A projection light's image (pbrt-v4 ProjectionLight::Create), any size. */
static const projmap_t *load_projmap(loader_t *L, const scene_light_t *dl, err_t *err)
{
    float *rgb;
    int w, h;
    if (read_light_image(L, dl, &rgb, &w, &h, err))
        return NULL;
    projmap_t *m = projmap_new(rgb, w, h, dl->fov, dl->filename, err);
    free(rgb);
    if (!m || scene_own_projmap(L->sc, m, err))
        return light_image_error(dl, err);
    return m;
}

/* A light's polarisation (docs/physics.md §14.2): its degree, and its plane's direction in
 * world space from the angle in the x-y plane of the space to_world maps (the light's CTM, or
 * the emitting shape's). A transform that flattens that plane leaves the light unpolarised. */
static void light_polarisation(light_t *l, const transform_t *to_world, double degree,
                               double angle_deg)
{
    const double a = angle_deg * (PF_PI / 180.0);
    const vec3_t axis = transform_vector(to_world, vec3_make(cos(a), sin(a), 0.0));
    if (!(degree > 0.0) || !(vec3_length(axis) > 0.0))
        return;
    l->polarisation = degree;
    l->polarisation_axis = vec3_normalize(axis);
}

int load_lights(loader_t *L, err_t *err)
{
    const scene_desc_t *d = L->desc;
    for (size_t i = 0; i < d->nlights; i++) {
        const scene_light_t *dl = &d->lights[i];
        light_t l = {.scale = dl->scale, .shape = -1};
        if (!(l.spectrum = loader_light_spectrum(L->sc, &dl->spectrum, err)))
            return -1;
        vec3_t from = transform_point(&dl->to_world, dl->from);
        vec3_t to = transform_point(&dl->to_world, dl->to);
        vec3_t dir = vec3_sub(to, from);
        switch (dl->type) {
        case SCENE_LIGHT_POINT:
            l.kind = LIGHT_POINT;
            l.position = from;
            break;
        case SCENE_LIGHT_SPOT:
            l.kind = LIGHT_SPOT;
            l.position = from;
            if (!(vec3_length(dir) > 0))
                return pbrt_error(err, dl->loc,
                                  "spot light: \"from\" and \"to\" are the same point");
            l.direction = vec3_normalize(dir);
            l.cos_total_width = cos(dl->coneangle * PF_PI / 180.0);
            l.cos_falloff_start = cos((dl->coneangle - dl->conedeltaangle) * PF_PI / 180.0);
            break;
        case SCENE_LIGHT_DISTANT:
            l.kind = LIGHT_DISTANT;
            if (!(vec3_length(dir) > 0))
                return pbrt_error(err, dl->loc,
                                  "distant light: \"from\" and \"to\" are the same point");
            l.direction = vec3_normalize(dir);
            break;
        case SCENE_LIGHT_INFINITE:
            l.kind = LIGHT_INFINITE;
            l.from_light = dl->to_world;
            l.to_light = transform_inverse(dl->to_world);
            if (dl->filename && !(l.envmap = load_envmap(L, dl, err)))
                return -1;
            break;
        case SCENE_LIGHT_GONIOMETRIC: {
            /* pbrt-v4 lights.cpp: renderFromLight * swapYZ, so light-space (x, y, z) is the
             * CTM's (x, z, y) and the image centre (+z) points along the CTM's +y. */
            const transform_t swap = transform_from_matrix(
                (const double[4][4]){{1, 0, 0, 0}, {0, 0, 1, 0}, {0, 1, 0, 0}, {0, 0, 0, 1}});
            l.kind = LIGHT_GONIOMETRIC;
            l.position = transform_point(&dl->to_world, vec3_make(0, 0, 0));
            l.from_light = transform_compose(dl->to_world, swap);
            l.to_light = transform_inverse(l.from_light);
            if (!(l.gonio = load_gonio(L, dl, err)))
                return -1;
            break;
        }
        case SCENE_LIGHT_PROJECTION: {
            /* pbrt-v4 lights.cpp: renderFromLight * Scale(1, -1, 1), so that the image's top
             * row lands toward the CTM's +y. */
            const transform_t flip = transform_scale(1.0, -1.0, 1.0);
            l.kind = LIGHT_PROJECTION;
            l.position = transform_point(&dl->to_world, vec3_make(0, 0, 0));
            l.from_light = transform_compose(dl->to_world, flip);
            l.to_light = transform_inverse(l.from_light);
            if (!(l.projmap = load_projmap(L, dl, err)))
                return -1;
            break;
        }
        }
        /* pbrt-v4 lights.cpp: with its spectrum normalised, a light of scale 1 has power (or
         * illuminance) k_e; "power" / "illuminance" multiplies scale by target / k_e. */
        if (dl->power > 0.0) {
            double k_e = 1.0;
            if (l.kind == LIGHT_POINT)
                k_e = 4.0 * PF_PI;
            else if (l.kind == LIGHT_SPOT)
                k_e = 2.0 * PF_PI * (1.0 - 0.5 * (l.cos_falloff_start + l.cos_total_width));
            else if (l.kind == LIGHT_INFINITE)
                /* uniform radiance L gives illuminance pi L; an image, what its upper
                 * hemisphere gives (pbrt-v4 lights.cpp, "illuminance") */
                k_e = l.envmap ? envmap_upper_illuminance(l.envmap) : PF_PI;
            else if (l.kind == LIGHT_GONIOMETRIC)
                /* 4 pi times the mean of the image's channel averages */
                k_e = 4.0 * PF_PI * envmap_mean_luminance(l.gonio);
            else if (l.kind == LIGHT_PROJECTION)
                /* A / N times the sum of Y cos^3 over the texels (projmap.h) */
                k_e = projmap_power(l.projmap);
            if (!(k_e > 0.0))
                return pbrt_error(
                    err, dl->loc,
                    l.kind == LIGHT_INFINITE ? "\"illuminance\" cannot be met by an image "
                                               "that is black above the horizon"
                    : l.kind == LIGHT_SPOT ? "\"power\" cannot be met by a spot light of zero width"
                                           : "\"power\" cannot be met by a black image");
            l.scale *= dl->power / k_e;
        }
        light_polarisation(&l, &dl->to_world, dl->polarization, dl->polarization_angle);
        if (scene_add_light(L->sc, &l, err) < 0)
            return err_prefix(err, "%s:%d:%d: ", dl->loc.file, dl->loc.line, dl->loc.col);
    }
    return 0;
}

int load_lights_area_power(loader_t *L, const scene_area_light_t *a, const shape_t *sh, light_t *l,
                           err_t *err)
{
    (void)L;
    double n = 1.0;
    if (sh->kind == SHAPE_MESH) {
        double first = -1.0;
        for (size_t t = 0; t < sh->ntris; t++) {
            const double *p0 = sh->positions + 3 * sh->indices[3 * t];
            const double *p1 = sh->positions + 3 * sh->indices[3 * t + 1];
            const double *p2 = sh->positions + 3 * sh->indices[3 * t + 2];
            vec3_t e1 = vec3_make(p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]);
            vec3_t e2 = vec3_make(p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]);
            double area = 0.5 * vec3_length(vec3_cross(e1, e2));
            if (first < 0.0)
                first = area;
            else if (fabs(area - first) > 1e-6 * first)
                return pbrt_error(
                    err, a->loc,
                    "\"power\" on a mesh whose triangles differ in area is not supported "
                    "(pbrt-v4 gives each triangle that power); use \"scale\"");
        }
        n = (double)sh->ntris;
    }
    double k_e =
        l->kind == LIGHT_COLLIMATED ? sh->area : PF_PI * sh->area * (l->twosided ? 2.0 : 1.0);
    if (!(k_e > 0.0))
        return pbrt_error(err, a->loc, "\"power\" on a shape of zero area");
    /* pbrt-v4: an image's k_e is also multiplied by the mean of its texels' luminance. */
    if (l->area_image && !((k_e *= l->area_image_y) > 0.0))
        return pbrt_error(err, a->loc, "\"power\" cannot be met by a black image");
    l->scale *= n * a->power / k_e;
    return 0;
}

int load_lights_area(loader_t *L, const scene_shape_t *s, int object, int *light, err_t *err)
{
    *light = -1;
    if (s->area_light < 0)
        return 0;
    const scene_area_light_t *a = &L->desc->area_lights[s->area_light];
    if (object >= 0)
        return pbrt_error(err, s->loc, "area lights are not supported in instanced objects");
    light_t l = {.kind = a->type == SCENE_AREA_COLLIMATED ? LIGHT_COLLIMATED : LIGHT_AREA,
                 .scale = a->scale,
                 .twosided = a->twosided};
    if (!(l.spectrum = loader_light_spectrum(L->sc, &a->L, err)))
        return -1;
    if (a->filename && !(l.area_image = load_area_image(L, a, &l.area_image_y, err)))
        return -1;
    light_polarisation(&l, &s->to_world, a->polarization, a->polarization_angle);
    if ((*light = scene_add_light(L->sc, &l, err)) < 0)
        return err_prefix(err, "%s:%d:%d: ", a->loc.file, a->loc.line, a->loc.col);
    return 0;
}
