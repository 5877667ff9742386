/* image_png: 8-bit sRGB PNG output of tone-mapped images, and a small reader (tests, image
 * textures) through libpng. Writes are atomic (PATH.tmp, fsync, rename); every libpng error,
 * including a truncated or corrupt file, becomes an err_t message naming the file, with nothing
 * leaked. */
#ifndef PRISMFARM_IMAGE_PNG_H
#define PRISMFARM_IMAGE_PNG_H

#include "err.h"

#include <stdint.h>

/* Writes an 8-bit RGB PNG from rgb (width * height * 3 bytes, row-major, top row first, values
 * already tone-mapped and sRGB-encoded). The file carries an sRGB chunk (perceptual intent) with
 * the gAMA (1/2.2) and cHRM chunks the PNG specification recommends beside it for decoders that
 * do not know sRGB. */
int image_png_write_rgb(const char *path, int width, int height, const uint8_t *rgb, err_t *err);

/* A PNG read into memory as 8-bit RGBA. */
typedef struct image_png image_png_t;

/* Reads any PNG libpng decodes (grey, grey+alpha, RGB, RGBA, palette; 1 to 16 bits) and
 * converts it to 8-bit RGBA: grey is copied to R, G and B, alpha is 255 where the file has none,
 * 16-bit samples keep their high byte. The bytes are returned as stored, without gamma or sRGB
 * decoding (the caller linearises them with the sRGB curve if the image is colour). Returns NULL
 * with a message naming the file on failure (not a PNG, truncated, corrupt, too large). */
image_png_t *image_png_read(const char *path, err_t *err);
void image_png_destroy(image_png_t **self_p);

int image_png_width(const image_png_t *self);
int image_png_height(const image_png_t *self);
/* Channels the file itself holds: 1 grey, 2 grey+alpha, 3 RGB, 4 RGBA (palette images count as
 * 3, or 4 with a transparency chunk). */
int image_png_channels(const image_png_t *self);
/* width * height * 4 bytes, R, G, B, A interleaved, top row first. */
const uint8_t *image_png_rgba(const image_png_t *self);

#endif
