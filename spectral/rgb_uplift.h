/* rgb_uplift: linear-sRGB colours as smooth spectra, the one rule that image textures and
 * image environment lights share. A colour rgb (components >= 0) becomes m * s(lambda) with
 * m = 2 max(r, g, b) and s the Jakob-Hanika sigmoid uplift (spectrum_sigmoid_fit) of rgb / m,
 * whose largest component is 1/2 (pbrt-v4's RGBUnboundedSpectrum and, times the illuminant,
 * RGBIlluminantSpectrum). The sigmoid's coefficients are not fitted per colour: they are
 * interpolated bilinearly in a table of fits over the three faces max(rgb / m) = 1/2 of the
 * colour cube, (RGB_UPLIFT_RES + 1)^2 nodes per face (pbrt-v4's RGBToSpectrumTable uses 64
 * per axis), every node fitted when prismfarm is built (spectral/bake/rgb_uplift_bake.c, as
 * pbrt-v4 builds its tables with rgb2spec_opt), so a scene's load fits none (fitting per
 * texture was 2.4 of the 3.5 CPU-s that bench/load_scene.sh's six 1024x1024 textures and 800
 * meshes took to load). So a colour costs a table lookup and its
 * spectrum one sigmoid per wavelength; m * s reproduces the colour's XYZ to the fit's residual
 * and the interpolation's error (tests/unit/test_texture.c measures it). Greys are exactly
 * flat. */
#ifndef PRISMFARM_RGB_UPLIFT_H
#define PRISMFARM_RGB_UPLIFT_H

#include "err.h"
#include "spectrum.h"

#define RGB_UPLIFT_RES 64

typedef struct rgb_uplift rgb_uplift_t;

rgb_uplift_t *rgb_uplift_new(err_t *err);
void rgb_uplift_destroy(rgb_uplift_t **self_p);

/* The coefficients of rgb into out: c0, c1, c2 (lambda in nm) and m; c = 0 means flat
 * (grey and black). Every node of a new table is fitted, so this is a lookup; -1 with err
 * filled only in the bake's own build, for a node not fitted yet. Thread-safe. */
int rgb_uplift_coef(const rgb_uplift_t *self, const float rgb[3], double out[4], err_t *err);

/* m * s(lambda) for coefficients from rgb_uplift_coef. */
static inline double rgb_uplift_eval(const double c[4], double lambda)
{
    if (c[0] == 0.0 && c[1] == 0.0 && c[2] == 0.0)
        return 0.5 * c[3];
    return c[3] * spectrum_sigmoid((c[0] * lambda + c[1]) * lambda + c[2]);
}

#ifdef RGB_UPLIFT_BAKE
#include <stdio.h>
/* The bake (spectral/bake/rgb_uplift_bake.c): fits every node on threads threads and writes
 * the table as C source with exact (hexadecimal) doubles. */
int rgb_uplift_bake_write(FILE *f, int threads, err_t *err);
#endif

#endif
