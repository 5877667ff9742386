#include "scene_load.h"

#include "load_instances.h"
#include "load_integrator.h"
#include "load_lights.h"
#include "load_materials.h"
#include "load_media.h"
#include "load_options.h"
#include "load_shapes.h"
#include "load_textures.h"
#include "loader.h"
#include "pbrt_parser.h"
#include "plan.h"

#include <stdlib.h>

/* The entities in the order their dependencies ask: the film before the integrator (sppm's
 * photon count) and before any texture (the image budget is checked first); textures before
 * the materials and lights that take them; materials, lights and media before the shapes that
 * name them by index; the plan last, on the finished scene. */
scene_t *scene_load(const scene_desc_t *desc, const scene_overrides_t *ov, err_t *err)
{
    scene_t *sc = scene_new(err);
    if (!sc)
        return NULL;
    loader_t L = {
        .desc = desc, .sc = sc, .budget = ov ? ov->budget : NULL, .threads = ov ? ov->threads : 0};
    L.tex = calloc(desc->ntextures ? desc->ntextures : 1, sizeof *L.tex);
    int r = L.tex ? 0 : err_set(err, "out of memory");
    if (!r && (!(sc->warnings = warnings_new(err)) || warnings_copy(sc->warnings, desc->warnings)))
        r = err_set(err, "out of memory");
    if (!r)
        r = load_options(&L, ov, err);
    if (!r)
        r = load_integrator(&L, ov, err);
    if (!r)
        r = load_textures(&L, err);
    if (!r)
        r = load_materials(&L, err);
    if (!r)
        r = load_lights(&L, err);
    if (!r)
        r = load_media(&L, err);
    if (!r)
        r = load_shapes(&L, err);
    if (!r)
        r = load_instances(&L, err);
    free(L.tex);
    /* pbrt-v4 renders a scene without lights black, silently; say why the image is black. */
    if (!r && sc->nlights == 0) {
        pbrt_loc_t at = desc->camera.loc;
        at.line = at.line > 0 ? at.line : 1;
        at.col = at.col > 0 ? at.col : 1;
        if (warnings_add(sc->warnings, at,
                         "the scene has no light source: the image will be black"))
            r = err_set(err, "out of memory");
    }
    if (!r)
        r = scene_finish(sc, err);
    /* Integrator "auto" (also when the file names none) follows the plan (plan.h). */
    if (!r)
        r = plan_apply_auto(sc, desc, ov, err);
    /* The plan may choose the photon integrator for "auto": both its passes carry the media
     * (render/photon_volume.h). */
    if (r) {
        scene_destroy(&sc);
        return NULL;
    }
    return sc;
}

int scene_load_check_materials(const scene_desc_t *desc, warnings_t *refusals, err_t *err)
{
    scene_t *sc = scene_new(err);
    if (!sc)
        return -1;
    loader_t L = {.desc = desc, .sc = sc};
    L.tex = calloc(desc->ntextures ? desc->ntextures : 1, sizeof *L.tex);
    texture_t *stand_in = NULL;
    int r = L.tex && (sc->warnings = warnings_new(err)) ? 0 : err_set(err, "out of memory");
    if (!r && (!(stand_in = texture_new_constant_value(0.5, err)) ||
               scene_own_texture(sc, stand_in, err)))
        r = -1;
    for (size_t i = 0; !r && i < desc->ntextures; i++)
        L.tex[i] = stand_in;
    if (!r)
        r = load_materials_check(&L, refusals, err);
    free(L.tex);
    scene_destroy(&sc);
    return r;
}

scene_t *scene_load_file(const char *path, const scene_overrides_t *ov, err_t *err)
{
    scene_desc_t *d =
        pbrt_parse_file_opts(path, &(pbrt_parse_opts_t){.threads = ov ? ov->threads : 0}, err);
    if (!d)
        return NULL;
    scene_t *s = scene_load(d, ov, err);
    scene_desc_destroy(&d);
    return s;
}

scene_t *scene_load_file_confined(const char *path, const char *root, const scene_overrides_t *ov,
                                  err_t *err)
{
    if (!root)
        return err_set(err, "a confined parse needs the scene's folder"), NULL;
    pbrt_parse_opts_t po = {
        .root = root, .budget = ov ? ov->budget : NULL, .threads = ov ? ov->threads : 0};
    scene_desc_t *d = pbrt_parse_file_opts(path, &po, err);
    if (!d)
        return NULL;
    scene_t *s = scene_load(d, ov, err);
    scene_desc_destroy(&d);
    return s;
}
