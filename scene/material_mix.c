/* pbrt-v4's MixMaterial: one of two named materials, the second with probability "amount",
 * chosen per hit (render/shading.h shading_resolve) before any BSDF is made. */
#include "material_mix.h"
#include "material_class.h"
#include "material_params.h"

#include "pbrt_parser.h"

/* "string materials": two materials made by MakeNamedMaterial before the mix; "amount" (0.5). */
static int load(material_params_t *mp, material_t *m)
{
    (void)m;
    material_mix_t *mix = mp->data;
    const param_t *p = params_find(mp->ps, "materials");
    if (!p)
        return pbrt_error(mp->err, mp->dm->loc,
                          "mix: \"string materials\" (two named materials) is missing");
    if (p->type != PARAM_STRING)
        return params_wrong_type(mp->ps, p, "\"string materials\"", mp->err);
    if (p->count != 2)
        return pbrt_error(mp->err, p->loc,
                          "expected 2 material names after \"string materials\", got %zu",
                          p->count);
    const scene_desc_t *d = mp->L->desc;
    const int self = (int)(mp->dm - d->materials);
    for (int i = 0; i < 2; i++) {
        mix->materials[i] = scene_desc_find_material(d, p->strings[i]);
        if (mix->materials[i] < 0 || mix->materials[i] >= self)
            return pbrt_error(mp->err, p->loc,
                              "mix: named material \"%s\" is not defined (a MakeNamedMaterial must "
                              "come before the mix that uses it)",
                              p->strings[i]);
    }
    return (mix->amount = material_params_float_texture(mp, "amount", 0.5)) ? 0 : -1;
}

const material_class_t material_mix = {
    .name = "mix", .data_size = sizeof(material_mix_t), .load = load};
