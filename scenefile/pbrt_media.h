/* pbrt_media: MakeNamedMedium (pbrt-v4 media.cpp: "homogeneous" and "uniformgrid" read,
 * "nanovdb" naming its file for the loader, "rgbgrid" and "cloud" accepted with a warning and
 * rendered as vacuum) and
 * MediumInterface. */
#ifndef PRISMFARM_PBRT_MEDIA_H
#define PRISMFARM_PBRT_MEDIA_H

#include "pbrt_state.h"

int pbrt_media_read(parser_t *P, pbrt_loc_t loc);
int pbrt_media_interface(parser_t *P, pbrt_loc_t loc);

#endif
