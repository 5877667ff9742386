/* prismfarm's uniaxial birefringent crystal (docs/physics.md §15, bsdf/uniaxial.h): it loads as
 * a smooth dielectric (material_kind.h) whose ior is the ordinary index, with the crystal's
 * principal indices and dichroic absorption, its optic axis (turned into world space per shape:
 * load_materials_for_shape) and the millimetres in a scene unit; at a hit it is the dielectric
 * class. */
#include "material_class.h"
#include "material_inputs.h"

#include "loader.h"

static int load(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    m->kind = MATERIAL_DIELECTRIC;
    m->uniaxial = 1;
    if (material_inputs_crystal(L, dm, m, err))
        return -1;
    if (dm->has_sigma) {
        /* Constant coefficients replace the catalogue's table. */
        m->crystal.absorption = (crystal_absorption_t){
            .rows = 1, .lambda_nm = {550.0}, .o_per_mm = {dm->sigma_o}, .e_per_mm = {dm->sigma_e}};
    }
    m->ior = m->crystal.no;
    m->optic_axis =
        vec3_normalize(vec3_make(dm->optic_axis[0], dm->optic_axis[1], dm->optic_axis[2]));
    m->mm_per_unit = dm->mm_per_unit;
    m->coherent = dm->coherent;
    return 0;
}

const material_class_t material_uniaxial = {.load = load};
