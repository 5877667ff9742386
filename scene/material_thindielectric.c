/* pbrt-v4's ThinDielectricMaterial: a thin slab of an index, reflecting and transmitting
 * straight through. */
#include "material_class.h"
#include "material_inputs.h"

#include "material_params.h"

static int load(material_params_t *mp, material_t *m)
{
    return material_inputs_load_ior(mp, "", &m->ior);
}

static void bsdf(const material_t *m, const surface_t *sf, const double *lambda, int n, bsdf_t *b)
{
    (void)sf;
    b->kind = BSDF_THIN_DIELECTRIC;
    for (int j = 0; j < n; j++)
        b->eta[j] = ior_eval(&m->ior, lambda[j]);
}

const material_class_t material_thindielectric = {
    .name = "thindielectric", .load = load, .bsdf = bsdf};
