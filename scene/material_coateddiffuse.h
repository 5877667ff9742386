/* material_coateddiffuse: the numbers of pbrt-v4's CoatedDiffuseMaterial
 * (scene/material_coateddiffuse.c) that only its class reads, its own record behind
 * material_t.data. */
#ifndef PRISMFARM_MATERIAL_COATEDDIFFUSE_H
#define PRISMFARM_MATERIAL_COATEDDIFFUSE_H

#include "material_inputs.h"
#include "scene.h"

#include <stddef.h>

typedef struct material_coateddiffuse_data {
    material_layer_t layer; /* the medium between the coat and the diffuse base */
} material_coateddiffuse_t;

/* m's record; NULL when m is of another kind (or built in code without one). */
static inline const material_coateddiffuse_t *material_coateddiffuse_of(const material_t *m)
{
    return m->data_kind == MATERIAL_COATED_DIFFUSE ? (const material_coateddiffuse_t *)m->data
                                                   : NULL;
}

#endif
