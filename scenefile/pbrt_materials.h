/* pbrt_materials: Material and MakeNamedMaterial into the description: the material's type as
 * written, which the loader looks up in its registry of classes (scene/material_kind.h), and its
 * parameters, kept unread for its class to read when the scene loads
 * (scene/material_<name>.c), as pbrt-v4 keeps a material's ParameterDictionary.
 * What must happen while the scene is parsed -- the files a material names confined, charged
 * and listed for the bundle -- is one rule keyed on the parameters' declared types and names
 * that knows no material: a new material needs nothing here. */
#ifndef PRISMFARM_PBRT_MATERIALS_H
#define PRISMFARM_PBRT_MATERIALS_H

#include "pbrt_state.h"

/* On success the description owns ps (scene_material_t.params). */
int pbrt_materials_read(parser_t *P, params_t *ps, const str_arg_t *type, const char *name,
                        pbrt_loc_t loc, pbrt_loc_t type_loc);
/* MakeNamedMaterial "name" params (name: the directive's argument). */
int pbrt_materials_read_named(parser_t *P, params_t *ps, const str_arg_t *name, pbrt_loc_t loc);

#endif
