/* material_sheet: the numbers of prismfarm's polariser and retarder sheets
 * (scene/material_sheet.c, docs/physics.md §14), the two sheet classes' own record behind
 * material_t.data, which render/sheet.c's Mueller matrices read. */
#ifndef PRISMFARM_MATERIAL_SHEET_H
#define PRISMFARM_MATERIAL_SHEET_H

#include "crystal.h"
#include "scene.h"

#include <stddef.h>

/* How a retarder sheet's retardance depends on wavelength (material_sheet_t.retarder_mode). */
typedef enum retarder_mode {
    RETARDER_CONSTANT,    /* the same retardance (radians) at every wavelength */
    RETARDER_RETARDATION, /* a dispersion-free optical path difference in nm */
    RETARDER_PLATE,       /* a crystal plate of given thickness: dispersion, oblique incidence */
} retarder_mode_t;

typedef struct material_sheet_data {
    /* The transmission axis or fast axis, in radians from the surface's dp/du toward
     * ng x dp/du (ng the geometric normal, the side the shape's orientation calls outside). */
    double angle;
    /* A retarder's retardance per wavelength (docs/physics.md §14.1): the constant retardance
     * in radians (pi/2: a quarter-wave plate), a dispersion-free optical path difference
     * retardation_nm (delta = 2 pi Gamma / lambda), or a crystal plate (crystal's indices,
     * optic axis along angle) of plate_thickness_nm (polar/waveplate.h). */
    retarder_mode_t retarder_mode;
    double retardance;
    double retardation_nm, plate_thickness_nm;
    crystal_t crystal;
    /* A crystal plate cut across its optic axis ("bool axial"; waveplate_axial_mueller): light
     * along the axis, turned by the crystal's optical activity (quartz) and retarded by the
     * linear birefringence of oblique incidence. 0: the axis in the plate, along angle. */
    int plate_axial;
} material_sheet_t;

/* m's sheet record; NULL when m is neither a polariser nor a retarder. */
static inline const material_sheet_t *material_sheet_of(const material_t *m)
{
    return m->data_kind == MATERIAL_POLARISER || m->data_kind == MATERIAL_RETARDER
               ? (const material_sheet_t *)m->data
               : NULL;
}

#endif
