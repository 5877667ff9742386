#include "pbrt_materials.h"

#include "pbrt_inputs.h"
#include "pbrt_upgrade.h"

#include <stdio.h>
#include <string.h>

/* The string parameters that name a file, by name, for every material (pbrt-v4 writes a file as
 * "string <name>"): what messages call it and how the bundle lists it. */
static const struct {
    const char *name;
    const char *what;
    scene_file_kind_t kind;
} FILE_PARAMS[] = {
    {"normalmap", "image", SCENE_FILE_IMAGE},       /* every material's normal map */
    {"filename", "measured BSDF", SCENE_FILE_BSDF}, /* "measured": an RGL .bsdf file */
};

/* The one parse-time rule for a material's parameters: a "spectrum" given by a string is read
 * now (a spectrum file is confined, read and listed; any other string is kept as a name), and a
 * file parameter's file is confined, charged and listed; both into m->resolved for the class. No
 * parameter is marked used: the class reads each one when the scene loads. */
static int resolve_files(parser_t *P, params_t *ps, scene_material_t *m)
{
    const size_t n = params_count(ps);
    for (size_t i = 0; i < n; i++) {
        const param_t *p = params_at(ps, i);
        scene_material_resolved_t r = {.param = p->name};
        if (p->type == PARAM_SPECTRUM && p->values == PARAM_VALUES_STRINGS) {
            if (pbrt_inputs_spectrum_param(P, ps, p, SPECTRUM_ANY, &r.spectrum) != 0)
                return -1;
        } else if (p->type == PARAM_STRING && p->count == 1 && *p->strings[0]) {
            size_t f = 0;
            while (f < COUNT_OF(FILE_PARAMS) && strcmp(FILE_PARAMS[f].name, p->name))
                f++;
            if (f == COUNT_OF(FILE_PARAMS))
                continue;
            if (pbrt_inputs_data_file(P, p, p->strings[0], FILE_PARAMS[f].what, FILE_PARAMS[f].kind,
                                      &r.path) != 0)
                return -1;
        } else {
            continue;
        }
        if (m->nresolved % 8 == 0) {
            scene_material_resolved_t *grown =
                scene_desc_alloc(P->scene, (m->nresolved + 8) * sizeof *grown, P->err);
            if (!grown)
                return -1;
            if (m->nresolved)
                memcpy(grown, m->resolved, m->nresolved * sizeof *grown);
            m->resolved = grown;
        }
        m->resolved[m->nresolved++] = r;
    }
    return 0;
}

int pbrt_materials_read(parser_t *P, params_t *ps, const str_arg_t *type, const char *name,
                        pbrt_loc_t loc, pbrt_loc_t type_loc)
{
    const char *v4 = pbrt_upgrade_v3_material(type->s);
    if (v4)
        return pbrt_error(P->err, type_loc, "pbrt-v3's material \"%s\" (pbrt-v4's \"%s\"): %s",
                          type->s, v4, PBRT_UPGRADE_HINT);
    int idx = scene_desc_add_material(P->scene, P->err);
    if (idx < 0)
        return -1;
    scene_material_t *m = &P->scene->materials[idx];
    m->type_loc = type_loc;
    m->loc = loc;
    if (!(m->type = scene_desc_strdup(P->scene, type->s, P->err)))
        return -1;
    m->ntextures = P->scene->ntextures;
    if (name && !(m->name = scene_desc_strdup(P->scene, name, P->err)))
        return -1;
    if (resolve_files(P, ps, m) != 0)
        return -1;
    m->params = ps;
    if (!name)
        P->gs.material = idx;
    return 0;
}

/* MakeNamedMaterial "name" "string type" ...: a material defined once, by name. */
int pbrt_materials_read_named(parser_t *P, params_t *ps, const str_arg_t *name, pbrt_loc_t loc)
{
    int prev = scene_desc_find_material(P->scene, name->s);
    if (prev >= 0)
        return pbrt_error(P->err, name->loc, "named material \"%s\" is already defined (line %d)",
                          name->s, P->scene->materials[prev].loc.line);
    const char *mtype;
    if (params_get_string(ps, "type", NULL, &mtype, P->err) != 0)
        return -1;
    if (!mtype)
        return pbrt_error(P->err, loc, "MakeNamedMaterial \"%s\" needs \"string type\"", name->s);
    str_arg_t mt;
    snprintf(mt.s, sizeof mt.s, "%s", mtype);
    mt.loc = params_find(ps, "type")->loc;
    return pbrt_materials_read(P, ps, &mt, name->s, loc, mt.loc);
}
