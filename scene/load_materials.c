#include "load_materials.h"

#include "load_textures.h"
#include "material_class.h"
#include "microfacet.h"

#include <stdio.h>
#include <string.h>

int load_materials_for_shape(loader_t *L, int idx, const transform_t *to_world, err_t *err)
{
    if (idx < 0 || (size_t)idx >= L->sc->nmaterials || !L->sc->materials[idx].uniaxial)
        return idx;
    material_t m = L->sc->materials[idx];
    const vec3_t a = vec3_normalize(transform_vector(to_world, m.optic_axis));
    if (a.x == m.optic_axis.x && a.y == m.optic_axis.y && a.z == m.optic_axis.z)
        return idx;
    m.optic_axis = a;
    return scene_add_material(L->sc, &m, err);
}

int load_materials(loader_t *L, err_t *err)
{
    const scene_desc_t *d = L->desc;
    for (size_t i = 0; i < d->nmaterials; i++) {
        const scene_material_t *dm = &d->materials[i];
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
        m.remaproughness = dm->remaproughness;
        m.mix[0] = m.mix[1] = -1;
        /* The class loads its own inputs; uniaxial and subsurface set their kind to
         * dielectric (material_kind.h). */
        m.kind = dm->kind;
        const material_class_t *c = material_class_of(dm->kind);
        if (c && c->load && c->load(L, dm, &m, err))
            return -1;
        /* A thin film on smooth glass or metal (the parser refuses one on a rough surface). */
        if (dm->film_thickness > 0.0 &&
            (dm->kind == MATERIAL_DIELECTRIC || dm->kind == MATERIAL_CONDUCTOR)) {
            m.film_thickness = dm->film_thickness;
            m.film_ior = ior_constant(dm->film_eta);
        }
        /* Smooth everywhere: constant roughness that pbrt-v4 calls effectively smooth. A
         * roughness texture may still be smooth at a hit; render decides there. */
        if ((m.kind == MATERIAL_CONDUCTOR || m.kind == MATERIAL_DIELECTRIC) &&
            dm->uroughness.texture < 0 && dm->vroughness.texture < 0) {
            microfacet_t mf =
                microfacet_make(dm->uroughness.value, dm->vroughness.value, dm->remaproughness);
            m.smooth = microfacet_smooth(&mf);
            m.rough = !m.smooth;
        }
        if (dm->normalmap && !(m.normalmap = load_textures_normal_map(L, dm, err)))
            return -1;
        if (!m.normalmap && dm->displacement.texture >= 0)
            m.displacement = L->tex[dm->displacement.texture];
        if (scene_add_material(L->sc, &m, err) < 0)
            return -1;
    }
    return 0;
}
