/* texture: values that vary over a surface and with wavelength (reflectances, mix amounts).
 * Every texture evaluates to a double at (uv, lambda); a "float" texture simply ignores lambda.
 * Textures form an immutable DAG once built; evaluation is thread-safe and never NaN/Inf. */
#ifndef PRISMFARM_TEXTURE_H
#define PRISMFARM_TEXTURE_H

#include "err.h"
#include "spectrum.h"

typedef struct texture texture_t;

/* The texture takes ownership of the spectrum. */
texture_t *texture_new_constant(spectrum_t *spectrum, err_t *err);
texture_t *texture_new_constant_value(double value, err_t *err);
/* pbrt-v4 "checkerboard" (2D, uv mapping): tex1 where floor(u*uscale) + floor(v*vscale) is
 * even, tex2 where it is odd. The inputs are borrowed: they must outlive this texture. */
texture_t *texture_new_checkerboard(const texture_t *tex1, const texture_t *tex2, double uscale,
                                    double vscale, err_t *err);
/* tex * scale (both borrowed). */
texture_t *texture_new_scale(const texture_t *tex, const texture_t *scale, err_t *err);
/* (1 - amount) * tex1 + amount * tex2 (all borrowed). */
texture_t *texture_new_mix(const texture_t *tex1, const texture_t *tex2, const texture_t *amount,
                           err_t *err);
/* An image of linear RGB reflectances (w*h*3 floats, row 0 at the top, as PNGs store them),
 * each texel uplifted once at load (Jakob & Hanika), looked up bilinearly with pbrt's
 * uv convention (v = 0 at the bottom row), wrapping ("repeat"). uscale/vscale tile it. */
texture_t *texture_new_image(const float *rgb, int w, int h, double uscale, double vscale,
                             err_t *err);
void texture_destroy(texture_t **self_p);

double texture_eval(const texture_t *self, double u, double v, double lambda_nm);

#endif
