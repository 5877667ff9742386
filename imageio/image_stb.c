#include "image_stb.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <stb_image.h>

static float srgb_to_linear(double c)
{
    return (float)(c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4));
}

int image_stb_read_encoded(const char *path, int *width, int *height, float **rgb, float **alpha,
                           int *is_float, err_t *err)
{
    int w, h, comp;
    if (!stbi_info(path, &w, &h, &comp))
        return err_set(err, "%s: cannot read image: %s", path, stbi_failure_reason());
    if (w <= 0 || h <= 0 || (size_t)w > IMAGE_STB_MAX_PIXELS / (size_t)h)
        return err_set(err, "%s: image of %dx%d pixels is empty or larger than %zu pixels", path, w,
                       h, IMAGE_STB_MAX_PIXELS);
    size_t n = (size_t)w * (size_t)h;
    float *out = malloc(n * 3 * sizeof *out);
    if (!out)
        return err_set(err, "%s: out of memory for %dx%d pixels", path, w, h);
    *is_float = stbi_is_hdr(path);
    /* Grey + alpha and RGBA files keep their alpha when asked: 4 channels decoded. */
    int nc = alpha && (comp == 2 || comp == 4) ? 4 : 3;
    float *a = NULL;
    if (nc == 4 && !(a = malloc(n * sizeof *a))) {
        free(out);
        return err_set(err, "%s: out of memory for %dx%d pixels", path, w, h);
    }
    if (*is_float) {
        float *px = stbi_loadf(path, &w, &h, &comp, nc);
        if (!px) {
            free(out);
            free(a);
            return err_set(err, "%s: cannot decode image: %s", path, stbi_failure_reason());
        }
        for (size_t i = 0; i < n; i++) {
            memcpy(out + 3 * i, px + nc * i, 3 * sizeof *out);
            if (a)
                a[i] = px[nc * i + 3];
        }
        stbi_image_free(px);
    } else if (stbi_is_16_bit(path)) {
        stbi_us *px = stbi_load_16(path, &w, &h, &comp, nc);
        if (!px) {
            free(out);
            free(a);
            return err_set(err, "%s: cannot decode image: %s", path, stbi_failure_reason());
        }
        for (size_t i = 0; i < n; i++) {
            for (int c = 0; c < 3; c++)
                out[3 * i + c] = (float)(px[nc * i + c] / 65535.0);
            if (a)
                a[i] = (float)(px[nc * i + 3] / 65535.0);
        }
        stbi_image_free(px);
    } else {
        stbi_uc *px = stbi_load(path, &w, &h, &comp, nc);
        if (!px) {
            free(out);
            free(a);
            return err_set(err, "%s: cannot decode image: %s", path, stbi_failure_reason());
        }
        for (size_t i = 0; i < n; i++) {
            for (int c = 0; c < 3; c++)
                out[3 * i + c] = (float)(px[nc * i + c] / 255.0);
            if (a)
                a[i] = (float)(px[nc * i + 3] / 255.0);
        }
        stbi_image_free(px);
    }
    *width = w;
    *height = h;
    *rgb = out;
    if (alpha)
        *alpha = a;
    return 0;
}

int image_stb_read(const char *path, int *width, int *height, float **rgb, err_t *err)
{
    int is_float;
    if (image_stb_read_encoded(path, width, height, rgb, NULL, &is_float, err))
        return -1;
    if (is_float)
        return 0;
    size_t n = (size_t)*width * (size_t)*height * 3;
    float lut[256];
    for (int i = 0; i < 256; i++)
        lut[i] = srgb_to_linear(i / 255.0);
    for (size_t i = 0; i < n; i++) {
        float v = (*rgb)[i], k = v * 255.0f;
        int ki = (int)lrintf(k);
        (*rgb)[i] = ki >= 0 && ki < 256 && (float)(ki / 255.0) == v ? lut[ki] : srgb_to_linear(v);
    }
    return 0;
}
