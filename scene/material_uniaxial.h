/* material_uniaxial: the numbers of prismfarm's uniaxial birefringent crystal
 * (scene/material_uniaxial.c, bsdf/uniaxial.h, docs/physics.md §15), the uniaxial class's own
 * record behind material_t.data. The material loads as a smooth MATERIAL_DIELECTRIC whose ior
 * is the ordinary index (what reads a dielectric's index sees n_o); render/crystal_scatter.c
 * and render/crystal_coherent.c read the rest here. */
#ifndef PRISMFARM_MATERIAL_UNIAXIAL_H
#define PRISMFARM_MATERIAL_UNIAXIAL_H

#include "crystal.h"
#include "scene.h"
#include "vec3.h"

#include <stddef.h>

typedef struct material_uniaxial_data {
    /* The principal indices and dichroic absorption. */
    crystal_t crystal;
    /* Unit; in object space as the material gives it, in world space once the loader has
     * turned it with the shape (load_materials_for_shape). */
    vec3_t optic_axis;
    double mm_per_unit; /* the millimetres in a scene unit that the absorption (1/mm) scales by */
    /* "bool coherent": a thin crystal whose o and e waves cross it as one ray, their phases
     * (and quartz's optical activity) carried (render/crystal_coherent.h; with polarisation). */
    int coherent;
} material_uniaxial_t;

/* m's crystal record; NULL when m is not a uniaxial crystal (a plain dielectric, ...). */
static inline const material_uniaxial_t *material_uniaxial_of(const material_t *m)
{
    return m->data_kind == MATERIAL_UNIAXIAL ? (const material_uniaxial_t *)m->data : NULL;
}

#endif
