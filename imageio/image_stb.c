#include "image_stb.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <stb_image.h>

static float srgb_to_linear(double c)
{
    return (float)(c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4));
}

int image_stb_read(const char *path, int *width, int *height, float **rgb, err_t *err)
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
    if (stbi_is_hdr(path)) {
        float *px = stbi_loadf(path, &w, &h, &comp, 3);
        if (!px) {
            free(out);
            return err_set(err, "%s: cannot decode image: %s", path, stbi_failure_reason());
        }
        memcpy(out, px, n * 3 * sizeof *out);
        stbi_image_free(px);
    } else if (stbi_is_16_bit(path)) {
        stbi_us *px = stbi_load_16(path, &w, &h, &comp, 3);
        if (!px) {
            free(out);
            return err_set(err, "%s: cannot decode image: %s", path, stbi_failure_reason());
        }
        for (size_t i = 0; i < 3 * n; i++)
            out[i] = srgb_to_linear(px[i] / 65535.0);
        stbi_image_free(px);
    } else {
        stbi_uc *px = stbi_load(path, &w, &h, &comp, 3);
        if (!px) {
            free(out);
            return err_set(err, "%s: cannot decode image: %s", path, stbi_failure_reason());
        }
        float lut[256];
        for (int i = 0; i < 256; i++)
            lut[i] = srgb_to_linear(i / 255.0);
        for (size_t i = 0; i < 3 * n; i++)
            out[i] = lut[px[i]];
        stbi_image_free(px);
    }
    *width = w;
    *height = h;
    *rgb = out;
    return 0;
}
