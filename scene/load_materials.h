/* load_materials: the description's materials (Material, MakeNamedMaterial) made into the
 * scene's material_t, in the description's order (shapes name them by index): its name, what
 * its class reads and loads (material_class.h: each kind's own parameters, in
 * scene/material_<name>.c), what every material but mix and interface shares (bump and normal
 * maps), and the refusal of a parameter nothing read. It names no material: a new one is its
 * class. */
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

/* Reads every material as load_materials does, each refusal (its parameters, in the class's
 * words) added to refusals instead of stopping at the first: prismfarm check's look at a scene
 * that did not parse cleanly (scene_load_check_materials). -1 only when out of memory. */
int load_materials_check(loader_t *L, warnings_t *refusals, err_t *err);

#endif
