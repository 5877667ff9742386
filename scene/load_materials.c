#include "load_materials.h"

#include "load_textures.h"
#include "material_class.h"
#include "material_params.h"
#include "material_uniaxial.h"

#include "pbrt_parser.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int load_materials_for_shape(loader_t *L, int idx, const transform_t *to_world, err_t *err)
{
    if (idx < 0 || (size_t)idx >= L->sc->nmaterials)
        return idx;
    const material_uniaxial_t *u = material_uniaxial_of(&L->sc->materials[idx]);
    if (!u)
        return idx;
    const vec3_t a = vec3_normalize(transform_vector(to_world, u->optic_axis));
    if (a.x == u->optic_axis.x && a.y == u->optic_axis.y && a.z == u->optic_axis.z)
        return idx;
    /* The turned shape's own copy, record and all (scene_add_material copies the record). */
    material_t m = L->sc->materials[idx];
    material_uniaxial_t turned = *u;
    turned.optic_axis = a;
    m.data = &turned;
    return scene_add_material(L->sc, &m, err);
}

/* pbrt-v4's "displacement" and "normalmap" of every material but mix and interface (its
 * BumpMap and NormalMap; the normal map wins when both are given, as in pbrt-v4). */
static int surface_maps(material_params_t *mp, material_kind_t kind, material_t *m)
{
    if (kind == MATERIAL_MIX || kind == MATERIAL_INTERFACE)
        return 0;
    scene_float_input_t displacement;
    const char *normalmap;
    if (material_params_float(mp, "displacement", 0.0, &displacement) != 0 ||
        params_get_string(mp->ps, "normalmap", NULL, &normalmap, mp->err) != 0)
        return -1;
    const param_t *np = params_find(mp->ps, "normalmap");
    const char *path = material_params_file(mp, np);
    if (normalmap && !path)
        return pbrt_error(mp->err, np->loc, "\"string normalmap\" names no file");
    if (path && !(m->normalmap = load_textures_normal_map(mp->L, path, np->loc, mp->err)))
        return -1;
    if (!m->normalmap && displacement.texture >= 0)
        m->displacement = mp->L->tex[displacement.texture];
    return 0;
}

/* One material: its class reads its parameters and loads it, then what every material shares;
 * a parameter nothing read is refused, as the parser refuses any other directive's. */
static int load_one(loader_t *L, const scene_material_t *dm, err_t *err)
{
    material_kind_t kind;
    if (material_class_lookup(dm->type, dm->type_loc, &kind, err) != 0)
        return -1;
    material_t m = {0};
    if (dm->name) {
        snprintf(m.name, sizeof m.name, "%s", dm->name);
        m.named = 1;
    } else if (dm->loc.file && dm->loc.line > 0) {
        const char *base = strrchr(dm->loc.file, '/');
        snprintf(m.name, sizeof m.name, "%s:%d", base ? base + 1 : dm->loc.file, dm->loc.line);
    } else {
        snprintf(m.name, sizeof m.name, "(unnamed)");
    }
    m.remaproughness = 1;
    /* The class loads its own inputs; uniaxial and subsurface set their kind to dielectric
     * (material_kind.h). */
    m.kind = kind;
    params_t *none = NULL;
    if (!dm->params) {
        char context[64];
        snprintf(context, sizeof context, "Material \"%s\"", material_kind_name(kind));
        if (!(none = params_new(context, err)))
            return -1;
    }
    const material_class_t *c = material_class_of(kind);
    void *data = c->data_size ? calloc(1, c->data_size) : NULL;
    if (c->data_size && !data) {
        params_destroy(&none);
        return err_set(err, "out of memory");
    }
    material_params_t mp = {.L = L,
                            .dm = dm,
                            .ps = dm->params ? dm->params : none,
                            .name = m.name,
                            .err = err,
                            .data = data};
    m.data_kind = kind;
    m.data = data;
    int rc = (c->load && c->load(&mp, &m)) || surface_maps(&mp, kind, &m) ||
                     params_check_unused(mp.ps, err) || scene_add_material(L->sc, &m, err) < 0
                 ? -1
                 : 0;
    material_params_finish(&mp);
    params_destroy(&none);
    free(data);
    return rc;
}

int load_materials(loader_t *L, err_t *err)
{
    for (size_t i = 0; i < L->desc->nmaterials; i++)
        if (load_one(L, &L->desc->materials[i], err) != 0)
            return -1;
    return 0;
}

int load_materials_check(loader_t *L, warnings_t *refusals, err_t *err)
{
    for (size_t i = 0; i < L->desc->nmaterials; i++) {
        err_t why = {{0}};
        if (load_one(L, &L->desc->materials[i], &why) != 0 &&
            warnings_add_text(refusals, why.msg) != 0)
            return err_set(err, "out of memory");
    }
    return 0;
}
