/* material_diffusetransmission: the numbers of pbrt-v4's DiffuseTransmissionMaterial
 * (scene/material_diffusetransmission.c) that only its class reads, its own record behind
 * material_t.data. */
#ifndef PRISMFARM_MATERIAL_DIFFUSETRANSMISSION_H
#define PRISMFARM_MATERIAL_DIFFUSETRANSMISSION_H

#include "scene.h"

#include <stddef.h>

typedef struct material_diffusetransmission_data {
    /* Lambertian transmission (the reflectance is material_t's, shared), both times scale. */
    const texture_t *transmittance;
    double scale;
} material_diffusetransmission_t;

/* m's record; NULL when m is of another kind (or built in code without one). */
static inline const material_diffusetransmission_t *
material_diffusetransmission_of(const material_t *m)
{
    return m->data_kind == MATERIAL_DIFFUSE_TRANSMISSION
               ? (const material_diffusetransmission_t *)m->data
               : NULL;
}

#endif
