#define _XOPEN_SOURCE 700 /* strdup */

#include "pbrt_textures.h"

#include "pbrt_inputs.h"
#include "pbrt_upgrade.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

static int tex_input(parser_t *P, params_t *ps, scene_texture_t *t, const char *name, double def,
                     scene_float_input_t *f, scene_spectrum_input_t *s)
{
    if (t->type == SCENE_TEXTURE_FLOAT)
        return pbrt_inputs_float(P, ps, name, def, f);
    return pbrt_inputs_spectrum_input(P, ps, name, pbrt_inputs_constant(def, t->loc), SPECTRUM_ANY,
                                      s);
}

static int do_texture(parser_t *P, params_t *ps, const str_arg_t *name, const str_arg_t *type,
                      const str_arg_t *cls, pbrt_loc_t loc)
{
    static const pbrt_name_t TYPES[] = {{"float", SCENE_TEXTURE_FLOAT},
                                        {"spectrum", SCENE_TEXTURE_SPECTRUM}};
    int kt;
    if (!strcmp(type->s, "color"))
        return pbrt_error(P->err, type->loc,
                          "texture type \"color\" is pbrt-v3's (\"spectrum\"): %s",
                          PBRT_UPGRADE_HINT);
    if (pbrt_state_lookup(P, "unsupported texture type", type->s, type->loc, TYPES,
                          COUNT_OF(TYPES), &kt) != 0)
        return -1;
    const scene_texture_type_t tt = (scene_texture_type_t)kt;
    int prev = scene_desc_find_texture(P->scene, name->s, tt);
    if (prev >= 0)
        return pbrt_error(P->err, name->loc, "%s texture \"%s\" is already defined (line %d)",
                          type->s, name->s, P->scene->textures[prev].loc.line);
    /* pbrt-v4 "ptex" (per-face textures): no reader here; a constant 0.5 stands in. */
    enum { PTEX = -1 };
    static const pbrt_name_t CLASSES[] = {{"constant", SCENE_TEX_CONSTANT},
                                          {"checkerboard", SCENE_TEX_CHECKERBOARD},
                                          {"imagemap", SCENE_TEX_IMAGEMAP},
                                          {"scale", SCENE_TEX_SCALE},
                                          {"mix", SCENE_TEX_MIX},
                                          {"bilerp", SCENE_TEX_BILERP},
                                          {"dots", SCENE_TEX_DOTS},
                                          {"fbm", SCENE_TEX_FBM},
                                          {"wrinkled", SCENE_TEX_WRINKLED},
                                          {"windy", SCENE_TEX_WINDY},
                                          {"marble", SCENE_TEX_MARBLE},
                                          {"directionmix", SCENE_TEX_DIRECTIONMIX},
                                          {NULL, 0},
                                          {"ptex", PTEX}};
    int cls_value;
    if (pbrt_state_lookup(P, "unsupported texture", cls->s, cls->loc, CLASSES, COUNT_OF(CLASSES),
                          &cls_value) != 0)
        return -1;
    bool ptex = cls_value == PTEX;
    /* pbrt-v4 makes the noise textures of one kind only (textures.cpp's Create functions). */
    const bool float_only = cls_value == SCENE_TEX_FBM || cls_value == SCENE_TEX_WRINKLED ||
                            cls_value == SCENE_TEX_WINDY;
    if ((float_only && tt != SCENE_TEXTURE_FLOAT) ||
        (cls_value == SCENE_TEX_MARBLE && tt != SCENE_TEXTURE_SPECTRUM))
        return pbrt_error(P->err, cls->loc, "Texture \"%s\": \"%s\" is a %s texture in pbrt-v4",
                          name->s, cls->s, float_only ? "float" : "spectrum");
    if (ptex) {
        cls_value = SCENE_TEX_CONSTANT;
        param_t *fp = params_find(ps, "filename");
        (void)params_find(ps, "encoding");
        (void)params_find(ps, "scale");
        (void)params_find(ps, "invert");
        if (warnings_add(P->scene->warnings, fp ? fp->loc : cls->loc,
                         "Texture \"%s\": \"ptex\" is not read; the texture is the constant 0.5",
                         name->s))
            return pbrt_error(P->err, cls->loc, "out of memory");
    }
    if (pbrt_state_check_transform(P, &P->gs.ctm, "Texture", loc) != 0)
        return -1;
    int idx = scene_desc_add_texture(P->scene, P->err);
    if (idx < 0)
        return -1;
    scene_texture_t *t = &P->scene->textures[idx];
    t->name = scene_desc_strdup(P->scene, name->s, P->err);
    if (!t->name)
        return -1;
    t->type = tt;
    t->cls = (scene_texture_class_t)cls_value;
    t->loc = loc;
    t->to_world = P->gs.ctm;
    t->float_in1.texture = t->float_in2.texture = t->amount.texture = -1;
    t->float_in3.texture = t->float_in4.texture = -1;
    t->spec_in1.texture = t->spec_in2.texture = -1;
    t->spec_in3.texture = t->spec_in4.texture = -1;
    t->dimension = 2;

    const char *mapping;
    if (params_get_string(ps, "mapping", "uv", &mapping, P->err) != 0)
        return -1;
    static const pbrt_name_t MAPPINGS[] = {
        {"uv", 0}, {"spherical", 1}, {"cylindrical", 2}, {"planar", 3}};
    if (pbrt_state_lookup(P, "unsupported texture mapping", mapping,
                          params_find(ps, "mapping") ? params_find(ps, "mapping")->loc : loc,
                          MAPPINGS, COUNT_OF(MAPPINGS), &t->map.kind) != 0)
        return -1;
    t->uscale = t->vscale = 1.0;
    t->udelta = t->vdelta = 0.0;
    if (t->map.kind == 0) {
        if (params_get_float(ps, "uscale", 1.0, &t->uscale, P->err) != 0 ||
            params_get_float(ps, "vscale", 1.0, &t->vscale, P->err) != 0 ||
            params_get_float(ps, "udelta", 0.0, &t->udelta, P->err) != 0 ||
            params_get_float(ps, "vdelta", 0.0, &t->vdelta, P->err) != 0)
            return -1;
    } else if (t->map.kind == 3) {
        /* pbrt-v4's planar mapping: "vector3 v1" (1 0 0), "v2" (0 1 0), udelta, vdelta. */
        const char *vn[2] = {"v1", "v2"};
        double *vv[2] = {t->map.v1, t->map.v2};
        for (int k = 0; k < 2; k++) {
            param_t *vp;
            if (params_get_array(ps, vn[k], PARAM_VECTOR3, &vp, P->err) != 0)
                return -1;
            vv[k][0] = k == 0, vv[k][1] = k == 1, vv[k][2] = 0.0;
            if (vp && vp->count != 3)
                return pbrt_error(P->err, vp->loc, "expected 3 numbers after \"vector3 %s\"",
                                  vn[k]);
            for (int i = 0; vp && i < 3; i++)
                vv[k][i] = vp->numbers[i];
        }
        if (params_get_float(ps, "udelta", 0.0, &t->map.ds, P->err) != 0 ||
            params_get_float(ps, "vdelta", 0.0, &t->map.dt, P->err) != 0)
            return -1;
    }

    if (ptex) {
        t->float_in1.value = 0.5;
        t->spec_in1.spectrum = pbrt_inputs_constant(0.5, t->loc);
        return 0;
    }
    /* Inputs and their defaults as pbrt-v4 textures.cpp creates them. */
    switch (t->cls) {
    case SCENE_TEX_CONSTANT:
        return tex_input(P, ps, t, "value", 1.0, &t->float_in1, &t->spec_in1);
    case SCENE_TEX_CHECKERBOARD: {
        int dim;
        if (params_get_int(ps, "dimension", 2, &dim, P->err) != 0)
            return -1;
        if (dim != 2 && dim != 3)
            return pbrt_error(P->err, params_find(ps, "dimension")->loc,
                              "checkerboard \"integer dimension\" must be 2 or 3, got %d", dim);
        t->dimension = dim;
        return tex_input(P, ps, t, "tex1", 1.0, &t->float_in1, &t->spec_in1) != 0 ||
                       tex_input(P, ps, t, "tex2", 0.0, &t->float_in2, &t->spec_in2) != 0
                   ? -1
                   : 0;
    }
    case SCENE_TEX_SCALE:
        return tex_input(P, ps, t, "tex", 1.0, &t->float_in1, &t->spec_in1) != 0 ||
                       pbrt_inputs_float(P, ps, "scale", 1.0, &t->amount) != 0
                   ? -1
                   : 0;
    case SCENE_TEX_MIX:
        return tex_input(P, ps, t, "tex1", 0.0, &t->float_in1, &t->spec_in1) != 0 ||
                       tex_input(P, ps, t, "tex2", 1.0, &t->float_in2, &t->spec_in2) != 0 ||
                       pbrt_inputs_float(P, ps, "amount", 0.5, &t->amount) != 0
                   ? -1
                   : 0;
    case SCENE_TEX_BILERP:
        return tex_input(P, ps, t, "v00", 0.0, &t->float_in1, &t->spec_in1) != 0 ||
                       tex_input(P, ps, t, "v01", 1.0, &t->float_in2, &t->spec_in2) != 0 ||
                       tex_input(P, ps, t, "v10", 0.0, &t->float_in3, &t->spec_in3) != 0 ||
                       tex_input(P, ps, t, "v11", 1.0, &t->float_in4, &t->spec_in4) != 0
                   ? -1
                   : 0;
    case SCENE_TEX_DOTS:
        return tex_input(P, ps, t, "inside", 1.0, &t->float_in1, &t->spec_in1) != 0 ||
                       tex_input(P, ps, t, "outside", 0.0, &t->float_in2, &t->spec_in2) != 0
                   ? -1
                   : 0;
    case SCENE_TEX_FBM:
    case SCENE_TEX_WRINKLED:
    case SCENE_TEX_MARBLE:
        if (params_get_int(ps, "octaves", 8, &t->noise.octaves, P->err) != 0 ||
            params_get_float(ps, "roughness", 0.5, &t->noise.roughness, P->err) != 0)
            return -1;
        if (t->noise.octaves < 1 || t->noise.octaves > 64)
            return pbrt_error(P->err, params_find(ps, "octaves")->loc,
                              "\"integer octaves\" must be in 1..64, got %d", t->noise.octaves);
        if (t->cls != SCENE_TEX_MARBLE)
            return 0;
        return params_get_float(ps, "scale", 1.0, &t->noise.scale, P->err) != 0 ||
                       params_get_float(ps, "variation", 0.2, &t->noise.variation, P->err) != 0
                   ? -1
                   : 0;
    case SCENE_TEX_WINDY:
        return 0;
    case SCENE_TEX_DIRECTIONMIX: {
        param_t *dp;
        if (params_get_array(ps, "dir", PARAM_VECTOR3, &dp, P->err) != 0)
            return -1;
        t->dir[0] = 0.0, t->dir[1] = 1.0, t->dir[2] = 0.0;
        if (dp) {
            if (dp->count != 3)
                return pbrt_error(P->err, dp->loc, "expected 3 numbers after \"vector3 dir\"");
            for (int i = 0; i < 3; i++)
                t->dir[i] = dp->numbers[i];
        }
        return tex_input(P, ps, t, "tex1", 0.0, &t->float_in1, &t->spec_in1) != 0 ||
                       tex_input(P, ps, t, "tex2", 1.0, &t->float_in2, &t->spec_in2) != 0
                   ? -1
                   : 0;
    }
    case SCENE_TEX_IMAGEMAP:
        break;
    }
    const char *filename, *wrap, *filter, *encoding;
    if (params_get_string(ps, "filename", NULL, &filename, P->err) != 0 ||
        params_get_string(ps, "wrap", "repeat", &wrap, P->err) != 0 ||
        params_get_string(ps, "filter", "bilinear", &filter, P->err) != 0 ||
        params_get_string(ps, "encoding", "sRGB", &encoding, P->err) != 0 ||
        params_get_float(ps, "scale", 1.0, &t->image.scale, P->err) != 0 ||
        params_get_bool(ps, "invert", false, &t->image.invert, P->err) != 0)
        return -1;
    if (!filename)
        return pbrt_error(P->err, loc, "Texture \"imagemap\" needs \"string filename\"");
    param_t *fp = params_find(ps, "filename");
    static const pbrt_name_t WRAPS[] = {
        {"repeat", 0}, {"black", 1}, {"clamp", 2}, {"octahedralsphere", 3}};
    static const pbrt_name_t FILTERS[] = {
        {"point", 0}, {"bilinear", 1}, {"trilinear", 2}, {"ewa", 3}};
    int k;
    if (pbrt_state_lookup(P, "unsupported wrap mode", wrap,
                          params_find(ps, "wrap") ? params_find(ps, "wrap")->loc : loc, WRAPS,
                          COUNT_OF(WRAPS), &k) != 0 ||
        pbrt_state_lookup(P, "unknown filter", filter,
                          params_find(ps, "filter") ? params_find(ps, "filter")->loc : loc, FILTERS,
                          COUNT_OF(FILTERS), &k) != 0)
        return -1;
    if (!strcmp(filter, "ewa") &&
        warnings_add(P->scene->warnings, params_find(ps, "filter")->loc,
                     "Texture \"%s\": filter \"ewa\" is read as \"trilinear\" (and, without ray "
                     "differentials, at the full resolution)",
                     name->s))
        return pbrt_error(P->err, loc, "out of memory");
    double gamma;
    char tail;
    if (strcmp(encoding, "sRGB") != 0 && strcmp(encoding, "linear") != 0 &&
        !(sscanf(encoding, "gamma %lf%c", &gamma, &tail) == 1 && isfinite(gamma) && gamma > 0.0))
        return pbrt_error(P->err, params_find(ps, "encoding")->loc,
                          "unknown encoding \"%s\" (\"sRGB\", \"linear\" or \"gamma G\")",
                          encoding);
    if (pbrt_inputs_image_file(P, fp, filename, &t->image.filename) != 0)
        return -1;
    t->image.wrap = scene_desc_strdup(P->scene, wrap, P->err);
    t->image.filter = scene_desc_strdup(P->scene, filter, P->err);
    t->image.encoding = scene_desc_strdup(P->scene, encoding, P->err);
    return t->image.wrap && t->image.filter && t->image.encoding ? 0 : -1;
}

int pbrt_textures_read(parser_t *P, pbrt_loc_t loc)
{
    str_arg_t name, type, cls;
    if (pbrt_state_read_string(P, "Texture", loc, "texture name", &name) != 0 ||
        pbrt_state_read_string(P, "Texture", loc, "texture type",
                               &type) != 0 ||
        pbrt_state_read_string(P, "Texture", loc, "texture class", &cls) != 0)
        return -1;
    char context[192];
    snprintf(context, sizeof context, "Texture \"%.100s\"", cls.s);
    params_t *ps = pbrt_state_read_params(P, context);
    if (!ps)
        return -1;
    int rc = pbrt_state_attr_apply(P, ps, ATTR_TEXTURE) ||
                     pbrt_state_need_world(P, "Texture", loc) ||
                     do_texture(P, ps, &name, &type, &cls, loc) || params_check_unused(ps, P->err)
                 ? -1
                 : 0;
    params_destroy(&ps);
    return rc;
}
