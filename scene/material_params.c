#include "material_params.h"

#include "pbrt_parser.h"
#include "spectrum_param.h"

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

static void *scratch_alloc(void *ctx, size_t size)
{
    return material_params_alloc(ctx, size);
}

/* pbrt-v4 paramdict.cpp extractSpectrumArray: the numeric forms by the parser's one reader
 * (scenefile/spectrum_param.h), a string by what the parser read. */
int material_params_spectrum(material_params_t *mp, const param_t *p, spec_use_t use,
                             scene_spectrum_t *out)
{
    const int rc =
        spectrum_param_numbers(mp->ps, p, use == SPEC_REFLECTANCE, scratch_alloc, mp, out, mp->err);
    return rc == 1 ? spectrum_string(mp, p, use, out) : rc;
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
