/* pbrt-v4's DiffuseMaterial: Lambertian reflection of "reflectance" (0.5). */
#include "material_class.h"
#include "material_inputs.h"

#include "material_params.h"

static int load(material_params_t *mp, material_t *m)
{
    return (m->reflectance = material_params_spectrum_texture(
                mp, "reflectance", material_params_constant(0.5, mp->dm->loc), SPEC_REFLECTANCE))
               ? 0
               : -1;
}

/* Also the BSDF of a kind without one (material_class.h); a material without a reflectance
 * (built in code) reflects 0.5, pbrt-v4's default. */
static void bsdf(const material_t *m, const surface_t *sf, const double *lambda, int n, bsdf_t *b)
{
    b->kind = BSDF_DIFFUSE;
    if (m->reflectance)
        material_inputs_texture_lanes01(m->reflectance, sf, lambda, n, b->reflectance);
    else
        for (int j = 0; j < n; j++)
            b->reflectance[j] = 0.5;
}

const material_class_t material_diffuse = {.name = "diffuse", .load = load, .bsdf = bsdf};
