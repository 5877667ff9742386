#include "load_integrator.h"

#include "pbrt_names.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#define COUNT_OF(a) (sizeof(a) / sizeof((a)[0]))

/* A string parameter's value in its table (pbrt_names.h), refused at the parameter, or at
 * fallback when the value is the default. */
static int lookup_string(params_t *p, const char *name, const char *value, pbrt_loc_t fallback,
                         const pbrt_name_t *table, size_t n, int *out, err_t *err)
{
    const param_t *q = params_find(p, name);
    char what[64];
    snprintf(what, sizeof what, "unsupported \"string %s\"", name);
    return pbrt_names_lookup(table, n, what, value, q ? q->loc : fallback, out, err);
}

/* Integrator "photon" (docs/rendering.md): the photon pass's parameters; the gather decides
 * the camera pass's integrator. Read whenever the file names "photon", so that an override to
 * another integrator does not leave them unused. */
static int load_photon(loader_t *L, params_t *p, int enable, err_t *err)
{
    render_settings_t *rs = &L->sc->settings;
    photon_settings_t *ph = &rs->photon;
    int photons, k, mono, mindepth;
    double radius, threshold, density;
    const char *store, *gather;
    if (params_get_int(p, "photons", 1000000, &photons, err) ||
        params_get_string(p, "store", "photonmap", &store, err) ||
        params_get_float(p, "radius", 0.0, &radius, err) || params_get_int(p, "k", 0, &k, err) ||
        params_get_string(p, "gather", "path", &gather, err) ||
        params_get_float(p, "threshold", 0.01, &threshold, err) ||
        params_get_int(p, "monochromerays", 1, &mono, err) ||
        params_get_float(p, "lightmapdensity", 400.0, &density, err) ||
        params_get_int(p, "mindepth", 1, &mindepth, err))
        return -1;
    if (photons < 1)
        return pbrt_error(err, params_find(p, "photons")->loc,
                          "\"integer photons\" must be at least 1, got %d", photons);
    static const pbrt_name_t STORES[] = {{"photonmap", PHOTON_STORE_PHOTONMAP},
                                         {"lightmap", PHOTON_STORE_LIGHTMAP}};
    static const pbrt_name_t GATHERS[] = {{"path", INTEGRATOR_PATH},
                                          {"whitted", INTEGRATOR_WHITTED}};
    int st, g;
    if (lookup_string(p, "store", store, L->desc->integrator.loc, STORES, COUNT_OF(STORES), &st,
                      err))
        return -1;
    if (!(radius >= 0.0) || !isfinite(radius))
        return pbrt_error(err, params_find(p, "radius")->loc,
                          "\"float radius\" must be positive, got %g", radius);
    if (params_find(p, "radius") && !(radius > 0.0))
        return pbrt_error(err, params_find(p, "radius")->loc,
                          "\"float radius\" must be positive, got %g", radius);
    if (k < 0 || k > 1024)
        return pbrt_error(err, params_find(p, "k")->loc, "\"integer k\" must be in 0..1024, got %d",
                          k);
    if (!(density > 0.0 && density <= 1e7))
        return pbrt_error(
            err, params_find(p, "lightmapdensity")->loc,
            "\"float lightmapdensity\" must be in (0, 1e7] texels per unit area, got %g", density);
    if (mindepth < 1 || mindepth > 10000)
        return pbrt_error(err, params_find(p, "mindepth")->loc,
                          "\"integer mindepth\" must be in 1..10000, got %d", mindepth);
    if (!(threshold >= 0.0 && threshold < 1.0))
        return pbrt_error(err, params_find(p, "threshold")->loc,
                          "\"float threshold\" must be in [0, 1), got %g", threshold);
    /* 64: PHOTON_MAX_MONOCHROME_RAYS (render/photon.h), the lanes a photon can carry. */
    if (mono < 1 || mono > 64)
        return pbrt_error(err, params_find(p, "monochromerays")->loc,
                          "\"integer monochromerays\" must be in 1..64, got %d", mono);
    if (lookup_string(p, "gather", gather, L->desc->integrator.loc, GATHERS, COUNT_OF(GATHERS), &g,
                      err))
        return -1;
    if (!enable)
        return 0;
    rs->integrator = (integrator_kind_t)g;
    ph->enabled = 1;
    ph->photons = (uint64_t)photons;
    ph->radius = radius;
    ph->k = k;
    ph->maxdepth = rs->maxdepth;
    ph->threshold = threshold;
    ph->monochromerays = mono;
    ph->store = (photon_store_kind_t)st;
    ph->lightmap_density = density;
    ph->mindepth = mindepth;
    return 0;
}

/* A pbrt-v4 integrator read as one of prismfarm's (scenefile/integrators.c): the warning that
 * says which and why, and one for each of its parameters that is accepted but not simulated.
 * from_file: the file's integrator is the one used (no --integrator override). */
static int load_pbrt_mapping(loader_t *L, const integrator_name_t *named, bool from_file,
                             err_t *err)
{
    const scene_integrator_t *in = &L->desc->integrator;
    if (!named->mapped_from_pbrt)
        return 0;
    if (from_file && named->why && warnings_add(L->sc->warnings, in->loc, "%s", named->why))
        return err_set(err, "out of memory");
    for (const char *const *n = named->ignored; n && *n; n++) {
        param_t *q = params_find(in->params, *n);
        if (!q)
            continue;
        q->used = true;
        if (from_file &&
            warnings_add(L->sc->warnings, q->loc, "\"%s\" of Integrator \"%s\" is not simulated",
                         *n, named->name))
            return err_set(err, "out of memory");
    }
    return 0;
}

/* pbrt-v4's SPPMIntegrator (photonsperiteration -1: one photon per pixel; radius 1; as many
 * iterations as the sampler's pixelsamples) read as the photon integrator: one pass of
 * photonsperiteration x pixelsamples photons at the fixed radius, gathered by the path tracer. */
static int load_sppm(loader_t *L, params_t *p, int enable, err_t *err)
{
    render_settings_t *rs = &L->sc->settings;
    photon_settings_t *ph = &rs->photon;
    int ppi;
    double radius;
    if (params_get_int(p, "photonsperiteration", -1, &ppi, err) ||
        params_get_float(p, "radius", 1.0, &radius, err))
        return -1;
    if (ppi == 0 || ppi < -1)
        return pbrt_error(err, params_find(p, "photonsperiteration")->loc,
                          "\"integer photonsperiteration\" must be positive or -1, got %d", ppi);
    if (!(radius > 0.0) || !isfinite(radius))
        return pbrt_error(err, params_find(p, "radius")->loc,
                          "\"float radius\" must be positive, got %g", radius);
    if (!enable)
        return 0;
    uint64_t per = ppi > 0 ? (uint64_t)ppi
                           : (uint64_t)(rs->full_xres ? rs->full_xres : rs->xres) *
                                 (uint64_t)(rs->full_yres ? rs->full_yres : rs->yres);
    uint64_t n = per * (uint64_t)rs->spp;
    rs->integrator = INTEGRATOR_PATH;
    ph->enabled = 1;
    ph->photons = n > (uint64_t)INT32_MAX ? (uint64_t)INT32_MAX : n;
    ph->radius = radius;
    ph->k = 0;
    ph->maxdepth = rs->maxdepth;
    ph->store = PHOTON_STORE_PHOTONMAP;
    return 0;
}

int load_integrator(loader_t *L, const scene_overrides_t *ov, err_t *err)
{
    const scene_integrator_t *in = &L->desc->integrator;
    render_settings_t *rs = &L->sc->settings;
    params_t *p = in->params;
    const char *type = ov && ov->integrator ? ov->integrator : in->type;
    snprintf(L->sc->integrator_asked, sizeof L->sc->integrator_asked, "%s", type ? type : "");
    const integrator_name_t *named = integrators_find(type);
    if (!named) {
        char names[INTEGRATORS_LIST_MAX];
        integrators_list(false, names, sizeof names);
        const char *best = integrators_suggest(type);
        if (best)
            return pbrt_error(
                err, in->loc,
                "Integrator \"%s\" is not supported yet (did you mean \"%s\"? use %s)", type, best,
                names);
        return pbrt_error(err, in->loc, "Integrator \"%s\" is not supported yet (use %s)", type,
                          names);
    }
    /* Media are simulated by the integrators whose pbrt-v4 counterparts simulate them
     * (integrators.h); pbrt-v4's "path" ignores them as well (its PathIntegrator has no
     * medium code), so there the image is pbrt-v4's. The photon integrators carry them in both
     * passes (render/photon_volume.h: photons fly through media, volume photons). */
    size_t simulated = 0;
    for (size_t i = 0; i < L->desc->nmedia; i++)
        simulated += L->desc->media[i].type != SCENE_MEDIUM_IGNORED;
    rs->media = 0;
    if (simulated > 0) {
        const char *fmt = NULL;
        if (named->photon)
            rs->media = 1;
        else if (!named->media && !named->mapped_from_pbrt)
            fmt = "the scene's %zu %s ignored; pbrt-v4's \"%s\" integrator ignores media too, so "
                  "the image is the one pbrt-v4 renders (Integrator \"volpath\" renders them)";
        else if (!named->media)
            fmt = "the scene's %zu %s ignored: the \"%s\" integrator's fog, haze and absorption "
                  "are missing from the image";
        else
            rs->media = 1;
        if (fmt && warnings_add(L->sc->warnings, L->desc->media_loc, fmt, simulated,
                                simulated == 1 ? "medium is" : "media are", type))
            return err_set(err, "out of memory");
    }
    if (named->refused)
        return pbrt_error(err, in->loc, "Integrator \"%s\" is not supported: %s", type,
                          named->refused);
    int photon = named->photon;
    rs->integrator = named->kind;
    const integrator_name_t *file_named = integrators_find(in->type);
    if (file_named && load_pbrt_mapping(L, file_named, !strcmp(type, in->type), err))
        return -1;
    int maxdepth, split_depth;
    const char *disp, *wl;
    bool spectral_mis, polarized;
    if (params_get_int(p, "maxdepth", 5, &maxdepth, err) ||
        params_get_int(p, "splitdepth", rs->split_depth, &split_depth, err) ||
        params_get_bool(p, "spectralmis", true, &spectral_mis, err) ||
        params_get_bool(p, "polarized", false, &polarized, err) ||
        params_get_string(p, "dispersion", integrators_dispersion_name(DISPERSION_HERO), &disp,
                          err) ||
        params_get_string(p, "wavelengths", "uniform", &wl, err))
        return -1;
    if (maxdepth < 0 || maxdepth > 10000)
        return pbrt_error(err, in->loc, "\"integer maxdepth\" must be in 0..10000, got %d",
                          maxdepth);
    rs->maxdepth = maxdepth;
    if (split_depth < 0 || split_depth > 8)
        return pbrt_error(err, in->loc, "\"integer splitdepth\" must be in 0..8, got %d",
                          split_depth);
    rs->split_depth = split_depth;
    rs->spectral_mis = spectral_mis;
    /* Polarised transport asked for by the file (docs/physics.md §14): what the plan's pilot
     * advises where ignoring polarisation would change the image by more than 1 %. */
    rs->polarised |= polarized;
    rs->polarised_asked = polarized;
    /* The plan's decision (render/polar_pilot.h), made once for the job and given to every
     * host that renders it: the same as setting it on the loaded scene (polar_pilot_record). */
    if (ov && ov->polarized == SCENE_POLARIZED_ON)
        rs->polarised = 1;
    rs->polarised_setting = ov ? ov->polarized : SCENE_POLARIZED_FILE;
    if (!strcmp(named->name, "sppm") || !strcmp(in->type, "sppm")) {
        if (load_sppm(L, p, !strcmp(named->name, "sppm"), err))
            return -1;
    } else if ((photon || !strcmp(in->type, "photon")) && load_photon(L, p, photon, err)) {
        return -1;
    }
    if (ov && ov->dispersion)
        disp = ov->dispersion;
    const pbrt_name_t dispersions[] = {
        {integrators_dispersion_name(DISPERSION_HERO), DISPERSION_HERO},
        {integrators_dispersion_name(DISPERSION_FANOUT), DISPERSION_FANOUT}};
    static const pbrt_name_t WAVELENGTHS[] = {{"uniform", 0}, {"visible", 1}};
    int dk, visible;
    if (pbrt_names_lookup(dispersions, COUNT_OF(dispersions), "unsupported \"string dispersion\"",
                          disp, in->loc, &dk, err) ||
        pbrt_names_lookup(WAVELENGTHS, COUNT_OF(WAVELENGTHS), "unsupported \"string wavelengths\"",
                          wl, in->loc, &visible, err))
        return -1;
    rs->dispersion = (dispersion_kind_t)dk;
    rs->visible_sampling = visible;
    if (rs->integrator == INTEGRATOR_PATH) {
        /* pbrt-v4's PathIntegrator options: how next-event estimation chooses lights (the
         * light BVH by default, scene/emitters.h) and regularisation (a biased blur of
         * specular paths after a non-specular bounce, bsdf/regularize.h). */
        bool regularize;
        const char *ls, *ms;
        if (params_get_bool(p, "regularize", false, &regularize, err) ||
            params_get_string(p, "lightsampler", "bvh", &ls, err) ||
            params_get_string(p, "mediumsampling", "equiangular", &ms, err))
            return -1;
        rs->regularize = regularize;
        if (regularize && photon &&
            warnings_add(L->sc->warnings, params_find(p, "regularize")->loc,
                         "\"bool regularize\" is ignored with a photon pass: its store already "
                         "carries the caustics that regularisation would blur"))
            return err_set(err, "out of memory");
        static const pbrt_name_t SAMPLERS[] = {{"bvh", LIGHT_SAMPLER_BVH},
                                               {"power", LIGHT_SAMPLER_POWER},
                                               {"uniform", LIGHT_SAMPLER_UNIFORM}};
        int k;
        if (lookup_string(p, "lightsampler", ls, in->loc, SAMPLERS, COUNT_OF(SAMPLERS), &k, err))
            return -1;
        rs->light_sampler = (light_sampler_kind_t)k;
        /* An extension: where camera paths scatter in media (docs/physics.md §12). */
        static const pbrt_name_t MEDIUM_SAMPLINGS[] = {
            {"freeflight", MEDIUM_SAMPLING_FREEFLIGHT}, {"equiangular", MEDIUM_SAMPLING_EQUIANGULAR}};
        if (lookup_string(p, "mediumsampling", ms, in->loc, MEDIUM_SAMPLINGS,
                          COUNT_OF(MEDIUM_SAMPLINGS), &k, err))
            return -1;
        rs->medium_sampling = (medium_sampling_kind_t)k;
    }
    return params_check_unused(p, err);
}
