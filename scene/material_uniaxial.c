/* prismfarm's uniaxial birefringent crystal (docs/physics.md §15, bsdf/uniaxial.h): it loads as
 * a smooth dielectric (material_kind.h) whose ior is the ordinary index, with the crystal's
 * principal indices and dichroic absorption, its optic axis (turned into world space per shape:
 * load_materials_for_shape) and the millimetres in a scene unit; at a hit it is the dielectric
 * class. */
#include "material_uniaxial.h"
#include "material_class.h"
#include "material_inputs.h"

#include "material_params.h"

#include "pbrt_parser.h"

#include <math.h>

/* The crystal (material_inputs_load_crystal), "vector3 opticaxis" in the shape's object space
 * ([0 0 1]), the absorption "float sigma_o", "sigma_e" in 1/mm (either given: both replace the
 * catalogue's table) and "float mmperunit", the millimetres in a scene unit (1). */
static int load(material_params_t *mp, material_t *m)
{
    material_uniaxial_t *u = mp->data;
    params_t *ps = mp->ps;
    err_t *err = mp->err;
    if (material_inputs_load_crystal(mp, "uniaxial", &u->crystal) != 0)
        return -1;
    param_t *axis;
    if (params_get_array(ps, "opticaxis", PARAM_VECTOR3, &axis, err) != 0)
        return -1;
    double a[3] = {0.0, 0.0, 1.0};
    if (axis) {
        if (axis->count != 3)
            return pbrt_error(err, axis->loc,
                              "expected 3 numbers after \"vector3 opticaxis\", got %zu",
                              axis->count);
        const double *g = axis->numbers;
        if (!(g[0] * g[0] + g[1] * g[1] + g[2] * g[2] > 0.0) || !isfinite(g[0] + g[1] + g[2]))
            return pbrt_error(err, axis->loc,
                              "\"vector3 opticaxis\" must be a finite non-zero vector");
        a[0] = g[0];
        a[1] = g[1];
        a[2] = g[2];
    }
    const bool has_sigma = params_find(ps, "sigma_o") || params_find(ps, "sigma_e");
    double sigma_o, sigma_e;
    bool coherent;
    if (params_get_float(ps, "sigma_o", 0.0, &sigma_o, err) ||
        params_get_float(ps, "sigma_e", 0.0, &sigma_e, err) ||
        params_get_float(ps, "mmperunit", 1.0, &u->mm_per_unit, err) ||
        params_get_bool(ps, "coherent", false, &coherent, err) ||
        material_params_range(mp, "sigma_o", sigma_o, 0.0, 1e6) ||
        material_params_range(mp, "sigma_e", sigma_e, 0.0, 1e6) ||
        material_params_range(mp, "mmperunit", u->mm_per_unit, 1e-12, 1e12))
        return -1;
    m->kind = MATERIAL_DIELECTRIC;
    if (has_sigma) {
        /* Constant coefficients replace the catalogue's table. */
        u->crystal.absorption = (crystal_absorption_t){
            .rows = 1, .lambda_nm = {550.0}, .o_per_mm = {sigma_o}, .e_per_mm = {sigma_e}};
    }
    m->ior = u->crystal.no;
    u->optic_axis = vec3_normalize(vec3_make(a[0], a[1], a[2]));
    /* "bool coherent" (false): the o and e waves cross the crystal as one ray, coherently
     * (docs/physics.md §15.2: a thin plate's interference colours, optical activity). */
    u->coherent = coherent;
    m->needs_polarisation = coherent;
    /* Both indices over the film's range, which load_options has set (the ordinary one, the
     * dielectric's ior, first, as scene_finish checks every ior). */
    const spectral_grid_t g = mp->L->sc->settings.grid;
    if (ior_validate(&u->crystal.no, m->name, g.lambda_min, g.lambda_max, err) ||
        ior_validate(&u->crystal.ne, m->name, g.lambda_min, g.lambda_max, err))
        return -1;
    /* Smooth everywhere (a crystal has no roughness). */
    const scene_float_input_t zero = {-1, 0.0};
    material_inputs_smoothness(m, &zero, &zero);
    return 0;
}

const material_class_t material_uniaxial = {
    .name = "uniaxial", .data_size = sizeof(material_uniaxial_t), .load = load};
