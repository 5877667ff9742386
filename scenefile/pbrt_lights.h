/* pbrt_lights: LightSource and AreaLightSource with pbrt-v4's parameters (lights.cpp): the
 * spectrum, its scale and power, and each light's own (cones, images). */
#ifndef PRISMFARM_PBRT_LIGHTS_H
#define PRISMFARM_PBRT_LIGHTS_H

#include "pbrt_state.h"

int pbrt_lights_read_area(parser_t *P, params_t *ps, const str_arg_t *type, pbrt_loc_t loc);
int pbrt_lights_read(parser_t *P, params_t *ps, const str_arg_t *type, pbrt_loc_t loc);

#endif
