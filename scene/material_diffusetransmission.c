/* pbrt-v4's DiffuseTransmissionMaterial: Lambertian reflection "reflectance" and transmission
 * "transmittance" (0.25 each), both times "scale". */
#include "material_class.h"
#include "material_inputs.h"

#include "material_params.h"

static int load(material_params_t *mp, material_t *m)
{
    const pbrt_loc_t loc = mp->dm->loc;
    if (!(m->reflectance = material_params_spectrum_texture(
              mp, "reflectance", material_params_constant(0.25, loc), SPEC_REFLECTANCE)) ||
        !(m->transmittance = material_params_spectrum_texture(
              mp, "transmittance", material_params_constant(0.25, loc), SPEC_REFLECTANCE)) ||
        params_get_float(mp->ps, "scale", 1.0, &m->scale, mp->err) != 0)
        return -1;
    return m->scale >= 0.0 ? 0 : material_params_range(mp, "scale", m->scale, 0.0, 1.0);
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

const material_class_t material_diffusetransmission = {
    .name = "diffusetransmission", .load = load, .bsdf = bsdf};
