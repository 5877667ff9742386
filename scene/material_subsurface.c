/* pbrt-v4's SubsurfaceMaterial: a dielectric boundary (index, roughness) over a scattering
 * medium, loaded as a dielectric with a BSSRDF beneath (material_kind.h; scene/subsurface_load.h
 * makes the table); at a hit it is the dielectric class, and the path integrator follows the
 * BSSRDF (render/subsurface.h). */
#include "material_class.h"
#include "material_inputs.h"

#include "loader.h"

#include "subsurface_load.h"

static int load(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    if (material_inputs_roughness(L, &dm->uroughness, &m->uroughness, err) ||
        material_inputs_roughness(L, &dm->vroughness, &m->vroughness, err))
        return -1;
    return (m->sss.sigma_a = loader_spectrum_input(L, &dm->sigma_a, SPEC_UNBOUNDED, err)) &&
                   (m->sss.sigma_s =
                        loader_spectrum_input(L, &dm->sss_sigma_s, SPEC_UNBOUNDED, err)) &&
                   (m->sss.reflectance =
                        loader_spectrum_input(L, &dm->reflectance, SPEC_REFLECTANCE, err)) &&
                   (m->sss.mfp = loader_spectrum_input(L, &dm->sss_mfp, SPEC_UNBOUNDED, err))
               ? subsurface_load(L->sc, dm, m, err)
               : -1;
}

const material_class_t material_subsurface = {.load = load};
