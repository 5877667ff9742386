/* pbrt-v4's ConductorMaterial: Fresnel of a complex index (eta and k, or a reflectance) under
 * a microfacet distribution (a mirror when smooth), with prismfarm's optional thin film. */
#include "material_class.h"
#include "material_inputs.h"

#include "loader.h"

static int load(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    return material_inputs_roughness(L, &dm->uroughness, &m->uroughness, err) ||
                   material_inputs_roughness(L, &dm->vroughness, &m->vroughness, err) ||
                   material_inputs_conductor(L, dm, m, err)
               ? -1
               : 0;
}

static void bsdf(const material_t *m, const surface_t *sf, const double *lambda, int n, bsdf_t *b)
{
    b->kind = BSDF_CONDUCTOR;
    for (int j = 0; j < n; j++)
        material_inputs_conductor_index(m, sf, lambda[j], &b->cond_eta[j], &b->cond_k[j]);
}

const material_class_t material_conductor = {.load = load, .bsdf = bsdf};
