/* load_shapes: Shape directives placed in world space (or in an instanced object's space) and
 * added to the scene with their material, area light, media and alpha: spheres, disks, curves
 * and triangle meshes (every other pbrt-v4 shape is a mesh by the parser's time). */
#ifndef PRISMFARM_LOAD_SHAPES_H
#define PRISMFARM_LOAD_SHAPES_H

#include "loader.h"

/* Adds one shape to the world (object < 0, in world space) or to a scene object (in the
 * object's space); the shape's own transform is applied here. */
int load_shapes_add(loader_t *L, const scene_shape_t *s, int object, err_t *err);

/* The world's shapes, in file order. */
int load_shapes(loader_t *L, err_t *err);

#endif
