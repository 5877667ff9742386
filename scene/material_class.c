#include "material_class.h"

#include <stddef.h>

#define MATERIAL_CLASS_ROW(kind, name) [kind] = &name,
static const material_class_t *const CLASSES[] = {MATERIAL_CLASS_LIST(MATERIAL_CLASS_ROW)};
#undef MATERIAL_CLASS_ROW

const material_class_t *material_class_of(material_kind_t kind)
{
    return (size_t)kind < sizeof CLASSES / sizeof CLASSES[0] ? CLASSES[kind] : NULL;
}

void material_class_bsdf(const material_t *m, const surface_t *sf, const double *lambda, int n,
                         bsdf_t *b)
{
    const material_class_t *c = material_class_of(m->kind);
    if (!c || !c->bsdf)
        c = &material_diffuse;
    c->bsdf(m, sf, lambda, n, b);
}
