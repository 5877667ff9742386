#include "material_params.h"

#include "pbrt_parser.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void *material_params_alloc(material_params_t *mp, size_t n)
{
    void **grown = realloc(mp->scratch, (mp->nscratch + 1) * sizeof *grown);
    void *p = grown ? malloc(n ? n : 1) : NULL;
    if (grown)
        mp->scratch = grown;
    if (!p) {
        err_set(mp->err, "out of memory");
        return NULL;
    }
    mp->scratch[mp->nscratch++] = p;
    return p;
}

void material_params_finish(material_params_t *mp)
{
    for (size_t i = 0; i < mp->nscratch; i++)
        free(mp->scratch[i]);
    free(mp->scratch);
    mp->scratch = NULL;
    mp->nscratch = 0;
}

scene_spectrum_t material_params_constant(double v, pbrt_loc_t loc)
{
    return (scene_spectrum_t){.kind = SCENE_SPECTRUM_CONSTANT, .constant = v, .loc = loc};
}

scene_spectrum_t material_params_named(const char *name, pbrt_loc_t loc)
{
    return (scene_spectrum_t){.kind = SCENE_SPECTRUM_NAMED, .name = name, .loc = loc};
}

static const scene_material_resolved_t *resolved(const material_params_t *mp, const param_t *p)
{
    for (size_t i = 0; i < mp->dm->nresolved; i++)
        if (!strcmp(mp->dm->resolved[i].param, p->name))
            return &mp->dm->resolved[i];
    return NULL;
}

const char *material_params_file(const material_params_t *mp, const param_t *p)
{
    const scene_material_resolved_t *r = p ? resolved(mp, p) : NULL;
    return r ? r->path : NULL;
}

/* A spectrum given by a string: what the parser read (a spectrum file's samples, whose values
 * an albedo keeps within [0, 1], or a name for the loader). */
static int spectrum_string(material_params_t *mp, const param_t *p, spec_use_t use,
                           scene_spectrum_t *out)
{
    const scene_material_resolved_t *r = resolved(mp, p);
    if (!r || r->path)
        return pbrt_error(mp->err, p->loc, "\"%s %s\" was not read with the scene", p->type_name,
                          p->name);
    *out = r->spectrum;
    if (use == SPEC_REFLECTANCE && out->kind == SCENE_SPECTRUM_SAMPLED)
        for (size_t i = 0; i < out->count; i++)
            if (out->value[i] < 0.0 || out->value[i] > 1.0)
                return pbrt_error(mp->err, p->loc,
                                  "spectrum file \"%s\": value %g at %g nm is outside [0, 1] (a "
                                  "reflectance)",
                                  out->file, out->value[i], out->lambda[i]);
    return 0;
}

/* pbrt-v4 paramdict.cpp extractSpectrumArray: float (constant), rgb, blackbody, or spectrum
 * given as (lambda, value) pairs or by a string. */
int material_params_spectrum(material_params_t *mp, const param_t *p, spec_use_t use,
                             scene_spectrum_t *out)
{
    const bool albedo = use == SPEC_REFLECTANCE;
    err_t *err = mp->err;
    memset(out, 0, sizeof *out);
    out->loc = p->loc;
    switch (p->type) {
    case PARAM_FLOAT:
        if (p->count != 1)
            return pbrt_error(err, p->loc, "expected 1 number after \"%s %s\", got %zu",
                              p->type_name, p->name, p->count);
        if (albedo && (p->numbers[0] < 0.0 || p->numbers[0] > 1.0))
            return pbrt_error(err, p->loc, "\"%s %s\" must be within [0, 1], got %g", p->type_name,
                              p->name, p->numbers[0]);
        out->kind = SCENE_SPECTRUM_CONSTANT;
        out->constant = p->numbers[0];
        return 0;
    case PARAM_RGB:
        if (p->count != 3)
            return pbrt_error(err, p->loc, "expected 3 numbers after \"%s %s\", got %zu",
                              p->type_name, p->name, p->count);
        for (int i = 0; i < 3; i++) {
            if (p->numbers[i] < 0.0)
                return pbrt_error(err, p->loc, "\"%s %s\" has a negative component", p->type_name,
                                  p->name);
            if (albedo && p->numbers[i] > 1.0)
                return pbrt_error(err, p->loc,
                                  "\"%s %s\" has a component above 1 (a "
                                  "reflectance is at most 1)",
                                  p->type_name, p->name);
            out->rgb[i] = p->numbers[i];
        }
        out->kind = SCENE_SPECTRUM_RGB;
        return 0;
    case PARAM_BLACKBODY:
        if (p->count != 1)
            return pbrt_error(err, p->loc,
                              "expected 1 number after \"%s %s\", got %zu "
                              "(pbrt-v4 takes only the temperature)",
                              p->type_name, p->name, p->count);
        if (!(p->numbers[0] > 0.0))
            return pbrt_error(err, p->loc, "\"%s %s\" needs a temperature above 0 K, got %g",
                              p->type_name, p->name, p->numbers[0]);
        out->kind = SCENE_SPECTRUM_BLACKBODY;
        out->temperature = p->numbers[0];
        return 0;
    case PARAM_SPECTRUM: {
        if (p->values == PARAM_VALUES_STRINGS)
            return spectrum_string(mp, p, use, out);
        if (p->count == 0)
            return pbrt_error(err, p->loc, "no values after \"%s %s\"", p->type_name, p->name);
        if (p->count % 2 != 0)
            return pbrt_error(err, p->loc,
                              "\"%s %s\" needs (wavelength, value) pairs, got %zu "
                              "numbers",
                              p->type_name, p->name, p->count);
        size_t n = p->count / 2;
        for (size_t i = 0; i < n; i++) {
            double l = p->numbers[2 * i], v = p->numbers[2 * i + 1];
            if (!(l > 0.0))
                return pbrt_error(err, p->loc,
                                  "\"%s %s\": wavelength %g in pair %zu is not "
                                  "positive",
                                  p->type_name, p->name, l, i + 1);
            if (i > 0 && !(l > p->numbers[2 * i - 2]))
                return pbrt_error(err, p->loc,
                                  "\"%s %s\": wavelengths must increase, but pair "
                                  "%zu has %g nm after %g nm",
                                  p->type_name, p->name, i + 1, l, p->numbers[2 * i - 2]);
            if (albedo && (v < 0.0 || v > 1.0))
                return pbrt_error(err, p->loc,
                                  "\"%s %s\": value %g in pair %zu is outside "
                                  "[0, 1] (a reflectance)",
                                  p->type_name, p->name, v, i + 1);
        }
        double *lv = material_params_alloc(mp, 2 * n * sizeof *lv);
        if (!lv)
            return -1;
        for (size_t i = 0; i < n; i++) {
            lv[i] = p->numbers[2 * i];
            lv[n + i] = p->numbers[2 * i + 1];
        }
        out->kind = SCENE_SPECTRUM_SAMPLED;
        out->count = n;
        out->lambda = lv;
        out->value = lv + n;
        return 0;
    }
    default:
        break;
    }
    char expected[256];
    snprintf(expected, sizeof expected,
             "\"spectrum %s\", \"rgb %s\", \"blackbody %s\" or \"float %s\"", p->name, p->name,
             p->name, p->name);
    return params_wrong_type(mp->ps, p, expected, err);
}

/* A "texture" parameter: a texture of the type wanted, defined before the material. */
static int texture_ref(material_params_t *mp, const param_t *p, scene_texture_type_t type, int *out)
{
    if (p->count != 1)
        return pbrt_error(mp->err, p->loc, "expected 1 string after \"%s %s\", got %zu",
                          p->type_name, p->name, p->count);
    const scene_desc_t *d = mp->L->desc;
    const size_t before = mp->dm->ntextures;
    int t = scene_desc_find_texture(d, p->strings[0], type);
    if (t >= 0 && (size_t)t < before) {
        *out = t;
        return 0;
    }
    const char *want = type == SCENE_TEXTURE_FLOAT ? "float" : "spectrum";
    const char *other = type == SCENE_TEXTURE_FLOAT ? "spectrum" : "float";
    int o = scene_desc_find_texture(d, p->strings[0],
                                    type == SCENE_TEXTURE_FLOAT ? SCENE_TEXTURE_SPECTRUM
                                                                : SCENE_TEXTURE_FLOAT);
    if (o >= 0 && (size_t)o < before)
        return pbrt_error(mp->err, p->loc,
                          "texture \"%s\" is a %s texture, but \"%s\" needs a %s "
                          "texture",
                          p->strings[0], other, p->name, want);
    return pbrt_error(mp->err, p->loc,
                      "%s texture \"%s\" is not defined (a Texture must come "
                      "before its use)",
                      want, p->strings[0]);
}

int material_params_float(material_params_t *mp, const char *name, double def,
                          scene_float_input_t *out)
{
    out->texture = -1;
    out->value = def;
    param_t *p = params_find(mp->ps, name);
    if (!p)
        return 0;
    if (p->type == PARAM_TEXTURE)
        return texture_ref(mp, p, SCENE_TEXTURE_FLOAT, &out->texture);
    if (p->type != PARAM_FLOAT) {
        char expected[160];
        snprintf(expected, sizeof expected, "\"float %s\" or \"texture %s\"", name, name);
        return params_wrong_type(mp->ps, p, expected, mp->err);
    }
    if (p->count != 1)
        return pbrt_error(mp->err, p->loc, "expected 1 number after \"%s %s\", got %zu",
                          p->type_name, p->name, p->count);
    out->value = p->numbers[0];
    return 0;
}

int material_params_spectrum_input(material_params_t *mp, const char *name, scene_spectrum_t def,
                                   spec_use_t use, scene_spectrum_input_t *out)
{
    out->texture = -1;
    out->spectrum = def;
    param_t *p = params_find(mp->ps, name);
    if (!p)
        return 0;
    if (p->type == PARAM_TEXTURE)
        return texture_ref(mp, p, SCENE_TEXTURE_SPECTRUM, &out->texture);
    return material_params_spectrum(mp, p, use, &out->spectrum);
}

const texture_t *material_params_float_texture(material_params_t *mp, const char *name, double def)
{
    scene_float_input_t in;
    return material_params_float(mp, name, def, &in) ? NULL
                                                     : loader_float_input(mp->L, &in, mp->err);
}

const texture_t *material_params_spectrum_texture(material_params_t *mp, const char *name,
                                                  scene_spectrum_t def, spec_use_t use)
{
    scene_spectrum_input_t in;
    return material_params_spectrum_input(mp, name, def, use, &in)
               ? NULL
               : loader_spectrum_input(mp->L, &in, use, mp->err);
}

int material_params_range(material_params_t *mp, const char *name, double v, double lo, double hi)
{
    if (v >= lo && v <= hi)
        return 0;
    param_t *p = params_find(mp->ps, name);
    return pbrt_error(mp->err, p ? p->loc : mp->dm->loc,
                      "\"%s %s\" must be within [%g, %g], got %g", p ? p->type_name : "float", name,
                      lo, hi, v);
}

int material_params_positive(material_params_t *mp, const char *name, double v)
{
    if (v > 0.0)
        return 0;
    param_t *p = params_find(mp->ps, name);
    return pbrt_error(mp->err, p ? p->loc : mp->dm->loc, "\"%s %s\" must be greater than 0, got %g",
                      p ? p->type_name : "float", name, v);
}
