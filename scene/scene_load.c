#include "scene_load.h"

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
#include "medium_file.h"
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

typedef enum { SPEC_REFLECTANCE, SPEC_ILLUMINANT, SPEC_UNBOUNDED } spec_use_t;

/* The message for a string that is neither a named spectrum nor a file (pbrt-v4 looks for the
 * name first, then for a file; the parser found no file). */
static void unknown_spectrum(const scene_spectrum_t *s, const char *what, err_t *err)
{
    char names[1024];
    pbrt_error(err, s->loc, "\"%s\" is neither a named spectrum nor a spectrum file (looked for %s); %s: %s",
               s->name, s->searched ? s->searched : "no file", what, named_spectra_list(names, sizeof names));
}

/* A named spectrum (pbrt-v4 spectrum.cpp Spectra::Init). stdillum-D65 and stdillum-A keep
 * prismfarm's CIE D65 table (data/d65_5nm.csv: pbrt-v4's table within 5.5e-8 relative) and the
 * CIE formula for A (pbrt-v4 tabulates it at 5 nm), so lights, which normalise their spectrum
 * anyway, are as before; used otherwise they are normalised to luminance 1 as pbrt-v4 does. */
static spectrum_t *named_spectrum(const scene_spectrum_t *s, spec_use_t use, err_t *err)
{
    const named_spectrum_t *e = named_spectra_find(s->name);
    if (!e) {
        unknown_spectrum(s, "named spectra", err);
        return NULL;
    }
    spectrum_t *r = NULL;
    int d65 = !strcmp(s->name, "stdillum-D65"), a = !strcmp(s->name, "stdillum-A");
    if (d65 || a) {
        r = d65 ? spectrum_new_cie_d65(err) : spectrum_new_cie_a(err);
        if (r && use != SPEC_ILLUMINANT) {
            spectrum_t *n = spectrum_new_scaled(r, CIE_Y_INTEGRAL / spectrum_photometric(r), err);
            spectrum_destroy(&r);
            r = n;
        }
    } else {
        r = named_spectrum_new(e, err);
    }
    if (!r)
        err_prefix(err, "%s:%d:%d: ", s->loc.file, s->loc.line, s->loc.col);
    return r;
}

static spectrum_t *build_spectrum(const scene_spectrum_t *s, spec_use_t use, err_t *err)
{
    spectrum_t *r = NULL;
    switch (s->kind) {
    case SCENE_SPECTRUM_CONSTANT:
        r = spectrum_new_constant(s->constant, err);
        break;
    case SCENE_SPECTRUM_RGB: {
        rgb_t c = {s->rgb[0], s->rgb[1], s->rgb[2]};
        if (use == SPEC_ILLUMINANT)
            r = spectrum_new_rgb_illuminant(c, err);
        else if (use == SPEC_REFLECTANCE)
            r = spectrum_new_rgb_reflectance(c, err);
        else {
            /* An unbounded RGB (a conductor's eta or k): the uplift of the colour scaled into
             * [0, 1] by its maximum, scaled back. */
            double m = fmax(c.r, fmax(c.g, c.b));
            if (!(m > 0)) {
                r = spectrum_new_constant(0.0, err);
            } else {
                spectrum_t *u = spectrum_new_rgb_reflectance((rgb_t){c.r / m, c.g / m, c.b / m}, err);
                r = u ? spectrum_new_scaled(u, m, err) : NULL;
                spectrum_destroy(&u);
            }
        }
        break;
    }
    case SCENE_SPECTRUM_BLACKBODY:
        r = spectrum_new_blackbody(s->temperature, 1, err);
        break;
    case SCENE_SPECTRUM_NAMED:
        r = named_spectrum(s, use, err);
        if (!r)
            return NULL; /* the message names the parameter */
        break;
    case SCENE_SPECTRUM_SAMPLED:
        /* pbrt-v4 takes a named spectrum before a file of the same name. */
        if (s->file && named_spectra_find(s->name))
            r = named_spectrum(s, use, err);
        else
            r = spectrum_new_tabulated(s->lambda, s->value, s->count, err);
        break;
    }
    if (!r)
        err_prefix(err, "%s:%d:%d: ", s->loc.file, s->loc.line, s->loc.col);
    return r;
}

/* Builds a spectrum the scene owns. */
static spectrum_t *owned_spectrum(scene_t *sc, const scene_spectrum_t *s, spec_use_t use, err_t *err)
{
    spectrum_t *r = build_spectrum(s, use, err);
    if (!r || scene_own_spectrum(sc, r, err))
        return NULL;
    return r;
}

/* pbrt-v4 normalises every light's spectrum by its photometric value (SpectrumToPhotometric),
 * so the spectrum gives the colour and "scale" the luminance: here the result has luminance
 * Y = 1 (Y = integral of s y-bar / integral of y-bar), and the light multiplies it by scale.
 * As in pbrt-v4, an "rgb" spectrum is normalised by its illuminant (D65) alone, so rgb
 * [r g b] keeps the luminance of that colour (rgb [1 1 1] has Y = 1, [10 10 10] Y = 10).
 * prismfarm's "float L" v (pbrt-v4 has none) is likewise not normalised: an equal-energy
 * spectrum of luminance v. */
static spectrum_t *light_spectrum(scene_t *sc, const scene_spectrum_t *s, err_t *err)
{
    spectrum_t *raw = build_spectrum(s, SPEC_ILLUMINANT, err);
    if (!raw)
        return NULL;
    double photometric = s->kind == SCENE_SPECTRUM_CONSTANT ? CIE_Y_INTEGRAL * (s->constant > 0 ? 1.0 : 0.0)
                                                            : spectrum_photometric_light(raw);
    if (!(photometric > 0.0) || !isfinite(photometric)) {
        spectrum_destroy(&raw);
        pbrt_error(err, s->loc, "light spectrum has no energy in the visible range (360-830 nm)");
        return NULL;
    }
    spectrum_t *n = spectrum_new_scaled(raw, CIE_Y_INTEGRAL / photometric, err);
    spectrum_destroy(&raw);
    if (!n || scene_own_spectrum(sc, n, err))
        return NULL;
    return n;
}

typedef struct loader {
    const scene_desc_t *desc;
    scene_t *sc;
    texture_t **tex;    /* by desc texture index (borrowed from the scene) */
    int *area_light_of; /* unused */
    const scene_budget_t *budget; /* the overrides' (budget.h); NULL: none */
    uint64_t texels;              /* image pixels read so far, against it */
    int threads;                  /* the overrides' (<= 0: all cores) */
} loader_t;

/* budget.h: an image of w x h pixels, decoded but not yet made a texture (its uplift
 * coefficients and pyramid, the larger allocation). */
static int budget_texels(loader_t *L, int w, int h, err_t *err)
{
    if (!L->budget || !L->budget->texels)
        return 0;
    uint64_t n = (uint64_t)w * (uint64_t)h;
    if (n <= L->budget->texels - L->texels) {
        L->texels += n;
        return 0;
    }
    return err_set(err,
                   "this %dx%d image takes the scene over %llu texels, the master's budget "
                   "(prismfarm master --max-texels)",
                   w, h, (unsigned long long)L->budget->texels);
}

/* budget.h: an image's texels charged from its header (image_info.h), before anything decodes
 * it: 1 charged (or no texel budget), 0 when the header cannot be read (the decoder says why;
 * the texels are charged once decoded), -1 over the budget. */
static int budget_texels_header(loader_t *L, const char *path, err_t *err)
{
    int w, h;
    err_t unread;
    if (!L->budget || !L->budget->texels)
        return 1;
    if (image_info_read(path, &w, &h, &unread) != 0)
        return 0;
    return budget_texels(L, w, h, err) ? -1 : 1;
}

static const texture_t *spectrum_input(loader_t *L, const scene_spectrum_input_t *in, spec_use_t use,
                                       err_t *err)
{
    if (in->texture >= 0)
        return L->tex[in->texture];
    spectrum_t *s = build_spectrum(&in->spectrum, use, err);
    if (!s)
        return NULL;
    texture_t *t = texture_new_constant(s, err);
    if (!t || scene_own_texture(L->sc, t, err))
        return NULL;
    return t;
}

static const texture_t *float_input(loader_t *L, const scene_float_input_t *in, err_t *err)
{
    if (in->texture >= 0)
        return L->tex[in->texture];
    texture_t *t = texture_new_constant_value(in->value, err);
    if (!t || scene_own_texture(L->sc, t, err))
        return NULL;
    return t;
}

static int ends_with_ci(const char *s, const char *suffix)
{
    size_t n = strlen(s), k = strlen(suffix);
    return n >= k && !strcasecmp(s + n - k, suffix);
}

/* pbrt-v4 ColorEncoding for 8- and 16-bit files: "sRGB" (the default), "linear", or
 * "gamma G" (v^G). Float files (EXR, PFM, HDR) are linear whatever it says, as in pbrt-v4. */
typedef struct encoding {
    int linear;
    double gamma; /* > 0: gamma; else sRGB unless linear */
    float lut[256];
} encoding_t;

static double srgb_to_linear(double v)
{
    return v <= 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4);
}

static double decode(const encoding_t *e, double v)
{
    return e->linear ? v : e->gamma > 0.0 ? pow(v, e->gamma) : srgb_to_linear(v);
}

static int encoding_parse(const char *s, encoding_t *e)
{
    char tail;
    memset(e, 0, sizeof *e);
    e->linear = !strcmp(s, "linear");
    if (!e->linear && strcmp(s, "sRGB") != 0 &&
        !(sscanf(s, "gamma %lf%c", &e->gamma, &tail) == 1 && isfinite(e->gamma) && e->gamma > 0.0))
        return -1;
    for (int i = 0; i < 256; i++)
        e->lut[i] = (float)decode(e, i / 255.0);
    return 0;
}

/* A stored value v in [0, 1] decoded, through the table when v is k / 255. */
static float decode_stored(const encoding_t *e, float v)
{
    long k = lrintf(v * 255.0f);
    return k >= 0 && k < 256 && (float)(k / 255.0) == v ? e->lut[k] : (float)decode(e, v);
}

/* Reads an image file for a texture or a normal map as linear RGB (top row first), and its
 * alpha channel into *alpha when the file has one (else NULL), both malloc'ed: OpenEXR and
 * PFM by their extension, PNG through libpng, the rest (TGA, JPEG, BMP, HDR, ...) through
 * stb_image. 8- and 16-bit values are decoded by enc (the alpha too, as pbrt-v4 does). */
static int read_image(const char *path, const encoding_t *enc, int *w, int *h, float **rgb,
                      float **alpha, err_t *err)
{
    *rgb = NULL;
    *alpha = NULL;
    if (ends_with_ci(path, ".exr")) {
        image_exr_t *im = image_exr_read(path, err);
        if (!im)
            return -1;
        *w = image_exr_width(im);
        *h = image_exr_height(im);
        size_t n = (size_t)*w * (size_t)*h;
        *rgb = malloc(n * 3 * sizeof **rgb);
        const float *a = image_exr_alpha(im);
        if (a && *rgb)
            *alpha = malloc(n * sizeof **alpha);
        if (!*rgb || (a && !*alpha)) {
            image_exr_destroy(&im);
            free(*rgb);
            return err_set(err, "%s: out of memory", path);
        }
        memcpy(*rgb, image_exr_rgb(im), n * 3 * sizeof **rgb);
        if (a)
            memcpy(*alpha, a, n * sizeof **alpha);
        image_exr_destroy(&im);
        return 0;
    }
    if (ends_with_ci(path, ".pfm"))
        return image_pfm_read(path, w, h, rgb, err);
    if (ends_with_ci(path, ".png")) {
        image_png_t *png = image_png_read(path, err);
        if (!png)
            return -1;
        *w = image_png_width(png);
        *h = image_png_height(png);
        size_t n = (size_t)*w * (size_t)*h;
        int has_alpha = image_png_channels(png) == 2 || image_png_channels(png) == 4;
        *rgb = malloc(n * 3 * sizeof **rgb);
        if (has_alpha && *rgb)
            *alpha = malloc(n * sizeof **alpha);
        if (!*rgb || (has_alpha && !*alpha)) {
            image_png_destroy(&png);
            free(*rgb);
            return err_set(err, "%s: out of memory", path);
        }
        const uint8_t *px = image_png_rgba(png);
        for (size_t i = 0; i < n; i++) {
            for (int c = 0; c < 3; c++)
                (*rgb)[3 * i + c] = enc->lut[px[4 * i + c]];
            if (has_alpha)
                (*alpha)[i] = enc->lut[px[4 * i + 3]];
        }
        image_png_destroy(&png);
        return 0;
    }
    int is_float;
    if (image_stb_read_encoded(path, w, h, rgb, alpha, &is_float, err))
        return -1;
    if (!is_float) {
        size_t n = (size_t)*w * (size_t)*h;
        for (size_t i = 0; i < 3 * n; i++)
            (*rgb)[i] = decode_stored(enc, (*rgb)[i]);
        if (*alpha)
            for (size_t i = 0; i < n; i++)
                (*alpha)[i] = decode_stored(enc, (*alpha)[i]);
    }
    return 0;
}

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
    int state; /* 0 not run, 1 decoded, 2 built, 3 skipped (after a failure), -1 failed (err) */
    int charged; /* its texels charged from its header (budget_texels_header) */
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
    encoding_t enc;
    if (encoding_parse(t->image.encoding, &enc))
        return err_set(
            &j->err,
            "imagemap encoding \"%s\" is not supported (\"sRGB\", \"linear\" or \"gamma G\")",
            t->image.encoding);
    float *rgb, *alpha;
    if (read_image(t->image.filename, &enc, &j->w, &j->h, &rgb, &alpha, &j->err))
        return -1; /* the caller names the texture and its line */
    size_t n = (size_t)j->w * (size_t)j->h;
    int use_alpha = 0;
    if (alpha && o->grey)
        for (size_t i = 0; i < n && !use_alpha; i++)
            use_alpha = alpha[i] != 1.0f;
    double sc = t->image.scale;
    for (size_t i = 0; i < n; i++) {
        if (o->grey) {
            double v = use_alpha ? alpha[i] : ((double)rgb[3 * i] + rgb[3 * i + 1] + rgb[3 * i + 2]) / 3.0;
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
            } else if ((j->charged = budget_texels_header(L, j->t->image.filename, &j->err)) < 0) {
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
            if (j->state == 1 && !j->charged && budget_texels(L, j->w, j->h, &j->err))
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

/* A material's "normalmap": the image read linear (pbrt-v4 reads normal maps with
 * ColorEncoding::Linear), as a texture the scene owns. */
static const texture_t *normal_map(loader_t *L, const scene_material_t *dm, err_t *err)
{
    encoding_t enc;
    encoding_parse("linear", &enc);
    int w, h;
    float *rgb = NULL, *alpha;
    int charged = budget_texels_header(L, dm->normalmap, err);
    if (charged < 0 || read_image(dm->normalmap, &enc, &w, &h, &rgb, &alpha, err)) {
        err_prefix(err, "%s:%d:%d: normalmap: ", dm->normalmap_loc.file, dm->normalmap_loc.line,
                   dm->normalmap_loc.col);
        return NULL;
    }
    free(alpha);
    if (!charged && budget_texels(L, w, h, err)) {
        err_prefix(err, "%s:%d:%d: normalmap: ", dm->normalmap_loc.file, dm->normalmap_loc.line,
                   dm->normalmap_loc.col);
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
    const int ninputs = t->cls == SCENE_TEX_BILERP ? 4
                        : t->cls == SCENE_TEX_DOTS || t->cls == SCENE_TEX_DIRECTIONMIX ? 2
                                                                                      : 0;
    const texture_t *in[4] = {NULL};
    for (int k = 0; k < ninputs; k++)
        if (!(in[k] = spectral ? spectrum_input(L, si[k], SPEC_REFLECTANCE, err) : float_input(L, fi[k], err)))
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
            in[0], in[1], transform_vector(&t->to_world, vec3_make(t->dir[0], t->dir[1], t->dir[2])), err);
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
        if (t->cls != SCENE_TEX_IMAGEMAP && t->cls != SCENE_TEX_BILERP && t->cls != SCENE_TEX_DOTS &&
            (t->udelta != 0.0 || t->vdelta != 0.0))
            return pbrt_error(err, t->loc, "texture \"%s\": udelta/vdelta are not supported", t->name);
        texture_t *made = NULL;
        switch (t->cls) {
        case SCENE_TEX_CONSTANT:
            a = spectral ? spectrum_input(L, &t->spec_in1, SPEC_REFLECTANCE, err) : float_input(L, &t->float_in1, err);
            if (!a)
                return -1;
            L->tex[i] = (texture_t *)a;
            continue;
        case SCENE_TEX_CHECKERBOARD:
            a = spectral ? spectrum_input(L, &t->spec_in1, SPEC_REFLECTANCE, err) : float_input(L, &t->float_in1, err);
            b = spectral ? spectrum_input(L, &t->spec_in2, SPEC_REFLECTANCE, err) : float_input(L, &t->float_in2, err);
            if (!a || !b)
                return -1;
            made = t->dimension == 3 ? texture_new_checkerboard3d(a, b, transform_inverse(t->to_world), err)
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
            a = spectral ? spectrum_input(L, &t->spec_in1, SPEC_REFLECTANCE, err) : float_input(L, &t->float_in1, err);
            const texture_t *s = float_input(L, &t->amount, err);
            if (!a || !s)
                return -1;
            made = texture_new_scale(a, s, err);
            break;
        }
        case SCENE_TEX_MIX: {
            a = spectral ? spectrum_input(L, &t->spec_in1, SPEC_REFLECTANCE, err) : float_input(L, &t->float_in1, err);
            b = spectral ? spectrum_input(L, &t->spec_in2, SPEC_REFLECTANCE, err) : float_input(L, &t->float_in2, err);
            const texture_t *m = float_input(L, &t->amount, err);
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
                                      vec3_make(t->map.v2[0], t->map.v2[1], t->map.v2[2]), t->map.ds,
                                      t->map.dt, err);
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

/* The scene's textures in file order, its image textures made beforehand on the pool
 * (load_image_textures): the same textures, and the same first failure, for any threads. */
static int load_textures(loader_t *L, err_t *err)
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

/* A tabulated index the scene owns: the pairs are copied into a spectrum the scene keeps, whose
 * arrays the model borrows (IOR_TABULATED's lifetime rule: as long as the scene). */
static int tabulated_ior(scene_t *sc, const double *lambda, const double *n, size_t count, const pbrt_loc_t *loc,
                         ior_model_t *out, err_t *err)
{
    spectrum_t *copy = spectrum_new_tabulated(lambda, n, count, err);
    if (!copy || scene_own_spectrum(sc, copy, err))
        return copy ? -1 : pbrt_error(err, *loc, "%s", err ? err->msg : "");
    size_t k;
    const double *l, *v;
    spectrum_tabulated_pairs(copy, &k, &l, &v);
    if (ior_tabulated(out, l, v, k, err))
        return pbrt_error(err, *loc, "%s", err ? err->msg : "");
    return 0;
}

static int build_ior(scene_t *sc, const scene_ior_t *in, const char *material, ior_model_t *out, err_t *err)
{
    switch (in->kind) {
    case SCENE_IOR_SPECTRUM: {
        const scene_spectrum_t *sp = &in->spectrum;
        if (sp->kind == SCENE_SPECTRUM_CONSTANT) {
            *out = ior_constant(sp->constant);
            return 0;
        }
        /* pbrt-v4's named spectra first (its glass-* tables), then prismfarm's catalogue names. */
        const named_spectrum_t *e =
            sp->kind == SCENE_SPECTRUM_NAMED || (sp->kind == SCENE_SPECTRUM_SAMPLED && sp->file) ? named_spectra_find(sp->name)
                                                                                              : NULL;
        if (e && e->kind == NAMED_SPECTRUM_ILLUMINANT)
            return pbrt_error(err, in->loc, "material \"%s\": \"%s\" is an illuminant, not an index of refraction", material,
                              sp->name);
        if (e) {
            if (ior_tabulated(out, e->lambda, e->value, e->count, err)) /* static tables */
                return pbrt_error(err, in->loc, "material \"%s\": %s", material, err ? err->msg : "");
            return 0;
        }
        if (sp->kind == SCENE_SPECTRUM_NAMED) {
            const glass_t *g = glass_find(sp->name);
            if (g) {
                *out = g->ior;
                return 0;
            }
            char names[1024];
            return pbrt_error(err, in->loc,
                              "material \"%s\": \"%s\" is neither a named spectrum, a glass of the catalogue "
                              "(prismfarm glass --list) nor a spectrum file (looked for %s); named spectra: %s",
                              material, sp->name, sp->searched ? sp->searched : "no file",
                              named_spectra_list(names, sizeof names));
        }
        if (sp->kind == SCENE_SPECTRUM_SAMPLED)
            return tabulated_ior(sc, sp->lambda, sp->value, sp->count, &in->loc, out, err);
        return pbrt_error(err, in->loc,
                          "material \"%s\": eta must be a number, (wavelength, n) pairs, a spectrum file, a glass name, or "
                          "given by \"string glass\", \"float sellmeier\" or \"float cauchy\"",
                          material);
    }
    case SCENE_IOR_GLASS: {
        const glass_t *g = glass_find(in->glass);
        if (!g)
            return pbrt_error(err, in->loc, "material \"%s\": unknown glass \"%s\" (see prismfarm glass --list)",
                              material, in->glass);
        *out = g->ior;
        return 0;
    }
    case SCENE_IOR_SELLMEIER: {
        double b[IOR_SELLMEIER_MAX_TERMS], c[IOR_SELLMEIER_MAX_TERMS];
        if (in->nterms > IOR_SELLMEIER_MAX_TERMS)
            return pbrt_error(err, in->loc, "material \"%s\": at most %d Sellmeier terms, got %zu", material,
                              IOR_SELLMEIER_MAX_TERMS, in->nterms);
        for (size_t i = 0; i < in->nterms; i++) {
            b[i] = in->sellmeier[2 * i];
            c[i] = in->sellmeier[2 * i + 1];
        }
        if (ior_sellmeier(out, 0.0, b, c, (int)in->nterms, err))
            return err_prefix(err, "%s:%d:%d: ", in->loc.file, in->loc.line, in->loc.col);
        return 0;
    }
    case SCENE_IOR_CAUCHY:
        *out = ior_cauchy(in->cauchy[0], in->cauchy[1]);
        return 0;
    }
    return err_set(err, "unknown index model");
}

/* A roughness input: NULL when it is the constant 0 (the smooth case needs no texture). */
static int roughness_input(loader_t *L, const scene_float_input_t *in, const texture_t **out,
                           err_t *err)
{
    *out = NULL;
    if (in->texture < 0 && in->value == 0.0)
        return 0;
    return (*out = float_input(L, in, err)) ? 0 : -1;
}

/* A conductor's eta and k (or its reflectance, pbrt-v4's alternative). */
static int conductor_inputs(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    if (dm->use_reflectance)
        return (m->reflectance = spectrum_input(L, &dm->reflectance, SPEC_REFLECTANCE, err)) ? 0 : -1;
    if (dm->eta.texture >= 0 || dm->k.texture >= 0)
        return pbrt_error(err, dm->loc, "material \"%s\": textured eta/k are not supported", m->name);
    return (m->eta = owned_spectrum(L->sc, &dm->eta.spectrum, SPEC_UNBOUNDED, err)) &&
                   (m->k = owned_spectrum(L->sc, &dm->k.spectrum, SPEC_UNBOUNDED, err))
               ? 0
               : -1;
}

static int layer_inputs(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    m->maxdepth = dm->maxdepth;
    m->nsamples = dm->nsamples;
    return (m->thickness = float_input(L, &dm->thickness, err)) &&
                   (m->g = float_input(L, &dm->g, err)) &&
                   (m->albedo = spectrum_input(L, &dm->albedo, SPEC_REFLECTANCE, err))
               ? 0
               : -1;
}

/* A uniaxial crystal: a smooth dielectric whose ior is the ordinary index (material_t). */
/* A crystal's indices (a uniaxial material's, a retarder plate's): the catalogue's, or the
 * given ones, which replace them. */
static int crystal_inputs(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    if (dm->crystal) {
        const crystal_t *c = crystal_find(dm->crystal);
        if (!c)
            return pbrt_error(err, dm->loc,
                              "material \"%s\": unknown crystal \"%s\" (known: calcite, quartz, "
                              "sapphire, rutile, MgF2, tourmaline)",
                              m->name, dm->crystal);
        m->crystal = *c;
    } else {
        m->crystal = (crystal_t){.name = "(given)", .description = "", .source = "the scene file"};
    }
    if (dm->has_o && build_ior(L->sc, &dm->ior_o, m->name, &m->crystal.no, err))
        return -1;
    if (dm->has_e && build_ior(L->sc, &dm->ior_e, m->name, &m->crystal.ne, err))
        return -1;
    return 0;
}

static int uniaxial_inputs(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    m->kind = MATERIAL_DIELECTRIC;
    m->uniaxial = 1;
    if (crystal_inputs(L, dm, m, err))
        return -1;
    if (dm->has_sigma) {
        /* Constant coefficients replace the catalogue's table. */
        m->crystal.absorption = (crystal_absorption_t){
            .rows = 1, .lambda_nm = {550.0}, .o_per_mm = {dm->sigma_o}, .e_per_mm = {dm->sigma_e}};
    }
    m->ior = m->crystal.no;
    m->optic_axis = vec3_normalize(vec3_make(dm->optic_axis[0], dm->optic_axis[1], dm->optic_axis[2]));
    m->mm_per_unit = dm->mm_per_unit;
    return 0;
}

/* pbrt-v4 HairMaterial: the fibre's numbers and its absorption's source. Constant melanin
 * concentrations become one absorption spectrum, the uplift of pbrt-v4's RGB sum
 * (SigmaAFromConcentration); textured ones weigh each pigment's own spectrum per hit. */
static int hair_inputs(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    m->kind = MATERIAL_HAIR;
    if (!(m->hair.eta = float_input(L, &dm->hair_eta, err)) ||
        !(m->hair.beta_m = float_input(L, &dm->beta_m, err)) ||
        !(m->hair.beta_n = float_input(L, &dm->beta_n, err)) ||
        !(m->hair.alpha = float_input(L, &dm->hair_alpha, err)))
        return -1;
    if (dm->hair_from == SCENE_HAIR_SIGMA_A)
        return (m->hair.sigma_a = spectrum_input(L, &dm->sigma_a, SPEC_UNBOUNDED, err)) ? 0 : -1;
    if (dm->hair_from == SCENE_HAIR_REFLECTANCE)
        return (m->hair.reflectance = spectrum_input(L, &dm->reflectance, SPEC_REFLECTANCE, err))
                   ? 0
                   : -1;
    scene_spectrum_input_t in = {.texture = -1,
                                 .spectrum = {.kind = SCENE_SPECTRUM_RGB, .loc = dm->loc}};
    if (dm->eumelanin.texture < 0 && dm->pheomelanin.texture < 0) {
        hair_sigma_a_from_concentration(dm->eumelanin.value, dm->pheomelanin.value,
                                        in.spectrum.rgb);
        return (m->hair.sigma_a = spectrum_input(L, &in, SPEC_UNBOUNDED, err)) ? 0 : -1;
    }
    if (!(m->hair.eumelanin = float_input(L, &dm->eumelanin, err)) ||
        !(m->hair.pheomelanin = float_input(L, &dm->pheomelanin, err)))
        return -1;
    hair_sigma_a_from_concentration(1.0, 0.0, in.spectrum.rgb);
    if (!(m->hair.eu_sigma = spectrum_input(L, &in, SPEC_UNBOUNDED, err)))
        return -1;
    hair_sigma_a_from_concentration(0.0, 1.0, in.spectrum.rgb);
    return (m->hair.pheo_sigma = spectrum_input(L, &in, SPEC_UNBOUNDED, err)) ? 0 : -1;
}

/* The material a shape placed by to_world uses: a crystal's optic axis is given in the shape's
 * object space, so each differently turned crystal shape gets its own copy with the axis in
 * world space (in an object's space for shapes of instanced objects: instances do not turn it,
 * docs/physics.md §15). Any other material is used as it is. */
static int material_for_shape(loader_t *L, int idx, const transform_t *to_world, err_t *err)
{
    if (idx < 0 || (size_t)idx >= L->sc->nmaterials || !L->sc->materials[idx].uniaxial)
        return idx;
    material_t m = L->sc->materials[idx];
    const vec3_t a = vec3_normalize(transform_vector(to_world, m.optic_axis));
    if (a.x == m.optic_axis.x && a.y == m.optic_axis.y && a.z == m.optic_axis.z)
        return idx;
    m.optic_axis = a;
    return scene_add_material(L->sc, &m, err);
}

/* pbrt-v4's MeasuredMaterial: the .bsdf file, read once however many materials name it (as
 * pbrt-v4 does), its bytes bounded as any file a scene reads is. */
static int measured_input(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    m->kind = MATERIAL_MEASURED;
    if ((m->measured = scene_find_measured(L->sc, dm->filename)))
        return 0;
    const pbrt_loc_t at = dm->filename_loc;
    uint8_t *bytes;
    size_t len;
    measured_t *md = NULL;
    if (files_read(dm->filename, PBRT_FILE_BYTES_MAX, &bytes, &len, err) == 0) {
        md = measured_new(bytes, len, dm->filename, err);
        free(bytes);
    }
    if (!md)
        return err_prefix(err, "%s:%d:%d: Material \"measured\": ", at.file, at.line, at.col);
    m->measured = md;
    return scene_own_measured(L->sc, md, dm->filename, err);
}

static int load_materials(loader_t *L, err_t *err)
{
    const scene_desc_t *d = L->desc;
    for (size_t i = 0; i < d->nmaterials; i++) {
        const scene_material_t *dm = &d->materials[i];
        material_t m = {0};
        if (dm->name) {
            snprintf(m.name, sizeof m.name, "%s", dm->name);
            m.named = 1;
        } else if (dm->loc.file && dm->loc.line > 0) {
            const char *base = strrchr(dm->loc.file, '/');
            snprintf(m.name, sizeof m.name, "%s:%d", base ? base + 1 : dm->loc.file, dm->loc.line);
        } else {
            snprintf(m.name, sizeof m.name, "(unnamed)");
        }
        m.remaproughness = dm->remaproughness;
        m.mix[0] = m.mix[1] = -1;
        const int has_roughness = dm->type == SCENE_MATERIAL_CONDUCTOR ||
                                  dm->type == SCENE_MATERIAL_DIELECTRIC ||
                                  dm->type == SCENE_MATERIAL_COATEDDIFFUSE ||
                                  dm->type == SCENE_MATERIAL_COATEDCONDUCTOR;
        if (has_roughness && (roughness_input(L, &dm->uroughness, &m.uroughness, err) ||
                              roughness_input(L, &dm->vroughness, &m.vroughness, err)))
            return -1;
        if (dm->type == SCENE_MATERIAL_COATEDCONDUCTOR &&
            (roughness_input(L, &dm->base_uroughness, &m.base_uroughness, err) ||
             roughness_input(L, &dm->base_vroughness, &m.base_vroughness, err)))
            return -1;
        int rc = 0;
        switch (dm->type) {
        case SCENE_MATERIAL_DIFFUSE:
            m.kind = MATERIAL_DIFFUSE;
            rc = (m.reflectance = spectrum_input(L, &dm->reflectance, SPEC_REFLECTANCE, err)) ? 0 : -1;
            break;
        case SCENE_MATERIAL_CONDUCTOR:
            m.kind = MATERIAL_CONDUCTOR;
            rc = conductor_inputs(L, dm, &m, err);
            break;
        case SCENE_MATERIAL_DIELECTRIC:
            m.kind = MATERIAL_DIELECTRIC;
            rc = build_ior(L->sc, &dm->ior, m.name, &m.ior, err);
            break;
        case SCENE_MATERIAL_THINDIELECTRIC:
            m.kind = MATERIAL_THIN_DIELECTRIC;
            rc = build_ior(L->sc, &dm->ior, m.name, &m.ior, err);
            break;
        case SCENE_MATERIAL_DIFFUSETRANSMISSION:
            m.kind = MATERIAL_DIFFUSE_TRANSMISSION;
            m.scale = dm->scale;
            rc = (m.reflectance = spectrum_input(L, &dm->reflectance, SPEC_REFLECTANCE, err)) &&
                         (m.transmittance = spectrum_input(L, &dm->transmittance, SPEC_REFLECTANCE, err))
                     ? 0
                     : -1;
            break;
        case SCENE_MATERIAL_COATEDDIFFUSE:
            m.kind = MATERIAL_COATED_DIFFUSE;
            rc = (m.reflectance = spectrum_input(L, &dm->reflectance, SPEC_REFLECTANCE, err)) &&
                         !build_ior(L->sc, &dm->ior, m.name, &m.ior, err) && !layer_inputs(L, dm, &m, err)
                     ? 0
                     : -1;
            break;
        case SCENE_MATERIAL_COATEDCONDUCTOR:
            m.kind = MATERIAL_COATED_CONDUCTOR;
            rc = conductor_inputs(L, dm, &m, err) || build_ior(L->sc, &dm->ior, m.name, &m.ior, err) ||
                         layer_inputs(L, dm, &m, err)
                     ? -1
                     : 0;
            break;
        case SCENE_MATERIAL_MIX:
            m.kind = MATERIAL_MIX;
            m.mix[0] = dm->mix[0];
            m.mix[1] = dm->mix[1];
            rc = (m.amount = float_input(L, &dm->amount, err)) ? 0 : -1;
            break;
        case SCENE_MATERIAL_INTERFACE:
            m.kind = MATERIAL_INTERFACE;
            break;
        case SCENE_MATERIAL_UNIAXIAL:
            rc = uniaxial_inputs(L, dm, &m, err);
            break;
        case SCENE_MATERIAL_HAIR:
            rc = hair_inputs(L, dm, &m, err);
            break;
        case SCENE_MATERIAL_POLARIZER:
        case SCENE_MATERIAL_RETARDER:
            m.kind = dm->type == SCENE_MATERIAL_POLARIZER ? MATERIAL_POLARISER : MATERIAL_RETARDER;
            m.sheet_angle = dm->sheet_angle * (PF_PI / 180.0);
            m.retardance = dm->retardance * (PF_PI / 180.0);
            m.retarder_mode = dm->type == SCENE_MATERIAL_RETARDER ? dm->retarder_mode : 0;
            m.retardation_nm = dm->retardation;
            m.plate_thickness_nm = dm->plate_thickness * 1000.0;
            if (m.retarder_mode == RETARDER_PLATE)
                rc = crystal_inputs(L, dm, &m, err);
            break;
        case SCENE_MATERIAL_MEASURED:
            rc = measured_input(L, dm, &m, err);
            break;
        }
        if (rc)
            return -1;
        /* A thin film on smooth glass or metal (the parser refuses one on a rough surface). */
        if (dm->film_thickness > 0.0 &&
            (dm->type == SCENE_MATERIAL_DIELECTRIC || dm->type == SCENE_MATERIAL_CONDUCTOR)) {
            m.film_thickness = dm->film_thickness;
            m.film_ior = ior_constant(dm->film_eta);
        }
        /* Smooth everywhere: constant roughness that pbrt-v4 calls effectively smooth. A
         * roughness texture may still be smooth at a hit; render decides there. */
        if ((m.kind == MATERIAL_CONDUCTOR || m.kind == MATERIAL_DIELECTRIC) &&
            dm->uroughness.texture < 0 && dm->vroughness.texture < 0) {
            microfacet_t mf = microfacet_make(dm->uroughness.value, dm->vroughness.value,
                                              dm->remaproughness);
            m.smooth = microfacet_smooth(&mf);
            m.rough = !m.smooth;
        }
        if (dm->normalmap && !(m.normalmap = normal_map(L, dm, err)))
            return -1;
        if (!m.normalmap && dm->displacement.texture >= 0)
            m.displacement = L->tex[dm->displacement.texture];
        if (scene_add_material(L->sc, &m, err) < 0)
            return -1;
    }
    return 0;
}

/* The name of a light's kind in messages: LightSource "...". */
static const char *light_kind_word(scene_light_type_t t)
{
    return t == SCENE_LIGHT_GONIOMETRIC ? "goniometric" : t == SCENE_LIGHT_PROJECTION ? "projection" : "infinite";
}

/* A light's image at path, by its extension: OpenEXR, PFM, or whatever stb_image reads (HDR,
 * PNG, JPEG, TGA, BMP), as w * h * 3 linear floats (*rgb, the caller frees), charged to the
 * texel budget. Errors name the "filename" parameter at loc and the directive what. */
static int read_image_at(loader_t *L, const char *path, pbrt_loc_t loc, const char *what, float **rgb,
                         int *w, int *h, err_t *err)
{
    int rc;
    *rgb = NULL;
    *w = *h = 0;
    int charged = budget_texels_header(L, path, err);
    if (charged < 0) {
        rc = -1;
    } else if (ends_with_ci(path, ".exr")) {
        image_exr_t *im = image_exr_read(path, err);
        rc = im ? 0 : -1;
        if (im) {
            *w = image_exr_width(im);
            *h = image_exr_height(im);
            *rgb = malloc((size_t)*w * (size_t)*h * 3 * sizeof **rgb);
            if (*rgb)
                memcpy(*rgb, image_exr_rgb(im), (size_t)*w * (size_t)*h * 3 * sizeof **rgb);
            else
                rc = err_set(err, "%s: out of memory", path);
            image_exr_destroy(&im);
        }
    } else if (ends_with_ci(path, ".pfm")) {
        rc = image_pfm_read(path, w, h, rgb, err);
    } else {
        rc = image_stb_read(path, w, h, rgb, err);
    }
    if (rc == 0 && !charged && budget_texels(L, *w, *h, err))
        rc = -1;
    if (rc) {
        free(*rgb);
        *rgb = NULL;
        return err_prefix(err, "%s:%d:%d: %s: ", loc.file, loc.line, loc.col, what);
    }
    return 0;
}

static int read_light_image(loader_t *L, const scene_light_t *dl, float **rgb, int *w, int *h, err_t *err)
{
    char what[64];
    snprintf(what, sizeof what, "LightSource \"%s\"", light_kind_word(dl->type));
    return read_image_at(L, dl->filename, dl->filename_loc, what, rgb, w, h, err);
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
    if (read_image_at(L, a->filename, a->filename_loc, "AreaLightSource \"diffuse\"", &rgb, &w, &h, err))
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
        if (!(l.spectrum = light_spectrum(L->sc, &dl->spectrum, err)))
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
static int area_light_power(loader_t *L, const scene_area_light_t *a, const shape_t *sh, light_t *l,
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

/* Adds one shape to the world (object < 0, in world space) or to a scene object (in the
 * object's space); the shape's own transform is applied here. */
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
            if (!(p.sigma_a = owned_spectrum(L->sc, &dm->sigma_a, SPEC_UNBOUNDED, err)) ||
                !(p.sigma_s = owned_spectrum(L->sc, &dm->sigma_s, SPEC_UNBOUNDED, err)))
                return -1;
            int black = dm->Le.kind == SCENE_SPECTRUM_CONSTANT ? !(dm->Le.constant > 0.0)
                        : dm->Le.kind == SCENE_SPECTRUM_RGB
                            ? !(dm->Le.rgb[0] > 0.0 || dm->Le.rgb[1] > 0.0 || dm->Le.rgb[2] > 0.0)
                            : 0;
            if (dm->has_Le && !black && dm->Le_scale > 0.0 && !(p.Le = light_spectrum(L->sc, &dm->Le, err)))
                return -1;
            if (dm->type == SCENE_MEDIUM_NANOVDB) {
                /* its voxels share the texel budget: both are samples a scene makes the master hold */
                uint64_t budget = L->budget ? L->budget->texels : 0;
                m = medium_file_load_nanovdb(dm, &p, budget, &L->texels, err);
            } else {
                m = dm->type == SCENE_MEDIUM_GRID ? medium_new_grid(&p, dm->nx, dm->ny, dm->nz, dm->density, dm->p0,
                                                                    dm->p1, &dm->to_world, err)
                                                  : medium_new_homogeneous(&p, err);
            }
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

static int load_shape(loader_t *L, const scene_shape_t *s, int object, err_t *err)
{
    const scene_desc_t *d = L->desc;
    int light = -1;
    if (s->area_light >= 0) {
        const scene_area_light_t *a = &d->area_lights[s->area_light];
        if (object >= 0)
            return pbrt_error(err, s->loc, "area lights are not supported in instanced objects");
        light_t l = {.kind = a->type == SCENE_AREA_COLLIMATED ? LIGHT_COLLIMATED : LIGHT_AREA,
                     .scale = a->scale, .twosided = a->twosided};
        if (!(l.spectrum = light_spectrum(L->sc, &a->L, err)))
            return -1;
        if (a->filename && !(l.area_image = load_area_image(L, a, &l.area_image_y, err)))
            return -1;
        light_polarisation(&l, &s->to_world, a->polarization, a->polarization_angle);
        if ((light = scene_add_light(L->sc, &l, err)) < 0)
            return err_prefix(err, "%s:%d:%d: ", a->loc.file, a->loc.line, a->loc.col);
    }
    const transform_t *to_world = &s->to_world;
    int flip = s->flip_normals;
    const int material = material_for_shape(L, s->material, to_world, err);
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
        if (!(L->sc->shapes[r].alpha = float_input(L, &s->alpha, err)))
            return -1;
        L->sc->has_alpha = 1;
    }
    if (light >= 0 && d->area_lights[s->area_light].power > 0.0)
        return area_light_power(L, &d->area_lights[s->area_light], &L->sc->shapes[r],
                                &L->sc->lights[light], err);
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
                r = load_shape(L, &d->object_shapes[o->first_shape + k], obj, err);
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

/* pbrt-v4 FilmBaseParameters: pixelbounds [x0 x1 y0 y1] clipped to the film, or the crop
 * window [x0 x1 y0 y1] (clamped to [0, 1]) as pixels ceil(res * x0) .. ceil(res * x1). The
 * rendered image is the bounds' size; full_xres keeps the film's (see scene.h). */
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
    return load_integrator(L, ov, err);
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
        r = load_textures(&L, err);
    if (!r)
        r = load_materials(&L, err);
    if (!r)
        r = load_lights(&L, err);
    if (!r)
        r = load_media(&L, err);
    for (size_t i = 0; !r && i < desc->nshapes; i++)
        r = load_shape(&L, &desc->shapes[i], -1, err);
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
