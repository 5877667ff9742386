/* pbrt-v4's DiffuseTransmissionMaterial: Lambertian reflection "reflectance" and transmission
 * "transmittance" (0.25 each), both times "scale". */
#include "material_diffusetransmission.h"
#include "material_class.h"
#include "material_inputs.h"

#include "material_params.h"

static int load(material_params_t *mp, material_t *m)
{
    material_diffusetransmission_t *dt = mp->data;
    const pbrt_loc_t loc = mp->dm->loc;
    if (!(m->reflectance = material_params_spectrum_texture(
              mp, "reflectance", material_params_constant(0.25, loc), SPEC_REFLECTANCE)) ||
        !(dt->transmittance = material_params_spectrum_texture(
              mp, "transmittance", material_params_constant(0.25, loc), SPEC_REFLECTANCE)) ||
        params_get_float(mp->ps, "scale", 1.0, &dt->scale, mp->err) != 0)
        return -1;
    return dt->scale >= 0.0 ? 0 : material_params_range(mp, "scale", dt->scale, 0.0, 1.0);
}

static void bsdf(const material_t *m, const surface_t *sf, const double *lambda, int n, bsdf_t *b)
{
    static const material_diffusetransmission_t NONE = {0}; /* built in code: black */
    const material_diffusetransmission_t *dt =
        material_diffusetransmission_of(m) ? material_diffusetransmission_of(m) : &NONE;
    b->kind = BSDF_DIFFUSE_TRANSMISSION;
    for (int j = 0; j < n; j++) {
        b->reflectance[j] = material_inputs_clamp01(
            dt->scale * material_inputs_texture(m->reflectance, sf, lambda[j]));
        b->transmittance[j] = material_inputs_clamp01(
            dt->scale * material_inputs_texture(dt->transmittance, sf, lambda[j]));
    }
}

const material_class_t material_diffusetransmission = {.name = "diffusetransmission",
                                                       .data_size =
                                                           sizeof(material_diffusetransmission_t),
                                                       .load = load,
                                                       .bsdf = bsdf};
