/* material_params: a material class's reading of its own parameters when the scene loads
 * (pbrt-v4's Material::Create over its ParameterDictionary): the description keeps a
 * material's parameters unread (scene_desc.h, scene_material_t), and its class
 * (scene/material_<name>.c) reads each one through these, which check the declared type and
 * the values and fail with the parameter's file:line:col and what was expected, in the
 * parser's words. A parameter read is marked used; the loader refuses the rest afterwards
 * (params_check_unused: `unsupported parameter "float x" for Material "diffuse"`). Internal to
 * the loader and the material classes. */
#ifndef PRISMFARM_MATERIAL_PARAMS_H
#define PRISMFARM_MATERIAL_PARAMS_H

#include "loader.h"

#include <stddef.h>

/* One material's reading: what its class's load gets (material_class.h). */
typedef struct material_params {
    loader_t *L;
    const scene_material_t *dm; /* the description's material */
    params_t *ps;               /* its parameters (dm's, or an empty list) */
    const char *name;           /* the material's name in messages (material_t.name) */
    err_t *err;
    /* The class's own record, data_size zeroed bytes (material_class.h) that load fills and
     * the scene keeps a copy of (material_t.data); NULL for a class without one. */
    void *data;
    void **scratch; /* memory a reading needs until the material is loaded */
    size_t nscratch;
} material_params_t;

/* A float parameter (a number or a float texture named before the material) as the
 * description's input; absent gives def. */
int material_params_float(material_params_t *mp, const char *name, double def,
                          scene_float_input_t *out);

/* A spectrum-valued parameter p ("spectrum", "rgb", "blackbody", "float") into out; use
 * SPEC_REFLECTANCE checks it within [0, 1] (pbrt-v4's albedo spectra). Sampled values live
 * until material_params_finish. */
int material_params_spectrum(material_params_t *mp, const param_t *p, spec_use_t use,
                             scene_spectrum_t *out);

/* A spectrum parameter or spectrum texture as the description's input; absent gives def. */
int material_params_spectrum_input(material_params_t *mp, const char *name, scene_spectrum_t def,
                                   spec_use_t use, scene_spectrum_input_t *out);

/* The same, made the scene's: a texture, or its constant made one (loader_float_input,
 * loader_spectrum_input); NULL with err on failure. */
const texture_t *material_params_float_texture(material_params_t *mp, const char *name, double def);
const texture_t *material_params_spectrum_texture(material_params_t *mp, const char *name,
                                                  scene_spectrum_t def, spec_use_t use);

/* The path to open of a file parameter ("string filename", "string normalmap"), confined and
 * listed when the scene was parsed; NULL when p names none. */
const char *material_params_file(const material_params_t *mp, const param_t *p);

/* v within [lo, hi], or positive: else `"float name" must be within [lo, hi], got v`. */
int material_params_range(material_params_t *mp, const char *name, double v, double lo, double hi);
int material_params_positive(material_params_t *mp, const char *name, double v);

/* A constant spectrum, a named one, at loc (the material's place for a default). */
scene_spectrum_t material_params_constant(double v, pbrt_loc_t loc);
scene_spectrum_t material_params_named(const char *name, pbrt_loc_t loc);

/* n bytes that live until material_params_finish; NULL with err when out of memory. */
void *material_params_alloc(material_params_t *mp, size_t n);

/* Frees the reading's memory. */
void material_params_finish(material_params_t *mp);

#endif
