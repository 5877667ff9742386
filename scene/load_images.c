#include "load_images.h"

#include "image_exr.h"
#include "image_pfm.h"
#include "image_png.h"
#include "image_stb.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

static int ends_with_ci(const char *s, const char *suffix)
{
    size_t n = strlen(s), k = strlen(suffix);
    return n >= k && !strcasecmp(s + n - k, suffix);
}

static double srgb_to_linear(double v)
{
    return v <= 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4);
}

static double decode(const load_encoding_t *e, double v)
{
    return e->linear ? v : e->gamma > 0.0 ? pow(v, e->gamma) : srgb_to_linear(v);
}

int load_images_encoding_parse(const char *s, load_encoding_t *e)
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
static float decode_stored(const load_encoding_t *e, float v)
{
    long k = lrintf(v * 255.0f);
    return k >= 0 && k < 256 && (float)(k / 255.0) == v ? e->lut[k] : (float)decode(e, v);
}

int load_images_read(const char *path, const load_encoding_t *enc, int *w, int *h, float **rgb,
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

int load_images_read_at(loader_t *L, const char *path, pbrt_loc_t loc, const char *what,
                        float **rgb, int *w, int *h, err_t *err)
{
    int rc;
    *rgb = NULL;
    *w = *h = 0;
    int charged = loader_budget_texels_header(L, path, err);
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
    if (rc == 0 && !charged && loader_budget_texels(L, *w, *h, err))
        rc = -1;
    if (rc) {
        free(*rgb);
        *rgb = NULL;
        return err_prefix(err, "%s:%d:%d: %s: ", loc.file, loc.line, loc.col, what);
    }
    return 0;
}
