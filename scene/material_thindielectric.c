/* pbrt-v4's ThinDielectricMaterial: a thin slab of an index, reflecting and transmitting
 * straight through. */
#include "material_class.h"
#include "material_inputs.h"

#include "loader.h"

static int load(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    return material_inputs_ior(L->sc, &dm->ior, m->name, &m->ior, err);
}

static void bsdf(const material_t *m, const surface_t *sf, const double *lambda, int n, bsdf_t *b)
{
    (void)sf;
    b->kind = BSDF_THIN_DIELECTRIC;
    for (int j = 0; j < n; j++)
        b->eta[j] = ior_eval(&m->ior, lambda[j]);
}

const material_class_t material_thindielectric = {.load = load, .bsdf = bsdf};
