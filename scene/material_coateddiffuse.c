/* pbrt-v4's CoatedDiffuseMaterial: a dielectric interface (index, roughness) over a medium
 * (thickness, albedo, g) over a Lambertian base of "reflectance" (bsdf/layered.h). */
#include "material_class.h"
#include "material_inputs.h"

#include "loader.h"

static int load(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    if (material_inputs_roughness(L, &dm->uroughness, &m->uroughness, err) ||
        material_inputs_roughness(L, &dm->vroughness, &m->vroughness, err))
        return -1;
    return (m->reflectance = loader_spectrum_input(L, &dm->reflectance, SPEC_REFLECTANCE, err)) &&
                   !material_inputs_ior(L->sc, &dm->ior, m->name, &m->ior, err) &&
                   !material_inputs_layer(L, dm, m, err)
               ? 0
               : -1;
}

static void bsdf(const material_t *m, const surface_t *sf, const double *lambda, int n, bsdf_t *b)
{
    b->kind = BSDF_COATED_DIFFUSE;
    material_inputs_layer_at(m, sf, lambda, n, b);
    for (int j = 0; j < n; j++)
        b->eta[j] = material_inputs_coat_eta(m, lambda[j]);
    material_inputs_texture_lanes01(m->reflectance, sf, lambda, n, b->reflectance);
}

const material_class_t material_coateddiffuse = {.load = load, .bsdf = bsdf};
