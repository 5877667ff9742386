#include "texture.h"

#include <math.h>
#include <stdlib.h>

typedef enum { TEX_CONSTANT, TEX_CHECKER, TEX_SCALE, TEX_MIX, TEX_IMAGE } tex_kind_t;

struct texture {
    tex_kind_t kind;
    spectrum_t *spectrum; /* constant */
    const texture_t *a, *b, *c;
    double uscale, vscale;
    int w, h;
    double *coef; /* image: per texel 3 sigmoid coefficients and a flat value (NaN if none) */
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

texture_t *texture_new_image(const float *rgb, int w, int h, double uscale, double vscale,
                             err_t *err)
{
    if (!rgb || w <= 0 || h <= 0 || (size_t)w * (size_t)h > ((size_t)1 << 28)) {
        err_set(err, "image texture of %dx%d texels is empty or too large", w, h);
        return NULL;
    }
    texture_t *t = alloc_texture(TEX_IMAGE, err);
    if (!t)
        return NULL;
    size_t n = (size_t)w * (size_t)h;
    t->coef = malloc(4 * n * sizeof *t->coef);
    if (!t->coef) {
        free(t);
        err_set(err, "out of memory for a %dx%d image texture", w, h);
        return NULL;
    }
    t->w = w;
    t->h = h;
    t->uscale = uscale;
    t->vscale = vscale;
    /* Uplift each texel once; neighbouring texels often share colours, so reuse the last fit. */
    rgb_t last = {-1, -1, -1};
    spectrum_sigmoid_t fit = {0};
    for (size_t i = 0; i < n; i++) {
        rgb_t c = {rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]};
        if (c.r != last.r || c.g != last.g || c.b != last.b) {
            if (spectrum_sigmoid_fit(c, &fit, err)) {
                texture_destroy(&t);
                return NULL;
            }
            last = c;
        }
        double *k = t->coef + 4 * i;
        k[0] = fit.c[0];
        k[1] = fit.c[1];
        k[2] = fit.c[2];
        /* Greys are exactly flat (the sigmoid cannot reach 0 or 1 for black and white). */
        k[3] = (c.r == c.g && c.g == c.b) ? fmin(1.0, fmax(0.0, c.r)) : NAN;
    }
    return t;
}

void texture_destroy(texture_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    spectrum_destroy(&(*self_p)->spectrum);
    free((*self_p)->coef);
    free(*self_p);
    *self_p = NULL;
}

static double texel(const texture_t *t, int x, int y, double lambda)
{
    x %= t->w;
    y %= t->h;
    if (x < 0)
        x += t->w;
    if (y < 0)
        y += t->h;
    const double *c = t->coef + 4 * ((size_t)y * (size_t)t->w + (size_t)x);
    if (!isnan(c[3]))
        return c[3];
    return spectrum_sigmoid((c[0] * lambda + c[1]) * lambda + c[2]);
}

/* Whether the integer-valued, finite x is odd: (long)fmod(x, 2) & 1 without the libm call.
 * Every double of magnitude 2^53 or more is even; below that the conversion is exact. */
static inline long odd(double x)
{
    return fabs(x) < 0x1p53 ? (long)((long long)x & 1) : 0;
}

double texture_eval(const texture_t *t, double u, double v, double lambda)
{
    switch (t->kind) {
    case TEX_CONSTANT:
        return spectrum_eval(t->spectrum, lambda);
    case TEX_CHECKER: {
        double fu = floor(u * t->uscale), fv = floor(v * t->vscale);
        if (!isfinite(fu) || !isfinite(fv))
            return texture_eval(t->a, u, v, lambda);
        long parity = (odd(fu) + odd(fv)) & 1;
        return texture_eval(parity ? t->b : t->a, u, v, lambda);
    }
    case TEX_SCALE:
        return texture_eval(t->a, u, v, lambda) * texture_eval(t->b, u, v, lambda);
    case TEX_MIX: {
        double a = texture_eval(t->c, u, v, lambda);
        return (1.0 - a) * texture_eval(t->a, u, v, lambda) + a * texture_eval(t->b, u, v, lambda);
    }
    case TEX_IMAGE: {
        /* pbrt's image lookup: v = 0 is the image's bottom row; texel centres at half
         * integers; bilinear filtering of the uplifted spectra. */
        double x = u * t->uscale * t->w - 0.5;
        double y = (1.0 - v * t->vscale) * t->h - 0.5;
        if (!isfinite(x) || !isfinite(y))
            return 0.0;
        double fx = floor(x), fy = floor(y);
        double dx = x - fx, dy = y - fy;
        long ix = (long)fmod(fx, (double)t->w), iy = (long)fmod(fy, (double)t->h);
        return (1 - dx) * (1 - dy) * texel(t, (int)ix, (int)iy, lambda) +
               dx * (1 - dy) * texel(t, (int)ix + 1, (int)iy, lambda) +
               (1 - dx) * dy * texel(t, (int)ix, (int)iy + 1, lambda) +
               dx * dy * texel(t, (int)ix + 1, (int)iy + 1, lambda);
    }
    }
    return 0.0;
}
