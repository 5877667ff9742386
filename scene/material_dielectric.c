/* pbrt-v4's DielectricMaterial: glass of an index-of-refraction model (dispersive or not),
 * smooth or rough, with prismfarm's optional thin film. A uniaxial crystal and a subsurface
 * material load as one (material_kind.h) and are this class at a hit. */
#include "material_class.h"
#include "material_inputs.h"

#include "material_params.h"

static int load(material_params_t *mp, material_t *m)
{
    scene_float_input_t u, v;
    if (material_inputs_load_ior(mp, "", &m->ior) ||
        material_inputs_load_roughness(mp, "", &u, &v, &m->uroughness, &m->vroughness) ||
        material_inputs_load_remap(mp, m) || material_inputs_load_film(mp, m))
        return -1;
    material_inputs_smoothness(m, &u, &v);
    return 0;
}

static void bsdf(const material_t *m, const surface_t *sf, const double *lambda, int n, bsdf_t *b)
{
    (void)sf;
    b->kind = BSDF_DIELECTRIC;
    for (int j = 0; j < n; j++)
        b->eta[j] = ior_eval(&m->ior, lambda[j]);
}

const material_class_t material_dielectric = {.name = "dielectric", .load = load, .bsdf = bsdf};
