/* material_measured: the numbers of pbrt-v4's MeasuredMaterial (scene/material_measured.c)
 * that only its class reads, its own record behind material_t.data. */
#ifndef PRISMFARM_MATERIAL_MEASURED_H
#define PRISMFARM_MATERIAL_MEASURED_H

#include "measured.h"
#include "scene.h"

#include <stddef.h>

typedef struct material_measured_data {
    const measured_t *bsdf; /* the file's data (owned by the scene, scene_own_measured) */
} material_measured_t;

/* m's record; NULL when m is of another kind (or built in code without one). */
static inline const material_measured_t *material_measured_of(const material_t *m)
{
    return m->data_kind == MATERIAL_MEASURED ? (const material_measured_t *)m->data : NULL;
}

#endif
