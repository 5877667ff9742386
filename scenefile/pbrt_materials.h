/* pbrt_materials: Material and MakeNamedMaterial: each material's parameters as pbrt-v4's
 * materials.cpp reads them, into a scene_material_t. A new material is its name's row in
 * material_kind.c and its reader here (its class in scene/material_<name>.c loads it). */
#ifndef PRISMFARM_PBRT_MATERIALS_H
#define PRISMFARM_PBRT_MATERIALS_H

#include "pbrt_state.h"

int pbrt_materials_read(parser_t *P, params_t *ps, const str_arg_t *type, const char *name,
                        pbrt_loc_t loc, pbrt_loc_t type_loc);
/* MakeNamedMaterial "name" params (name: the directive's argument). */
int pbrt_materials_read_named(parser_t *P, params_t *ps, const str_arg_t *name, pbrt_loc_t loc);

#endif
