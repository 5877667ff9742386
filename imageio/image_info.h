/* image_info: an image file's width and height from its header alone, by the rule the scene
 * loader reads images with (".exr": OpenEXR, ".pfm", ".png", anything else through stb_image:
 * HDR, JPEG, TGA, BMP), so that its pixels are charged to a budget before anything decodes it
 * (issue 26: a small file whose header claims huge dimensions must not make the master
 * allocate them). Reads the header only, never the pixels. */
#ifndef PRISMFARM_IMAGE_INFO_H
#define PRISMFARM_IMAGE_INFO_H

#include "err.h"

/* The image's size. -1 with a message naming the file when its header cannot be read or its
 * size is empty or beyond int; the decoder then says the same or more. */
int image_info_read(const char *path, int *width, int *height, err_t *err);

#endif
