/* spectrum_param: a spectrum-valued parameter given by numbers -- "float" (a constant), "rgb",
 * "blackbody" or "spectrum" (wavelength, value) pairs, as pbrt-v4's paramdict.cpp
 * extractSpectrumArray reads them -- checked, with the parameter's location in every message.
 * The one reader of those forms for the parser (lights, media, textures) and for the material
 * loader (scene/material_params.c). A "spectrum" given by a string (a named spectrum or a file)
 * is left to the caller: the parser reads the file, the loader takes what the parser read. */
#ifndef PRISMFARM_SPECTRUM_PARAM_H
#define PRISMFARM_SPECTRUM_PARAM_H

#include "params.h"
#include "scene_desc.h"

#include <stdbool.h>
#include <stddef.h>

/* Memory for a sampled spectrum's values, owned by the caller's description; NULL when there is
 * none, with the caller's err set. */
typedef void *(*spectrum_param_alloc_t)(void *ctx, size_t size);

/* Reads p into *out (its loc set in every case). albedo: every value within [0, 1] (pbrt-v4's
 * albedo spectra). Returns 0, 1 when p is a "spectrum" given by a string (the caller's), or -1
 * with err set: a wrong count, a negative, non-increasing or out-of-range value, a parameter of
 * another type (params_wrong_type's "expected" list), or no memory. */
int spectrum_param_numbers(const params_t *ps, const param_t *p, bool albedo,
                           spectrum_param_alloc_t alloc, void *ctx, scene_spectrum_t *out,
                           err_t *err);

#endif
