/* image_exr: OpenEXR output and input through the OpenEXRCore C API.
 * Writes float32 (never half) scanline images with ZIP compression, atomically (PATH.tmp, fsync,
 * rename), either RGB(A) or spectral in the Fichet, Pacanowski & Wilkie layout (JCGT 10(3), 2021)
 * with linear sRGB beside the buckets, as pbrt-v4 writes them; reads them (or another tool's
 * EXR) back, matching channels by name, never by position. */
#ifndef PRISMFARM_IMAGE_EXR_H
#define PRISMFARM_IMAGE_EXR_H

#include "err.h"

#include <stdbool.h>
#include <stddef.h>

/* Units written in `emissiveUnits` when the caller passes NULL (pbrt-v4's choice). */
#define IMAGE_EXR_DEFAULT_EMISSIVE_UNITS "W.m^-2.sr^-1"

/* Longest channel name a file without the long-name flag may hold, plus the NUL. */
#define IMAGE_EXR_CHANNEL_NAME_MAX 32

/* Every pixel array in this module is row-major, top row first, with the values of one pixel
 * adjacent ("interleaved"): rgb[(y * width + x) * channels + c] and
 * spectral[(y * width + x) * n_buckets + k]. */

/* Writes a linear-sRGB image: channels is 3 (R, G, B) or 4 (R, G, B, A). info, when not NULL, is
 * stored in the string attribute "prismfarm" (key=value lines describing the job). */
int image_exr_write_rgb(const char *path, int width, int height, const float *rgb, int channels,
                        const char *info, err_t *err);

/* Writes the spectral layout: one FLOAT channel `S0.<centre>nm` per bucket (centres_nm[k] is
 * bucket k's centre), the string attributes spectralLayoutVersion = "1.0" and emissiveUnits
 * (IMAGE_EXR_DEFAULT_EMISSIVE_UNITS when NULL), and scene-referred linear sRGB R, G, B from rgb
 * (3 floats per pixel). Centres must be positive, finite and distinct to the name's 6 decimals. */
int image_exr_write_spectral(const char *path, int width, int height, const float *rgb,
                             const float *spectral, int n_buckets, const double *centres_nm,
                             const char *emissive_units, const char *info, err_t *err);

/* The polarised layout: planes (1 or 4) Stokes components per bucket, `S<k>.<centre>nm` for
 * k < planes, spectral[(y * width + x) * planes * n_buckets + k * n_buckets + b]; with 4
 * planes the attribute polarisationHandedness = "right" (S3 > 0: the right-circular light of
 * polar/stokes.h's convention). planes 1 is image_exr_write_spectral. */
int image_exr_write_stokes(const char *path, int width, int height, const float *rgb,
                           const float *spectral, int n_buckets, int planes,
                           const double *centres_nm, const char *emissive_units, const char *info,
                           err_t *err);

/* Formats the name of the unpolarised emissive channel for a bucket centred at centre_nm, as
 * the layout's reference code does: "S0." + printf("%f") with a decimal comma + "nm", e.g.
 * "S0.550,000000nm". Returns -1 if the name would not fit in IMAGE_EXR_CHANNEL_NAME_MAX. */
int image_exr_format_channel_name(double centre_nm, char *buf, size_t size, err_t *err);
/* The same for Stokes component k (0..3): "S<k>.550,000000nm". */
int image_exr_format_stokes_channel_name(int k, double centre_nm, char *buf, size_t size,
                                         err_t *err);

/* Parses a channel name against the layout's pattern
 *   ^((S([0-3]))|T)\.(\d*,?\d*([Ee][+-]?\d+)?)(Y|Z|E|P|T|G|M|k|h|da|d|c|m|u|n|p)?(m|Hz)$
 * and converts the value to nanometres (frequencies through c = 299792458 m/s). Returns true for
 * a match with a positive finite wavelength, filling *stokes (0..3 for S0..S3, -1 for the
 * reflective T) and *wavelength_nm; false for any other name (R, G, B, A, "S0.nm", ...). */
bool image_exr_parse_channel_name(const char *name, int *stokes, double *wavelength_nm);

/* An EXR image read into memory: linear RGB, optional alpha, the unpolarised emissive (S0)
 * spectral channels sorted by wavelength, and the part's string attributes. */
typedef struct image_exr image_exr_t;

/* Reads part 0 of an EXR file (scanline or tiled, any compression OpenEXRCore decodes, HALF,
 * FLOAT or UINT channels, converted to float). R, G and B are required. Returns NULL with a
 * message naming the file and the fault (not an EXR, missing channel, unsupported compression,
 * truncated data, ...). */
image_exr_t *image_exr_read(const char *path, err_t *err);
void image_exr_destroy(image_exr_t **self_p);

int image_exr_width(const image_exr_t *self);
int image_exr_height(const image_exr_t *self);
/* width * height * 3 floats, interleaved R, G, B. */
const float *image_exr_rgb(const image_exr_t *self);
/* width * height floats, or NULL when the file has no A channel. */
const float *image_exr_alpha(const image_exr_t *self);
/* Number of S0 spectral channels (0 for a plain RGB file). */
int image_exr_n_spectral(const image_exr_t *self);
/* n_spectral wavelengths in nanometres, strictly increasing; NULL when n_spectral is 0. */
const double *image_exr_wavelengths_nm(const image_exr_t *self);
/* width * height * n_spectral floats, interleaved in wavelength order; NULL when n_spectral
 * is 0. */
const float *image_exr_spectral(const image_exr_t *self);
/* Stokes plane k (1..3) laid out as image_exr_spectral, read when the file has S1, S2 and S3
 * channels at each S0 wavelength (image_exr_write_stokes); NULL otherwise. Two channels of a
 * plane at one wavelength: the later one is kept. */
const float *image_exr_stokes(const image_exr_t *self, int k);
/* The value of a string attribute ("emissiveUnits", "spectralLayoutVersion", "prismfarm", ...),
 * or NULL when the part has no string attribute of that name. */
const char *image_exr_attribute(const image_exr_t *self, const char *name);

#endif
