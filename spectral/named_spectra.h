/* named_spectra: pbrt-v4's named spectra (glass-*, metal-*-eta/-k, stdillum-*, illum-acesD60,
 * the camera sensors' response curves NAME_r/_g/_b)
 * as constant tables generated from data/named_spectra/ (tools/gen_named_spectra.py), each
 * naming its source there. Lookup is exact (case matters, as in pbrt-v4); entries live for the
 * whole program and are never written. */
#ifndef PRISMFARM_NAMED_SPECTRA_H
#define PRISMFARM_NAMED_SPECTRA_H

#include "err.h"
#include "spectrum.h"

#include <stddef.h>

typedef enum named_spectrum_kind {
    NAMED_SPECTRUM_GLASS_ETA,  /* a dielectric's index of refraction */
    NAMED_SPECTRUM_METAL_ETA,  /* a conductor's eta */
    NAMED_SPECTRUM_METAL_K,    /* a conductor's k */
    NAMED_SPECTRUM_ILLUMINANT, /* a relative spectral power distribution */
    NAMED_SPECTRUM_SENSOR,     /* one channel of a camera's relative spectral response */
} named_spectrum_kind_t;

typedef struct named_spectrum {
    const char *name; /* "metal-Au-eta" */
    named_spectrum_kind_t kind;
    size_t count;         /* (lambda, value) pairs, lambda strictly increasing */
    const double *lambda; /* nm */
    const double *value;  /* as tabulated by pbrt-v4 (illuminants before normalising) */
} named_spectrum_t;

/* The entry of that exact name, or NULL. */
const named_spectrum_t *named_spectra_find(const char *name);

/* Number of entries, and entry i (NULL when out of range), in listing order: glass, metal,
 * standard illuminants, other illuminants, camera sensors. */
int named_spectra_count(void);
const named_spectrum_t *named_spectra_get(int i);

/* The names, comma separated, into buf (truncated with "..." to fit); returns buf. */
const char *named_spectra_list(char *buf, size_t size);

/* The spectrum pbrt-v4 means by the entry (pbrt-v4 spectrum.cpp, Spectra::Init):
 * - an illuminant: piecewise linear, 0 outside its table, scaled to luminance 1
 *   (pbrt-v4 normalises it by SpectrumToY: sum of s y-bar over 360-830 nm at 1 nm / CIE_Y_INTEGRAL);
 * - a sensor curve: piecewise linear, 0 outside its table (380-720 nm), not normalised;
 * - glass and metal tables: piecewise linear, the end values held outside (pbrt-v4 gives 0
 *   there, which no index of refraction means; the film ranges lie inside all but MgO's and
 *   the glasses' tables, see docs/scene-format.md).
 * NULL with err filled when out of memory. */
spectrum_t *named_spectrum_new(const named_spectrum_t *entry, err_t *err);

#endif
