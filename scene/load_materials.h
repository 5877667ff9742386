/* load_materials: the description's materials (Material, MakeNamedMaterial) made into the
 * scene's material_t, in the description's order (shapes name them by index): indices of
 * refraction from numbers, pairs, files, named spectra or the glass catalogue; texture-or-constant
 * inputs; a measured material's file read once. A new material is its case in load_materials
 * (with a reader beside it when it takes more than a line). */
#ifndef PRISMFARM_LOAD_MATERIALS_H
#define PRISMFARM_LOAD_MATERIALS_H

#include "loader.h"

/* The material a shape placed by to_world uses: a crystal's optic axis is given in the shape's
 * object space, so each differently turned crystal shape gets its own copy with the axis in
 * world space (in an object's space for shapes of instanced objects: instances do not turn it,
 * docs/physics.md §15). Any other material is used as it is. */
int load_materials_for_shape(loader_t *L, int idx, const transform_t *to_world, err_t *err);

/* The description's materials into the scene, in its order. */
int load_materials(loader_t *L, err_t *err);

#endif
