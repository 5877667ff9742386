/* prismfarm's polariser and retarder sheets (docs/physics.md §14): thin sheets crossed
 * straight, whose Mueller matrices render/sheet.c applies; no BSDF. The angle and the
 * retardance arrive in degrees and are kept in radians; a retarder's retardation in nm, its
 * crystal plate's thickness from micrometres in nm. */
#include "material_class.h"
#include "material_inputs.h"

#include "loader.h"

static int load_sheet(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    m->sheet_angle = dm->sheet_angle * (PF_PI / 180.0);
    m->retardance = dm->retardance * (PF_PI / 180.0);
    m->retarder_mode = dm->kind == MATERIAL_RETARDER ? dm->retarder_mode : 0;
    m->retardation_nm = dm->retardation;
    m->plate_thickness_nm = dm->plate_thickness * 1000.0;
    m->plate_axial = dm->plate_axial;
    return m->retarder_mode == RETARDER_PLATE ? material_inputs_crystal(L, dm, m, err) : 0;
}

const material_class_t material_polarizer = {.load = load_sheet};
const material_class_t material_retarder = {.load = load_sheet};
