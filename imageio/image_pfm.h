/* image_pfm: a reader of Portable Float Maps ("PF": RGB, "Pf": grey), the format pbrt-v4 reads
 * and writes (util/image.cpp ReadPFM). The header is "PF" or "Pf", the width, the height and a
 * scale whose sign gives the byte order (negative: little-endian, positive: big-endian), each
 * separated by white space, with exactly one white-space byte before the 32-bit floats, which
 * run from the bottom row up. */
#ifndef PRISMFARM_IMAGE_PFM_H
#define PRISMFARM_IMAGE_PFM_H

#include "err.h"

#include <stddef.h>
#include <stdint.h>

/* Largest number of pixels image_pfm_read accepts. */
#define IMAGE_PFM_MAX_PIXELS ((size_t)1 << 26)

/* Decodes a PFM held in memory into *rgb (malloc'ed, width * height * 3 floats, R G B
 * interleaved, top row first, grey copied to all three; the |scale| is not applied, as pbrt-v4
 * does not). name is for messages. Returns -1 with a message naming name and the fault. */
int image_pfm_decode(const uint8_t *data, size_t size, const char *name, int *width, int *height,
                     float **rgb, err_t *err);

/* Reads the file path and decodes it. */
int image_pfm_read(const char *path, int *width, int *height, float **rgb, err_t *err);

#endif
