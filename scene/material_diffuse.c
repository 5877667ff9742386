/* pbrt-v4's DiffuseMaterial: Lambertian reflection of "reflectance" (0.5). */
#include "material_class.h"
#include "material_inputs.h"

#include "loader.h"

static int load(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    return (m->reflectance = loader_spectrum_input(L, &dm->reflectance, SPEC_REFLECTANCE, err))
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

const material_class_t material_diffuse = {.load = load, .bsdf = bsdf};
