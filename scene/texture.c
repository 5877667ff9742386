#include "texture.h"

#include "noise.h"
#include "pool.h"
#include "rgb_uplift.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef enum {
    TEX_CONSTANT,
    TEX_CHECKER,
    TEX_SCALE,
    TEX_MIX,
    TEX_IMAGE,
    TEX_NORMALMAP,
    TEX_BILERP,
    TEX_DOTS,
    TEX_CHECKER3D,
    TEX_FBM,
    TEX_WRINKLED,
    TEX_WINDY,
    TEX_MARBLE,
    TEX_DIRECTIONMIX,
    TEX_MAPPED,
} tex_kind_t;

/* One level of an image texture: per texel rgb_uplift's four coefficients (coef), or one
 * value (val, a float texture), or three floats (rgb, a normal map). */
typedef struct level {
    int w, h;
    double *coef;
    float *val;
    float *rgb;
} level_t;

#define LEVELS_MAX 32
/* Lanes texture_eval_lanes combines at once (a path's most: render.h RENDER_MAX_BUCKETS); more
 * read lane by lane. */
#define TEXTURE_MAX_LANES 64

struct texture {
    tex_kind_t kind;
    spectrum_t *spectrum; /* constant */
    const texture_t *a, *b, *c, *d;
    double uscale, vscale, udelta, vdelta;
    /* The procedural textures: world to texture space, octaves and their weight, marble's
     * scale and variation and its colour uplift (owned), directionmix's unit direction. */
    transform_t to_texture;
    int octaves;
    double omega, scale, variation;
    rgb_uplift_t *uplift;
    vec3_t dir, vt;
    texture_mapping_t mapping;
    texture_wrap_t wrap;
    texture_filter_t filter;
    int nlevels;
    level_t level[LEVELS_MAX];
};

static texture_t *alloc_texture(tex_kind_t kind, err_t *err)
{
    texture_t *t = calloc(1, sizeof *t);
    if (!t)
        err_set(err, "out of memory");
    else
        t->kind = kind;
    return t;
}

texture_t *texture_new_constant(spectrum_t *spectrum, err_t *err)
{
    if (!spectrum) {
        err_set(err, "constant texture without a spectrum");
        return NULL;
    }
    texture_t *t = alloc_texture(TEX_CONSTANT, err);
    if (!t) {
        spectrum_destroy(&spectrum);
        return NULL;
    }
    t->spectrum = spectrum;
    return t;
}

texture_t *texture_new_constant_value(double value, err_t *err)
{
    spectrum_t *s = spectrum_new_constant(value, err);
    return s ? texture_new_constant(s, err) : NULL;
}

texture_t *texture_new_checkerboard(const texture_t *tex1, const texture_t *tex2, double uscale,
                                    double vscale, err_t *err)
{
    if (!tex1 || !tex2 || !isfinite(uscale) || !isfinite(vscale)) {
        err_set(err, "checkerboard needs two textures and finite uscale/vscale");
        return NULL;
    }
    texture_t *t = alloc_texture(TEX_CHECKER, err);
    if (t) {
        t->a = tex1;
        t->b = tex2;
        t->uscale = uscale;
        t->vscale = vscale;
    }
    return t;
}

texture_t *texture_new_scale(const texture_t *tex, const texture_t *scale, err_t *err)
{
    if (!tex || !scale) {
        err_set(err, "scale texture needs a texture and a scale");
        return NULL;
    }
    texture_t *t = alloc_texture(TEX_SCALE, err);
    if (t) {
        t->a = tex;
        t->b = scale;
    }
    return t;
}

texture_t *texture_new_mix(const texture_t *tex1, const texture_t *tex2, const texture_t *amount,
                           err_t *err)
{
    if (!tex1 || !tex2 || !amount) {
        err_set(err, "mix texture needs tex1, tex2 and amount");
        return NULL;
    }
    texture_t *t = alloc_texture(TEX_MIX, err);
    if (t) {
        t->a = tex1;
        t->b = tex2;
        t->c = amount;
    }
    return t;
}

static bool uv_map_ok(texture_uv_map_t m)
{
    return isfinite(m.su) && isfinite(m.sv) && isfinite(m.du) && isfinite(m.dv);
}

texture_t *texture_new_bilerp(const texture_t *v00, const texture_t *v01, const texture_t *v10,
                              const texture_t *v11, texture_uv_map_t map, err_t *err)
{
    if (!v00 || !v01 || !v10 || !v11 || !uv_map_ok(map)) {
        err_set(err, "bilerp needs four textures and a finite uv mapping");
        return NULL;
    }
    texture_t *t = alloc_texture(TEX_BILERP, err);
    if (t) {
        t->a = v00;
        t->b = v01;
        t->c = v10;
        t->d = v11;
        t->uscale = map.su;
        t->vscale = map.sv;
        t->udelta = map.du;
        t->vdelta = map.dv;
    }
    return t;
}

texture_t *texture_new_dots(const texture_t *inside, const texture_t *outside, texture_uv_map_t map,
                            err_t *err)
{
    if (!inside || !outside || !uv_map_ok(map)) {
        err_set(err, "dots needs inside and outside textures and a finite uv mapping");
        return NULL;
    }
    texture_t *t = alloc_texture(TEX_DOTS, err);
    if (t) {
        t->a = inside;
        t->b = outside;
        t->uscale = map.su;
        t->vscale = map.sv;
        t->udelta = map.du;
        t->vdelta = map.dv;
    }
    return t;
}

static texture_t *alloc_3d(tex_kind_t kind, transform_t to_texture, err_t *err)
{
    if (to_texture.singular) {
        err_set(err, "the texture's transformation is singular");
        return NULL;
    }
    texture_t *t = alloc_texture(kind, err);
    if (t)
        t->to_texture = to_texture;
    return t;
}

texture_t *texture_new_checkerboard3d(const texture_t *tex1, const texture_t *tex2,
                                      transform_t to_texture, err_t *err)
{
    if (!tex1 || !tex2) {
        err_set(err, "checkerboard needs two textures");
        return NULL;
    }
    texture_t *t = alloc_3d(TEX_CHECKER3D, to_texture, err);
    if (t) {
        t->a = tex1;
        t->b = tex2;
    }
    return t;
}

static texture_t *noise_texture(tex_kind_t kind, transform_t to_texture, int octaves,
                                double roughness, err_t *err)
{
    if (octaves < 1 || octaves > 64 || !isfinite(roughness)) {
        err_set(err,
                "\"integer octaves\" must be in 1..64 and \"float roughness\" finite, got %d "
                "and %g",
                octaves, roughness);
        return NULL;
    }
    texture_t *t = alloc_3d(kind, to_texture, err);
    if (t) {
        t->octaves = octaves;
        t->omega = roughness;
    }
    return t;
}

texture_t *texture_new_fbm(transform_t to_texture, int octaves, double roughness, err_t *err)
{
    return noise_texture(TEX_FBM, to_texture, octaves, roughness, err);
}

texture_t *texture_new_wrinkled(transform_t to_texture, int octaves, double roughness, err_t *err)
{
    return noise_texture(TEX_WRINKLED, to_texture, octaves, roughness, err);
}

texture_t *texture_new_windy(transform_t to_texture, err_t *err)
{
    return alloc_3d(TEX_WINDY, to_texture, err);
}

texture_t *texture_new_marble(transform_t to_texture, int octaves, double roughness, double scale,
                              double variation, err_t *err)
{
    if (!isfinite(scale) || !isfinite(variation)) {
        err_set(err, "marble needs a finite \"float scale\" and \"float variation\"");
        return NULL;
    }
    texture_t *t = noise_texture(TEX_MARBLE, to_texture, octaves, roughness, err);
    if (!t)
        return NULL;
    t->scale = scale;
    t->variation = variation;
    if (!(t->uplift = rgb_uplift_new(err)))
        texture_destroy(&t);
    return t;
}

texture_t *texture_new_directionmix(const texture_t *tex1, const texture_t *tex2, vec3_t dir,
                                    err_t *err)
{
    double len = vec3_length(dir);
    if (!tex1 || !tex2 || !(len > 0.0) || !isfinite(len)) {
        err_set(err, "directionmix needs two textures and a non-zero direction");
        return NULL;
    }
    texture_t *t = alloc_texture(TEX_DIRECTIONMIX, err);
    if (t) {
        t->a = tex1;
        t->b = tex2;
        t->dir = vec3_scale(dir, 1.0 / len);
    }
    return t;
}

texture_t *texture_new_mapped(const texture_t *inner, texture_mapping_t mapping,
                              transform_t to_texture, vec3_t vs, vec3_t vt, double ds, double dt,
                              err_t *err)
{
    if (!inner || !isfinite(vs.x + vs.y + vs.z + vt.x + vt.y + vt.z + ds + dt)) {
        err_set(err, "a mapped texture needs a texture and finite mapping vectors");
        return NULL;
    }
    texture_t *t = alloc_3d(TEX_MAPPED, to_texture, err);
    if (t) {
        t->a = inner;
        t->mapping = mapping;
        t->dir = vs;
        t->vt = vt;
        t->udelta = ds;
        t->vdelta = dt;
    }
    return t;
}

texture_image_opts_t texture_image_opts_default(void)
{
    return (texture_image_opts_t){.uscale = 1.0,
                                  .vscale = 1.0,
                                  .wrap = TEXTURE_WRAP_REPEAT,
                                  .filter = TEXTURE_FILTER_BILINEAR};
}

static float clamp_zero(float v)
{
    return v > 0.0f && v <= 3.4e38f ? v : (v > 3.4e38f ? 3.4e38f : 0.0f);
}

/* The next pyramid level of rgb (w x h, nc floats per texel): each texel the mean of the
 * 2x2 block below it, the last row or column repeated where the size is odd. */
static float *halve(const float *src, int w, int h, int nc, int *nw, int *nh)
{
    *nw = w > 1 ? (w + 1) / 2 : 1;
    *nh = h > 1 ? (h + 1) / 2 : 1;
    float *dst = malloc((size_t)*nw * (size_t)*nh * (size_t)nc * sizeof *dst);
    if (!dst)
        return NULL;
    for (int y = 0; y < *nh; y++)
        for (int x = 0; x < *nw; x++) {
            int x0 = w > 1 ? 2 * x : 0, y0 = h > 1 ? 2 * y : 0;
            int x1 = x0 + 1 < w ? x0 + 1 : x0, y1 = y0 + 1 < h ? y0 + 1 : y0;
            for (int c = 0; c < nc; c++)
                dst[((size_t)y * *nw + x) * nc + c] =
                    0.25f *
                    (src[((size_t)y0 * w + x0) * nc + c] + src[((size_t)y0 * w + x1) * nc + c] +
                     src[((size_t)y1 * w + x0) * nc + c] + src[((size_t)y1 * w + x1) * nc + c]);
        }
    return dst;
}

typedef struct coef_job {
    const rgb_uplift_t *table;
    const float *rgb;
    double *coef;
    size_t n;
} coef_job_t;

#define COEF_CHUNK 16384

static int coef_chunk(void *user, int index, err_t *err)
{
    coef_job_t *j = user;
    size_t lo = (size_t)index * COEF_CHUNK, hi = lo + COEF_CHUNK < j->n ? lo + COEF_CHUNK : j->n;
    for (size_t i = lo; i < hi; i++)
        if (rgb_uplift_coef(j->table, j->rgb + 3 * i, j->coef + 4 * i, err))
            return -1;
    return 0;
}

texture_t *texture_new_image(const float *rgb, int w, int h, const texture_image_opts_t *o,
                             err_t *err)
{
    if (!rgb || !o || w <= 0 || h <= 0 || (size_t)w * (size_t)h > ((size_t)1 << 28)) {
        err_set(err, "image texture of %dx%d texels is empty or too large", w, h);
        return NULL;
    }
    if (!isfinite(o->uscale) || !isfinite(o->vscale) || !isfinite(o->udelta) ||
        !isfinite(o->vdelta)) {
        err_set(err, "image texture with a non-finite uscale, vscale, udelta or vdelta");
        return NULL;
    }
    texture_t *t = alloc_texture(TEX_IMAGE, err);
    if (!t)
        return NULL;
    t->uscale = o->uscale;
    t->vscale = o->vscale;
    t->udelta = o->udelta;
    t->vdelta = o->vdelta;
    t->wrap = o->wrap;
    t->filter = o->filter;
    int nc = o->grey ? 1 : 3;
    /* The levels' linear values (clamped to >= 0; a float texture's channel means), kept until
     * the coefficients are made. */
    float *lv[LEVELS_MAX] = {0};
    rgb_uplift_t *table = NULL;
    size_t n0 = (size_t)w * (size_t)h;
    if (!(lv[0] = malloc(n0 * (size_t)nc * sizeof *lv[0])))
        goto oom;
    for (size_t i = 0; i < n0; i++) {
        if (o->grey)
            lv[0][i] = clamp_zero((rgb[3 * i] + rgb[3 * i + 1] + rgb[3 * i + 2]) / 3.0f);
        else
            for (int c = 0; c < 3; c++)
                lv[0][3 * i + c] = clamp_zero(rgb[3 * i + c]);
    }
    t->nlevels = 1;
    t->level[0].w = w;
    t->level[0].h = h;
    if (o->filter == TEXTURE_FILTER_TRILINEAR)
        while (t->nlevels < LEVELS_MAX &&
               (t->level[t->nlevels - 1].w > 1 || t->level[t->nlevels - 1].h > 1)) {
            level_t *p = &t->level[t->nlevels - 1], *q = &t->level[t->nlevels];
            if (!(lv[t->nlevels] = halve(lv[t->nlevels - 1], p->w, p->h, nc, &q->w, &q->h)))
                goto oom;
            t->nlevels++;
        }
    if (o->grey) {
        for (int l = 0; l < t->nlevels; l++) {
            t->level[l].val = lv[l];
            lv[l] = NULL;
        }
        return t;
    }
    /* A new table holds every node's fit (rgb_uplift.h): nothing to note or prepare. */
    if (!(table = rgb_uplift_new(err)))
        goto fail;
    for (int l = 0; l < t->nlevels; l++) {
        size_t n = (size_t)t->level[l].w * (size_t)t->level[l].h;
        if (!(t->level[l].coef = malloc(4 * n * sizeof *t->level[l].coef)))
            goto oom;
        coef_job_t job = {table, lv[l], t->level[l].coef, n};
        if (pool_for(o->threads, (int)((n + COEF_CHUNK - 1) / COEF_CHUNK), coef_chunk, &job, err) <
            0)
            goto fail;
        free(lv[l]);
        lv[l] = NULL;
    }
    rgb_uplift_destroy(&table);
    return t;
oom:
    err_set(err, "out of memory for a %dx%d image texture", w, h);
fail:
    for (int l = 0; l < LEVELS_MAX; l++)
        free(lv[l]);
    rgb_uplift_destroy(&table);
    texture_destroy(&t);
    return NULL;
}

texture_t *texture_new_normalmap(const float *rgb, int w, int h, err_t *err)
{
    if (!rgb || w <= 0 || h <= 0 || (size_t)w * (size_t)h > ((size_t)1 << 28)) {
        err_set(err, "normal map of %dx%d texels is empty or too large", w, h);
        return NULL;
    }
    texture_t *t = alloc_texture(TEX_NORMALMAP, err);
    if (!t)
        return NULL;
    size_t n = (size_t)w * (size_t)h * 3;
    if (!(t->level[0].rgb = malloc(n * sizeof *t->level[0].rgb))) {
        free(t);
        err_set(err, "out of memory for a %dx%d normal map", w, h);
        return NULL;
    }
    memcpy(t->level[0].rgb, rgb, n * sizeof *rgb);
    t->level[0].w = w;
    t->level[0].h = h;
    t->nlevels = 1;
    t->uscale = t->vscale = 1.0;
    t->wrap = TEXTURE_WRAP_REPEAT;
    return t;
}

void texture_destroy(texture_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    spectrum_destroy(&(*self_p)->spectrum);
    rgb_uplift_destroy(&(*self_p)->uplift);
    for (int l = 0; l < LEVELS_MAX; l++) {
        free((*self_p)->level[l].coef);
        free((*self_p)->level[l].val);
        free((*self_p)->level[l].rgb);
    }
    free(*self_p);
    *self_p = NULL;
}

/* pbrt-v4 RemapPixelCoords: 0 when (x, y) reads as black, else the texel to read. */
static int remap(texture_wrap_t wrap, int w, int h, long *x, long *y)
{
    switch (wrap) {
    case TEXTURE_WRAP_REPEAT:
        *x %= w;
        *y %= h;
        if (*x < 0)
            *x += w;
        if (*y < 0)
            *y += h;
        return 1;
    case TEXTURE_WRAP_BLACK:
        return *x >= 0 && *x < w && *y >= 0 && *y < h;
    case TEXTURE_WRAP_OCTAHEDRAL_SPHERE:
        /* Across an edge of the equal-area square the sphere continues mirrored. */
        if (*x < 0) {
            *x = -*x - 1;
            *y = h - 1 - *y;
        } else if (*x >= w) {
            *x = 2 * (long)w - 1 - *x;
            *y = h - 1 - *y;
        }
        if (*y < 0) {
            *x = w - 1 - *x;
            *y = -*y - 1;
        } else if (*y >= h) {
            *x = w - 1 - *x;
            *y = 2 * (long)h - 1 - *y;
        }
        /* A far-away coordinate (or a 1-texel side) clamps. */
        __attribute__((fallthrough));
    case TEXTURE_WRAP_CLAMP:
        *x = *x < 0 ? 0 : (*x >= w ? w - 1 : *x);
        *y = *y < 0 ? 0 : (*y >= h ? h - 1 : *y);
        return 1;
    }
    return 0;
}

static double texel(const texture_t *t, int l, long x, long y, double lambda)
{
    const level_t *lv = &t->level[l];
    if (!remap(t->wrap, lv->w, lv->h, &x, &y))
        return 0.0;
    size_t i = (size_t)y * (size_t)lv->w + (size_t)x;
    return lv->val ? lv->val[i] : rgb_uplift_eval(lv->coef + 4 * i, lambda);
}

/* Coordinates so large that the texel index overflows a long read as texel 0. */
static long to_index(double f)
{
    return fabs(f) < 0x1p52 ? (long)f : 0;
}

/* pbrt-v4 Image::Bilerp at level l: texel centres at half-integers. */
static double bilerp(const texture_t *t, int l, double s, double tt, double lambda)
{
    double x = s * t->level[l].w - 0.5, y = tt * t->level[l].h - 0.5;
    double fx = floor(x), fy = floor(y);
    double dx = x - fx, dy = y - fy;
    long ix = to_index(fx), iy = to_index(fy);
    return (1 - dx) * (1 - dy) * texel(t, l, ix, iy, lambda) +
           dx * (1 - dy) * texel(t, l, ix + 1, iy, lambda) +
           (1 - dx) * dy * texel(t, l, ix, iy + 1, lambda) +
           dx * dy * texel(t, l, ix + 1, iy + 1, lambda);
}

/* pbrt-v4 MIPMap::Filter for the point, bilinear and trilinear filters. */
static double image_lookup(const texture_t *t, double u, double v, double width, double lambda)
{
    double s = t->uscale * u + t->udelta, tt = 1.0 - (t->vscale * v + t->vdelta);
    if (!isfinite(s) || !isfinite(tt))
        return 0.0;
    switch (t->filter) {
    case TEXTURE_FILTER_POINT:
        return texel(t, 0, to_index(round(s * t->level[0].w - 0.5)),
                     to_index(round(tt * t->level[0].h - 0.5)), lambda);
    case TEXTURE_FILTER_BILINEAR:
        return bilerp(t, 0, s, tt, lambda);
    case TEXTURE_FILTER_TRILINEAR:
        break;
    }
    /* pbrt-v4's level choice, level 0 itself included: below level 1 it reads level 0. */
    double level = t->nlevels - 1 + log2(fmax(width, 1e-8));
    if (level >= t->nlevels - 1)
        return texel(t, t->nlevels - 1, 0, 0, lambda);
    if (!(level >= 1.0))
        return bilerp(t, 0, s, tt, lambda);
    int il = (int)level;
    double d = level - il;
    return (1 - d) * bilerp(t, il, s, tt, lambda) + d * bilerp(t, il + 1, s, tt, lambda);
}

/* One texel's value from its address i (-1: black, remap refused it). */
static double texel_at(const level_t *lv, long i, double lambda)
{
    if (i < 0)
        return 0.0;
    return lv->val ? lv->val[i] : rgb_uplift_eval(lv->coef + 4 * (size_t)i, lambda);
}

static long texel_index(const texture_t *t, int l, long x, long y)
{
    const level_t *lv = &t->level[l];
    if (!remap(t->wrap, lv->w, lv->h, &x, &y))
        return -1;
    return (long)((size_t)y * (size_t)lv->w + (size_t)x);
}

/* image_lookup at n wavelengths, for the lookups of width 0 (texture_eval_lanes): the bilinear
 * read of level 0, the bilinear and trilinear filters' (a trilinear filter's level at width 0
 * is below 1: level 0). The same products and sums in the same order as bilerp, so the same
 * bits; the point filter and the rest read lane by lane. */
static void image_lookup_lanes(const texture_t *t, double u, double v, const double *lambda, int n,
                               double *out)
{
    double s = t->uscale * u + t->udelta, tt = 1.0 - (t->vscale * v + t->vdelta);
    int lanes = isfinite(s) && isfinite(tt) &&
                (t->filter == TEXTURE_FILTER_BILINEAR ||
                 (t->filter == TEXTURE_FILTER_TRILINEAR &&
                  !(t->nlevels - 1 + log2(1e-8) >= t->nlevels - 1) &&
                  !(t->nlevels - 1 + log2(1e-8) >= 1.0)));
    if (!lanes) {
        for (int j = 0; j < n; j++)
            out[j] = image_lookup(t, u, v, 0.0, lambda[j]);
        return;
    }
    const level_t *lv = &t->level[0];
    double x = s * lv->w - 0.5, y = tt * lv->h - 0.5;
    double fx = floor(x), fy = floor(y);
    double dx = x - fx, dy = y - fy;
    long ix = to_index(fx), iy = to_index(fy);
    const long at[4] = {texel_index(t, 0, ix, iy), texel_index(t, 0, ix + 1, iy),
                        texel_index(t, 0, ix, iy + 1), texel_index(t, 0, ix + 1, iy + 1)};
    const double w[4] = {(1 - dx) * (1 - dy), dx * (1 - dy), (1 - dx) * dy, dx * dy};
    /* A texel whose value does not depend on the wavelength (black, a float texture's, a grey
     * one: rgb_uplift_eval's flat coefficients) is read once for all lanes, and when all four
     * are, so is their sum: the same value texel_at gives at every lambda, so the same bits. */
    double tv[4];
    int varies = 0;
    for (int k = 0; k < 4; k++) {
        const double *c = at[k] >= 0 && !lv->val ? lv->coef + 4 * (size_t)at[k] : NULL;
        if (c && !(c[0] == 0.0 && c[1] == 0.0 && c[2] == 0.0))
            varies |= 1 << k;
        else
            tv[k] = texel_at(lv, at[k], 0.0);
    }
    if (!varies) {
        const double r = w[0] * tv[0] + w[1] * tv[1] + w[2] * tv[2] + w[3] * tv[3];
        for (int j = 0; j < n; j++)
            out[j] = r;
        return;
    }
    for (int j = 0; j < n; j++) {
        for (int k = 0; k < 4; k++)
            if (varies & (1 << k))
                tv[k] = texel_at(lv, at[k], lambda[j]);
        out[j] = w[0] * tv[0] + w[1] * tv[1] + w[2] * tv[2] + w[3] * tv[3];
    }
}

vec3_t texture_eval_normalmap(const texture_t *t, double u, double v)
{
    if (t->kind != TEX_NORMALMAP)
        return vec3_make(0, 0, 1);
    const level_t *lv = &t->level[0];
    double s = u, tt = 1.0 - v;
    if (!isfinite(s) || !isfinite(tt))
        return vec3_make(0, 0, 1);
    double x = s * lv->w - 0.5, y = tt * lv->h - 0.5;
    double fx = floor(x), fy = floor(y);
    double dx = x - fx, dy = y - fy;
    double n[3] = {0, 0, 0};
    for (int k = 0; k < 4; k++) {
        long ix = to_index(fx) + (k & 1), iy = to_index(fy) + (k >> 1);
        remap(TEXTURE_WRAP_REPEAT, lv->w, lv->h, &ix, &iy);
        double wgt = ((k & 1) ? dx : 1 - dx) * ((k >> 1) ? dy : 1 - dy);
        const float *p = lv->rgb + 3 * ((size_t)iy * (size_t)lv->w + (size_t)ix);
        for (int c = 0; c < 3; c++)
            n[c] += wgt * p[c];
    }
    vec3_t r = vec3_make(2 * n[0] - 1, 2 * n[1] - 1, 2 * n[2] - 1);
    double len = vec3_length(r);
    return len > 1e-12 && isfinite(len) ? vec3_scale(r, 1.0 / len) : vec3_make(0, 0, 1);
}

/* Whether the integer-valued, finite x is odd: (long)fmod(x, 2) & 1 without the libm call.
 * Every double of magnitude 2^53 or more is even; below that the conversion is exact. */
static inline long odd(double x)
{
    return fabs(x) < 0x1p53 ? (long)((long long)x & 1) : 0;
}

/* pbrt-v4 InsidePolkaDot: the cell of integer (s, t) nearest holds a dot when the noise at its
 * centre is positive; the dot's centre is shifted by noise within the cell. */
static int inside_dot(double s, double t)
{
    const double radius = 0.35, max_shift = 0.5 - radius;
    double sc = floor(s + 0.5), tc = floor(t + 0.5);
    if (!(noise_perlin(vec3_make(sc + 0.5, tc + 0.5, 0.5)) > 0.0))
        return 0;
    double s0 = sc + max_shift * noise_perlin(vec3_make(sc + 1.5, tc + 2.8, 0.5));
    double t0 = tc + max_shift * noise_perlin(vec3_make(sc + 4.5, tc + 9.8, 0.5));
    return (s - s0) * (s - s0) + (t - t0) * (t - t0) < radius * radius;
}

/* pbrt-v4 MarbleTexture's spline: nine linear sRGB control points, read as three cubic Bezier
 * segments (points k..k+3 for k = 0..5, one segment per sixth of t). Data from pbrt-v4
 * src/pbrt/textures.cpp. */
static void marble_rgb(double t, float rgb[3])
{
    static const double C[9][3] = {{.58, .58, .6}, {.58, .58, .6}, {.58, .58, .6},
                                   {.5, .5, .5},   {.6, .59, .58}, {.58, .58, .6},
                                   {.58, .58, .6}, {.2, .2, .33},  {.58, .58, .6}};
    const int nseg = 6;
    double x = fmin(fmax(t, 0.0), 1.0) * nseg;
    int first = (int)floor(x);
    if (first > nseg - 1)
        first = nseg - 1;
    double u = x - first, w = 1.0 - u;
    /* Bernstein weights of a cubic Bezier curve */
    double b[4] = {w * w * w, 3.0 * u * w * w, 3.0 * u * u * w, u * u * u};
    for (int c = 0; c < 3; c++) {
        double v = 0.0;
        for (int k = 0; k < 4; k++)
            v += b[k] * C[first + k][c];
        rgb[c] = (float)(1.5 * v);
    }
}

static double eval(const texture_t *t, const texture_point_t *at, double width, double lambda)
{
    double u = at->u, v = at->v;
    switch (t->kind) {
    case TEX_CONSTANT:
        return spectrum_eval(t->spectrum, lambda);
    case TEX_CHECKER: {
        double fu = floor(u * t->uscale), fv = floor(v * t->vscale);
        if (!isfinite(fu) || !isfinite(fv))
            return eval(t->a, at, width, lambda);
        long parity = (odd(fu) + odd(fv)) & 1;
        return eval(parity ? t->b : t->a, at, width, lambda);
    }
    case TEX_SCALE:
        return eval(t->a, at, width, lambda) * eval(t->b, at, width, lambda);
    case TEX_MIX: {
        double a = eval(t->c, at, width, lambda);
        return (1.0 - a) * eval(t->a, at, width, lambda) + a * eval(t->b, at, width, lambda);
    }
    case TEX_IMAGE:
        return image_lookup(t, u, v, width, lambda);
    case TEX_NORMALMAP:
        return 0.0;
    case TEX_BILERP: {
        double s = t->uscale * u + t->udelta, tt = t->vscale * v + t->vdelta;
        if (!isfinite(s) || !isfinite(tt))
            return eval(t->a, at, width, lambda);
        return (1 - s) * (1 - tt) * eval(t->a, at, width, lambda) +
               (1 - s) * tt * eval(t->b, at, width, lambda) +
               s * (1 - tt) * eval(t->c, at, width, lambda) +
               s * tt * eval(t->d, at, width, lambda);
    }
    case TEX_DOTS: {
        double s = t->uscale * u + t->udelta, tt = t->vscale * v + t->vdelta;
        int in = isfinite(s) && isfinite(tt) && inside_dot(s, tt);
        return eval(in ? t->a : t->b, at, width, lambda);
    }
    case TEX_CHECKER3D: {
        vec3_t p = transform_point(&t->to_texture, at->p);
        double fx = floor(p.x), fy = floor(p.y), fz = floor(p.z);
        if (!isfinite(fx) || !isfinite(fy) || !isfinite(fz))
            return eval(t->a, at, width, lambda);
        long parity = (odd(fx) + odd(fy) + odd(fz)) & 1;
        return eval(parity ? t->b : t->a, at, width, lambda);
    }
    case TEX_FBM:
        return noise_fbm(transform_point(&t->to_texture, at->p), t->omega, t->octaves);
    case TEX_WRINKLED:
        return noise_turbulence(transform_point(&t->to_texture, at->p), t->omega, t->octaves);
    case TEX_WINDY: {
        vec3_t p = transform_point(&t->to_texture, at->p);
        double strength = noise_fbm(vec3_scale(p, 0.1), 0.5, 3);
        return fabs(strength) * noise_fbm(p, 0.5, 6);
    }
    case TEX_MARBLE: {
        vec3_t q = vec3_scale(transform_point(&t->to_texture, at->p), t->scale);
        double m = q.y + t->variation * noise_fbm(q, t->omega, t->octaves);
        float rgb[3];
        marble_rgb(0.5 + 0.5 * sin(m), rgb);
        double c[4];
        if (!isfinite(m) || rgb_uplift_coef(t->uplift, rgb, c, NULL))
            return 0.0;
        return rgb_uplift_eval(c, lambda);
    }
    case TEX_MAPPED: {
        const double pi = 3.14159265358979323846;
        vec3_t q = transform_point(&t->to_texture, at->p);
        texture_point_t st = *at;
        if (t->mapping == TEXTURE_MAP_SPHERICAL) {
            double r = vec3_length(q);
            double z = r > 0.0 ? fmin(fmax(q.z / r, -1.0), 1.0) : 1.0;
            double phi = atan2(q.y, q.x);
            st.u = acos(z) / pi;
            st.v = (phi < 0.0 ? phi + 2.0 * pi : phi) / (2.0 * pi);
        } else if (t->mapping == TEXTURE_MAP_CYLINDRICAL) {
            st.u = (pi + atan2(q.y, q.x)) / (2.0 * pi);
            st.v = q.z;
        } else {
            st.u = t->udelta + vec3_dot(q, t->dir);
            st.v = t->vdelta + vec3_dot(q, t->vt);
        }
        if (!isfinite(st.u) || !isfinite(st.v))
            st.u = st.v = 0.0;
        return eval(t->a, &st, width, lambda);
    }
    case TEX_DIRECTIONMIX: {
        double a = fmin(fabs(vec3_dot(at->n, t->dir)), 1.0);
        if (!(a >= 0.0))
            a = 0.0;
        return a * eval(t->a, at, width, lambda) + (1.0 - a) * eval(t->b, at, width, lambda);
    }
    }
    return 0.0;
}

double texture_eval_width(const texture_t *t, double u, double v, double width, double lambda)
{
    const texture_point_t at = {.u = u, .v = v};
    return eval(t, &at, width, lambda);
}

double texture_eval(const texture_t *t, double u, double v, double lambda)
{
    const texture_point_t at = {.u = u, .v = v};
    return eval(t, &at, 0.0, lambda);
}

double texture_eval_at(const texture_t *t, const texture_point_t *at, double lambda)
{
    return eval(t, at, 0.0, lambda);
}

void texture_eval_lanes(const texture_t *t, const texture_point_t *at, const double *lambda, int n,
                        double *out)
{
    switch (t->kind) {
    case TEX_CONSTANT:
        /* eval's case, without its dispatch per lane. */
        for (int j = 0; j < n; j++)
            out[j] = spectrum_eval(t->spectrum, lambda[j]);
        return;
    case TEX_IMAGE:
        image_lookup_lanes(t, at->u, at->v, lambda, n, out);
        return;
    case TEX_SCALE: {
        /* eval's a * b lane by lane, each factor read for all lanes first. */
        double b[TEXTURE_MAX_LANES];
        if (n <= TEXTURE_MAX_LANES) {
            texture_eval_lanes(t->a, at, lambda, n, out);
            texture_eval_lanes(t->b, at, lambda, n, b);
            for (int j = 0; j < n; j++)
                out[j] *= b[j];
            return;
        }
        break;
    }
    default:
        break;
    }
    for (int j = 0; j < n; j++)
        out[j] = eval(t, at, 0.0, lambda[j]);
}
