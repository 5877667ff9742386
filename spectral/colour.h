/* colour: from spectra (or framebuffer buckets) to CIE 1931 XYZ, to linear sRGB and back
 * (IEC 61966-2-1), the sRGB transfer curve, and display: exposure, a tone curve and a
 * hue-preserving gamut clip down to 8-bit sRGB. XYZ is normalised as in pbrt-v4: divided by
 * the integral of y-bar, so a constant spectrum of value 1 has Y = 1. Pure functions. */
#ifndef PRISMFARM_COLOUR_H
#define PRISMFARM_COLOUR_H

#include "cie.h"
#include "spectral_grid.h"

/* Linear (unless a function says otherwise) sRGB components. */
typedef struct rgb {
    double r, g, b;
} rgb_t;

/* weights[i] = integral of the CMFs over bucket i (clipped to 360-830 nm; buckets outside
 * the visible range weigh 0) / CIE_Y_INTEGRAL, so that XYZ = sum_i buckets[i] * weights[i]
 * treats each bucket as its average spectral value held over its width. weights has grid.n
 * entries; the grid must be valid. Precompute once per image. */
void colour_grid_weights(spectral_grid_t grid, xyz_t *weights);
xyz_t colour_buckets_to_xyz_weighted(int n, const xyz_t *weights, const double *buckets);
/* The same without precomputed weights (recomputes them: about 500 operations per call). */
xyz_t colour_buckets_to_xyz(spectral_grid_t grid, const double *buckets);

/* IEC 61966-2-1 matrices: sRGB -> XYZ is the standard's 4-decimal matrix, XYZ -> sRGB its
 * inverse rounded to 8 decimals; the two are inverses to 4e-9 (data/srgb_matrices.txt). D65
 * white; no chromatic adaptation. */
rgb_t colour_xyz_to_linear_srgb(xyz_t xyz);
xyz_t colour_linear_srgb_to_xyz(rgb_t rgb);

/* Relative luminance of linear sRGB: 0.2126 R + 0.7152 G + 0.0722 B (the Y row; sums to 1). */
double colour_luminance(rgb_t rgb);

/* Chromaticity x = X/(X+Y+Z), y = Y/(X+Y+Z). Returns 0, or -1 when X+Y+Z is not > 0 or not
 * finite, in which case (x, y) is set to the sRGB white (0.3127, 0.3290) rather than NaN. */
int colour_xyz_to_xy(xyz_t xyz, double *x, double *y);

/* sRGB transfer curve (IEC 61966-2-1): encode V = 12.92 L for L <= 0.0031308, else
 * 1.055 L^(1/2.4) - 0.055; decode is its inverse (threshold 0.04045). Inputs are clamped to
 * [0, 1]; NaN gives 0. */
double colour_srgb_encode(double linear);
double colour_srgb_decode(double encoded);

typedef enum colour_curve {
    /* Narkowicz 2015, "ACES Filmic Tone Mapping Curve": x(2.51x + 0.03) / (x(2.43x + 0.59) + 0.14).
     * The fit is pre-exposed (1 maps to about 0.8); the original ACES RRT+ODT corresponds to an
     * extra factor 0.6, i.e. exposure_stops - 0.737. A luminance-only fit, so it is applied to
     * the luminance here. */
    COLOUR_CURVE_ACES,
    /* Reinhard et al. 2002, "Photographic Tone Reproduction", L / (1 + L). */
    COLOUR_CURVE_REINHARD,
    /* No curve: exposure and gamut clip only. */
    COLOUR_CURVE_CLIP,
} colour_curve_t;

typedef struct colour_tonemap {
    double exposure_stops; /* scene values are multiplied by 2^exposure_stops */
    colour_curve_t curve;
} colour_tonemap_t;

/* Hue-preserving gamut clip of linear sRGB into [0, 1]^3: mixes the colour with the grey of
 * equal luminance, c' = Y + t (c - Y) with the largest t in [0, 1] that brings every channel
 * into [0, 1]. Luminance and the dominant wavelength are kept; only saturation drops. Y <= 0
 * gives black, Y >= 1 white, a non-finite channel black. */
rgb_t colour_gamut_clip(rgb_t rgb);

/* Scene-linear sRGB to display-linear sRGB in [0, 1]: exposure, then the curve applied to the
 * luminance with the colour scaled by Y'/Y (so hue and saturation survive the curve), then
 * colour_gamut_clip. Non-finite input gives black. */
rgb_t colour_tonemap_apply(colour_tonemap_t tm, rgb_t rgb);

/* colour_tonemap_apply, then the sRGB transfer curve, then round to 8 bits. */
void colour_tonemap_to_srgb8(colour_tonemap_t tm, rgb_t rgb, unsigned char out[3]);

#endif
