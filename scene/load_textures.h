/* load_textures: the scene's Texture directives made into textures in file order (L->tex by
 * description index), image textures decoded beforehand on the pool, the same textures and the
 * same first failure for any number of threads; and a material's normal map. A new texture is
 * its case in load_textures_in_order (or load_procedural) and its constructor in texture.h. */
#ifndef PRISMFARM_LOAD_TEXTURES_H
#define PRISMFARM_LOAD_TEXTURES_H

#include "loader.h"

/* A material's "normalmap", the image at path (named at at), read linear (pbrt-v4 reads normal
 * maps with ColorEncoding::Linear), as a texture the scene owns. */
const texture_t *load_textures_normal_map(loader_t *L, const char *path, pbrt_loc_t at, err_t *err);

/* The scene's textures in file order, its image textures made beforehand on the pool
 * (load_image_textures): the same textures, and the same first failure, for any threads. */
int load_textures(loader_t *L, err_t *err);

#endif
