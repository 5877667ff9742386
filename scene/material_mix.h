/* material_mix: the numbers of pbrt-v4's MixMaterial (scene/material_mix.c), the mix class's
 * own record behind material_t.data, which render/shading.c's shading_resolve reads. */
#ifndef PRISMFARM_MATERIAL_MIX_H
#define PRISMFARM_MATERIAL_MIX_H

#include "scene.h"

#include <stddef.h>

/* Two material indices (made before the mix) and the probability of the second (NULL: 0.5). */
typedef struct material_mix_data {
    int materials[2];
    const texture_t *amount;
} material_mix_t;

/* m's mix record; NULL when m is not a mix (or a mix built in code without one). */
static inline const material_mix_t *material_mix_of(const material_t *m)
{
    return m->data_kind == MATERIAL_MIX ? (const material_mix_t *)m->data : NULL;
}

#endif
