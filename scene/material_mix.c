/* pbrt-v4's MixMaterial: one of two named materials, the second with probability "amount",
 * chosen per hit (render/shading.h shading_resolve) before any BSDF is made. */
#include "material_class.h"

#include "loader.h"

static int load(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    m->mix[0] = dm->mix[0];
    m->mix[1] = dm->mix[1];
    return (m->amount = loader_float_input(L, &dm->amount, err)) ? 0 : -1;
}

const material_class_t material_mix = {.load = load};
