#include "subsurface_load.h"

int subsurface_load(scene_t *sc, const scene_material_t *dm, material_t *m, err_t *err)
{
    m->kind = MATERIAL_DIELECTRIC;
    m->ior = ior_constant(dm->sss_eta);
    m->sss.scale = dm->scale;
    /* Only the path integrators follow the BSSRDF (render.c); say so where it is not. */
    if (sc->settings.integrator == INTEGRATOR_WHITTED &&
        warnings_add(sc->warnings, dm->loc,
                     "Material \"subsurface\": the \"whitted\" integrator renders only its "
                     "dielectric boundary (no light leaves from beneath); \"path\" renders its "
                     "subsurface scattering"))
        return err_set(err, "out of memory");
    if (!dm->sss_from_reflectance)
        m->sss.reflectance = m->sss.mfp = NULL; /* sigma_a and sigma_s decide */
    else
        m->sss.sigma_a = m->sss.sigma_s = NULL;
    for (size_t i = 0; i < sc->nbssrdf; i++)
        if (bssrdf_table_g(sc->bssrdf[i]) == dm->sss_g &&
            bssrdf_table_eta(sc->bssrdf[i]) == dm->sss_eta) {
            m->sss.table = sc->bssrdf[i];
            return 0;
        }
    bssrdf_table_t *t = bssrdf_table_new(dm->sss_g, dm->sss_eta);
    if (!t)
        return err_set(err, "out of memory");
    if (scene_own_bssrdf(sc, t, err) != 0)
        return -1;
    m->sss.table = t;
    return 0;
}
