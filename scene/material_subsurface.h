/* material_subsurface: the numbers of pbrt-v4's SubsurfaceMaterial
 * (scene/material_subsurface.c), the subsurface class's own record behind material_t.data.
 * The material loads as a MATERIAL_DIELECTRIC (its ior and roughness are the boundary's) with a
 * BSSRDF beneath, which the path integrator follows (render/subsurface.h); the other
 * integrators see the dielectric (the plan warns). */
#ifndef PRISMFARM_MATERIAL_SUBSURFACE_H
#define PRISMFARM_MATERIAL_SUBSURFACE_H

#include "bssrdf.h"
#include "scene.h"

#include <stddef.h>

/* The profile table for its (g, eta) (owned by the scene), the medium's coefficients per unit
 * length (sigma_a and sigma_s, else reflectance and mfp, which SubsurfaceFromDiffuse turns
 * into them), all times scale. */
typedef struct material_subsurface_data {
    const bssrdf_table_t *table;
    const texture_t *sigma_a, *sigma_s, *reflectance, *mfp;
    double scale;
} material_subsurface_t;

/* m's subsurface record; NULL when m is not a subsurface material. */
static inline const material_subsurface_t *material_subsurface_of(const material_t *m)
{
    return m->data_kind == MATERIAL_SUBSURFACE ? (const material_subsurface_t *)m->data : NULL;
}

/* The BSSRDF's table of m; NULL when m has no BSSRDF beneath. */
static inline const bssrdf_table_t *material_subsurface_table(const material_t *m)
{
    const material_subsurface_t *s = material_subsurface_of(m);
    return s ? s->table : NULL;
}

#endif
