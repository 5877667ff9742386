/* pbrt-v4's SubsurfaceMaterial: a dielectric boundary (index, roughness) over a scattering
 * medium, loaded as a dielectric with a BSSRDF beneath (material_kind.h); at a hit it is the
 * dielectric class, and the path integrator follows the BSSRDF (render/subsurface.h). */
#include "material_subsurface.h"
#include "material_class.h"
#include "material_inputs.h"
#include "material_params.h"

#include "medium_presets.h"
#include "pbrt_parser.h"

#include <math.h>

/* The BSSRDF's profile table for (g, eta), computed once and shared by the materials that have
 * those (the scene owns it). */
static int profile_table(scene_t *sc, double g, double eta, material_subsurface_t *sss, err_t *err)
{
    for (size_t i = 0; i < sc->nbssrdf; i++)
        if (bssrdf_table_g(sc->bssrdf[i]) == g && bssrdf_table_eta(sc->bssrdf[i]) == eta) {
            sss->table = sc->bssrdf[i];
            return 0;
        }
    bssrdf_table_t *t = bssrdf_table_new(g, eta);
    if (!t)
        return err_set(err, "out of memory");
    if (scene_own_bssrdf(sc, t, err) != 0)
        return -1;
    sss->table = t;
    return 0;
}

/* The medium's coefficients one of four mutually exclusive ways (pbrt-v4
 * SubsurfaceMaterial::Create): a named measured medium; "sigma_a" with "sigma_s"; "reflectance"
 * with "mfp" (SubsurfaceFromDiffuse turns them into coefficients at a hit); else pbrt-v4's
 * defaults, RGB (.0011, .0024, .014) and (2.55, 3.21, 3.77) per mm. *g is forced to 0 by a
 * name (its coefficients are reduced ones). */
static int coefficients(material_params_t *mp, double *g)
{
    material_subsurface_t *sss = mp->data;
    params_t *ps = mp->ps;
    const pbrt_loc_t loc = mp->dm->loc;
    const char *name = NULL;
    if (params_get_string(ps, "name", NULL, &name, mp->err) != 0)
        return -1;
    scene_spectrum_input_t sa = {.texture = -1}, ss = {.texture = -1};
    if (name && *name) {
        const param_t *np = params_find(ps, "name");
        double s[3], a[3];
        if (!medium_preset_find(name, s, a))
            return pbrt_error(mp->err, np->loc,
                              "Material \"subsurface\": named medium \"%s\" is not in pbrt-v4's "
                              "table of measured media (e.g. \"Skin1\", \"Ketchup\", \"Apple\", "
                              "\"Wholemilk\"; docs/scene-format.md lists them)",
                              name);
        const param_t *gp = params_find(ps, "g");
        if (*g != 0.0 &&
            warnings_add(mp->L->sc->warnings, gp->loc,
                         "Material \"subsurface\": \"g\" is ignored with a named medium (its "
                         "coefficients are reduced ones, so g is 0), as in pbrt-v4"))
            return pbrt_error(mp->err, gp->loc, "out of memory");
        *g = 0.0;
        sa.spectrum = (scene_spectrum_t){
            .kind = SCENE_SPECTRUM_RGB, .rgb = {a[0], a[1], a[2]}, .loc = np->loc};
        ss.spectrum = (scene_spectrum_t){
            .kind = SCENE_SPECTRUM_RGB, .rgb = {s[0], s[1], s[2]}, .loc = np->loc};
    } else if (params_find(ps, "sigma_a") || params_find(ps, "sigma_s")) {
        const param_t *pa = params_find(ps, "sigma_a"), *pss = params_find(ps, "sigma_s");
        if ((pa != NULL) != (pss != NULL))
            return pbrt_error(mp->err, (pa ? pa : pss)->loc,
                              "Material \"subsurface\": \"%s\" is given without \"%s\"",
                              pa ? "sigma_a" : "sigma_s", pa ? "sigma_s" : "sigma_a");
        if (material_params_spectrum_input(mp, "sigma_a", material_params_constant(0.0, loc),
                                           SPEC_UNBOUNDED, &sa) ||
            material_params_spectrum_input(mp, "sigma_s", material_params_constant(0.0, loc),
                                           SPEC_UNBOUNDED, &ss))
            return -1;
    } else if (params_find(ps, "reflectance")) {
        return (sss->reflectance = material_params_spectrum_texture(
                    mp, "reflectance", material_params_constant(0.5, loc), SPEC_REFLECTANCE)) &&
                       (sss->mfp = material_params_spectrum_texture(
                            mp, "mfp", material_params_constant(1.0, loc), SPEC_UNBOUNDED))
                   ? 0
                   : -1;
    } else {
        sa.spectrum =
            (scene_spectrum_t){.kind = SCENE_SPECTRUM_RGB, .rgb = {.0011, .0024, .014}, .loc = loc};
        ss.spectrum =
            (scene_spectrum_t){.kind = SCENE_SPECTRUM_RGB, .rgb = {2.55, 3.21, 3.77}, .loc = loc};
    }
    return (sss->sigma_a = loader_spectrum_input(mp->L, &sa, SPEC_UNBOUNDED, mp->err)) &&
                   (sss->sigma_s = loader_spectrum_input(mp->L, &ss, SPEC_UNBOUNDED, mp->err))
               ? 0
               : -1;
}

/* Then "scale" (1) times all coefficients, the boundary's "eta" (1.33), "g" (0) and
 * roughness. */
static int load(material_params_t *mp, material_t *m)
{
    material_subsurface_t *sss = mp->data;
    params_t *ps = mp->ps;
    double g, eta;
    scene_float_input_t u, v;
    if (params_get_float(ps, "g", 0.0, &g, mp->err) != 0 ||
        params_get_float(ps, "eta", 1.33, &eta, mp->err) != 0 ||
        params_get_float(ps, "scale", 1.0, &sss->scale, mp->err) != 0 ||
        material_params_range(mp, "scale", sss->scale, 0.0, INFINITY) != 0 ||
        material_inputs_load_roughness(mp, "", &u, &v, &m->uroughness, &m->vroughness) != 0 ||
        material_inputs_load_remap(mp, m) != 0)
        return -1;
    /* The Fresnel moments' polynomial fits (bsdf/bssrdf.h) hold over this range; pbrt-v4 takes
     * any index and goes wrong outside it. */
    if (!(eta >= 0.5 && eta <= 3.0))
        return material_params_range(mp, "eta", eta, 0.5, 3.0);
    if (!(g > -1.0 && g < 1.0))
        return material_params_range(mp, "g", g, -0.999, 0.999);
    if (coefficients(mp, &g) != 0)
        return -1;
    m->kind = MATERIAL_DIELECTRIC;
    m->ior = ior_constant(eta);
    material_inputs_smoothness(m, &u, &v);
    scene_t *sc = mp->L->sc;
    /* Only the path integrators follow the BSSRDF (render.c); say so where it is not. */
    if (sc->settings.integrator == INTEGRATOR_WHITTED &&
        warnings_add(sc->warnings, mp->dm->loc,
                     "Material \"subsurface\": the \"whitted\" integrator renders only its "
                     "dielectric boundary (no light leaves from beneath); \"path\" renders its "
                     "subsurface scattering"))
        return err_set(mp->err, "out of memory");
    return profile_table(sc, g, eta, sss, mp->err);
}

const material_class_t material_subsurface = {
    .name = "subsurface", .data_size = sizeof(material_subsurface_t), .load = load};
