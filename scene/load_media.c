#include "load_media.h"
#include "medium_file.h"

int load_media(loader_t *L, err_t *err)
{
    const scene_desc_t *d = L->desc;
    for (size_t i = 0; i < d->nmedia; i++) {
        const scene_medium_t *dm = &d->media[i];
        medium_t *m = NULL;
        if (dm->type != SCENE_MEDIUM_IGNORED) {
            medium_params_t p = {.scale = dm->scale, .g = dm->g, .Le_scale = dm->Le_scale};
            if (!(p.sigma_a = loader_owned_spectrum(L->sc, &dm->sigma_a, SPEC_UNBOUNDED, err)) ||
                !(p.sigma_s = loader_owned_spectrum(L->sc, &dm->sigma_s, SPEC_UNBOUNDED, err)))
                return -1;
            int black = dm->Le.kind == SCENE_SPECTRUM_CONSTANT ? !(dm->Le.constant > 0.0)
                        : dm->Le.kind == SCENE_SPECTRUM_RGB
                            ? !(dm->Le.rgb[0] > 0.0 || dm->Le.rgb[1] > 0.0 || dm->Le.rgb[2] > 0.0)
                            : 0;
            if (dm->has_Le && !black && dm->Le_scale > 0.0 &&
                !(p.Le = loader_light_spectrum(L->sc, &dm->Le, err)))
                return -1;
            if (dm->type == SCENE_MEDIUM_NANOVDB) {
                /* its voxels share the texel budget: both are samples a scene makes the master
                 * hold */
                uint64_t budget = L->budget ? L->budget->texels : 0;
                m = medium_file_load_nanovdb(dm, &p, budget, &L->texels, err);
            } else {
                m = dm->type == SCENE_MEDIUM_GRID
                        ? medium_new_grid(&p, dm->nx, dm->ny, dm->nz, dm->density, dm->p0,
                                          dm->p1, &dm->to_world, err)
                        : medium_new_homogeneous(&p, err);
            }
            if (!m)
                return err_prefix(err, "%s:%d:%d: MakeNamedMedium \"%s\": ", dm->loc.file,
                                  dm->loc.line, dm->loc.col, dm->name);
        }
        if (scene_add_medium(L->sc, m, err) < 0)
            return -1;
    }
    L->sc->camera_medium = d->camera.medium;
    return 0;
}
