/* pbrt-v4's ConductorMaterial: Fresnel of a complex index (eta and k, or a reflectance) under
 * a microfacet distribution (a mirror when smooth), with prismfarm's optional thin film. */
#include "material_class.h"
#include "material_inputs.h"

#include "material_params.h"

static int load(material_params_t *mp, material_t *m)
{
    scene_float_input_t u, v;
    if (material_inputs_load_conductor(mp, "", m) ||
        material_inputs_load_roughness(mp, "", &u, &v, &m->uroughness, &m->vroughness) ||
        material_inputs_load_remap(mp, m) || material_inputs_load_film(mp, m))
        return -1;
    material_inputs_smoothness(m, &u, &v);
    return 0;
}

static void bsdf(const material_t *m, const surface_t *sf, const double *lambda, int n, bsdf_t *b)
{
    b->kind = BSDF_CONDUCTOR;
    for (int j = 0; j < n; j++)
        material_inputs_conductor_index(m, sf, lambda[j], &b->cond_eta[j], &b->cond_k[j]);
}

const material_class_t material_conductor = {.name = "conductor", .load = load, .bsdf = bsdf};
