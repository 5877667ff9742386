#include "loader.h"

#include "cie.h"
#include "image_info.h"
#include "named_spectra.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* The message for a string that is neither a named spectrum nor a file (pbrt-v4 looks for the
 * name first, then for a file; the parser found no file). */
static void unknown_spectrum(const scene_spectrum_t *s, const char *what, err_t *err)
{
    char names[1024];
    pbrt_error(err, s->loc,
               "\"%s\" is neither a named spectrum nor a spectrum file (looked for %s); %s: %s",
               s->name, s->searched ? s->searched : "no file", what,
               named_spectra_list(names, sizeof names));
}

/* A named spectrum (pbrt-v4 spectrum.cpp Spectra::Init). stdillum-D65 and stdillum-A keep
 * prismfarm's CIE D65 table (data/d65_5nm.csv: pbrt-v4's table within 5.5e-8 relative) and the
 * CIE formula for A (pbrt-v4 tabulates it at 5 nm), so lights, which normalise their spectrum
 * anyway, are as before; used otherwise they are normalised to luminance 1 as pbrt-v4 does. */
static spectrum_t *named_spectrum(const scene_spectrum_t *s, spec_use_t use, err_t *err)
{
    const named_spectrum_t *e = named_spectra_find(s->name);
    if (!e) {
        unknown_spectrum(s, "named spectra", err);
        return NULL;
    }
    spectrum_t *r = NULL;
    int d65 = !strcmp(s->name, "stdillum-D65"), a = !strcmp(s->name, "stdillum-A");
    if (d65 || a) {
        r = d65 ? spectrum_new_cie_d65(err) : spectrum_new_cie_a(err);
        if (r && use != SPEC_ILLUMINANT) {
            spectrum_t *n = spectrum_new_scaled(r, CIE_Y_INTEGRAL / spectrum_photometric(r), err);
            spectrum_destroy(&r);
            r = n;
        }
    } else {
        r = named_spectrum_new(e, err);
    }
    if (!r)
        err_prefix(err, "%s:%d:%d: ", s->loc.file, s->loc.line, s->loc.col);
    return r;
}

spectrum_t *loader_build_spectrum(const scene_spectrum_t *s, spec_use_t use, err_t *err)
{
    spectrum_t *r = NULL;
    switch (s->kind) {
    case SCENE_SPECTRUM_CONSTANT:
        r = spectrum_new_constant(s->constant, err);
        break;
    case SCENE_SPECTRUM_RGB: {
        rgb_t c = {s->rgb[0], s->rgb[1], s->rgb[2]};
        if (use == SPEC_ILLUMINANT)
            r = spectrum_new_rgb_illuminant(c, err);
        else if (use == SPEC_REFLECTANCE)
            r = spectrum_new_rgb_reflectance(c, err);
        else {
            /* An unbounded RGB (a conductor's eta or k, an absorption): pbrt-v4's
             * RGBUnboundedSpectrum, the uplift of the colour scaled to a maximum of 1/2, scaled
             * back by m = 2 max. The scale shapes the spectrum: scaled to a maximum of 1, the
             * uplift saturates into a step whose exp(-sigma_a d) differs (hair of eumelanin 2:
             * G 4 % brighter than pbrt-v4's, docs/compatibility.md). */
            double m = 2.0 * fmax(c.r, fmax(c.g, c.b));
            if (!(m > 0)) {
                r = spectrum_new_constant(0.0, err);
            } else {
                spectrum_t *u =
                    spectrum_new_rgb_reflectance((rgb_t){c.r / m, c.g / m, c.b / m}, err);
                r = u ? spectrum_new_scaled(u, m, err) : NULL;
                spectrum_destroy(&u);
            }
        }
        break;
    }
    case SCENE_SPECTRUM_BLACKBODY:
        r = spectrum_new_blackbody(s->temperature, 1, err);
        break;
    case SCENE_SPECTRUM_NAMED:
        r = named_spectrum(s, use, err);
        if (!r)
            return NULL; /* the message names the parameter */
        break;
    case SCENE_SPECTRUM_SAMPLED:
        /* pbrt-v4 takes a named spectrum before a file of the same name. */
        if (s->file && named_spectra_find(s->name))
            r = named_spectrum(s, use, err);
        else
            r = spectrum_new_tabulated(s->lambda, s->value, s->count, err);
        break;
    }
    if (!r)
        err_prefix(err, "%s:%d:%d: ", s->loc.file, s->loc.line, s->loc.col);
    return r;
}

spectrum_t *loader_owned_spectrum(scene_t *sc, const scene_spectrum_t *s, spec_use_t use,
                                  err_t *err)
{
    spectrum_t *r = loader_build_spectrum(s, use, err);
    if (!r || scene_own_spectrum(sc, r, err))
        return NULL;
    return r;
}

spectrum_t *loader_light_spectrum(scene_t *sc, const scene_spectrum_t *s, err_t *err)
{
    spectrum_t *raw = loader_build_spectrum(s, SPEC_ILLUMINANT, err);
    if (!raw)
        return NULL;
    double photometric = s->kind == SCENE_SPECTRUM_CONSTANT
                             ? CIE_Y_INTEGRAL * (s->constant > 0 ? 1.0 : 0.0)
                             : spectrum_photometric_light(raw);
    if (!(photometric > 0.0) || !isfinite(photometric)) {
        spectrum_destroy(&raw);
        pbrt_error(err, s->loc, "light spectrum has no energy in the visible range (360-830 nm)");
        return NULL;
    }
    spectrum_t *n = spectrum_new_scaled(raw, CIE_Y_INTEGRAL / photometric, err);
    spectrum_destroy(&raw);
    if (!n || scene_own_spectrum(sc, n, err))
        return NULL;
    return n;
}

int loader_budget_texels(loader_t *L, int w, int h, err_t *err)
{
    if (!L->budget || !L->budget->texels)
        return 0;
    uint64_t n = (uint64_t)w * (uint64_t)h;
    if (n <= L->budget->texels - L->texels) {
        L->texels += n;
        return 0;
    }
    return err_set(err,
                   "this %dx%d image takes the scene over %llu texels, the master's budget "
                   "(prismfarm master --max-texels)",
                   w, h, (unsigned long long)L->budget->texels);
}

int loader_budget_texels_header(loader_t *L, const char *path, err_t *err)
{
    int w, h;
    err_t unread;
    if (!L->budget || !L->budget->texels)
        return 1;
    if (image_info_read(path, &w, &h, &unread) != 0)
        return 0;
    return loader_budget_texels(L, w, h, err) ? -1 : 1;
}

const texture_t *loader_spectrum_input(loader_t *L, const scene_spectrum_input_t *in,
                                       spec_use_t use, err_t *err)
{
    if (in->texture >= 0)
        return L->tex[in->texture];
    spectrum_t *s = loader_build_spectrum(&in->spectrum, use, err);
    if (!s)
        return NULL;
    texture_t *t = texture_new_constant(s, err);
    if (!t || scene_own_texture(L->sc, t, err))
        return NULL;
    return t;
}

const texture_t *loader_float_input(loader_t *L, const scene_float_input_t *in, err_t *err)
{
    if (in->texture >= 0)
        return L->tex[in->texture];
    texture_t *t = texture_new_constant_value(in->value, err);
    if (!t || scene_own_texture(L->sc, t, err))
        return NULL;
    return t;
}
