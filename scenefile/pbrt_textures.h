/* pbrt_textures: Texture "name" "float"|"spectrum" "class": each class's inputs and defaults
 * as pbrt-v4's textures.cpp creates them. */
#ifndef PRISMFARM_PBRT_TEXTURES_H
#define PRISMFARM_PBRT_TEXTURES_H

#include "pbrt_state.h"

int pbrt_textures_read(parser_t *P, pbrt_loc_t loc);

#endif
