/* pbrt_shapes: Shape: sphere, disk, cylinder, trianglemesh, plymesh, bilinearmesh and
 * loopsubdiv with pbrt-v4's parameters (shapes.cpp), the analytic ones kept as such where
 * Embree has them, the others made into meshes. */
#ifndef PRISMFARM_PBRT_SHAPES_H
#define PRISMFARM_PBRT_SHAPES_H

#include "pbrt_state.h"

int pbrt_shapes_read(parser_t *P, params_t *ps, const str_arg_t *type, pbrt_loc_t loc);

#endif
