/* material_coatedconductor: the numbers of pbrt-v4's CoatedConductorMaterial
 * (scene/material_coatedconductor.c) that only its class reads, its own record behind
 * material_t.data. */
#ifndef PRISMFARM_MATERIAL_COATEDCONDUCTOR_H
#define PRISMFARM_MATERIAL_COATEDCONDUCTOR_H

#include "material_inputs.h"
#include "scene.h"

#include <stddef.h>

typedef struct material_coatedconductor_data {
    material_layer_t layer; /* the medium between the coat and the conductor */
    /* The conductor's own roughness (NULL: 0), remapped as the coat's when remaproughness. */
    const texture_t *base_uroughness, *base_vroughness;
} material_coatedconductor_t;

/* m's record; NULL when m is of another kind (or built in code without one). */
static inline const material_coatedconductor_t *material_coatedconductor_of(const material_t *m)
{
    return m->data_kind == MATERIAL_COATED_CONDUCTOR ? (const material_coatedconductor_t *)m->data
                                                     : NULL;
}

#endif
