#include "named_spectra.h"

#include "cie.h"

#include <stdio.h>
#include <string.h>

/* spectral/named_spectra_table.c, generated. */
extern const named_spectrum_t NAMED_SPECTRA_TABLE[];
extern const int NAMED_SPECTRA_TABLE_COUNT;

int named_spectra_count(void)
{
    return NAMED_SPECTRA_TABLE_COUNT;
}

const named_spectrum_t *named_spectra_get(int i)
{
    return i >= 0 && i < NAMED_SPECTRA_TABLE_COUNT ? &NAMED_SPECTRA_TABLE[i] : NULL;
}

const named_spectrum_t *named_spectra_find(const char *name)
{
    if (!name)
        return NULL;
    for (int i = 0; i < NAMED_SPECTRA_TABLE_COUNT; i++)
        if (!strcmp(NAMED_SPECTRA_TABLE[i].name, name))
            return &NAMED_SPECTRA_TABLE[i];
    return NULL;
}

const char *named_spectra_list(char *buf, size_t size)
{
    if (size == 0)
        return buf;
    buf[0] = 0;
    size_t len = 0;
    for (int i = 0; i < NAMED_SPECTRA_TABLE_COUNT; i++) {
        const char *name = NAMED_SPECTRA_TABLE[i].name;
        size_t need = strlen(name) + (i ? 2 : 0);
        if (len + need + 4 >= size) {
            if (len + 4 < size)
                strcat(buf, "...");
            break;
        }
        if (i)
            strcat(buf, ", ");
        strcat(buf, name);
        len += need;
    }
    return buf;
}

spectrum_t *named_spectrum_new(const named_spectrum_t *e, err_t *err)
{
    if (e->kind == NAMED_SPECTRUM_SENSOR)
        return spectrum_new_tabulated_zero_outside(e->lambda, e->value, e->count, err);
    if (e->kind != NAMED_SPECTRUM_ILLUMINANT)
        return spectrum_new_tabulated(e->lambda, e->value, e->count, err);
    spectrum_t *raw = spectrum_new_tabulated_zero_outside(e->lambda, e->value, e->count, err);
    if (!raw)
        return NULL;
    /* pbrt-v4 MakeSpectrumFromInterleaved(..., normalize = true): s / SpectrumToY(s), with
     * SpectrumToY = sum s y-bar / CIE_Y_integral; spectrum_photometric is that sum. */
    double y = spectrum_photometric(raw) / CIE_Y_INTEGRAL;
    spectrum_t *s = y > 0.0 ? spectrum_new_scaled(raw, 1.0 / y, err) : NULL;
    if (!(y > 0.0))
        err_set(err, "named spectrum \"%s\" has no luminance", e->name);
    spectrum_destroy(&raw);
    return s;
}
