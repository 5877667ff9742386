#include "load_textures.h"

#include "load_images.h"
#include "pool.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* pbrt-v4 ImageTexture (textures.cpp, mipmap.cpp). A spectrum texture's texel is
 * clamp(scale rgb, or 1 - scale rgb with "invert", to [0, 1]) (pbrt-v4 clamps to >= 0 after
 * invert and reads reflectances as RGBAlbedoSpectrum, clamped to [0, 1]). A float texture
 * reads pbrt-v4's MIPMap::Bilerp<Float>: the alpha channel of a file whose alpha is not all 1,
 * else the mean of R, G and B; then scale and invert (max(0, 1 - v)). Scale and invert apply
 * per texel, which equals pbrt-v4's after-filter rule except at a "black" edge with invert.
 *
 * An image texture is made in three steps so that several can be made at once
 * (load_image_textures): decoded into texel values (image_decode, any thread), counted
 * against the budget (in file order), then made a texture (image_build, any thread). */
typedef struct image_job {
    const scene_texture_t *t;
    texture_image_opts_t o;
    int w, h;
    float *rgb; /* the texels, scaled, inverted and clamped as above */
    texture_t *tex;
    int state;   /* 0 not run, 1 decoded, 2 built, 3 skipped (after a failure), -1 failed (err) */
    int charged; /* its texels charged from its header (loader_budget_texels_header) */
    err_t err;
} image_job_t;

static int image_decode(image_job_t *j)
{
    const scene_texture_t *t = j->t;
    texture_image_opts_t *o = &j->o;
    *o = texture_image_opts_default();
    o->uscale = t->uscale;
    o->vscale = t->vscale;
    o->udelta = t->udelta;
    o->vdelta = t->vdelta;
    o->wrap = !strcmp(t->image.wrap, "black")              ? TEXTURE_WRAP_BLACK
              : !strcmp(t->image.wrap, "clamp")            ? TEXTURE_WRAP_CLAMP
              : !strcmp(t->image.wrap, "octahedralsphere") ? TEXTURE_WRAP_OCTAHEDRAL_SPHERE
                                                           : TEXTURE_WRAP_REPEAT;
    o->filter = !strcmp(t->image.filter, "point")      ? TEXTURE_FILTER_POINT
                : !strcmp(t->image.filter, "bilinear") ? TEXTURE_FILTER_BILINEAR
                                                       : TEXTURE_FILTER_TRILINEAR;
    o->grey = t->type == SCENE_TEXTURE_FLOAT;
    load_encoding_t enc;
    if (load_images_encoding_parse(t->image.encoding, &enc))
        return err_set(
            &j->err,
            "imagemap encoding \"%s\" is not supported (\"sRGB\", \"linear\" or \"gamma G\")",
            t->image.encoding);
    float *rgb, *alpha;
    if (load_images_read(t->image.filename, &enc, &j->w, &j->h, &rgb, &alpha, &j->err))
        return -1; /* the caller names the texture and its line */
    size_t n = (size_t)j->w * (size_t)j->h;
    int use_alpha = 0;
    if (alpha && o->grey)
        for (size_t i = 0; i < n && !use_alpha; i++)
            use_alpha = alpha[i] != 1.0f;
    double sc = t->image.scale;
    for (size_t i = 0; i < n; i++) {
        if (o->grey) {
            double v =
                use_alpha ? alpha[i] : ((double)rgb[3 * i] + rgb[3 * i + 1] + rgb[3 * i + 2]) / 3.0;
            v *= sc;
            v = t->image.invert ? fmax(0.0, 1.0 - v) : v;
            rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = (float)v;
            continue;
        }
        for (int c = 0; c < 3; c++) {
            double v = sc * rgb[3 * i + c];
            v = t->image.invert ? 1.0 - v : v;
            rgb[3 * i + c] = (float)(v > 0.0 ? (v < 1.0 ? v : 1.0) : 0.0);
        }
    }
    free(alpha);
    j->rgb = rgb;
    return 0;
}

static int image_build(image_job_t *j)
{
    j->tex = texture_new_image(j->rgb, j->w, j->h, &j->o, &j->err);
    free(j->rgb);
    j->rgb = NULL;
    return j->tex ? 0 : -1;
}

/* A pool index: decodes (state 0) or builds (state 1) one job (state 3: skipped). Never fails the
 * pool: each job keeps its own outcome, taken in file order by the caller. */
static int image_job_step(void *user, int index, err_t *err)
{
    (void)err;
    image_job_t *j = ((image_job_t **)user)[index];
    if (j->state == 0)
        j->state = image_decode(j) == 0 ? 1 : -1;
    else if (j->state == 1)
        j->state = image_build(j) == 0 ? 2 : -1;
    return 0;
}

/* Every image texture of the scene made on the pool, threads images at a time (so that the
 * decoded texels of at most that many are held at once), each with threads / images threads
 * of its own for its uplift. Within a group the images are counted against the budget in file
 * order between decoding and building; the group after a failure is not started, so the
 * first failure in file order is among those made. Jobs hold their own outcome: load_textures
 * takes them in its order. */
static int load_image_textures(loader_t *L, image_job_t *jobs, size_t n, err_t *err)
{
    int threads = L->threads > 0 ? L->threads : pool_cores();
    image_job_t **group = calloc((size_t)threads, sizeof *group);
    if (!group)
        return err_set(err, "out of memory");
    size_t i = 0;
    while (i < n) {
        int k = 0;
        for (; i < n && k < threads; i++)
            if (jobs[i].t)
                group[k++] = &jobs[i];
        int inner = threads / (k > 0 ? k : 1);
        err_t ignored;
        /* Charged from their headers in file order before any decodes: one over the budget
         * is not decoded, nor is any after it. */
        for (int q = 0, over = 0; q < k; q++) {
            image_job_t *j = group[q];
            if (over) {
                j->state = 3;
            } else if ((j->charged =
                            loader_budget_texels_header(L, j->t->image.filename, &j->err)) < 0) {
                j->state = -1;
                over = 1;
            }
        }
        (void)pool_for(threads, k, image_job_step, group, &ignored);
        int failed = 0;
        for (int q = 0; q < k; q++) {
            image_job_t *j = group[q];
            if (failed) {
                free(j->rgb); /* not built: after the first failure */
                j->rgb = NULL;
                j->state = 3;
                continue;
            }
            if (j->state == 1 && !j->charged && loader_budget_texels(L, j->w, j->h, &j->err))
                j->state = -1;
            if (j->state != 1)
                failed = 1;
            else
                j->o.threads = inner;
        }
        (void)pool_for(threads, k, image_job_step, group, &ignored);
        if (failed)
            break;
    }
    free(group);
    return 0;
}

const texture_t *load_textures_normal_map(loader_t *L, const char *path, pbrt_loc_t at, err_t *err)
{
    load_encoding_t enc;
    load_images_encoding_parse("linear", &enc);
    int w, h;
    float *rgb = NULL, *alpha;
    int charged = loader_budget_texels_header(L, path, err);
    if (charged < 0 || load_images_read(path, &enc, &w, &h, &rgb, &alpha, err)) {
        err_prefix(err, "%s:%d:%d: normalmap: ", at.file, at.line, at.col);
        return NULL;
    }
    free(alpha);
    if (!charged && loader_budget_texels(L, w, h, err)) {
        err_prefix(err, "%s:%d:%d: normalmap: ", at.file, at.line, at.col);
        free(rgb);
        return NULL;
    }
    texture_t *t = texture_new_normalmap(rgb, w, h, err);
    free(rgb);
    if (!t || scene_own_texture(L->sc, t, err))
        return NULL;
    return t;
}

/* pbrt-v4's procedural textures (scene/texture.h): the 3D ones read the point in the space of
 * the CTM at their Texture directive, as pbrt-v4's PointTransformMapping does. NULL with err
 * set when an input or the texture cannot be made. */
static texture_t *load_procedural(loader_t *L, const scene_texture_t *t, err_t *err)
{
    const int spectral = t->type == SCENE_TEXTURE_SPECTRUM;
    const scene_float_input_t *fi[4] = {&t->float_in1, &t->float_in2, &t->float_in3, &t->float_in4};
    const scene_spectrum_input_t *si[4] = {&t->spec_in1, &t->spec_in2, &t->spec_in3, &t->spec_in4};
    const int ninputs = t->cls == SCENE_TEX_BILERP                                     ? 4
                        : t->cls == SCENE_TEX_DOTS || t->cls == SCENE_TEX_DIRECTIONMIX ? 2
                                                                                       : 0;
    const texture_t *in[4] = {NULL};
    for (int k = 0; k < ninputs; k++)
        if (!(in[k] = spectral ? loader_spectrum_input(L, si[k], SPEC_REFLECTANCE, err)
                               : loader_float_input(L, fi[k], err)))
            return NULL;
    const texture_uv_map_t map = {t->uscale, t->vscale, t->udelta, t->vdelta};
    const transform_t to_texture = transform_inverse(t->to_world);
    switch (t->cls) {
    case SCENE_TEX_BILERP:
        return texture_new_bilerp(in[0], in[1], in[2], in[3], map, err);
    case SCENE_TEX_DOTS:
        return texture_new_dots(in[0], in[1], map, err);
    case SCENE_TEX_FBM:
        return texture_new_fbm(to_texture, t->noise.octaves, t->noise.roughness, err);
    case SCENE_TEX_WRINKLED:
        return texture_new_wrinkled(to_texture, t->noise.octaves, t->noise.roughness, err);
    case SCENE_TEX_WINDY:
        return texture_new_windy(to_texture, err);
    case SCENE_TEX_MARBLE:
        return texture_new_marble(to_texture, t->noise.octaves, t->noise.roughness, t->noise.scale,
                                  t->noise.variation, err);
    case SCENE_TEX_DIRECTIONMIX:
        return texture_new_directionmix(
            in[0], in[1],
            transform_vector(&t->to_world, vec3_make(t->dir[0], t->dir[1], t->dir[2])), err);
    default:
        err_set(err, "not a procedural texture (internal error)");
        return NULL;
    }
}

static int load_textures_in_order(loader_t *L, image_job_t *jobs, err_t *err)
{
    const scene_desc_t *d = L->desc;
    for (size_t i = 0; i < d->ntextures; i++) {
        const scene_texture_t *t = &d->textures[i];
        int spectral = t->type == SCENE_TEXTURE_SPECTRUM;
        const texture_t *a = NULL, *b = NULL;
        if (t->cls != SCENE_TEX_IMAGEMAP && t->cls != SCENE_TEX_BILERP &&
            t->cls != SCENE_TEX_DOTS && (t->udelta != 0.0 || t->vdelta != 0.0))
            return pbrt_error(err, t->loc, "texture \"%s\": udelta/vdelta are not supported",
                              t->name);
        texture_t *made = NULL;
        switch (t->cls) {
        case SCENE_TEX_CONSTANT:
            a = spectral ? loader_spectrum_input(L, &t->spec_in1, SPEC_REFLECTANCE, err)
                         : loader_float_input(L, &t->float_in1, err);
            if (!a)
                return -1;
            L->tex[i] = (texture_t *)a;
            continue;
        case SCENE_TEX_CHECKERBOARD:
            a = spectral ? loader_spectrum_input(L, &t->spec_in1, SPEC_REFLECTANCE, err)
                         : loader_float_input(L, &t->float_in1, err);
            b = spectral ? loader_spectrum_input(L, &t->spec_in2, SPEC_REFLECTANCE, err)
                         : loader_float_input(L, &t->float_in2, err);
            if (!a || !b)
                return -1;
            made = t->dimension == 3
                       ? texture_new_checkerboard3d(a, b, transform_inverse(t->to_world), err)
                       : texture_new_checkerboard(a, b, t->uscale, t->vscale, err);
            break;
        case SCENE_TEX_BILERP:
        case SCENE_TEX_DOTS:
        case SCENE_TEX_FBM:
        case SCENE_TEX_WRINKLED:
        case SCENE_TEX_WINDY:
        case SCENE_TEX_MARBLE:
        case SCENE_TEX_DIRECTIONMIX:
            made = load_procedural(L, t, err);
            break;
        case SCENE_TEX_SCALE: {
            a = spectral ? loader_spectrum_input(L, &t->spec_in1, SPEC_REFLECTANCE, err)
                         : loader_float_input(L, &t->float_in1, err);
            const texture_t *s = loader_float_input(L, &t->amount, err);
            if (!a || !s)
                return -1;
            made = texture_new_scale(a, s, err);
            break;
        }
        case SCENE_TEX_MIX: {
            a = spectral ? loader_spectrum_input(L, &t->spec_in1, SPEC_REFLECTANCE, err)
                         : loader_float_input(L, &t->float_in1, err);
            b = spectral ? loader_spectrum_input(L, &t->spec_in2, SPEC_REFLECTANCE, err)
                         : loader_float_input(L, &t->float_in2, err);
            const texture_t *m = loader_float_input(L, &t->amount, err);
            if (!a || !b || !m)
                return -1;
            made = texture_new_mix(a, b, m, err);
            break;
        }
        case SCENE_TEX_IMAGEMAP:
            if (jobs[i].state == 2) {
                made = jobs[i].tex;
                jobs[i].tex = NULL;
            } else if (jobs[i].state == -1) {
                *err = jobs[i].err;
            } else {
                err_set(err, "not made (internal error)");
            }
            break;
        }
        /* pbrt-v4's other 2D mappings wrap the texture made with the identity uv mapping. */
        const bool planar2d = t->cls == SCENE_TEX_IMAGEMAP || t->cls == SCENE_TEX_BILERP ||
                              t->cls == SCENE_TEX_DOTS ||
                              (t->cls == SCENE_TEX_CHECKERBOARD && t->dimension == 2);
        if (made && planar2d && t->map.kind != 0) {
            if (scene_own_texture(L->sc, made, err))
                return -1;
            const texture_mapping_t kinds[] = {TEXTURE_MAP_SPHERICAL, TEXTURE_MAP_SPHERICAL,
                                               TEXTURE_MAP_CYLINDRICAL, TEXTURE_MAP_PLANAR};
            made = texture_new_mapped(made, kinds[t->map.kind], transform_inverse(t->to_world),
                                      vec3_make(t->map.v1[0], t->map.v1[1], t->map.v1[2]),
                                      vec3_make(t->map.v2[0], t->map.v2[1], t->map.v2[2]),
                                      t->map.ds, t->map.dt, err);
        }
        if (!made || scene_own_texture(L->sc, made, err)) {
            if (made)
                return -1;
            char why[sizeof err->msg]; /* err->msg cannot be its own argument */
            snprintf(why, sizeof why, "%s", err->msg);
            return pbrt_error(err, t->loc, "texture \"%s\": %s", t->name, why);
        }
        L->tex[i] = made;
    }
    return 0;
}

int load_textures(loader_t *L, err_t *err)
{
    const scene_desc_t *d = L->desc;
    image_job_t *jobs = calloc(d->ntextures ? d->ntextures : 1, sizeof *jobs);
    if (!jobs)
        return err_set(err, "out of memory");
    for (size_t i = 0; i < d->ntextures; i++)
        if (d->textures[i].cls == SCENE_TEX_IMAGEMAP)
            jobs[i].t = &d->textures[i];
    int rc = load_image_textures(L, jobs, d->ntextures, err);
    if (rc == 0)
        rc = load_textures_in_order(L, jobs, err);
    for (size_t i = 0; i < d->ntextures; i++) {
        free(jobs[i].rgb);
        texture_destroy(&jobs[i].tex);
    }
    free(jobs);
    return rc;
}
