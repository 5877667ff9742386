/* pbrt-v4's DielectricMaterial: glass of an index-of-refraction model (dispersive or not),
 * smooth or rough, with prismfarm's optional thin film. A uniaxial crystal and a subsurface
 * material load as one (material_kind.h) and are this class at a hit. */
#include "material_class.h"
#include "material_inputs.h"

#include "loader.h"

static int load(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    return material_inputs_roughness(L, &dm->uroughness, &m->uroughness, err) ||
                   material_inputs_roughness(L, &dm->vroughness, &m->vroughness, err) ||
                   material_inputs_ior(L->sc, &dm->ior, m->name, &m->ior, err)
               ? -1
               : 0;
}

static void bsdf(const material_t *m, const surface_t *sf, const double *lambda, int n, bsdf_t *b)
{
    (void)sf;
    b->kind = BSDF_DIELECTRIC;
    for (int j = 0; j < n; j++)
        b->eta[j] = ior_eval(&m->ior, lambda[j]);
}

const material_class_t material_dielectric = {.load = load, .bsdf = bsdf};
