/* pbrt_options: the rendering options before WorldBegin, each with pbrt-v4's parameters and
 * defaults: Camera (cameras.cpp), Film and its sensor (film.cpp), PixelFilter (filters.cpp),
 * Sampler (samplers.cpp) and Option (pbrt-v4's Options). */
#ifndef PRISMFARM_PBRT_OPTIONS_H
#define PRISMFARM_PBRT_OPTIONS_H

#include "pbrt_state.h"

int pbrt_options_camera(parser_t *P, params_t *ps, const str_arg_t *type, pbrt_loc_t loc);
int pbrt_options_pixelfilter(parser_t *P, params_t *ps, const str_arg_t *type, pbrt_loc_t loc);
int pbrt_options_film(parser_t *P, params_t *ps, const str_arg_t *type, pbrt_loc_t loc);
int pbrt_options_sampler(parser_t *P, params_t *ps, const str_arg_t *type, pbrt_loc_t loc);
int pbrt_options_integrator(parser_t *P, params_t *ps, const str_arg_t *type, pbrt_loc_t loc);
int pbrt_options_option(parser_t *P, pbrt_loc_t loc);

#endif
