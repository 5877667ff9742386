/* pbrt-v4's CoatedDiffuseMaterial: a dielectric interface (index, roughness) over a medium
 * (thickness, albedo, g) over a Lambertian base of "reflectance" (bsdf/layered.h). */
#include "material_coateddiffuse.h"
#include "material_class.h"
#include "material_inputs.h"

#include "material_params.h"

static int load(material_params_t *mp, material_t *m)
{
    material_coateddiffuse_t *cd = mp->data;
    scene_float_input_t u, v;
    return (m->reflectance = material_params_spectrum_texture(
                mp, "reflectance", material_params_constant(0.5, mp->dm->loc), SPEC_REFLECTANCE)) &&
                   !material_inputs_load_ior(mp, "", &m->ior) &&
                   !material_inputs_load_roughness(mp, "", &u, &v, &m->uroughness,
                                                   &m->vroughness) &&
                   !material_inputs_load_remap(mp, m) && !material_inputs_load_layer(mp, &cd->layer)
               ? 0
               : -1;
}

static void bsdf(const material_t *m, const surface_t *sf, const double *lambda, int n, bsdf_t *b)
{
    const material_coateddiffuse_t *cd = material_coateddiffuse_of(m);
    b->kind = BSDF_COATED_DIFFUSE;
    material_inputs_layer_at(cd ? &cd->layer : NULL, sf, lambda, n, b);
    for (int j = 0; j < n; j++)
        b->eta[j] = material_inputs_coat_eta(m, lambda[j]);
    material_inputs_texture_lanes01(m->reflectance, sf, lambda, n, b->reflectance);
}

const material_class_t material_coateddiffuse = {.name = "coateddiffuse",
                                                 .data_size = sizeof(material_coateddiffuse_t),
                                                 .load = load,
                                                 .bsdf = bsdf};
