#include "load_options.h"

#include "pbrt_names.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

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
        return err_prefix(err, "%s:%d:%d: Camera \"realistic\": ", c->lens_loc.file,
                          c->lens_loc.line, c->lens_loc.col);
    cam->lens_dispersive = 0;
    for (int i = 0; i < lens_system_count(cam->lens); i++) {
        const lens_element_t *e = lens_system_element(cam->lens, i);
        cam->lens_dispersive |=
            e->glass && ior_is_dispersive(&e->ior, rs->grid.lambda_min, rs->grid.lambda_max);
    }
    if (lens_system_clamped(cam->lens) &&
        warnings_add(L->sc->warnings, c->lens_loc,
                     "\"float aperturediameter\" %g mm is larger than the lens file's stop: the "
                     "stop is kept",
                     c->aperturediameter))
        return err_set(err, "out of memory");
    if (lens_system_defaulted(cam->lens)) {
        char names[512] = "";
        for (int i = 0; i < lens_system_count(cam->lens); i++) {
            const lens_element_t *e = lens_system_element(cam->lens, i);
            size_t n = strlen(names);
            if (e->defaulted && n + 48 < sizeof names)
                snprintf(names + n, sizeof names - n, "%s%.4f -> %s", n ? ", " : "", e->eta_d,
                         e->glass_name);
        }
        if (warnings_add(
                L->sc->warnings, c->lens_loc,
                "%d lens elements name no glass: each gets the catalogue glass nearest in n_d, "
                "shifted to the file's n_d, for its dispersion (%s); name them in a fifth column "
                "or "
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
        return err_prefix(err, "%s:%d:%d: PixelFilter: ", f->loc.file ? f->loc.file : "",
                          f->loc.line, f->loc.col);
    return 0;
}

int load_options(loader_t *L, const scene_overrides_t *ov, err_t *err)
{
    const scene_desc_t *d = L->desc;
    scene_t *sc = L->sc;
    render_settings_t *rs = &sc->settings;
    static const pbrt_name_t CAMERAS[] = {{"perspective", CAMERA_PERSPECTIVE},
                                          {"orthographic", CAMERA_ORTHOGRAPHIC},
                                          {"spherical", CAMERA_SPHERICAL},
                                          {"realistic", CAMERA_REALISTIC}};
    int kind;
    if (pbrt_names_lookup(CAMERAS, sizeof CAMERAS / sizeof CAMERAS[0], "unsupported camera",
                          d->camera.type, d->camera.loc, &kind, err))
        return -1;
    sc->camera.kind = (camera_kind_t)kind;
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
        return pbrt_error(err, d->camera.loc, "\"float fov\" must be in (0, 180) degrees, got %g",
                          d->camera.fov);
    rs->xres = ov && ov->xres > 0 ? ov->xres : d->film.xres;
    rs->yres = ov && ov->yres > 0 ? ov->yres : d->film.yres;
    if (rs->xres <= 0 || rs->yres <= 0 || rs->xres > 32768 || rs->yres > 32768)
        return pbrt_error(err, d->film.loc, "film resolution %dx%d is outside 1..32768", rs->xres,
                          rs->yres);
    if (load_film_crop(L, err) || load_filter(L, err))
        return -1;
    rs->imaging_ratio = d->film.exposuretime * d->film.iso / 100.0;
    rs->max_component = d->film.maxcomponentvalue;
    if (strcmp(d->film.sensor, "cie1931") != 0 || d->film.whitebalance != 0.0) {
        sc->sensor = sensor_new(d->film.sensor, d->film.whitebalance, err);
        if (!sc->sensor) {
            pbrt_loc_t at = strcmp(d->film.sensor, "cie1931") != 0 ? d->film.sensor_loc
                                                                   : d->film.whitebalance_loc;
            return err_prefix(err, "%s:%d:%d: Film: ", at.file, at.line, at.col);
        }
    }
    if (spectral_grid_init(&rs->grid, d->film.nbuckets, d->film.lambda_min, d->film.lambda_max,
                           err))
        return err_prefix(err, "%s:%d:%d: Film: ", d->film.loc.file, d->film.loc.line,
                          d->film.loc.col);
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
        return pbrt_error(err, d->sampler.loc, "pixelsamples must be in 1..%d, got %d", 1 << 24,
                          rs->spp);
    rs->seed = ov && ov->seed >= 0 ? (uint64_t)ov->seed : (uint64_t)(uint32_t)d->sampler.seed;
    const char *why;
    if (sampler_kind_parse(d->sampler.type, &rs->sampler, &why))
        return pbrt_error(err, d->sampler.loc, "unsupported sampler \"%s\"", d->sampler.type);
    if (why && warnings_add(L->sc->warnings, d->sampler.loc, "%s", why))
        return err_set(err, "out of memory");
    return 0;
}
