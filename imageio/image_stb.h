/* image_stb: HDR (Radiance RGBE), PNG, JPEG, TGA, BMP and other 8/16-bit images through
 * Debian's stb_image (libstb-dev), as linear RGB floats: Radiance files are linear already,
 * the others are decoded from the sRGB transfer curve (pbrt-v4 reads 8-bit images as sRGB). */
#ifndef PRISMFARM_IMAGE_STB_H
#define PRISMFARM_IMAGE_STB_H

#include "err.h"

/* Largest number of pixels image_stb_read accepts. */
#define IMAGE_STB_MAX_PIXELS ((size_t)1 << 26)

/* *rgb is malloc'ed: width * height * 3 floats, top row first. -1 with a message naming the
 * file and stb_image's reason. */
int image_stb_read(const char *path, int *width, int *height, float **rgb, err_t *err);

/* The same without the transfer curve: *rgb holds the values as the file stores them, scaled
 * to [0, 1] (8 and 16 bits), and *is_float is 1 for a Radiance file (linear floats), so that
 * the caller applies the encoding it was asked for (pbrt-v4 ImageTexture "encoding"). With
 * alpha not NULL, *alpha is the file's alpha channel (width * height floats, stored values
 * like rgb's, malloc'ed), or NULL when the file has none. */
int image_stb_read_encoded(const char *path, int *width, int *height, float **rgb, float **alpha,
                           int *is_float, err_t *err);

#endif
