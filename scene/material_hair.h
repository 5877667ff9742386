/* material_hair: the numbers of pbrt-v4's HairMaterial (scene/material_hair.c, bsdf/hair.h),
 * the hair class's own record behind material_t.data. */
#ifndef PRISMFARM_MATERIAL_HAIR_H
#define PRISMFARM_MATERIAL_HAIR_H

#include "scene.h"

#include <stddef.h>

/* The absorption per unit radius from sigma_a (an unbounded spectrum), else from reflectance
 * (Chiang et al.'s inversion), else eumelanin eu_sigma + pheomelanin pheo_sigma (the pigments'
 * own absorption spectra); the index, the roughnesses and the scales' tilt in degrees. */
typedef struct material_hair_data {
    const texture_t *sigma_a, *reflectance, *eumelanin, *pheomelanin, *eu_sigma, *pheo_sigma;
    const texture_t *eta, *beta_m, *beta_n, *alpha;
} material_hair_t;

/* m's hair record; NULL when m is not a hair. */
static inline const material_hair_t *material_hair_of(const material_t *m)
{
    return m->data_kind == MATERIAL_HAIR ? (const material_hair_t *)m->data : NULL;
}

#endif
