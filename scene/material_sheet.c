/* prismfarm's polariser and retarder sheets (docs/physics.md §14): thin sheets crossed
 * straight, whose Mueller matrices render/sheet.c applies; no BSDF. The angle and the
 * retardance arrive in degrees and are kept in radians; a retarder's retardation in nm, its
 * crystal plate's thickness from micrometres in nm. */
#include "material_class.h"
#include "material_inputs.h"

#include "material_params.h"
#include "material_sheet.h"

#include "pbrt_parser.h"

/* The axis "angle" in degrees from the surface's u direction (0). */
static int load_polarizer(material_params_t *mp, material_t *m)
{
    (void)m;
    material_sheet_t *sheet = mp->data;
    double angle;
    if (params_get_float(mp->ps, "angle", 0.0, &angle, mp->err) != 0 ||
        material_params_range(mp, "angle", angle, -360.0, 360.0) != 0)
        return -1;
    sheet->angle = angle * (PF_PI / 180.0);
    return 0;
}

/* The fast axis's "angle", and the retardation one of three ways (docs/physics.md §14.1):
 * "float retardance" in degrees, the same at every wavelength (90 by default); "float
 * retardation" Gamma in nm, the optical path difference of a dispersion-free plate (delta = 2
 * pi Gamma / lambda, as the Michel-Levy chart assumes); or a crystal plate, "string crystal" or
 * "o."/"e." indices with "float thickness" in micrometres, whose retardance follows the
 * indices' dispersion and the angle of incidence (polar/waveplate.h). */
static int load_retarder(material_params_t *mp, material_t *m)
{
    params_t *ps = mp->ps;
    err_t *err = mp->err;
    material_sheet_t *sheet = mp->data;
    if (load_polarizer(mp, m) != 0)
        return -1;
    const bool deg = params_find(ps, "retardance") != NULL;
    const bool nm = params_find(ps, "retardation") != NULL;
    const bool plate = material_inputs_names_crystal(mp);
    if (deg + nm + plate > 1)
        return pbrt_error(err, mp->dm->loc,
                          "Material \"retarder\": give one of \"float retardance\" (degrees), "
                          "\"float retardation\" (nm) or a crystal plate (\"string crystal\" or "
                          "indices, with \"float thickness\" in micrometres)");
    double retardance, retardation, thickness;
    if (params_get_float(ps, "retardance", 90.0, &retardance, err) != 0 ||
        material_params_range(mp, "retardance", retardance, 0.0, 360.0) != 0 ||
        params_get_float(ps, "retardation", 0.0, &retardation, err) != 0 ||
        material_params_range(mp, "retardation", retardation, -1e6, 1e6) != 0 ||
        params_get_float(ps, "thickness", 0.0, &thickness, err) != 0 ||
        material_params_range(mp, "thickness", thickness, 0.0, 1e5) != 0)
        return -1;
    sheet->retardance = retardance * (PF_PI / 180.0);
    sheet->retardation_nm = retardation;
    sheet->plate_thickness_nm = thickness * 1000.0;
    sheet->retarder_mode = nm ? RETARDER_RETARDATION : plate ? RETARDER_PLATE : RETARDER_CONSTANT;
    if (!plate) {
        if (params_find(ps, "thickness"))
            return pbrt_error(err, params_find(ps, "thickness")->loc,
                              "Material \"retarder\": \"float thickness\" needs a crystal "
                              "(\"string crystal\" or \"o.\" and \"e.\" indices)");
        return 0;
    }
    bool axial;
    if (material_inputs_load_crystal(mp, "retarder", &sheet->crystal) != 0 ||
        params_get_bool(ps, "axial", false, &axial, err) != 0)
        return -1;
    sheet->plate_axial = axial;
    if (!params_find(ps, "thickness"))
        return pbrt_error(err, mp->dm->loc,
                          "Material \"retarder\" with a crystal needs \"float thickness\" (in "
                          "micrometres)");
    /* The plate's indices over the film's range, which load_options has set. */
    const spectral_grid_t g = mp->L->sc->settings.grid;
    if (ior_validate(&sheet->crystal.no, m->name, g.lambda_min, g.lambda_max, err) ||
        ior_validate(&sheet->crystal.ne, m->name, g.lambda_min, g.lambda_max, err))
        return -1;
    return 0;
}

const material_class_t material_polarizer = {.name = "polarizer",
                                             .aliases = (const char *const[]){"polariser", NULL},
                                             .data_size = sizeof(material_sheet_t),
                                             .load = load_polarizer};
const material_class_t material_retarder = {
    .name = "retarder", .data_size = sizeof(material_sheet_t), .load = load_retarder};
