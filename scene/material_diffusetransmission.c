/* pbrt-v4's DiffuseTransmissionMaterial: Lambertian reflection "reflectance" and transmission
 * "transmittance" (0.25 each), both times "scale". */
#include "material_class.h"
#include "material_inputs.h"

#include "loader.h"

static int load(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    m->scale = dm->scale;
    return (m->reflectance = loader_spectrum_input(L, &dm->reflectance, SPEC_REFLECTANCE, err)) &&
                   (m->transmittance =
                        loader_spectrum_input(L, &dm->transmittance, SPEC_REFLECTANCE, err))
               ? 0
               : -1;
}

static void bsdf(const material_t *m, const surface_t *sf, const double *lambda, int n, bsdf_t *b)
{
    b->kind = BSDF_DIFFUSE_TRANSMISSION;
    for (int j = 0; j < n; j++) {
        b->reflectance[j] = material_inputs_clamp01(
            m->scale * material_inputs_texture(m->reflectance, sf, lambda[j]));
        b->transmittance[j] = material_inputs_clamp01(
            m->scale * material_inputs_texture(m->transmittance, sf, lambda[j]));
    }
}

const material_class_t material_diffusetransmission = {.load = load, .bsdf = bsdf};
