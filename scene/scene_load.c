#include "scene_load.h"

#include "load_images.h"
#include "load_instances.h"
#include "load_lights.h"
#include "load_materials.h"
#include "load_media.h"
#include "load_shapes.h"
#include "load_textures.h"
#include "loader.h"
#include "cie.h"
#include "colour.h"
#include "files.h"
#include "glass.h"
#include "hair.h"
#include "image_exr.h"
#include "image_info.h"
#include "image_pfm.h"
#include "image_png.h"
#include "image_stb.h"
#include "microfacet.h"
#include "named_spectra.h"
#include "pbrt_parser.h"
#include "plan.h"
#include "pool.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

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
        return pbrt_error(err, params_find(p, "photons")->loc, "\"integer photons\" must be at least 1, got %d", photons);
    if (strcmp(store, "photonmap") != 0 && strcmp(store, "lightmap") != 0)
        return pbrt_error(err, params_find(p, "store")->loc,
                          "\"string store\" must be \"photonmap\" or \"lightmap\", got \"%s\"", store);
    if (!(radius >= 0.0) || !isfinite(radius))
        return pbrt_error(err, params_find(p, "radius")->loc, "\"float radius\" must be positive, got %g", radius);
    if (params_find(p, "radius") && !(radius > 0.0))
        return pbrt_error(err, params_find(p, "radius")->loc, "\"float radius\" must be positive, got %g", radius);
    if (k < 0 || k > 1024)
        return pbrt_error(err, params_find(p, "k")->loc, "\"integer k\" must be in 0..1024, got %d", k);
    if (!(density > 0.0 && density <= 1e7))
        return pbrt_error(err, params_find(p, "lightmapdensity")->loc,
                          "\"float lightmapdensity\" must be in (0, 1e7] texels per unit area, got %g", density);
    if (mindepth < 1 || mindepth > 10000)
        return pbrt_error(err, params_find(p, "mindepth")->loc, "\"integer mindepth\" must be in 1..10000, got %d", mindepth);
    if (!(threshold >= 0.0 && threshold < 1.0))
        return pbrt_error(err, params_find(p, "threshold")->loc, "\"float threshold\" must be in [0, 1), got %g", threshold);
    /* 64: PHOTON_MAX_MONOCHROME_RAYS (render/photon.h), the lanes a photon can carry. */
    if (mono < 1 || mono > 64)
        return pbrt_error(err, params_find(p, "monochromerays")->loc,
                          "\"integer monochromerays\" must be in 1..64, got %d", mono);
    integrator_kind_t g;
    if (!strcmp(gather, "path"))
        g = INTEGRATOR_PATH;
    else if (!strcmp(gather, "whitted"))
        g = INTEGRATOR_WHITTED;
    else
        return pbrt_error(err, params_find(p, "gather")->loc, "\"string gather\" must be \"path\" or \"whitted\", got \"%s\"", gather);
    if (!enable)
        return 0;
    rs->integrator = g;
    ph->enabled = 1;
    ph->photons = (uint64_t)photons;
    ph->radius = radius;
    ph->k = k;
    ph->maxdepth = rs->maxdepth;
    ph->threshold = threshold;
    ph->monochromerays = mono;
    ph->store = !strcmp(store, "lightmap") ? PHOTON_STORE_LIGHTMAP : PHOTON_STORE_PHOTONMAP;
    ph->lightmap_density = density;
    ph->mindepth = mindepth;
    return 0;
}

/* A pbrt-v4 integrator read as one of prismfarm's (scenefile/integrators.c): the warning that
 * says which and why, and one for each of its parameters that is accepted but not simulated.
 * from_file: the file's integrator is the one used (no --integrator override). */
static int load_pbrt_mapping(loader_t *L, const integrator_name_t *named, bool from_file, err_t *err)
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
        if (from_file && warnings_add(L->sc->warnings, q->loc, "\"%s\" of Integrator \"%s\" is not simulated", *n,
                         named->name))
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
        return pbrt_error(err, params_find(p, "radius")->loc, "\"float radius\" must be positive, got %g", radius);
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

static int load_integrator(loader_t *L, const scene_overrides_t *ov, err_t *err)
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
            return pbrt_error(err, in->loc, "Integrator \"%s\" is not supported yet (did you mean \"%s\"? use %s)",
                              type, best, names);
        return pbrt_error(err, in->loc, "Integrator \"%s\" is not supported yet (use %s)", type,
                          names);
    }
    /* Media are simulated by the integrators whose pbrt-v4 counterparts simulate them
     * (integrators.h); pbrt-v4's "path" ignores them as well (its PathIntegrator has no
     * medium code), so there the image is pbrt-v4's. The photon passes do not carry them. */
    size_t simulated = 0;
    for (size_t i = 0; i < L->desc->nmedia; i++)
        simulated += L->desc->media[i].type != SCENE_MEDIUM_IGNORED;
    rs->media = 0;
    if (simulated > 0) {
        const char *fmt = NULL;
        if (named->photon)
            fmt = "the scene's %zu %s ignored: the \"%s\" integrator's photon pass and its gather "
                  "do not simulate participating media (Integrator \"volpath\" does)";
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
        return pbrt_error(err, in->loc, "Integrator \"%s\" is not supported: %s", type, named->refused);
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
        return pbrt_error(err, in->loc, "\"integer maxdepth\" must be in 0..10000, got %d", maxdepth);
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
    if (!strcmp(named->name, "sppm") || !strcmp(in->type, "sppm")) {
        if (load_sppm(L, p, !strcmp(named->name, "sppm"), err))
            return -1;
    } else if ((photon || !strcmp(in->type, "photon")) && load_photon(L, p, photon, err)) {
        return -1;
    }
    if (ov && ov->dispersion)
        disp = ov->dispersion;
    if (!integrators_dispersion_find(disp, &rs->dispersion))
        return pbrt_error(err, in->loc, "\"string dispersion\" must be \"hero\" or \"fanout\", got \"%s\"", disp);
    if (!strcmp(wl, "uniform"))
        rs->visible_sampling = 0;
    else if (!strcmp(wl, "visible"))
        rs->visible_sampling = 1;
    else
        return pbrt_error(err, in->loc, "\"string wavelengths\" must be \"uniform\" or \"visible\", got \"%s\"", wl);
    if (rs->integrator == INTEGRATOR_PATH) {
        /* pbrt-v4's PathIntegrator options: how next-event estimation chooses lights (the
         * light BVH by default, scene/emitters.h) and regularisation (a biased blur of
         * specular paths after a non-specular bounce, bsdf/regularize.h). */
        bool regularize;
        const char *ls;
        if (params_get_bool(p, "regularize", false, &regularize, err) ||
            params_get_string(p, "lightsampler", "bvh", &ls, err))
            return -1;
        rs->regularize = regularize;
        if (regularize && photon &&
            warnings_add(L->sc->warnings, params_find(p, "regularize")->loc,
                         "\"bool regularize\" is ignored with a photon pass: its store already "
                         "carries the caustics that regularisation would blur"))
            return err_set(err, "out of memory");
        if (!strcmp(ls, "bvh"))
            rs->light_sampler = LIGHT_SAMPLER_BVH;
        else if (!strcmp(ls, "power"))
            rs->light_sampler = LIGHT_SAMPLER_POWER;
        else if (!strcmp(ls, "uniform"))
            rs->light_sampler = LIGHT_SAMPLER_UNIFORM;
        else
            return pbrt_error(err, params_find(p, "lightsampler")->loc,
                              "\"string lightsampler\" must be \"bvh\", \"power\" or \"uniform\", got \"%s\"", ls);
    }
    return params_check_unused(p, err);
}

/* Camera "realistic": the lens system for the full film (its diagonal and aspect), focused
 * and its exit pupil bounded over the film's wavelengths (optics/lens.h). pbrt-v4 warns when
 * the stop is clamped; prismfarm also says which elements got a default glass. */
static int load_lens(loader_t *L, err_t *err)
{
    const scene_camera_t *c = &L->desc->camera;
    render_settings_t *rs = &L->sc->settings;
    camera_t *cam = &L->sc->camera;
    lens_params_t lp = {.file = c->lens_path,
                        .glasses = c->glasses,
                        .nglasses = c->nglasses,
                        .aperture_diameter_mm = c->aperturediameter,
                        .focus_distance = c->focusdistance,
                        .film_diagonal = L->desc->film.diagonal / 1000.0,
                        .xres = rs->full_xres > 0 ? rs->full_xres : rs->xres,
                        .yres = rs->full_yres > 0 ? rs->full_yres : rs->yres,
                        .lambda_min = rs->grid.lambda_min,
                        .lambda_max = rs->grid.lambda_max};
    cam->lens = lens_system_new(c->lens_text, c->lens_len, &lp, err);
    if (!cam->lens)
        return err_prefix(err, "%s:%d:%d: Camera \"realistic\": ", c->lens_loc.file, c->lens_loc.line,
                          c->lens_loc.col);
    cam->lens_dispersive = 0;
    for (int i = 0; i < lens_system_count(cam->lens); i++) {
        const lens_element_t *e = lens_system_element(cam->lens, i);
        cam->lens_dispersive |= e->glass && ior_is_dispersive(&e->ior, rs->grid.lambda_min, rs->grid.lambda_max);
    }
    if (lens_system_clamped(cam->lens) &&
        warnings_add(L->sc->warnings, c->lens_loc,
                     "\"float aperturediameter\" %g mm is larger than the lens file's stop: the stop is kept",
                     c->aperturediameter))
        return err_set(err, "out of memory");
    if (lens_system_defaulted(cam->lens)) {
        char names[512] = "";
        for (int i = 0; i < lens_system_count(cam->lens); i++) {
            const lens_element_t *e = lens_system_element(cam->lens, i);
            size_t n = strlen(names);
            if (e->defaulted && n + 48 < sizeof names)
                snprintf(names + n, sizeof names - n, "%s%.4f -> %s", n ? ", " : "", e->eta_d, e->glass_name);
        }
        if (warnings_add(L->sc->warnings, c->lens_loc,
                         "%d lens elements name no glass: each gets the catalogue glass nearest in n_d, "
                         "shifted to the file's n_d, for its dispersion (%s); name them in a fifth column or "
                         "\"string glasses\"",
                         lens_system_defaulted(cam->lens), names))
            return err_set(err, "out of memory");
    }
    return 0;
}

/* pbrt-v4 FilmBaseParameters: pixelbounds [x0 x1 y0 y1] clipped to the film, or the crop
 * window [x0 x1 y0 y1] (clamped to [0, 1]) as pixels ceil(res * x0) .. ceil(res * x1). The
 * rendered image is the bounds' size; full_xres keeps the film's (see scene.h). */
static int load_film_crop(loader_t *L, err_t *err)
{
    const scene_film_t *f = &L->desc->film;
    render_settings_t *rs = &L->sc->settings;
    if (!f->has_crop && !f->has_pixelbounds)
        return 0;
    int x0, x1, y0, y1;
    if (f->has_crop) {
        double c[4];
        for (int i = 0; i < 4; i++)
            c[i] = fmin(fmax(f->cropwindow[i], 0.0), 1.0);
        x0 = (int)ceil(rs->xres * fmin(c[0], c[1]));
        x1 = (int)ceil(rs->xres * fmax(c[0], c[1]));
        y0 = (int)ceil(rs->yres * fmin(c[2], c[3]));
        y1 = (int)ceil(rs->yres * fmax(c[2], c[3]));
    } else {
        x0 = f->pixelbounds[0] > 0 ? f->pixelbounds[0] : 0;
        x1 = f->pixelbounds[1] < rs->xres ? f->pixelbounds[1] : rs->xres;
        y0 = f->pixelbounds[2] > 0 ? f->pixelbounds[2] : 0;
        y1 = f->pixelbounds[3] < rs->yres ? f->pixelbounds[3] : rs->yres;
    }
    if (x1 <= x0 || y1 <= y0)
        return pbrt_error(err, f->crop_loc, "the film's %s leaves no pixel of the %dx%d image",
                          f->has_crop ? "\"cropwindow\"" : "\"pixelbounds\"", rs->xres, rs->yres);
    rs->full_xres = rs->xres;
    rs->full_yres = rs->yres;
    rs->crop_x0 = x0;
    rs->crop_y0 = y0;
    rs->xres = x1 - x0;
    rs->yres = y1 - y0;
    return 0;
}

static int load_filter(loader_t *L, err_t *err)
{
    const scene_filter_t *f = &L->desc->filter;
    scene_t *sc = L->sc;
    int kind = filter_kind_find(f->type);
    if (kind < 0)
        return pbrt_error(err, f->loc, "unsupported filter \"%s\"", f->type ? f->type : "");
    filter_params_t p = filter_params_default((filter_kind_t)kind);
    p.xradius = f->xradius;
    p.yradius = f->yradius;
    p.sigma = f->sigma;
    p.b = f->b;
    p.c = f->c;
    p.tau = f->tau;
    sc->settings.filter = p;
    filter_sampler_destroy(&sc->filter);
    sc->filter = filter_sampler_new(&p, err);
    if (!sc->filter)
        return err_prefix(err, "%s:%d:%d: PixelFilter: ", f->loc.file ? f->loc.file : "", f->loc.line, f->loc.col);
    return 0;
}

static int load_options(loader_t *L, const scene_overrides_t *ov, err_t *err)
{
    const scene_desc_t *d = L->desc;
    scene_t *sc = L->sc;
    render_settings_t *rs = &sc->settings;
    if (!strcmp(d->camera.type, "perspective"))
        sc->camera.kind = CAMERA_PERSPECTIVE;
    else if (!strcmp(d->camera.type, "orthographic"))
        sc->camera.kind = CAMERA_ORTHOGRAPHIC;
    else if (!strcmp(d->camera.type, "spherical"))
        sc->camera.kind = CAMERA_SPHERICAL;
    else if (!strcmp(d->camera.type, "realistic"))
        sc->camera.kind = CAMERA_REALISTIC;
    else
        return pbrt_error(err, d->camera.loc,
                          "Camera \"%s\" is not supported (perspective, orthographic, spherical or realistic)",
                          d->camera.type);
    if (d->camera.camera_from_world.singular)
        return pbrt_error(err, d->camera.loc, "the camera transform is singular");
    sc->camera.camera_to_world = transform_inverse(d->camera.camera_from_world);
    sc->camera.fov_deg = d->camera.fov;
    sc->camera.lens_radius = d->camera.lensradius;
    sc->camera.focal_distance = d->camera.focaldistance;
    sc->camera.equirect = d->camera.equirect;
    memcpy(sc->camera.screen, d->camera.screenwindow, sizeof sc->camera.screen);
    sc->camera.frame_aspect = d->camera.frameaspectratio;
    sc->camera.analyser = d->camera.has_analyzer;
    sc->camera.analyser_angle = d->camera.analyzer * (PF_PI / 180.0);
    if (sc->camera.kind == CAMERA_PERSPECTIVE && !(d->camera.fov > 0 && d->camera.fov < 180))
        return pbrt_error(err, d->camera.loc, "\"float fov\" must be in (0, 180) degrees, got %g", d->camera.fov);
    rs->xres = ov && ov->xres > 0 ? ov->xres : d->film.xres;
    rs->yres = ov && ov->yres > 0 ? ov->yres : d->film.yres;
    if (rs->xres <= 0 || rs->yres <= 0 || rs->xres > 32768 || rs->yres > 32768)
        return pbrt_error(err, d->film.loc, "film resolution %dx%d is outside 1..32768", rs->xres, rs->yres);
    if (load_film_crop(L, err) || load_filter(L, err))
        return -1;
    rs->imaging_ratio = d->film.exposuretime * d->film.iso / 100.0;
    rs->max_component = d->film.maxcomponentvalue;
    if (strcmp(d->film.sensor, "cie1931") != 0 || d->film.whitebalance != 0.0) {
        sc->sensor = sensor_new(d->film.sensor, d->film.whitebalance, err);
        if (!sc->sensor) {
            pbrt_loc_t at = strcmp(d->film.sensor, "cie1931") != 0 ? d->film.sensor_loc : d->film.whitebalance_loc;
            return err_prefix(err, "%s:%d:%d: Film: ", at.file, at.line, at.col);
        }
    }
    if (spectral_grid_init(&rs->grid, d->film.nbuckets, d->film.lambda_min, d->film.lambda_max, err))
        return err_prefix(err, "%s:%d:%d: Film: ", d->film.loc.file, d->film.loc.line, d->film.loc.col);
    /* A Stokes output is polarised transport's: it turns it on (scene_finish keeps it). */
    rs->stokes = d->film.stokes;
    rs->polarised |= rs->stokes;
    /* budget.h: the merged image is the master's largest allocation (all its planes:
     * render_settings_buckets); checked before any geometry or texture is built. */
    const int image_buckets = render_settings_buckets(rs);
    uint64_t image =
        scene_budget_image_bytes((uint64_t)rs->xres, (uint64_t)rs->yres, (uint64_t)image_buckets);
    if (L->budget && L->budget->image_bytes && image > L->budget->image_bytes)
        return pbrt_error(err, d->film.loc,
                          "Film: the merged image of %dx%d pixels and %d buckets takes %.1f MiB, "
                          "over the master's budget of %.0f MiB (prismfarm master "
                          "--max-image-mb)",
                          rs->xres, rs->yres, image_buckets, (double)image / 1048576.0,
                          (double)L->budget->image_bytes / 1048576.0);
    rs->film_spectral = d->film.type == SCENE_FILM_SPECTRAL;
    if (sc->camera.kind == CAMERA_REALISTIC && load_lens(L, err))
        return -1;
    snprintf(rs->filename, sizeof rs->filename, "%s", d->film.filename ? d->film.filename : "");
    rs->spp = ov && ov->spp > 0 ? ov->spp : d->sampler.pixelsamples;
    if (rs->spp <= 0 || rs->spp > (1 << 24))
        return pbrt_error(err, d->sampler.loc, "pixelsamples must be in 1..%d, got %d", 1 << 24, rs->spp);
    rs->seed = ov && ov->seed >= 0 ? (uint64_t)ov->seed : (uint64_t)(uint32_t)d->sampler.seed;
    const char *why;
    if (sampler_kind_parse(d->sampler.type, &rs->sampler, &why))
        return pbrt_error(err, d->sampler.loc, "unsupported sampler \"%s\"", d->sampler.type);
    if (why && warnings_add(L->sc->warnings, d->sampler.loc, "%s", why))
        return err_set(err, "out of memory");
    return 0;
}

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
        if (warnings_add(sc->warnings, at, "the scene has no light source: the image will be black"))
            r = err_set(err, "out of memory");
    }
    if (!r)
        r = scene_finish(sc, err);
    /* Integrator "auto" (also when the file names none) follows the plan (plan.h). */
    if (!r)
        r = plan_apply_auto(sc, desc, ov, err);
    /* The plan may choose the photon integrator for "auto": its passes carry no media. */
    if (!r && sc->settings.media && sc->settings.photon.enabled) {
        sc->settings.media = 0;
        if (warnings_add(sc->warnings, desc->media_loc,
                         "the scene's media are ignored: the plan chose the photon integrator, "
                         "whose passes do not simulate participating media (Integrator "
                         "\"volpath\" does)"))
            r = err_set(err, "out of memory");
    }
    if (r) {
        scene_destroy(&sc);
        return NULL;
    }
    return sc;
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
