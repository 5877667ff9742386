#include "material_class.h"

#include "pbrt_names.h"

#include <stddef.h>

#define MATERIAL_CLASS_ROW(kind, name) [kind] = &name,
static const material_class_t *const CLASSES[] = {MATERIAL_CLASS_LIST(MATERIAL_CLASS_ROW)};
#undef MATERIAL_CLASS_ROW

const material_class_t *material_class_of(material_kind_t kind)
{
    return (size_t)kind < MATERIAL_KIND_COUNT ? CLASSES[kind] : NULL;
}

const char *material_kind_name(material_kind_t kind)
{
    const material_class_t *c = material_class_of(kind);
    return c ? c->name : "?";
}

size_t material_kind_data_size(material_kind_t kind)
{
    const material_class_t *c = material_class_of(kind);
    return c ? c->data_size : 0;
}

/* The name table is written from the classes at each lookup (once per material a scene
 * makes): the listed names in the registry's order, then the aliases (pbrt_names.h). */
int material_class_lookup(const char *type, pbrt_loc_t loc, material_kind_t *kind, err_t *err)
{
    enum { MAX_ALIASES = 4 * MATERIAL_KIND_COUNT };
    pbrt_name_t table[MATERIAL_KIND_COUNT + 1 + MAX_ALIASES];
    size_t n = 0;
    for (int k = 0; k < MATERIAL_KIND_COUNT; k++)
        table[n++] = (pbrt_name_t){CLASSES[k]->name, k};
    table[n++] = (pbrt_name_t){NULL, 0};
    for (int k = 0; k < MATERIAL_KIND_COUNT; k++)
        for (const char *const *a = CLASSES[k]->aliases;
             a && *a && n < sizeof table / sizeof *table; a++)
            table[n++] = (pbrt_name_t){*a, k};
    int v;
    if (pbrt_names_lookup(table, n, "unsupported material", type, loc, &v, err) != 0)
        return -1;
    *kind = (material_kind_t)v;
    return 0;
}

void material_class_bsdf(const material_t *m, const surface_t *sf, const double *lambda, int n,
                         bsdf_t *b)
{
    const material_class_t *c = material_class_of(m->kind);
    if (!c || !c->bsdf)
        c = &material_diffuse;
    c->bsdf(m, sf, lambda, n, b);
}
