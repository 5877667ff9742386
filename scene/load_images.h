/* load_images: the image files a scene names (textures, normal maps, lights' images) read into
 * linear RGB floats, top row first: OpenEXR and PFM by their extension, PNG through libpng, the
 * rest through stb_image; 8- and 16-bit values decoded by pbrt-v4's ColorEncoding ("sRGB",
 * "linear", "gamma G"). load_images_read_at charges the texels to the loader's budget and names
 * the scene file's line in its errors. */
#ifndef PRISMFARM_LOAD_IMAGES_H
#define PRISMFARM_LOAD_IMAGES_H

#include "loader.h"
#include "scene_desc.h"

/* pbrt-v4 ColorEncoding for 8- and 16-bit files: "sRGB" (the default), "linear", or
 * "gamma G" (v^G). Float files (EXR, PFM, HDR) are linear whatever it says, as in pbrt-v4. */
typedef struct load_encoding {
    int linear;
    double gamma; /* > 0: gamma; else sRGB unless linear */
    float lut[256];
} load_encoding_t;

/* "sRGB", "linear" or "gamma G" into *e (its table of the 256 8-bit values); -1 for any other. */
int load_images_encoding_parse(const char *s, load_encoding_t *e);

/* Reads an image file for a texture or a normal map as linear RGB (top row first), and its
 * alpha channel into *alpha when the file has one (else NULL), both malloc'ed: OpenEXR and
 * PFM by their extension, PNG through libpng, the rest (TGA, JPEG, BMP, HDR, ...) through
 * stb_image. 8- and 16-bit values are decoded by enc (the alpha too, as pbrt-v4 does). */
int load_images_read(const char *path, const load_encoding_t *enc, int *w, int *h, float **rgb,
                     float **alpha, err_t *err);

/* A light's image at path, by its extension: OpenEXR, PFM, or whatever stb_image reads (HDR,
 * PNG, JPEG, TGA, BMP), as w * h * 3 linear floats (*rgb, the caller frees), charged to the
 * texel budget. Errors name the "filename" parameter at loc and the directive what. */
int load_images_read_at(loader_t *L, const char *path, pbrt_loc_t loc, const char *what,
                        float **rgb, int *w, int *h, err_t *err);

#endif
