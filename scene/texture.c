#include "texture.h"

#include "pool.h"
#include "rgb_uplift.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef enum { TEX_CONSTANT, TEX_CHECKER, TEX_SCALE, TEX_MIX, TEX_IMAGE, TEX_NORMALMAP } tex_kind_t;

/* One level of an image texture: per texel rgb_uplift's four coefficients (coef), or one
 * value (val, a float texture), or three floats (rgb, a normal map). */
typedef struct level {
    int w, h;
    double *coef;
    float *val;
    float *rgb;
} level_t;

#define LEVELS_MAX 32

struct texture {
    tex_kind_t kind;
    spectrum_t *spectrum; /* constant */
    const texture_t *a, *b, *c;
    double uscale, vscale, udelta, vdelta;
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

texture_image_opts_t texture_image_opts_default(void)
{
    return (texture_image_opts_t){.uscale = 1.0, .vscale = 1.0, .wrap = TEXTURE_WRAP_REPEAT,
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
                    0.25f * (src[((size_t)y0 * w + x0) * nc + c] + src[((size_t)y0 * w + x1) * nc + c] +
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
    if (!isfinite(o->uscale) || !isfinite(o->vscale) || !isfinite(o->udelta) || !isfinite(o->vdelta)) {
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
        if (pool_for(o->threads, (int)((n + COEF_CHUNK - 1) / COEF_CHUNK), coef_chunk, &job, err) < 0)
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
    return (1 - dx) * (1 - dy) * texel(t, l, ix, iy, lambda) + dx * (1 - dy) * texel(t, l, ix + 1, iy, lambda) +
           (1 - dx) * dy * texel(t, l, ix, iy + 1, lambda) + dx * dy * texel(t, l, ix + 1, iy + 1, lambda);
}

/* pbrt-v4 MIPMap::Filter for the point, bilinear and trilinear filters. */
static double image_lookup(const texture_t *t, double u, double v, double width, double lambda)
{
    double s = t->uscale * u + t->udelta, tt = 1.0 - (t->vscale * v + t->vdelta);
    if (!isfinite(s) || !isfinite(tt))
        return 0.0;
    switch (t->filter) {
    case TEXTURE_FILTER_POINT:
        return texel(t, 0, to_index(round(s * t->level[0].w - 0.5)), to_index(round(tt * t->level[0].h - 0.5)),
                     lambda);
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

double texture_eval_width(const texture_t *t, double u, double v, double width, double lambda)
{
    switch (t->kind) {
    case TEX_CONSTANT:
        return spectrum_eval(t->spectrum, lambda);
    case TEX_CHECKER: {
        double fu = floor(u * t->uscale), fv = floor(v * t->vscale);
        if (!isfinite(fu) || !isfinite(fv))
            return texture_eval_width(t->a, u, v, width, lambda);
        long parity = (odd(fu) + odd(fv)) & 1;
        return texture_eval_width(parity ? t->b : t->a, u, v, width, lambda);
    }
    case TEX_SCALE:
        return texture_eval_width(t->a, u, v, width, lambda) * texture_eval_width(t->b, u, v, width, lambda);
    case TEX_MIX: {
        double a = texture_eval_width(t->c, u, v, width, lambda);
        return (1.0 - a) * texture_eval_width(t->a, u, v, width, lambda) +
               a * texture_eval_width(t->b, u, v, width, lambda);
    }
    case TEX_IMAGE:
        return image_lookup(t, u, v, width, lambda);
    case TEX_NORMALMAP:
        return 0.0;
    }
    return 0.0;
}

double texture_eval(const texture_t *t, double u, double v, double lambda)
{
    return texture_eval_width(t, u, v, 0.0, lambda);
}
