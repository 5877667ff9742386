/* pbrt_inputs: the inputs entities share: spectra (constant, RGB, blackbody,
 * sampled, named, or a pbrt-v4 spectrum file), float and spectrum inputs that may name a
 * texture, and the files a scene names (images, spectrum and lens files), each listed among the
 * scene's files for bundling. Numbers are checked where they are read, with the parameter's
 * location in the message. */
#ifndef PRISMFARM_PBRT_INPUTS_H
#define PRISMFARM_PBRT_INPUTS_H

#include "pbrt_state.h"

/* What a spectrum is: any, or an albedo (within [0, 1]). */
enum { SPECTRUM_ANY, SPECTRUM_ALBEDO };

int pbrt_inputs_note_file(parser_t *P, scene_file_kind_t kind, const char *path, const char *name,
                          pbrt_loc_t loc);
scene_spectrum_t pbrt_inputs_constant(double v, pbrt_loc_t loc);
scene_spectrum_t pbrt_inputs_named(const char *name, pbrt_loc_t loc);
char *pbrt_inputs_read_file(parser_t *P, const param_t *p, const char *path, const char *what,
                            size_t *len);
int pbrt_inputs_spectrum_param(parser_t *P, params_t *ps, const param_t *p, int use,
                               scene_spectrum_t *out);
int pbrt_inputs_spectrum(parser_t *P, params_t *ps, const char *name, scene_spectrum_t def, int use,
                         scene_spectrum_t *out);
int pbrt_inputs_float(parser_t *P, params_t *ps, const char *name, double def,
                      scene_float_input_t *out);
int pbrt_inputs_spectrum_input(parser_t *P, params_t *ps, const char *name, scene_spectrum_t def,
                               int use, scene_spectrum_input_t *out);
int pbrt_inputs_image_file(parser_t *P, const param_t *fp, const char *filename, const char **out);
/* Any other file the loader reads (what: its kind in messages, "measured BSDF"), confined,
 * charged and listed as an image file is, as kind. */
int pbrt_inputs_data_file(parser_t *P, const param_t *fp, const char *filename, const char *what,
                          scene_file_kind_t kind, const char **out);

#endif
