/* prismfarm's polariser and retarder sheets (docs/physics.md §14): thin sheets crossed
 * straight, whose Mueller matrices render/sheet.c applies; no BSDF. The angle and the
 * retardance arrive in degrees and are kept in radians; a retarder's retardation in nm, its
 * crystal plate's thickness from micrometres in nm. */
#include "material_class.h"
#include "material_inputs.h"

#include "material_params.h"

#include "pbrt_parser.h"

/* The axis "angle" in degrees from the surface's u direction (0). */
static int load_polarizer(material_params_t *mp, material_t *m)
{
    double angle;
    if (params_get_float(mp->ps, "angle", 0.0, &angle, mp->err) != 0 ||
        material_params_range(mp, "angle", angle, -360.0, 360.0) != 0)
        return -1;
    m->sheet_angle = angle * (PF_PI / 180.0);
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
    m->retardance = retardance * (PF_PI / 180.0);
    m->retardation_nm = retardation;
    m->plate_thickness_nm = thickness * 1000.0;
    m->retarder_mode = nm ? RETARDER_RETARDATION : plate ? RETARDER_PLATE : RETARDER_CONSTANT;
    if (!plate) {
        if (params_find(ps, "thickness"))
            return pbrt_error(err, params_find(ps, "thickness")->loc,
                              "Material \"retarder\": \"float thickness\" needs a crystal "
                              "(\"string crystal\" or \"o.\" and \"e.\" indices)");
        return 0;
    }
    bool axial;
    if (material_inputs_load_crystal(mp, "retarder", m) != 0 ||
        params_get_bool(ps, "axial", false, &axial, err) != 0)
        return -1;
    m->plate_axial = axial;
    if (!params_find(ps, "thickness"))
        return pbrt_error(err, mp->dm->loc,
                          "Material \"retarder\" with a crystal needs \"float thickness\" (in "
                          "micrometres)");
    return 0;
}

const material_class_t material_polarizer = {.name = "polarizer",
                                             .aliases = (const char *const[]){"polariser", NULL},
                                             .load = load_polarizer};
const material_class_t material_retarder = {.name = "retarder", .load = load_retarder};
