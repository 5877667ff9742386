/* film: turns a rendered spectral image (a tilebuf covering the whole image) into output
 * files: a spectral OpenEXR (Fichet et al. 2021 layout, float32 buckets plus scene-linear sRGB
 * R, G, B from the image's XYZ sums) or an RGB OpenEXR, and a tone-mapped PNG preview. Writes are atomic. */
#ifndef PRISMFARM_FILM_H
#define PRISMFARM_FILM_H

#include "colour.h"
#include "err.h"
#include "spectral_grid.h"
#include "tilebuf.h"

typedef struct film_output {
    const char *exr_path;   /* NULL: no EXR */
    const char *png_path;   /* NULL: no PNG */
    int spectral;           /* write the S0.* bucket channels as well as R, G, B */
    colour_tonemap_t tonemap;
    const char *info;       /* key=value text stored in the EXR's "prismfarm" attribute */
} film_output_t;

/* Per-pixel linear sRGB of the image's mean XYZ (rgb: w*h*3 floats, top row first): the
 * colour of the samples at their own wavelengths, not of the bucket means (docs/rendering.md,
 * "Colour"); the spectral layers stay the bucket means. */
int film_to_rgb(const tilebuf_t *image, spectral_grid_t grid, float *rgb, err_t *err);

int film_write(const tilebuf_t *image, spectral_grid_t grid, const film_output_t *out, err_t *err);

/* An image with the Stokes planes (render_settings_t.stokes: 4 grid.n buckets, S0 then S1,
 * S2, S3) writes all four as the spectral layout's S0-S3 layers (image_exr_write_stokes, even
 * for an "rgb" film) and, beside the PNG "x.png", the polarisation previews "x_dop.png" (the
 * degree of polarisation sqrt(S1^2 + S2^2 + S3^2) / S0 of the buckets' sums, black 0 to white
 * 1) and "x_aop.png" (the angle of linear polarisation 1/2 atan2(S2, S1) as hue, red at 0 and
 * cyan at 90 degrees, its saturation and value the degree of linear polarisation). */
void film_stokes_preview_paths(const char *png_path, char *dop, size_t dop_size, char *aop,
                               size_t aop_size);

/* The polarisation previews of film_stokes_preview_paths(png_path) from an EXR that
 * film_write wrote with the Stokes planes (a farm's output, fetched), from its S0-S3 layers
 * (float bucket means, summed in double as film_write sums the image's); nothing for an EXR
 * without them. */
int film_stokes_previews_from_exr(const char *exr_path, const char *png_path, err_t *err);

/* Writes the tone-mapped PNG preview of an EXR file (its R, G, B channels). */
int film_png_from_exr(const char *exr_path, const char *png_path, colour_tonemap_t tonemap,
                      err_t *err);

/* The PNG path beside an EXR path: "x.exr" -> "x.png" (any other name gets ".png" added). */
void film_png_path(const char *exr_path, char *buf, size_t size);

/* The outputs of an image named name (the Film's "filename" or --output): the format follows
 * the extension (case ignored), as in pbrt-v4, and the spectral EXR is always written beside:
 * "x.exr" -> x.exr and x.png; "x.png" -> x.png and x.exr; another image extension that
 * prismfarm does not write ("x.pfm", ".tga", ".jpg", ".hdr", ".qoi") -> x.exr and x.png, and
 * *other_format is 1 so that the caller can say so; any other name -> name and name.png. */
void film_output_paths(const char *name, char *exr, size_t exr_size, char *png, size_t png_size,
                       int *other_format);

#endif
