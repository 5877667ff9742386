/* loader: what every part of the scene loader (scene_load.c and its load_*.c, one per entity)
 * shares: the loader's context (the description read, the scene being built, the textures made
 * so far, the texel budget) and the inputs every entity takes: spectra (uplifted as pbrt-v4
 * does, lights' normalised by their luminance), texture-or-constant inputs, and the texel
 * budget's count. Internal to the loader: only scene_load.c, the load_*.c files and the
 * material classes' files (material_*.c) include it.
 * Every function that fails returns -1 (or NULL) with err saying why, at the scene file's
 * line where the description gives one. */
#ifndef PRISMFARM_LOADER_H
#define PRISMFARM_LOADER_H

#include "budget.h"
#include "err.h"
#include "scene.h"
#include "scene_desc.h"
#include "spectrum.h"
#include "texture.h"

#include <stdint.h>

typedef enum { SPEC_REFLECTANCE, SPEC_ILLUMINANT, SPEC_UNBOUNDED } spec_use_t;

typedef struct loader {
    const scene_desc_t *desc;
    scene_t *sc;
    texture_t **tex;              /* by desc texture index (borrowed from the scene) */
    const scene_budget_t *budget; /* the overrides' (budget.h); NULL: none */
    uint64_t texels;              /* image pixels read so far, against it */
    int threads;                  /* the overrides' (<= 0: all cores) */
} loader_t;

/* A spectrum as the description gives it, uplifted for its use (pbrt-v4's SpectrumType);
 * the caller owns it. */
spectrum_t *loader_build_spectrum(const scene_spectrum_t *s, spec_use_t use, err_t *err);

/* Builds a spectrum the scene owns. */
spectrum_t *loader_owned_spectrum(scene_t *sc, const scene_spectrum_t *s, spec_use_t use,
                                  err_t *err);

/* pbrt-v4 normalises every light's spectrum by its photometric value (SpectrumToPhotometric),
 * so the spectrum gives the colour and "scale" the luminance: here the result has luminance
 * Y = 1 (Y = integral of s y-bar / integral of y-bar), and the light multiplies it by scale.
 * As in pbrt-v4, an "rgb" spectrum is normalised by its illuminant (D65) alone, so rgb
 * [r g b] keeps the luminance of that colour (rgb [1 1 1] has Y = 1, [10 10 10] Y = 10).
 * prismfarm's "float L" v (pbrt-v4 has none) is likewise not normalised: an equal-energy
 * spectrum of luminance v. */
spectrum_t *loader_light_spectrum(scene_t *sc, const scene_spectrum_t *s, err_t *err);

/* budget.h: an image of w x h pixels, decoded but not yet made a texture (its uplift
 * coefficients and pyramid, the larger allocation). */
int loader_budget_texels(loader_t *L, int w, int h, err_t *err);

/* budget.h: an image's texels charged from its header (image_info.h), before anything decodes
 * it: 1 charged (or no texel budget), 0 when the header cannot be read (the decoder says why;
 * the texels are charged once decoded), -1 over the budget. */
int loader_budget_texels_header(loader_t *L, const char *path, err_t *err);

/* A spectrum input: its texture, or its constant made a texture the scene owns. */
const texture_t *loader_spectrum_input(loader_t *L, const scene_spectrum_input_t *in,
                                       spec_use_t use, err_t *err);

/* A float input: its texture, or its constant made a texture the scene owns. */
const texture_t *loader_float_input(loader_t *L, const scene_float_input_t *in, err_t *err);

#endif
