#define _XOPEN_SOURCE 700 /* realpath, strdup */

/* The parser proper: directives, files and the graphics state's blocks. Each entity's
 * parameters are read in its own module (pbrt_options, pbrt_materials, pbrt_textures,
 * pbrt_lights, pbrt_shapes, pbrt_media), the way pbrt-v4 keeps its parser to directives. */
#include "pbrt_parser.h"

#include "gzip_data.h"
#include "paths.h"
#include "pbrt_confine.h"
#include "pbrt_inputs.h"
#include "pbrt_lights.h"
#include "pbrt_materials.h"
#include "pbrt_media.h"
#include "pbrt_meshes.h"
#include "pbrt_options.h"
#include "pbrt_shapes.h"
#include "pbrt_state.h"
#include "pbrt_textures.h"
#include "pbrt_upgrade.h"
#include "suggest.h"

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

/* The kinds of entity an `Attribute` directive gives defaults for, in pbrt-v4's words. */
static const pbrt_name_t ATTR_KIND_NAMES[] = {{"shape", ATTR_SHAPE},
                                              {"light", ATTR_LIGHT},
                                              {"material", ATTR_MATERIAL},
                                              {"medium", ATTR_MEDIUM},
                                              {"texture", ATTR_TEXTURE}};

/* pbrt-v4 directives that prismfarm knows but does not support. */
static const char *UNSUPPORTED_DIRECTIVES[] = {"WorldEnd"};

static int parse_file(parser_t *P, const char *path, const pbrt_loc_t *from, scene_file_kind_t kind,
                      const char *name);

/* Attribute "shape" | "light" | "material" | "medium" | "texture" params: default parameter
 * values for the entities of that kind that follow, until the attribute block ends. */
static int do_attribute(parser_t *P, pbrt_loc_t loc)
{
    str_arg_t target;
    if (pbrt_state_read_string(P, "Attribute", loc, "attribute target", &target) != 0)
        return -1;
    int kind;
    if (pbrt_state_lookup(P, "unknown Attribute target", target.s, target.loc, ATTR_KIND_NAMES,
                          COUNT_OF(ATTR_KIND_NAMES), &kind) != 0)
        return -1;
    char context[64];
    snprintf(context, sizeof context, "Attribute \"%.16s\"", target.s);
    params_t *ps = pbrt_state_read_params(P, context);
    if (!ps)
        return -1;
    if (pbrt_state_need_world(P, "Attribute", loc) != 0) {
        params_destroy(&ps);
        return -1;
    }
    attr_node_t *n = malloc(sizeof *n);
    if (!n) {
        params_destroy(&ps);
        return err_set(P->err, "out of memory");
    }
    n->ps = ps;
    n->older = P->gs.attr[kind];
    n->next_owned = P->attr_owned;
    P->attr_owned = n;
    P->gs.attr[kind] = n;
    return 0;
}

/* Directives of the form: Name "type" params. */
static int param_directive(parser_t *P, const char *dir, pbrt_loc_t loc)
{
    str_arg_t type;
    const char *what = !strcmp(dir, "MakeNamedMaterial") ? "material name" : "type name";
    if (pbrt_state_read_string(P, dir, loc, what, &type) != 0)
        return -1;
    char context[192];
    snprintf(context, sizeof context, "%s \"%.100s%s\"", dir, type.s,
             strlen(type.s) > 100 ? "..." : "");
    params_t *ps = pbrt_state_read_params(P, context);
    if (!ps)
        return -1;
    int rc = -1;
    bool keep = false;
    int kind = !strcmp(dir, "Shape")                                            ? ATTR_SHAPE
               : !strcmp(dir, "Material") || !strcmp(dir, "MakeNamedMaterial")  ? ATTR_MATERIAL
               : !strcmp(dir, "LightSource") || !strcmp(dir, "AreaLightSource") ? ATTR_LIGHT
                                                                                : -1;
    if (kind >= 0 && pbrt_state_attr_apply(P, ps, kind) != 0)
        goto done;
    if (!strcmp(dir, "Camera")) {
        rc =
            pbrt_state_need_options(P, dir, loc) || pbrt_options_camera(P, ps, &type, loc) ? -1 : 0;
    } else if (!strcmp(dir, "Film")) {
        rc = pbrt_state_need_options(P, dir, loc) || pbrt_options_film(P, ps, &type, loc) ? -1 : 0;
    } else if (!strcmp(dir, "Sampler")) {
        rc = pbrt_state_need_options(P, dir, loc) || pbrt_options_sampler(P, ps, &type, loc) ? -1
                                                                                             : 0;
    } else if (!strcmp(dir, "PixelFilter")) {
        rc = pbrt_state_need_options(P, dir, loc) || pbrt_options_pixelfilter(P, ps, &type, loc)
                 ? -1
                 : 0;
    } else if (!strcmp(dir, "Integrator")) {
        if (pbrt_state_need_options(P, dir, loc) != 0)
            goto done;
        rc = pbrt_options_integrator(P, ps, &type, loc);
        keep = rc == 0; /* the scene holds the parameters */
        goto done;
    } else if (!strcmp(dir, "Shape")) {
        rc = pbrt_state_need_world(P, dir, loc) || pbrt_shapes_read(P, ps, &type, loc) ? -1 : 0;
    } else if (!strcmp(dir, "Material") || !strcmp(dir, "MakeNamedMaterial")) {
        if (pbrt_state_need_world(P, dir, loc) != 0)
            goto done;
        rc = !strcmp(dir, "MakeNamedMaterial")
                 ? pbrt_materials_read_named(P, ps, &type, loc)
                 : pbrt_materials_read(P, ps, &type, NULL, loc, type.loc);
        /* The scene holds the parameters: the material's class reads them, and refuses the
         * ones it does not use, when the scene loads. */
        keep = rc == 0;
        goto done;
    } else if (!strcmp(dir, "AreaLightSource")) {
        rc =
            pbrt_state_need_world(P, dir, loc) || pbrt_lights_read_area(P, ps, &type, loc) ? -1 : 0;
    } else if (!strcmp(dir, "LightSource")) {
        rc = pbrt_state_need_world(P, dir, loc) || pbrt_lights_read(P, ps, &type, loc) ? -1 : 0;
    }
    if (rc == 0)
        rc = params_check_unused(ps, P->err);
done:
    if (!keep)
        params_destroy(&ps);
    return rc;
}

static int end_frame(parser_t *P, int kind, const char *dir, pbrt_loc_t loc)
{
    if (P->nframes == 0)
        return pbrt_error(P->err, loc, "%s without a matching %s", dir,
                          kind == FRAME_OBJECT ? "ObjectBegin" : "AttributeBegin");
    frame_t *top = &P->frames[P->nframes - 1];
    if (top->kind == FRAME_IMPORT)
        return pbrt_error(P->err, loc, "%s without a matching %s in this imported file", dir,
                          kind == FRAME_OBJECT ? "ObjectBegin" : "AttributeBegin");
    if (top->kind != kind)
        return pbrt_error(P->err, loc, "%s closes %s at line %d (mismatched nesting)", dir,
                          top->what, top->loc.line);
    P->gs = top->gs;
    P->nframes--;
    return 0;
}

static int do_object_begin(parser_t *P, pbrt_loc_t loc)
{
    str_arg_t name;
    if (pbrt_state_read_string(P, "ObjectBegin", loc, "object name", &name) != 0 ||
        pbrt_state_need_world(P, "ObjectBegin", loc) != 0)
        return -1;
    if (P->object >= 0)
        return pbrt_error(P->err, loc, "ObjectBegin inside ObjectBegin \"%s\" (line %d)",
                          P->scene->objects[P->object].name, P->scene->objects[P->object].loc.line);
    int prev = scene_desc_find_object(P->scene, name.s);
    if (prev >= 0)
        return pbrt_error(P->err, name.loc, "object \"%s\" is already defined (line %d)", name.s,
                          P->scene->objects[prev].loc.line);
    if (pbrt_state_push_frame(P, FRAME_OBJECT, "ObjectBegin", loc) != 0)
        return -1;
    int idx = scene_desc_add_object(P->scene, P->err);
    if (idx < 0)
        return -1;
    scene_object_t *o = &P->scene->objects[idx];
    o->name = scene_desc_strdup(P->scene, name.s, P->err);
    if (!o->name)
        return -1;
    o->loc = loc;
    o->first_shape = P->scene->nobject_shapes;
    P->object = idx;
    return 0;
}

static int do_object_end(parser_t *P, pbrt_loc_t loc)
{
    if (pbrt_state_need_world(P, "ObjectEnd", loc) != 0)
        return -1;
    if (P->object < 0)
        return pbrt_error(P->err, loc, "ObjectEnd without a matching ObjectBegin");
    if (end_frame(P, FRAME_OBJECT, "ObjectEnd", loc) != 0)
        return -1;
    scene_object_t *o = &P->scene->objects[P->object];
    o->nshapes = P->scene->nobject_shapes - o->first_shape;
    P->object = -1;
    return 0;
}

static int do_object_instance(parser_t *P, pbrt_loc_t loc)
{
    str_arg_t name;
    if (pbrt_state_read_string(P, "ObjectInstance", loc, "object name", &name) != 0 ||
        pbrt_state_need_world(P, "ObjectInstance", loc) != 0)
        return -1;
    if (P->object >= 0)
        return pbrt_error(P->err, loc, "ObjectInstance inside ObjectBegin \"%s\" is not supported",
                          P->scene->objects[P->object].name);
    if (pbrt_state_check_transform(P, &P->gs.ctm, "ObjectInstance", loc) != 0 ||
        pbrt_meshes_budget_shape(P, "ObjectInstance", loc) != 0)
        return -1;
    int idx = scene_desc_add_instance(P->scene, P->err);
    if (idx < 0)
        return -1;
    if ((size_t)idx >= P->cap_pending) {
        size_t cap = P->scene->cap_instances;
        const char **p = realloc(P->pending, cap * sizeof *p);
        if (!p)
            return pbrt_error(P->err, loc, "out of memory");
        P->pending = p;
        P->cap_pending = cap;
    }
    scene_instance_t *in = &P->scene->instances[idx];
    in->object = -1;
    in->loc = loc;
    in->to_world = P->gs.ctm;
    in->swaps_handedness = transform_swaps_handedness(&P->gs.ctm);
    /* pbrt-v4 resolves instances at the end, so an object may be defined after its use. */
    P->pending[idx] = scene_desc_strdup(P->scene, name.s, P->err);
    return P->pending[idx] ? 0 : -1;
}

static int do_include(parser_t *P, bool import, pbrt_loc_t loc)
{
    const char *dir = import ? "Import" : "Include";
    str_arg_t name;
    if (pbrt_state_read_string(P, dir, loc, "file name", &name) != 0)
        return -1;
    if (import && pbrt_state_need_world(P, dir, loc) != 0)
        return -1;
    char *path = pbrt_confine_locate(P, name.s);
    if (!path)
        return pbrt_error(P->err, loc, "out of memory");
    /* Import reads the file with a copy of the graphics state: nothing it changes (CTM,
     * material, attributes) leaks back into the importing file (pbrt-v4 CopyForImport). */
    if (import && pbrt_state_push_frame(P, FRAME_IMPORT, "Import", loc) != 0) {
        free(path);
        return -1;
    }
    const char *outer_file = P->file;
    pbrt_lexer_t *outer_lex = P->lex;
    int rc = parse_file(P, path, &name.loc, SCENE_FILE_INCLUDE, name.s);
    free(path);
    const char *inner_file = P->file;
    P->file = outer_file;
    P->lex = outer_lex;
    if (rc != 0 || !import)
        return rc;
    frame_t *top = &P->frames[P->nframes - 1];
    if (top->kind != FRAME_IMPORT)
        return pbrt_error(P->err, top->loc,
                          "%s has no matching end before the end of imported "
                          "file \"%s\"",
                          top->what, inner_file);
    P->gs = top->gs;
    P->nframes--;
    return 0;
}

static int do_transform_directive(parser_t *P, const char *dir, pbrt_loc_t loc)
{
    double v[16];
    transform_t t;
    err_t e;
    if (!strcmp(dir, "Translate")) {
        if (pbrt_state_read_numbers(P, dir, loc, v, 3) != 0)
            return -1;
        t = transform_translate(vec3_make(v[0], v[1], v[2]));
    } else if (!strcmp(dir, "Scale")) {
        if (pbrt_state_read_numbers(P, dir, loc, v, 3) != 0)
            return -1;
        t = transform_scale(v[0], v[1], v[2]);
    } else if (!strcmp(dir, "Rotate")) {
        if (pbrt_state_read_numbers(P, dir, loc, v, 4) != 0)
            return -1;
        if (transform_rotate(v[0], vec3_make(v[1], v[2], v[3]), &t, &e) != 0)
            return pbrt_error(P->err, loc, "Rotate: %s", e.msg);
    } else if (!strcmp(dir, "LookAt")) {
        if (pbrt_state_read_numbers(P, dir, loc, v, 9) != 0)
            return -1;
        if (transform_look_at(vec3_make(v[0], v[1], v[2]), vec3_make(v[3], v[4], v[5]),
                              vec3_make(v[6], v[7], v[8]), &t, &e) != 0)
            return pbrt_error(P->err, loc, "%s", e.msg);
    } else {
        if (pbrt_state_read_matrix(P, dir, loc, v) != 0)
            return -1;
        t = transform_from_pbrt_array(v);
        if (!strcmp(dir, "Transform")) {
            P->gs.ctm = t;
            return 0;
        }
    }
    P->gs.ctm = transform_compose(P->gs.ctm, t);
    return 0;
}

/* ActiveTransform StartTime | EndTime | All. prismfarm renders the scene at the shutter's
 * opening (no motion blur): transforms given for the end time alone are ignored, with a
 * warning; All and StartTime apply them as usual. */
static int do_active_transform(parser_t *P, pbrt_loc_t loc)
{
    pbrt_token_t t;
    if (pbrt_lexer_next(P->lex, &t, P->err) != 0)
        return -1;
    if (t.kind != PBRT_TOKEN_WORD ||
        (strcmp(t.text, "StartTime") && strcmp(t.text, "EndTime") && strcmp(t.text, "All"))) {
        char d[96];
        pbrt_state_describe(&t, d, sizeof d);
        return pbrt_error(P->err, t.kind == PBRT_TOKEN_EOF ? loc : t.loc,
                          "ActiveTransform expects StartTime, EndTime or All, got %s", d);
    }
    P->gs.end_time_only = !strcmp(t.text, "EndTime");
    /* StartTime or EndTime alone: what follows makes the start and end transforms differ. */
    if (strcmp(t.text, "All") != 0 &&
        warnings_add(P->scene->warnings, loc,
                     "motion blur is not simulated: the scene renders as at the shutter's "
                     "opening (the transforms for its end are ignored)"))
        return err_set(P->err, "out of memory");
    return 0;
}

static int directive(parser_t *P, const char *dir, pbrt_loc_t loc)
{
    static const char *PARAM_DIRECTIVES[] = {
        "Camera", "Film",     "Sampler",           "Integrator",      "PixelFilter",
        "Shape",  "Material", "MakeNamedMaterial", "AreaLightSource", "LightSource"};
    static const char *TRANSFORMS[] = {"Translate", "Scale",     "Rotate",
                                       "LookAt",    "Transform", "ConcatTransform"};
    if (pbrt_state_in_list(dir, PARAM_DIRECTIVES, COUNT_OF(PARAM_DIRECTIVES)))
        return param_directive(P, dir, loc);
    if (pbrt_state_in_list(dir, TRANSFORMS, COUNT_OF(TRANSFORMS))) {
        if (!P->gs.end_time_only)
            return do_transform_directive(P, dir, loc);
        transform_t keep = P->gs.ctm; /* read (and check) it, then leave the start CTM */
        int rc = do_transform_directive(P, dir, loc);
        P->gs.ctm = keep;
        return rc;
    }
    if (!strcmp(dir, "Identity")) {
        if (!P->gs.end_time_only)
            P->gs.ctm = transform_identity();
        return 0;
    }
    if (!strcmp(dir, "MakeNamedMedium"))
        return pbrt_media_read(P, loc);
    if (!strcmp(dir, "Attribute"))
        return do_attribute(P, loc);
    if (!strcmp(dir, "Option"))
        return pbrt_options_option(P, loc);
    if (!strcmp(dir, "MediumInterface"))
        return pbrt_media_interface(P, loc);
    if (!strcmp(dir, "ActiveTransform"))
        return do_active_transform(P, loc);
    if (!strcmp(dir, "TransformTimes")) {
        double v[2];
        if (pbrt_state_read_numbers(P, dir, loc, v, 2) != 0)
            return -1;
        return warnings_add(P->scene->warnings, loc,
                            "TransformTimes %g %g is ignored (no motion blur)", v[0], v[1])
                   ? err_set(P->err, "out of memory")
                   : 0;
    }
    if (!strcmp(dir, "ColorSpace")) {
        str_arg_t name;
        if (pbrt_state_read_string(P, dir, loc, "colour space name", &name) != 0)
            return -1;
        /* pbrt-v4's default, the only one prismfarm has. */
        if (strcmp(name.s, "srgb") != 0)
            return pbrt_error(P->err, name.loc,
                              "unsupported colour space \"%s\" (only \"srgb\", pbrt-v4's default)",
                              name.s);
        return 0;
    }
    if (!strcmp(dir, "Accelerator")) {
        /* How pbrt-v4 builds its BVH: no effect on the image; Embree builds its own. */
        str_arg_t type;
        if (pbrt_state_read_string(P, dir, loc, "type name", &type) != 0)
            return -1;
        params_t *ps = pbrt_state_read_params(P, "Accelerator");
        if (!ps)
            return -1;
        params_accept_all(ps);
        params_destroy(&ps);
        return 0;
    }
    if (!strcmp(dir, "Texture"))
        return pbrt_textures_read(P, loc);
    if (!strcmp(dir, "AttributeBegin") || !strcmp(dir, "TransformBegin"))
        /* pbrt-v4 reads the deprecated TransformBegin/End as AttributeBegin/End. */
        return pbrt_state_need_world(P, dir, loc) ||
                       pbrt_state_push_frame(P, FRAME_ATTRIBUTE,
                                             dir[0] == 'A' ? "AttributeBegin" : "TransformBegin",
                                             loc)
                   ? -1
                   : 0;
    if (!strcmp(dir, "AttributeEnd") || !strcmp(dir, "TransformEnd"))
        return pbrt_state_need_world(P, dir, loc) || end_frame(P, FRAME_ATTRIBUTE, dir, loc) ? -1
                                                                                             : 0;
    if (!strcmp(dir, "ReverseOrientation")) {
        if (pbrt_state_need_world(P, dir, loc) != 0)
            return -1;
        P->gs.reverse = !P->gs.reverse;
        return 0;
    }
    if (!strcmp(dir, "CoordinateSystem") || !strcmp(dir, "CoordSysTransform")) {
        str_arg_t name;
        if (pbrt_state_read_string(P, dir, loc, "coordinate system name", &name) != 0)
            return -1;
        if (!strcmp(dir, "CoordinateSystem"))
            return pbrt_state_set_coordsys(P, name.s, P->gs.ctm, loc);
        for (size_t i = 0; i < P->ncs; i++)
            if (!strcmp(P->cs[i].name, name.s)) {
                P->gs.ctm = P->cs[i].t;
                return 0;
            }
        return pbrt_error(P->err, name.loc, "unknown coordinate system \"%s\"", name.s);
    }
    if (!strcmp(dir, "WorldBegin")) {
        if (P->world)
            return pbrt_error(P->err, loc, "WorldBegin appears twice (first at line %d)",
                              P->world_loc.line);
        P->world = true;
        P->world_loc = loc;
        P->gs.ctm = transform_identity();
        return pbrt_state_set_coordsys(P, "world", P->gs.ctm, loc);
    }
    if (!strcmp(dir, "Include") || !strcmp(dir, "Import"))
        return do_include(P, !strcmp(dir, "Import"), loc);
    if (!strcmp(dir, "ObjectBegin"))
        return do_object_begin(P, loc);
    if (!strcmp(dir, "ObjectEnd"))
        return do_object_end(P, loc);
    if (!strcmp(dir, "ObjectInstance"))
        return do_object_instance(P, loc);
    if (!strcmp(dir, "NamedMaterial")) {
        str_arg_t name;
        if (pbrt_state_read_string(P, dir, loc, "material name", &name) != 0 ||
            pbrt_state_need_world(P, dir, loc) != 0)
            return -1;
        int m = scene_desc_find_material(P->scene, name.s);
        if (m < 0)
            return pbrt_error(P->err, name.loc,
                              "named material \"%s\" is not defined "
                              "(MakeNamedMaterial must come before its use)",
                              name.s);
        P->gs.material = m;
        return 0;
    }
    if (pbrt_state_in_list(dir, UNSUPPORTED_DIRECTIVES, COUNT_OF(UNSUPPORTED_DIRECTIVES)))
        return pbrt_error(P->err, loc, "unsupported directive %s (%s)", dir, PBRT_UPGRADE_HINT);
    /* Every directive pbrt-v4's parser knows (the spelling is the file format's, so the list
     * is fixed), for the "did you mean" of a misspelt one: Integrater, Attributebegin. */
    static const char *const PBRT_DIRECTIVES[] = {"Accelerator",
                                                  "ActiveTransform",
                                                  "AreaLightSource",
                                                  "Attribute",
                                                  "AttributeBegin",
                                                  "AttributeEnd",
                                                  "Camera",
                                                  "ColorSpace",
                                                  "ConcatTransform",
                                                  "CoordinateSystem",
                                                  "CoordSysTransform",
                                                  "Film",
                                                  "Identity",
                                                  "Import",
                                                  "Include",
                                                  "Integrator",
                                                  "LightSource",
                                                  "LookAt",
                                                  "MakeNamedMaterial",
                                                  "MakeNamedMedium",
                                                  "Material",
                                                  "MediumInterface",
                                                  "NamedMaterial",
                                                  "ObjectBegin",
                                                  "ObjectEnd",
                                                  "ObjectInstance",
                                                  "Option",
                                                  "PixelFilter",
                                                  "ReverseOrientation",
                                                  "Rotate",
                                                  "Sampler",
                                                  "Scale",
                                                  "Shape",
                                                  "Texture",
                                                  "Transform",
                                                  "TransformBegin",
                                                  "TransformEnd",
                                                  "TransformTimes",
                                                  "Translate",
                                                  "WorldBegin"};
    const char *best = suggest_nearest(dir, PBRT_DIRECTIVES, COUNT_OF(PBRT_DIRECTIVES));
    if (best)
        return pbrt_error(P->err, loc, "unknown directive %s (did you mean %s?)", dir, best);
    return pbrt_error(P->err, loc, "unknown directive %s", dir);
}

/* Check mode: records the refusal in P->err and skips to the next directive (a word that is
 * not a number: a directive's arguments are strings, numbers and brackets), so that every
 * refusal of a scene is found in one run. Returns 0 to go on, -1 to stop (not in check mode,
 * or the text itself cannot be read on: an unterminated string, a file that cannot be read). */
static int recover(parser_t *P)
{
    if (!P->errors || warnings_add_text(P->errors, P->err->msg) != 0)
        return -1;
    for (;;) {
        pbrt_token_t t;
        if (pbrt_lexer_peek(P->lex, &t, P->err) != 0)
            return -1;
        double number;
        if (t.kind == PBRT_TOKEN_EOF ||
            (t.kind == PBRT_TOKEN_WORD && pbrt_parse_number(t.text, &number) == -1))
            return 0;
        if (pbrt_lexer_next(P->lex, &t, P->err) != 0)
            return -1;
    }
}

static int parse_tokens(parser_t *P)
{
    for (;;) {
        pbrt_token_t t;
        if (pbrt_lexer_next(P->lex, &t, P->err) != 0)
            return -1;
        if (t.kind == PBRT_TOKEN_EOF)
            return 0;
        if (t.kind != PBRT_TOKEN_WORD) {
            char d[96];
            pbrt_state_describe(&t, d, sizeof d);
            return pbrt_error(P->err, t.loc, "expected a directive, got %s", d);
        }
        double number;
        if (pbrt_parse_number(t.text, &number) != -1)
            /* Most often one number too many after a transform ("Translate 1 2 3 4"). */
            return pbrt_error(P->err, t.loc,
                              "expected a directive, got the number %.40s (one too many for the "
                              "directive before it?)",
                              t.text);
        /* A word a directive cannot be (a line of a file that is not a scene: "root:x:0:0:...")
         * is not shown: the message must not echo a file's contents. */
        bool word = true;
        for (size_t i = 0; i < t.len && word; i++)
            word = (t.text[i] >= 'A' && t.text[i] <= 'Z') ||
                   (t.text[i] >= 'a' && t.text[i] <= 'z') ||
                   (t.text[i] >= '0' && t.text[i] <= '9') || t.text[i] == '_';
        if (!word)
            return pbrt_error(P->err, t.loc,
                              "expected a directive, got a word that cannot be one (is this file "
                              "a pbrt scene?)");
        char dir[64];
        if (t.len >= sizeof dir) {
            return pbrt_error(P->err, t.loc, "unknown directive %.40s...", t.text);
        }
        memcpy(dir, t.text, t.len + 1);
        if (directive(P, dir, t.loc) != 0 && recover(P) != 0)
            return -1;
    }
}

/* Reads a whole file; a file that cannot be read names the Include that asked for it. */
static char *read_file(parser_t *P, const char *path, const pbrt_loc_t *from, size_t *len)
{
    const char *kind;
    char why[96];
    FILE *f = pbrt_confine_open_regular(path, &kind);
    if (!f) {
        if (from)
            pbrt_error(P->err, *from, "cannot open included file \"%s\": %s%s", path,
                       pbrt_confine_open_failure(kind, why, sizeof why), P->also);
        else
            err_set(P->err, "cannot open scene file \"%s\": %s", path,
                    pbrt_confine_open_failure(kind, why, sizeof why));
        return NULL;
    }
    size_t cap = 1 << 16, n = 0;
    char *buf = malloc(cap);
    while (buf) {
        size_t got = fread(buf + n, 1, cap - n, f);
        n += got;
        if (n < cap) {
            if (ferror(f)) {
                free(buf);
                buf = NULL;
                if (from)
                    pbrt_error(P->err, *from, "cannot read included file \"%s\"", path);
                else
                    err_set(P->err, "cannot read scene file \"%s\"", path);
                fclose(f);
                return NULL;
            }
            break;
        }
        /* The lexer counts lines and columns in int: a scene text is bounded. */
        if (cap > PBRT_FILE_BYTES_MAX) {
            free(buf);
            fclose(f);
            pbrt_state_fail_at(P, from, "\"%s\" is larger than %zu bytes", path,
                               PBRT_FILE_BYTES_MAX);
            return NULL;
        }
        size_t grown = cap * 2 < PBRT_FILE_BYTES_MAX + 1 ? cap * 2 : PBRT_FILE_BYTES_MAX + 1;
        char *nb = realloc(buf, grown);
        if (!nb)
            free(buf);
        buf = nb;
        cap = grown;
    }
    fclose(f);
    if (!buf) {
        err_set(P->err, "out of memory reading \"%s\"", path);
        return NULL;
    }
    *len = n;
    return buf;
}

static int parse_buffer(parser_t *P, const char *name, const char *text, size_t len)
{
    const char *file = scene_desc_strdup(P->scene, name, P->err);
    if (!file)
        return -1;
    P->lex = pbrt_lexer_new(file, text, len, P->err);
    if (!P->lex)
        return -1;
    P->file = file;
    int rc = parse_tokens(P);
    pbrt_lexer_destroy(&P->lex);
    return rc;
}

/* The most a scene file may inflate to: its own bound, or what the text budget leaves. */
#define TEXT_LEFT(P) ((size_t)scene_budget_text_left((P)->budget, &(P)->used, PBRT_FILE_BYTES_MAX))

/* Reads and parses one file: the main file (from NULL) or one named by Include/Import at
 * *from, as `name`. */
static int parse_file(parser_t *P, const char *path, const pbrt_loc_t *from, scene_file_kind_t kind,
                      const char *name)
{
    if (from && P->nopen >= PBRT_INCLUDE_DEPTH_MAX)
        return pbrt_error(P->err, *from, "Include/Import nested deeper than %d files",
                          PBRT_INCLUDE_DEPTH_MAX);
    if (from && ++P->nfiles_read > PBRT_FILES_MAX)
        return pbrt_error(P->err, *from, "the scene reads more than %d files", PBRT_FILES_MAX);
    size_t len;
    char *text, *real;
    if (from && pbrt_confine_bundle_check(P, path, name, *from) != 0)
        return -1;
    if (P->root_real) {
        const char *what = from ? "included file" : "scene file";
        real = pbrt_confine_check(P, path, name, from, what);
        text = real ? pbrt_confine_read(P, real, name, path, from, what, &len) : NULL;
        if (!text || pbrt_confine_inflate(P, &text, &len, TEXT_LEFT(P), path, from) != 0) {
            free(text);
            free(real);
            return -1;
        }
    } else {
        text = read_file(P, path, from, &len);
        if (!text)
            return -1;
        if (pbrt_confine_inflate(P, &text, &len, TEXT_LEFT(P), path, from) != 0) {
            free(text);
            return -1;
        }
        real = realpath(path, NULL);
        if (!real) {
            free(text);
            return from ? pbrt_error(P->err, *from, "cannot resolve \"%s\": %s", path,
                                     strerror(errno))
                        : err_set(P->err, "cannot resolve \"%s\": %s", path, strerror(errno));
        }
    }
    for (int i = 0; i < P->nopen; i++)
        if (!strcmp(P->open_files[i], real)) {
            free(text);
            free(real);
            return pbrt_error(P->err, *from, "include cycle: \"%s\" is already being read", path);
        }
    P->open_files[P->nopen++] = real;
    pbrt_loc_t named = from ? *from : (pbrt_loc_t){P->main_name, 0, 0};
    err_t over;
    int rc = scene_budget_charge_text(P->budget, &P->used, len, path, &over) != 0
                 ? pbrt_state_fail_at(P, from, "%s", over.msg)
                 : pbrt_inputs_note_file(P, kind, path, name, named);
    if (rc == 0)
        rc = parse_buffer(P, path, text, len);
    free(text);
    free(P->open_files[--P->nopen]);
    return rc;
}

/* End of the scene: everything opened must be closed, and instances must name objects. */
static int finish(parser_t *P)
{
    if (P->option_seed_set && !P->sampler_seed_given)
        P->scene->sampler.seed = P->option_seed;
    if (P->nframes > 0) {
        frame_t *top = &P->frames[P->nframes - 1];
        return pbrt_error(P->err, top->loc, "%s has no matching end", top->what);
    }
    if (!P->world)
        return err_set(P->err, "%s: the scene has no WorldBegin", P->file ? P->file : "scene");
    for (size_t i = 0; i < P->scene->ninstances; i++) {
        scene_instance_t *in = &P->scene->instances[i];
        in->object = scene_desc_find_object(P->scene, P->pending[i]);
        if (in->object < 0)
            return pbrt_error(P->err, in->loc, "ObjectInstance: object \"%s\" is not defined",
                              P->pending[i]);
    }
    return 0;
}

static scene_desc_t *run(const char *name, const char *text, size_t len, const char *root,
                         const scene_budget_t *budget, warnings_t *errors, int threads, bool bundle,
                         err_t *err)
{
    parser_t P = {0};
    P.err = err;
    P.threads = threads;
    P.budget = budget;
    P.errors = errors;
    P.bundle = bundle;
    if (root) {
        P.root_real = realpath(root, NULL);
        if (!P.root_real) {
            err_set(err, "cannot open the scene's folder \"%s\": %s", root, strerror(errno));
            return NULL;
        }
        P.root_lex = paths_lexical(root);
        if (!P.root_lex) {
            free(P.root_real);
            err_set(err, "out of memory");
            return NULL;
        }
    }
    P.object = -1;
    P.scene = scene_desc_new(err);
    if (!P.scene) {
        free(P.root_real);
        free(P.root_lex);
        return NULL;
    }
    P.gs.ctm = transform_identity();
    P.gs.material = 0;
    P.gs.area_light = -1;
    P.gs.inside_medium = P.gs.outside_medium = -1;
    /* Defaults that no directive set point at line 0 of the main file. */
    const char *main_name = scene_desc_strdup(P.scene, name, err);
    if (!main_name) {
        scene_desc_destroy(&P.scene);
        free(P.root_real);
        free(P.root_lex);
        return NULL;
    }
    pbrt_loc_t none = {main_name, 0, 0};
    P.scene->camera.loc = P.scene->film.loc = P.scene->sampler.loc = none;
    P.scene->integrator.loc = none;
    P.scene->materials[0].loc = none;
    P.main_name = main_name;
    int rc = text ? parse_buffer(&P, name, text, len)
                  : parse_file(&P, name, NULL, SCENE_FILE_MAIN, name);
    if (rc == 0) {
        rc = pbrt_meshes_finish(&P);
    } else {
        err_t at_stop = *err;
        if (pbrt_meshes_finish(&P) == 0)
            *err = at_stop; /* nothing before the point where the parse stopped failed */
    }
    if (rc == 0) {
        P.file = main_name;
        rc = finish(&P);
        if (rc != 0 && errors && warnings_add_text(errors, err->msg) == 0)
            rc = 0; /* recorded; the scene parsed as far as it could */
    } else if (errors && warnings_add_text(errors, err->msg) == 0) {
        rc = 0; /* the text could not be read on: what was parsed is kept for the loader */
    }
    for (size_t i = 0; i < P.ncs; i++)
        free(P.cs[i].name);
    free(P.cs);
    free(P.frames);
    free(P.pending);
    while (P.attr_owned) {
        attr_node_t *n = P.attr_owned;
        P.attr_owned = n->next_owned;
        params_destroy(&n->ps);
        free(n);
    }
    for (int i = 0; i < P.nopen; i++)
        free(P.open_files[i]);
    free(P.root_real);
    free(P.root_lex);
    if (rc != 0)
        scene_desc_destroy(&P.scene);
    return P.scene;
}

scene_desc_t *pbrt_parse_file(const char *path, err_t *err)
{
    return run(path, NULL, 0, NULL, NULL, NULL, 0, false, err);
}

scene_desc_t *pbrt_parse_file_check(const char *path, warnings_t *errors, err_t *err)
{
    return run(path, NULL, 0, NULL, NULL, errors, 0, true, err);
}

scene_desc_t *pbrt_parse_file_confined(const char *path, const char *root,
                                       const scene_budget_t *budget, err_t *err)
{
    if (!root)
        return err_set(err, "a confined parse needs the scene's folder"), NULL;
    return pbrt_parse_file_opts(path, &(pbrt_parse_opts_t){.root = root, .budget = budget}, err);
}

scene_desc_t *pbrt_parse_file_opts(const char *path, const pbrt_parse_opts_t *opts, err_t *err)
{
    pbrt_parse_opts_t none = {0};
    if (!opts)
        opts = &none;
    return run(path, NULL, 0, opts->root, opts->budget, NULL, opts->threads, opts->bundle, err);
}

scene_desc_t *pbrt_parse_string(const char *text, size_t len, const char *name, err_t *err)
{
    return run(name ? name : "<string>", text ? text : "", text ? len : 0, NULL, NULL, NULL, 0,
               false, err);
}
