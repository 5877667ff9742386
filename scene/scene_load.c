#include "scene_load.h"

#include "load_images.h"
#include "load_materials.h"
#include "load_textures.h"
#include "loader.h"
#include "cie.h"
#include "colour.h"
#include "files.h"
#include "glass.h"
#include "hair.h"
#include "image_exr.h"
#include "image_info.h"
#include "image_pfm.h"
#include "image_png.h"
#include "image_stb.h"
#include "microfacet.h"
#include "named_spectra.h"
#include "pbrt_parser.h"
#include "plan.h"
#include "pool.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

/* The name of a light's kind in messages: LightSource "...". */
static const char *light_kind_word(scene_light_type_t t)
{
    return t == SCENE_LIGHT_GONIOMETRIC ? "goniometric" : t == SCENE_LIGHT_PROJECTION ? "projection" : "infinite";
}

static int read_light_image(loader_t *L, const scene_light_t *dl, float **rgb, int *w, int *h, err_t *err)
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
    if (load_images_read_at(L, a->filename, a->filename_loc, "AreaLightSource \"diffuse\"", &rgb, &w, &h, err))
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
        err_set(err, "%s: image is %dx%d, not square: a goniometric light's image is an equal-area "
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

static int load_lights(loader_t *L, err_t *err)
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
                return pbrt_error(err, dl->loc, "spot light: \"from\" and \"to\" are the same point");
            l.direction = vec3_normalize(dir);
            l.cos_total_width = cos(dl->coneangle * PF_PI / 180.0);
            l.cos_falloff_start = cos((dl->coneangle - dl->conedeltaangle) * PF_PI / 180.0);
            break;
        case SCENE_LIGHT_DISTANT:
            l.kind = LIGHT_DISTANT;
            if (!(vec3_length(dir) > 0))
                return pbrt_error(err, dl->loc, "distant light: \"from\" and \"to\" are the same point");
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
                return pbrt_error(err, dl->loc, l.kind == LIGHT_INFINITE
                                                    ? "\"illuminance\" cannot be met by an image "
                                                      "that is black above the horizon"
                                                : l.kind == LIGHT_SPOT
                                                    ? "\"power\" cannot be met by a spot light of zero width"
                                                    : "\"power\" cannot be met by a black image");
            l.scale *= dl->power / k_e;
        }
        light_polarisation(&l, &dl->to_world, dl->polarization, dl->polarization_angle);
        if (scene_add_light(L->sc, &l, err) < 0)
            return err_prefix(err, "%s:%d:%d: ", dl->loc.file, dl->loc.line, dl->loc.col);
    }
    return 0;
}

/* pbrt-v4 DiffuseAreaLight "power": scale *= power / k_e with k_e = pi A (2 pi A when
 * two-sided), A the area of the shape, so that the light emits that power. pbrt-v4 makes one
 * light per triangle of a mesh, each emitting the whole power over its own area; prismfarm's
 * light is the whole mesh, so it follows pbrt-v4 exactly when the triangles have equal areas
 * (quads, regular meshes: n triangles emit n times the power) and refuses other meshes.
 * A collimated light carries its radiance through its area: k_e = A. */
static int load_lights_area_power(loader_t *L, const scene_area_light_t *a, const shape_t *sh, light_t *l,
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
                return pbrt_error(err, a->loc,
                                  "\"power\" on a mesh whose triangles differ in area is not supported "
                                  "(pbrt-v4 gives each triangle that power); use \"scale\"");
        }
        n = (double)sh->ntris;
    }
    double k_e = l->kind == LIGHT_COLLIMATED ? sh->area : PF_PI * sh->area * (l->twosided ? 2.0 : 1.0);
    if (!(k_e > 0.0))
        return pbrt_error(err, a->loc, "\"power\" on a shape of zero area");
    /* pbrt-v4: an image's k_e is also multiplied by the mean of its texels' luminance. */
    if (l->area_image && !((k_e *= l->area_image_y) > 0.0))
        return pbrt_error(err, a->loc, "\"power\" cannot be met by a black image");
    l->scale *= n * a->power / k_e;
    return 0;
}

/* A shape's AreaLightSource as a light of the scene (its index into *light, -1 when the shape
 * has none); the shape itself is added after it. */
static int load_lights_area(loader_t *L, const scene_shape_t *s, int object, int *light,
                            err_t *err)
{
    *light = -1;
    if (s->area_light < 0)
        return 0;
    const scene_area_light_t *a = &L->desc->area_lights[s->area_light];
    if (object >= 0)
        return pbrt_error(err, s->loc, "area lights are not supported in instanced objects");
    light_t l = {.kind = a->type == SCENE_AREA_COLLIMATED ? LIGHT_COLLIMATED : LIGHT_AREA,
                 .scale = a->scale, .twosided = a->twosided};
    if (!(l.spectrum = loader_light_spectrum(L->sc, &a->L, err)))
        return -1;
    if (a->filename && !(l.area_image = load_area_image(L, a, &l.area_image_y, err)))
        return -1;
    light_polarisation(&l, &s->to_world, a->polarization, a->polarization_angle);
    if ((*light = scene_add_light(L->sc, &l, err)) < 0)
        return err_prefix(err, "%s:%d:%d: ", a->loc.file, a->loc.line, a->loc.col);
    return 0;
}

/* MakeNamedMedium into the scene's media, in the description's order (shapes and the camera
 * name them by index). The coefficients are unbounded spectra (pbrt-v4
 * SpectrumType::Unbounded); the emission Le is normalised as a light's spectrum is (pbrt-v4
 * divides Lescale by SpectrumToPhotometric(Le)), and a black Le is none. Media that are not
 * simulated (the parser warned) are NULL entries: vacuum. */
static int load_media(loader_t *L, err_t *err)
{
    const scene_desc_t *d = L->desc;
    for (size_t i = 0; i < d->nmedia; i++) {
        const scene_medium_t *dm = &d->media[i];
        medium_t *m = NULL;
        if (dm->type != SCENE_MEDIUM_IGNORED) {
            medium_params_t p = {.scale = dm->scale, .g = dm->g, .Le_scale = dm->Le_scale};
            if (!(p.sigma_a = loader_owned_spectrum(L->sc, &dm->sigma_a, SPEC_UNBOUNDED, err)) ||
                !(p.sigma_s = loader_owned_spectrum(L->sc, &dm->sigma_s, SPEC_UNBOUNDED, err)))
                return -1;
            int black = dm->Le.kind == SCENE_SPECTRUM_CONSTANT ? !(dm->Le.constant > 0.0)
                        : dm->Le.kind == SCENE_SPECTRUM_RGB
                            ? !(dm->Le.rgb[0] > 0.0 || dm->Le.rgb[1] > 0.0 || dm->Le.rgb[2] > 0.0)
                            : 0;
            if (dm->has_Le && !black && dm->Le_scale > 0.0 && !(p.Le = loader_light_spectrum(L->sc, &dm->Le, err)))
                return -1;
            m = dm->type == SCENE_MEDIUM_GRID
                    ? medium_new_grid(&p, dm->nx, dm->ny, dm->nz, dm->density, dm->p0, dm->p1, &dm->to_world, err)
                    : medium_new_homogeneous(&p, err);
            if (!m)
                return err_prefix(err, "%s:%d:%d: MakeNamedMedium \"%s\": ", dm->loc.file, dm->loc.line,
                                  dm->loc.col, dm->name);
        }
        if (scene_add_medium(L->sc, m, err) < 0)
            return -1;
    }
    L->sc->camera_medium = d->camera.medium;
    return 0;
}

/* pbrt-v4 "curve": its Bezier segments placed by the shape's transform; the widths scale by
 * the transform's mean linear scale (pbrt-v4 intersects in the curve's own space, so a
 * non-uniform scale widens it unevenly there), and a segment's radius is linear in u from half
 * its first width to half its last, as pbrt-v4 lerps the width. */
static int load_curve(loader_t *L, const scene_shape_t *s, int object, int material, err_t *err)
{
    const transform_t *m = &s->to_world;
    vec3_t ex = transform_vector(m, vec3_make(1, 0, 0)),
           ey = transform_vector(m, vec3_make(0, 1, 0)),
           ez = transform_vector(m, vec3_make(0, 0, 1));
    double scale = cbrt(fabs(vec3_dot(vec3_cross(ex, ey), ez)));
    size_t n = s->curve_segments;
    double *cp = malloc(12 * n * sizeof *cp), *radii = malloc(4 * n * sizeof *radii);
    if (!cp || !radii) {
        free(cp);
        free(radii);
        return err_set(err, "out of memory for a curve of %zu segments", n);
    }
    for (size_t i = 0; i < 4 * n; i++) {
        vec3_t p = transform_point(
            m, vec3_make(s->curve_cp[3 * i], s->curve_cp[3 * i + 1], s->curve_cp[3 * i + 2]));
        cp[3 * i] = p.x;
        cp[3 * i + 1] = p.y;
        cp[3 * i + 2] = p.z;
        const double *w = s->curve_width + 2 * (i / 4);
        radii[i] = 0.5 * scale * (w[0] + (w[1] - w[0]) * (double)(i % 4) / 3.0);
    }
    int r = scene_add_curves(L->sc, object, cp, radii, n, s->curve_cylinder, material, err);
    free(cp);
    free(radii);
    return r;
}

/* Adds one shape to the world (object < 0, in world space) or to a scene object (in the
 * object's space); the shape's own transform is applied here. */
static int load_shapes_add(loader_t *L, const scene_shape_t *s, int object, err_t *err)
{
    const scene_desc_t *d = L->desc;
    int light;
    if (load_lights_area(L, s, object, &light, err))
        return -1;
    const transform_t *to_world = &s->to_world;
    int flip = s->flip_normals;
    const int material = load_materials_for_shape(L, s->material, to_world, err);
    if (material < 0 && s->material >= 0)
        return -1;
    int r;
    if (s->type == SCENE_SHAPE_SPHERE) {
        r = object < 0 ? scene_add_sphere(L->sc, to_world, s->radius, material, light, flip, err)
                       : scene_add_object_sphere(L->sc, object, to_world, s->radius, material, flip, err);
    } else if (s->type == SCENE_SHAPE_DISK) {
        r = object < 0 ? scene_add_disk(L->sc, to_world, s->radius, s->height, material, light, flip, err)
                       : scene_add_object_disk(L->sc, object, to_world, s->radius, s->height, material,
                                               flip, err);
    } else if (s->type == SCENE_SHAPE_CURVE) {
        r = load_curve(L, s, object, material, err);
    } else {
        const scene_mesh_t *m = &s->mesh;
        double *P = malloc(3 * m->nvertices * sizeof *P);
        double *N = m->N ? malloc(3 * m->nvertices * sizeof *N) : NULL;
        if (!P || (m->N && !N)) {
            free(P);
            free(N);
            return err_set(err, "out of memory for a mesh of %zu vertices", m->nvertices);
        }
        /* pbrt-v4 TriangleMesh: vertex normals map as normals and turn with
         * ReverseOrientation (not with a handedness swap). */
        double nsign = s->reverse_orientation ? -1.0 : 1.0;
        for (size_t v = 0; v < m->nvertices; v++) {
            vec3_t p = transform_point(to_world, vec3_make(m->P[3 * v], m->P[3 * v + 1], m->P[3 * v + 2]));
            P[3 * v] = p.x;
            P[3 * v + 1] = p.y;
            P[3 * v + 2] = p.z;
            if (N) {
                vec3_t n = vec3_normalize(transform_normal(to_world, vec3_make(m->N[3 * v], m->N[3 * v + 1], m->N[3 * v + 2])));
                N[3 * v] = nsign * n.x;
                N[3 * v + 1] = nsign * n.y;
                N[3 * v + 2] = nsign * n.z;
            }
        }
        r = object < 0 ? scene_add_mesh(L->sc, P, m->nvertices, m->indices, m->ntriangles, N, m->uv,
                                        material, light, flip, err)
                       : scene_add_object_mesh(L->sc, object, P, m->nvertices, m->indices, m->ntriangles,
                                               N, m->uv, material, flip, err);
        free(P);
        free(N);
    }
    if (r < 0)
        return err_prefix(err, "%s:%d:%d: Shape \"%s\": ", s->loc.file, s->loc.line, s->loc.col, s->kind);
    L->sc->shapes[r].medium_inside = s->inside_medium;
    L->sc->shapes[r].medium_outside = s->outside_medium;
    if (s->has_alpha) {
        if (!(L->sc->shapes[r].alpha = loader_float_input(L, &s->alpha, err)))
            return -1;
        L->sc->has_alpha = 1;
    }
    if (light >= 0 && d->area_lights[s->area_light].power > 0.0)
        return load_lights_area_power(L, &d->area_lights[s->area_light], &L->sc->shapes[r],
                                &L->sc->lights[light], err);
    return 0;
}

/* The world's shapes, in file order. */
static int load_shapes(loader_t *L, err_t *err)
{
    for (size_t i = 0; i < L->desc->nshapes; i++)
        if (load_shapes_add(L, &L->desc->shapes[i], -1, err))
            return -1;
    return 0;
}

/* ObjectInstance as Embree instances: each object that is instanced at least once becomes one
 * scene object holding its shapes once, and every instance places it. Objects never
 * instanced, and empty ones, are left out. */
static int load_instances(loader_t *L, err_t *err)
{
    const scene_desc_t *d = L->desc;
    if (d->ninstances == 0)
        return 0;
    int *made = malloc(d->nobjects * sizeof *made);
    if (!made)
        return err_set(err, "out of memory");
    for (size_t i = 0; i < d->nobjects; i++)
        made[i] = -1;
    int r = 0;
    for (size_t i = 0; !r && i < d->ninstances; i++) {
        const scene_instance_t *in = &d->instances[i];
        const scene_object_t *o = &d->objects[in->object];
        if (o->nshapes == 0)
            continue;
        if (made[in->object] < 0) {
            int obj = scene_add_object(L->sc, err);
            if (obj < 0) {
                r = -1;
                break;
            }
            for (size_t k = 0; !r && k < o->nshapes; k++)
                r = load_shapes_add(L, &d->object_shapes[o->first_shape + k], obj, err);
            made[in->object] = obj;
        }
        if (!r && scene_add_instance(L->sc, made[in->object], &in->to_world, err) < 0)
            r = err_prefix(err, "%s:%d:%d: ObjectInstance \"%s\": ", in->loc.file, in->loc.line,
                           in->loc.col, o->name);
    }
    free(made);
    return r;
}

/* Integrator "photon" (docs/rendering.md): the photon pass's parameters; the gather decides
 * the camera pass's integrator. Read whenever the file names "photon", so that an override to
 * another integrator does not leave them unused. */
static int load_photon(loader_t *L, params_t *p, int enable, err_t *err)
{
    render_settings_t *rs = &L->sc->settings;
    photon_settings_t *ph = &rs->photon;
    int photons, k, mono, mindepth;
    double radius, threshold, density;
    const char *store, *gather;
    if (params_get_int(p, "photons", 1000000, &photons, err) ||
        params_get_string(p, "store", "photonmap", &store, err) ||
        params_get_float(p, "radius", 0.0, &radius, err) || params_get_int(p, "k", 0, &k, err) ||
        params_get_string(p, "gather", "path", &gather, err) ||
        params_get_float(p, "threshold", 0.01, &threshold, err) ||
        params_get_int(p, "monochromerays", 1, &mono, err) ||
        params_get_float(p, "lightmapdensity", 400.0, &density, err) ||
        params_get_int(p, "mindepth", 1, &mindepth, err))
        return -1;
    if (photons < 1)
        return pbrt_error(err, params_find(p, "photons")->loc, "\"integer photons\" must be at least 1, got %d", photons);
    if (strcmp(store, "photonmap") != 0 && strcmp(store, "lightmap") != 0)
        return pbrt_error(err, params_find(p, "store")->loc,
                          "\"string store\" must be \"photonmap\" or \"lightmap\", got \"%s\"", store);
    if (!(radius >= 0.0) || !isfinite(radius))
        return pbrt_error(err, params_find(p, "radius")->loc, "\"float radius\" must be positive, got %g", radius);
    if (params_find(p, "radius") && !(radius > 0.0))
        return pbrt_error(err, params_find(p, "radius")->loc, "\"float radius\" must be positive, got %g", radius);
    if (k < 0 || k > 1024)
        return pbrt_error(err, params_find(p, "k")->loc, "\"integer k\" must be in 0..1024, got %d", k);
    if (!(density > 0.0 && density <= 1e7))
        return pbrt_error(err, params_find(p, "lightmapdensity")->loc,
                          "\"float lightmapdensity\" must be in (0, 1e7] texels per unit area, got %g", density);
    if (mindepth < 1 || mindepth > 10000)
        return pbrt_error(err, params_find(p, "mindepth")->loc, "\"integer mindepth\" must be in 1..10000, got %d", mindepth);
    if (!(threshold >= 0.0 && threshold < 1.0))
        return pbrt_error(err, params_find(p, "threshold")->loc, "\"float threshold\" must be in [0, 1), got %g", threshold);
    /* 64: PHOTON_MAX_MONOCHROME_RAYS (render/photon.h), the lanes a photon can carry. */
    if (mono < 1 || mono > 64)
        return pbrt_error(err, params_find(p, "monochromerays")->loc,
                          "\"integer monochromerays\" must be in 1..64, got %d", mono);
    integrator_kind_t g;
    if (!strcmp(gather, "path"))
        g = INTEGRATOR_PATH;
    else if (!strcmp(gather, "whitted"))
        g = INTEGRATOR_WHITTED;
    else
        return pbrt_error(err, params_find(p, "gather")->loc, "\"string gather\" must be \"path\" or \"whitted\", got \"%s\"", gather);
    if (!enable)
        return 0;
    rs->integrator = g;
    ph->enabled = 1;
    ph->photons = (uint64_t)photons;
    ph->radius = radius;
    ph->k = k;
    ph->maxdepth = rs->maxdepth;
    ph->threshold = threshold;
    ph->monochromerays = mono;
    ph->store = !strcmp(store, "lightmap") ? PHOTON_STORE_LIGHTMAP : PHOTON_STORE_PHOTONMAP;
    ph->lightmap_density = density;
    ph->mindepth = mindepth;
    return 0;
}

/* A pbrt-v4 integrator read as one of prismfarm's (scenefile/integrators.c): the warning that
 * says which and why, and one for each of its parameters that is accepted but not simulated.
 * from_file: the file's integrator is the one used (no --integrator override). */
static int load_pbrt_mapping(loader_t *L, const integrator_name_t *named, bool from_file, err_t *err)
{
    const scene_integrator_t *in = &L->desc->integrator;
    if (!named->mapped_from_pbrt)
        return 0;
    if (from_file && named->why && warnings_add(L->sc->warnings, in->loc, "%s", named->why))
        return err_set(err, "out of memory");
    for (const char *const *n = named->ignored; n && *n; n++) {
        param_t *q = params_find(in->params, *n);
        if (!q)
            continue;
        q->used = true;
        if (from_file && warnings_add(L->sc->warnings, q->loc, "\"%s\" of Integrator \"%s\" is not simulated", *n,
                         named->name))
            return err_set(err, "out of memory");
    }
    return 0;
}

/* pbrt-v4's SPPMIntegrator (photonsperiteration -1: one photon per pixel; radius 1; as many
 * iterations as the sampler's pixelsamples) read as the photon integrator: one pass of
 * photonsperiteration x pixelsamples photons at the fixed radius, gathered by the path tracer. */
static int load_sppm(loader_t *L, params_t *p, int enable, err_t *err)
{
    render_settings_t *rs = &L->sc->settings;
    photon_settings_t *ph = &rs->photon;
    int ppi;
    double radius;
    if (params_get_int(p, "photonsperiteration", -1, &ppi, err) ||
        params_get_float(p, "radius", 1.0, &radius, err))
        return -1;
    if (ppi == 0 || ppi < -1)
        return pbrt_error(err, params_find(p, "photonsperiteration")->loc,
                          "\"integer photonsperiteration\" must be positive or -1, got %d", ppi);
    if (!(radius > 0.0) || !isfinite(radius))
        return pbrt_error(err, params_find(p, "radius")->loc, "\"float radius\" must be positive, got %g", radius);
    if (!enable)
        return 0;
    uint64_t per = ppi > 0 ? (uint64_t)ppi
                           : (uint64_t)(rs->full_xres ? rs->full_xres : rs->xres) *
                                 (uint64_t)(rs->full_yres ? rs->full_yres : rs->yres);
    uint64_t n = per * (uint64_t)rs->spp;
    rs->integrator = INTEGRATOR_PATH;
    ph->enabled = 1;
    ph->photons = n > (uint64_t)INT32_MAX ? (uint64_t)INT32_MAX : n;
    ph->radius = radius;
    ph->k = 0;
    ph->maxdepth = rs->maxdepth;
    ph->store = PHOTON_STORE_PHOTONMAP;
    return 0;
}

static int load_integrator(loader_t *L, const scene_overrides_t *ov, err_t *err)
{
    const scene_integrator_t *in = &L->desc->integrator;
    render_settings_t *rs = &L->sc->settings;
    params_t *p = in->params;
    const char *type = ov && ov->integrator ? ov->integrator : in->type;
    snprintf(L->sc->integrator_asked, sizeof L->sc->integrator_asked, "%s", type ? type : "");
    const integrator_name_t *named = integrators_find(type);
    if (!named) {
        char names[INTEGRATORS_LIST_MAX];
        integrators_list(false, names, sizeof names);
        const char *best = integrators_suggest(type);
        if (best)
            return pbrt_error(err, in->loc, "Integrator \"%s\" is not supported yet (did you mean \"%s\"? use %s)",
                              type, best, names);
        return pbrt_error(err, in->loc, "Integrator \"%s\" is not supported yet (use %s)", type,
                          names);
    }
    /* Media are simulated by the integrators whose pbrt-v4 counterparts simulate them
     * (integrators.h); pbrt-v4's "path" ignores them as well (its PathIntegrator has no
     * medium code), so there the image is pbrt-v4's. The photon passes do not carry them. */
    size_t simulated = 0;
    for (size_t i = 0; i < L->desc->nmedia; i++)
        simulated += L->desc->media[i].type != SCENE_MEDIUM_IGNORED;
    rs->media = 0;
    if (simulated > 0) {
        const char *fmt = NULL;
        if (named->photon)
            fmt = "the scene's %zu %s ignored: the \"%s\" integrator's photon pass and its gather "
                  "do not simulate participating media (Integrator \"volpath\" does)";
        else if (!named->media && !named->mapped_from_pbrt)
            fmt = "the scene's %zu %s ignored; pbrt-v4's \"%s\" integrator ignores media too, so "
                  "the image is the one pbrt-v4 renders (Integrator \"volpath\" renders them)";
        else if (!named->media)
            fmt = "the scene's %zu %s ignored: the \"%s\" integrator's fog, haze and absorption "
                  "are missing from the image";
        else
            rs->media = 1;
        if (fmt && warnings_add(L->sc->warnings, L->desc->media_loc, fmt, simulated,
                                simulated == 1 ? "medium is" : "media are", type))
            return err_set(err, "out of memory");
    }
    if (named->refused)
        return pbrt_error(err, in->loc, "Integrator \"%s\" is not supported: %s", type, named->refused);
    int photon = named->photon;
    rs->integrator = named->kind;
    const integrator_name_t *file_named = integrators_find(in->type);
    if (file_named && load_pbrt_mapping(L, file_named, !strcmp(type, in->type), err))
        return -1;
    int maxdepth, split_depth;
    const char *disp, *wl;
    bool spectral_mis, polarized;
    if (params_get_int(p, "maxdepth", 5, &maxdepth, err) ||
        params_get_int(p, "splitdepth", rs->split_depth, &split_depth, err) ||
        params_get_bool(p, "spectralmis", true, &spectral_mis, err) ||
        params_get_bool(p, "polarized", false, &polarized, err) ||
        params_get_string(p, "dispersion", integrators_dispersion_name(DISPERSION_HERO), &disp,
                          err) ||
        params_get_string(p, "wavelengths", "uniform", &wl, err))
        return -1;
    if (maxdepth < 0 || maxdepth > 10000)
        return pbrt_error(err, in->loc, "\"integer maxdepth\" must be in 0..10000, got %d", maxdepth);
    rs->maxdepth = maxdepth;
    if (split_depth < 0 || split_depth > 8)
        return pbrt_error(err, in->loc, "\"integer splitdepth\" must be in 0..8, got %d",
                          split_depth);
    rs->split_depth = split_depth;
    rs->spectral_mis = spectral_mis;
    /* Polarised transport asked for by the file (docs/physics.md §14): what the plan's pilot
     * advises where ignoring polarisation would change the image by more than 1 %. */
    rs->polarised |= polarized;
    rs->polarised_asked = polarized;
    if (!strcmp(named->name, "sppm") || !strcmp(in->type, "sppm")) {
        if (load_sppm(L, p, !strcmp(named->name, "sppm"), err))
            return -1;
    } else if ((photon || !strcmp(in->type, "photon")) && load_photon(L, p, photon, err)) {
        return -1;
    }
    if (ov && ov->dispersion)
        disp = ov->dispersion;
    if (!integrators_dispersion_find(disp, &rs->dispersion))
        return pbrt_error(err, in->loc, "\"string dispersion\" must be \"hero\" or \"fanout\", got \"%s\"", disp);
    if (!strcmp(wl, "uniform"))
        rs->visible_sampling = 0;
    else if (!strcmp(wl, "visible"))
        rs->visible_sampling = 1;
    else
        return pbrt_error(err, in->loc, "\"string wavelengths\" must be \"uniform\" or \"visible\", got \"%s\"", wl);
    if (rs->integrator == INTEGRATOR_PATH) {
        /* pbrt-v4's PathIntegrator options: how next-event estimation chooses lights (the
         * light BVH by default, scene/emitters.h) and regularisation (a biased blur of
         * specular paths after a non-specular bounce, bsdf/regularize.h). */
        bool regularize;
        const char *ls;
        if (params_get_bool(p, "regularize", false, &regularize, err) ||
            params_get_string(p, "lightsampler", "bvh", &ls, err))
            return -1;
        rs->regularize = regularize;
        if (regularize && photon &&
            warnings_add(L->sc->warnings, params_find(p, "regularize")->loc,
                         "\"bool regularize\" is ignored with a photon pass: its store already "
                         "carries the caustics that regularisation would blur"))
            return err_set(err, "out of memory");
        if (!strcmp(ls, "bvh"))
            rs->light_sampler = LIGHT_SAMPLER_BVH;
        else if (!strcmp(ls, "power"))
            rs->light_sampler = LIGHT_SAMPLER_POWER;
        else if (!strcmp(ls, "uniform"))
            rs->light_sampler = LIGHT_SAMPLER_UNIFORM;
        else
            return pbrt_error(err, params_find(p, "lightsampler")->loc,
                              "\"string lightsampler\" must be \"bvh\", \"power\" or \"uniform\", got \"%s\"", ls);
    }
    return params_check_unused(p, err);
}

/* Camera "realistic": the lens system for the full film (its diagonal and aspect), focused
 * and its exit pupil bounded over the film's wavelengths (optics/lens.h). pbrt-v4 warns when
 * the stop is clamped; prismfarm also says which elements got a default glass. */
static int load_lens(loader_t *L, err_t *err)
{
    const scene_camera_t *c = &L->desc->camera;
    render_settings_t *rs = &L->sc->settings;
    camera_t *cam = &L->sc->camera;
    lens_params_t lp = {.file = c->lens_path,
                        .glasses = c->glasses,
                        .nglasses = c->nglasses,
                        .aperture_diameter_mm = c->aperturediameter,
                        .focus_distance = c->focusdistance,
                        .film_diagonal = L->desc->film.diagonal / 1000.0,
                        .xres = rs->full_xres > 0 ? rs->full_xres : rs->xres,
                        .yres = rs->full_yres > 0 ? rs->full_yres : rs->yres,
                        .lambda_min = rs->grid.lambda_min,
                        .lambda_max = rs->grid.lambda_max};
    cam->lens = lens_system_new(c->lens_text, c->lens_len, &lp, err);
    if (!cam->lens)
        return err_prefix(err, "%s:%d:%d: Camera \"realistic\": ", c->lens_loc.file, c->lens_loc.line,
                          c->lens_loc.col);
    cam->lens_dispersive = 0;
    for (int i = 0; i < lens_system_count(cam->lens); i++) {
        const lens_element_t *e = lens_system_element(cam->lens, i);
        cam->lens_dispersive |= e->glass && ior_is_dispersive(&e->ior, rs->grid.lambda_min, rs->grid.lambda_max);
    }
    if (lens_system_clamped(cam->lens) &&
        warnings_add(L->sc->warnings, c->lens_loc,
                     "\"float aperturediameter\" %g mm is larger than the lens file's stop: the stop is kept",
                     c->aperturediameter))
        return err_set(err, "out of memory");
    if (lens_system_defaulted(cam->lens)) {
        char names[512] = "";
        for (int i = 0; i < lens_system_count(cam->lens); i++) {
            const lens_element_t *e = lens_system_element(cam->lens, i);
            size_t n = strlen(names);
            if (e->defaulted && n + 48 < sizeof names)
                snprintf(names + n, sizeof names - n, "%s%.4f -> %s", n ? ", " : "", e->eta_d, e->glass_name);
        }
        if (warnings_add(L->sc->warnings, c->lens_loc,
                         "%d lens elements name no glass: each gets the catalogue glass nearest in n_d, "
                         "shifted to the file's n_d, for its dispersion (%s); name them in a fifth column or "
                         "\"string glasses\"",
                         lens_system_defaulted(cam->lens), names))
            return err_set(err, "out of memory");
    }
    return 0;
}

/* pbrt-v4 FilmBaseParameters: pixelbounds [x0 x1 y0 y1] clipped to the film, or the crop
 * window [x0 x1 y0 y1] (clamped to [0, 1]) as pixels ceil(res * x0) .. ceil(res * x1). The
 * rendered image is the bounds' size; full_xres keeps the film's (see scene.h). */
static int load_film_crop(loader_t *L, err_t *err)
{
    const scene_film_t *f = &L->desc->film;
    render_settings_t *rs = &L->sc->settings;
    if (!f->has_crop && !f->has_pixelbounds)
        return 0;
    int x0, x1, y0, y1;
    if (f->has_crop) {
        double c[4];
        for (int i = 0; i < 4; i++)
            c[i] = fmin(fmax(f->cropwindow[i], 0.0), 1.0);
        x0 = (int)ceil(rs->xres * fmin(c[0], c[1]));
        x1 = (int)ceil(rs->xres * fmax(c[0], c[1]));
        y0 = (int)ceil(rs->yres * fmin(c[2], c[3]));
        y1 = (int)ceil(rs->yres * fmax(c[2], c[3]));
    } else {
        x0 = f->pixelbounds[0] > 0 ? f->pixelbounds[0] : 0;
        x1 = f->pixelbounds[1] < rs->xres ? f->pixelbounds[1] : rs->xres;
        y0 = f->pixelbounds[2] > 0 ? f->pixelbounds[2] : 0;
        y1 = f->pixelbounds[3] < rs->yres ? f->pixelbounds[3] : rs->yres;
    }
    if (x1 <= x0 || y1 <= y0)
        return pbrt_error(err, f->crop_loc, "the film's %s leaves no pixel of the %dx%d image",
                          f->has_crop ? "\"cropwindow\"" : "\"pixelbounds\"", rs->xres, rs->yres);
    rs->full_xres = rs->xres;
    rs->full_yres = rs->yres;
    rs->crop_x0 = x0;
    rs->crop_y0 = y0;
    rs->xres = x1 - x0;
    rs->yres = y1 - y0;
    return 0;
}

static int load_filter(loader_t *L, err_t *err)
{
    const scene_filter_t *f = &L->desc->filter;
    scene_t *sc = L->sc;
    int kind = filter_kind_find(f->type);
    if (kind < 0)
        return pbrt_error(err, f->loc, "unsupported filter \"%s\"", f->type ? f->type : "");
    filter_params_t p = filter_params_default((filter_kind_t)kind);
    p.xradius = f->xradius;
    p.yradius = f->yradius;
    p.sigma = f->sigma;
    p.b = f->b;
    p.c = f->c;
    p.tau = f->tau;
    sc->settings.filter = p;
    filter_sampler_destroy(&sc->filter);
    sc->filter = filter_sampler_new(&p, err);
    if (!sc->filter)
        return err_prefix(err, "%s:%d:%d: PixelFilter: ", f->loc.file ? f->loc.file : "", f->loc.line, f->loc.col);
    return 0;
}

static int load_options(loader_t *L, const scene_overrides_t *ov, err_t *err)
{
    const scene_desc_t *d = L->desc;
    scene_t *sc = L->sc;
    render_settings_t *rs = &sc->settings;
    if (!strcmp(d->camera.type, "perspective"))
        sc->camera.kind = CAMERA_PERSPECTIVE;
    else if (!strcmp(d->camera.type, "orthographic"))
        sc->camera.kind = CAMERA_ORTHOGRAPHIC;
    else if (!strcmp(d->camera.type, "spherical"))
        sc->camera.kind = CAMERA_SPHERICAL;
    else if (!strcmp(d->camera.type, "realistic"))
        sc->camera.kind = CAMERA_REALISTIC;
    else
        return pbrt_error(err, d->camera.loc,
                          "Camera \"%s\" is not supported (perspective, orthographic, spherical or realistic)",
                          d->camera.type);
    if (d->camera.camera_from_world.singular)
        return pbrt_error(err, d->camera.loc, "the camera transform is singular");
    sc->camera.camera_to_world = transform_inverse(d->camera.camera_from_world);
    sc->camera.fov_deg = d->camera.fov;
    sc->camera.lens_radius = d->camera.lensradius;
    sc->camera.focal_distance = d->camera.focaldistance;
    sc->camera.equirect = d->camera.equirect;
    memcpy(sc->camera.screen, d->camera.screenwindow, sizeof sc->camera.screen);
    sc->camera.frame_aspect = d->camera.frameaspectratio;
    sc->camera.analyser = d->camera.has_analyzer;
    sc->camera.analyser_angle = d->camera.analyzer * (PF_PI / 180.0);
    if (sc->camera.kind == CAMERA_PERSPECTIVE && !(d->camera.fov > 0 && d->camera.fov < 180))
        return pbrt_error(err, d->camera.loc, "\"float fov\" must be in (0, 180) degrees, got %g", d->camera.fov);
    rs->xres = ov && ov->xres > 0 ? ov->xres : d->film.xres;
    rs->yres = ov && ov->yres > 0 ? ov->yres : d->film.yres;
    if (rs->xres <= 0 || rs->yres <= 0 || rs->xres > 32768 || rs->yres > 32768)
        return pbrt_error(err, d->film.loc, "film resolution %dx%d is outside 1..32768", rs->xres, rs->yres);
    if (load_film_crop(L, err) || load_filter(L, err))
        return -1;
    rs->imaging_ratio = d->film.exposuretime * d->film.iso / 100.0;
    rs->max_component = d->film.maxcomponentvalue;
    if (strcmp(d->film.sensor, "cie1931") != 0 || d->film.whitebalance != 0.0) {
        sc->sensor = sensor_new(d->film.sensor, d->film.whitebalance, err);
        if (!sc->sensor) {
            pbrt_loc_t at = strcmp(d->film.sensor, "cie1931") != 0 ? d->film.sensor_loc : d->film.whitebalance_loc;
            return err_prefix(err, "%s:%d:%d: Film: ", at.file, at.line, at.col);
        }
    }
    if (spectral_grid_init(&rs->grid, d->film.nbuckets, d->film.lambda_min, d->film.lambda_max, err))
        return err_prefix(err, "%s:%d:%d: Film: ", d->film.loc.file, d->film.loc.line, d->film.loc.col);
    /* A Stokes output is polarised transport's: it turns it on (scene_finish keeps it). */
    rs->stokes = d->film.stokes;
    rs->polarised |= rs->stokes;
    /* budget.h: the merged image is the master's largest allocation (all its planes:
     * render_settings_buckets); checked before any geometry or texture is built. */
    const int image_buckets = render_settings_buckets(rs);
    uint64_t image =
        scene_budget_image_bytes((uint64_t)rs->xres, (uint64_t)rs->yres, (uint64_t)image_buckets);
    if (L->budget && L->budget->image_bytes && image > L->budget->image_bytes)
        return pbrt_error(err, d->film.loc,
                          "Film: the merged image of %dx%d pixels and %d buckets takes %.1f MiB, "
                          "over the master's budget of %.0f MiB (prismfarm master "
                          "--max-image-mb)",
                          rs->xres, rs->yres, image_buckets, (double)image / 1048576.0,
                          (double)L->budget->image_bytes / 1048576.0);
    rs->film_spectral = d->film.type == SCENE_FILM_SPECTRAL;
    if (sc->camera.kind == CAMERA_REALISTIC && load_lens(L, err))
        return -1;
    snprintf(rs->filename, sizeof rs->filename, "%s", d->film.filename ? d->film.filename : "");
    rs->spp = ov && ov->spp > 0 ? ov->spp : d->sampler.pixelsamples;
    if (rs->spp <= 0 || rs->spp > (1 << 24))
        return pbrt_error(err, d->sampler.loc, "pixelsamples must be in 1..%d, got %d", 1 << 24, rs->spp);
    rs->seed = ov && ov->seed >= 0 ? (uint64_t)ov->seed : (uint64_t)(uint32_t)d->sampler.seed;
    const char *why;
    if (sampler_kind_parse(d->sampler.type, &rs->sampler, &why))
        return pbrt_error(err, d->sampler.loc, "unsupported sampler \"%s\"", d->sampler.type);
    if (why && warnings_add(L->sc->warnings, d->sampler.loc, "%s", why))
        return err_set(err, "out of memory");
    return 0;
}

scene_t *scene_load(const scene_desc_t *desc, const scene_overrides_t *ov, err_t *err)
{
    scene_t *sc = scene_new(err);
    if (!sc)
        return NULL;
    loader_t L = {
        .desc = desc, .sc = sc, .budget = ov ? ov->budget : NULL, .threads = ov ? ov->threads : 0};
    L.tex = calloc(desc->ntextures ? desc->ntextures : 1, sizeof *L.tex);
    int r = L.tex ? 0 : err_set(err, "out of memory");
    if (!r && (!(sc->warnings = warnings_new(err)) || warnings_copy(sc->warnings, desc->warnings)))
        r = err_set(err, "out of memory");
    if (!r)
        r = load_options(&L, ov, err);
    if (!r)
        r = load_integrator(&L, ov, err);
    if (!r)
        r = load_textures(&L, err);
    if (!r)
        r = load_materials(&L, err);
    if (!r)
        r = load_lights(&L, err);
    if (!r)
        r = load_media(&L, err);
    if (!r)
        r = load_shapes(&L, err);
    if (!r)
        r = load_instances(&L, err);
    free(L.tex);
    /* pbrt-v4 renders a scene without lights black, silently; say why the image is black. */
    if (!r && sc->nlights == 0) {
        pbrt_loc_t at = desc->camera.loc;
        at.line = at.line > 0 ? at.line : 1;
        at.col = at.col > 0 ? at.col : 1;
        if (warnings_add(sc->warnings, at, "the scene has no light source: the image will be black"))
            r = err_set(err, "out of memory");
    }
    if (!r)
        r = scene_finish(sc, err);
    /* Integrator "auto" (also when the file names none) follows the plan (plan.h). */
    if (!r)
        r = plan_apply_auto(sc, desc, ov, err);
    /* The plan may choose the photon integrator for "auto": its passes carry no media. */
    if (!r && sc->settings.media && sc->settings.photon.enabled) {
        sc->settings.media = 0;
        if (warnings_add(sc->warnings, desc->media_loc,
                         "the scene's media are ignored: the plan chose the photon integrator, "
                         "whose passes do not simulate participating media (Integrator "
                         "\"volpath\" does)"))
            r = err_set(err, "out of memory");
    }
    if (r) {
        scene_destroy(&sc);
        return NULL;
    }
    return sc;
}

scene_t *scene_load_file(const char *path, const scene_overrides_t *ov, err_t *err)
{
    scene_desc_t *d =
        pbrt_parse_file_opts(path, &(pbrt_parse_opts_t){.threads = ov ? ov->threads : 0}, err);
    if (!d)
        return NULL;
    scene_t *s = scene_load(d, ov, err);
    scene_desc_destroy(&d);
    return s;
}

scene_t *scene_load_file_confined(const char *path, const char *root, const scene_overrides_t *ov,
                                  err_t *err)
{
    if (!root)
        return err_set(err, "a confined parse needs the scene's folder"), NULL;
    pbrt_parse_opts_t po = {
        .root = root, .budget = ov ? ov->budget : NULL, .threads = ov ? ov->threads : 0};
    scene_desc_t *d = pbrt_parse_file_opts(path, &po, err);
    if (!d)
        return NULL;
    scene_t *s = scene_load(d, ov, err);
    scene_desc_destroy(&d);
    return s;
}
