#define _XOPEN_SOURCE 700 /* strdup */

#include "pbrt_options.h"

#include "integrators.h"

#include "paths.h"
#include "pbrt_confine.h"
#include "pbrt_inputs.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

/* Every sampler pbrt-v4 has (samplers.cpp); prismfarm reads each as its own (docs). */
static const pbrt_name_t SAMPLERS[] = {{"halton", 0},  {"independent", 1}, {"paddedsobol", 2},
                                       {"pmj02bn", 3}, {"sobol", 4},       {"stratified", 5},
                                       {"zsobol", 6}};

/* pbrt-v4's RealisticCamera parameters: the lens file (read here, resolved like every file
 * name and listed in files), the stop's diameter (mm) and the focus distance; prismfarm's
 * "string glasses" names a glass per lens-file line. The aperture image is not simulated. */
static int do_camera_lens(parser_t *P, params_t *ps, scene_camera_t *c, pbrt_loc_t loc)
{
    const char *name;
    param_t *glasses;
    if (params_get_string(ps, "lensfile", "", &name, P->err) != 0 ||
        params_get_float(ps, "aperturediameter", 1.0, &c->aperturediameter, P->err) != 0 ||
        params_get_float(ps, "focusdistance", 10.0, &c->focusdistance, P->err) != 0 ||
        params_get_array(ps, "glasses", PARAM_STRING, &glasses, P->err) != 0)
        return -1;
    if (pbrt_state_check_positive(P, ps, "aperturediameter", c->aperturediameter) != 0 ||
        pbrt_state_check_positive(P, ps, "focusdistance", c->focusdistance) != 0)
        return -1;
    param_t *lp = params_find(ps, "lensfile");
    if (!lp || !*name)
        return pbrt_error(P->err, loc, "Camera \"realistic\" needs \"string lensfile\"");
    const char *aperture;
    if (params_get_string(ps, "aperture", "", &aperture, P->err) != 0)
        return -1;
    if (*aperture &&
        warnings_add(P->scene->warnings, params_find(ps, "aperture")->loc,
                     "\"string aperture\" \"%s\" is not simulated: the stop is round", aperture))
        return err_set(P->err, "out of memory");
    if (glasses) {
        c->glasses = scene_desc_alloc(P->scene, glasses->count * sizeof *c->glasses, P->err);
        if (!c->glasses)
            return -1;
        for (size_t i = 0; i < glasses->count; i++)
            if (!(c->glasses[i] = scene_desc_strdup(P->scene, glasses->strings[i], P->err)))
                return -1;
        c->nglasses = (int)glasses->count;
        c->glasses_loc = glasses->loc;
    }
    char *first = paths_resolve(P->file, name), *second = paths_resolve(P->main_name, name);
    if (!first || !second) {
        free(first);
        free(second);
        return pbrt_error(P->err, lp->loc, "out of memory");
    }
    const char *path = pbrt_confine_present(P, first)    ? first
                       : pbrt_confine_present(P, second) ? second
                                                         : first;
    size_t len = 0;
    char *buf = NULL;
    if (pbrt_confine_bundle_check(P, path, name, lp->loc) != 0) {
        free(first);
        free(second);
        return -1;
    }
    if (P->root_real) {
        char *real = pbrt_confine_check(P, path, name, &lp->loc, "lens file");
        buf = real ? pbrt_confine_read(P, real, name, path, &lp->loc, "lens file", &len) : NULL;
        free(real);
    } else {
        buf = pbrt_inputs_read_file(P, lp, path, "lens file", &len);
    }
    int rc = -1;
    if (buf) {
        c->lens_text = scene_desc_alloc(P->scene, len + 1, P->err);
        c->lens_path = c->lens_text ? scene_desc_strdup(P->scene, path, P->err) : NULL;
        if (c->lens_path) {
            memcpy(c->lens_text, buf, len);
            c->lens_text[len] = 0;
            c->lens_len = len;
            c->lens_loc = lp->loc;
            rc = pbrt_inputs_note_file(P, SCENE_FILE_LENS, path, name, lp->loc);
        }
    }
    free(buf);
    free(first);
    free(second);
    return rc;
}

/* pbrt-v4's cameras.cpp: the perspective camera (fov, thin lens), the orthographic one
 * (thin lens too, no fov), the spherical one (mapping); the screen window and frame aspect of
 * the first two; the shutter, which prismfarm has no use for (no motion blur). */
int pbrt_options_camera(parser_t *P, params_t *ps, const str_arg_t *type, pbrt_loc_t loc)
{
    scene_camera_t *c = &P->scene->camera;
    static const pbrt_name_t TYPES[] = {
        {"perspective", 0}, {"orthographic", 1}, {"spherical", 2}, {"realistic", 3}};
    int k;
    if (pbrt_state_lookup(P, "unsupported camera", type->s, type->loc, TYPES, COUNT_OF(TYPES),
                          &k) != 0 ||
        pbrt_state_check_transform(P, &P->gs.ctm, "Camera", loc) != 0)
        return -1;
    c->type = TYPES[k].name;
    c->loc = loc;
    double open_t, close_t;
    if (params_get_float(ps, "shutteropen", 0.0, &open_t, P->err) != 0 ||
        params_get_float(ps, "shutterclose", 1.0, &close_t, P->err) != 0)
        return -1;
    c->has_analyzer = params_find(ps, "analyzer") != NULL;
    if (c->has_analyzer &&
        (params_get_float(ps, "analyzer", 0.0, &c->analyzer, P->err) != 0 ||
         pbrt_state_check_range(P, ps, "analyzer", c->analyzer, -360.0, 360.0) != 0))
        return -1;
    if (k == 3) {
        if (do_camera_lens(P, ps, c, loc) != 0)
            return -1;
    } else if (k == 2) {
        static const pbrt_name_t MAPPINGS[] = {{"equalarea", 0}, {"equirectangular", 1}};
        const char *mapping;
        int equirect;
        if (params_get_string(ps, "mapping", "equalarea", &mapping, P->err) != 0)
            return -1;
        if (pbrt_state_lookup(P, "unsupported \"string mapping\"", mapping,
                              params_find(ps, "mapping") ? params_find(ps, "mapping")->loc : loc,
                              MAPPINGS, COUNT_OF(MAPPINGS), &equirect) != 0)
            return -1;
        c->equirect = equirect;
    } else {
        if ((k == 0 && params_get_float(ps, "fov", 90.0, &c->fov, P->err) != 0) ||
            params_get_float(ps, "lensradius", 0.0, &c->lensradius, P->err) != 0 ||
            params_get_float(ps, "focaldistance", 1e6, &c->focaldistance, P->err) != 0 ||
            params_get_float(ps, "frameaspectratio", 0.0, &c->frameaspectratio, P->err) != 0)
            return -1;
        param_t *w;
        if (params_get_array(ps, "screenwindow", PARAM_FLOAT, &w, P->err) != 0)
            return -1;
        if (w) {
            if (w->count != 4 || !(w->numbers[0] < w->numbers[1]) ||
                !(w->numbers[2] < w->numbers[3]))
                return pbrt_error(
                    P->err, w->loc,
                    "\"float screenwindow\" needs 4 numbers x0 < x1, y0 < y1, got %zu", w->count);
            memcpy(c->screenwindow, w->numbers, sizeof c->screenwindow);
        }
        if (params_find(ps, "frameaspectratio") && !(c->frameaspectratio > 0.0))
            return pbrt_state_check_positive(P, ps, "frameaspectratio", c->frameaspectratio);
        if (k == 0 && !(c->fov > 0.0 && c->fov < 180.0)) {
            param_t *p = params_find(ps, "fov");
            return pbrt_error(P->err, p->loc,
                              "\"float fov\" must be between 0 and 180 degrees, "
                              "got %g",
                              c->fov);
        }
        if (pbrt_state_check_range(P, ps, "lensradius", c->lensradius, 0.0, INFINITY) != 0 ||
            pbrt_state_check_positive(P, ps, "focaldistance", c->focaldistance) != 0)
            return -1;
    }
    if (open_t != close_t && (params_find(ps, "shutteropen") || params_find(ps, "shutterclose")) &&
        warnings_add(P->scene->warnings, loc,
                     "the shutter (%g to %g) is accepted, but motion blur is not simulated", open_t,
                     close_t))
        return err_set(P->err, "out of memory");
    /* pbrt-v4 scene.cpp: the CTM at Camera is camera-from-world, and the named coordinate
     * system "camera" is its inverse. */
    c->camera_from_world = P->gs.ctm;
    c->medium = P->gs.outside_medium;
    return pbrt_state_set_coordsys(P, "camera", transform_inverse(P->gs.ctm), loc);
}

static int film_warn(parser_t *P, params_t *ps, const char *name, const char *text)
{
    param_t *p = params_find(ps, name);
    if (warnings_add(P->scene->warnings, p->loc, "%s", text) != 0)
        return err_set(P->err, "out of memory");
    return 0;
}

/* pbrt-v4's FilmBase and PixelSensor parameters (film.cpp): the sensor's imaging ratio, the
 * per-sample clamp, the part of the image rendered; what is not simulated warns. */
static int do_film_sensor(parser_t *P, params_t *ps, scene_film_t *f)
{
    const char *sensor;
    bool fp16;
    if (params_get_float(ps, "iso", 100.0, &f->iso, P->err) != 0 ||
        params_get_float(ps, "exposuretime", 1.0, &f->exposuretime, P->err) != 0 ||
        params_get_float(ps, "whitebalance", 0.0, &f->whitebalance, P->err) != 0 ||
        params_get_string(ps, "sensor", "cie1931", &sensor, P->err) != 0 ||
        params_get_float(ps, "maxcomponentvalue", INFINITY, &f->maxcomponentvalue, P->err) != 0 ||
        params_get_float(ps, "diagonal", 35.0, &f->diagonal, P->err) != 0 ||
        params_get_bool(ps, "savefp16", true, &fp16, P->err) != 0)
        return -1;
    if (pbrt_state_check_range(P, ps, "iso", f->iso, 0.0, INFINITY) != 0 ||
        pbrt_state_check_range(P, ps, "exposuretime", f->exposuretime, 0.0, INFINITY) != 0 ||
        pbrt_state_check_range(P, ps, "whitebalance", f->whitebalance, 0.0, INFINITY) != 0 ||
        pbrt_state_check_positive(P, ps, "diagonal", f->diagonal) != 0)
        return -1;
    if (params_find(ps, "maxcomponentvalue") && !(f->maxcomponentvalue > 0.0))
        return pbrt_error(P->err, params_find(ps, "maxcomponentvalue")->loc,
                          "\"float maxcomponentvalue\" must be positive, got %g",
                          f->maxcomponentvalue);
    /* The sensor's name is checked by the loader against the sensors it has (spectral/sensor.h). */
    f->sensor = scene_desc_strdup(P->scene, sensor, P->err);
    if (!f->sensor)
        return -1;
    f->sensor_loc = params_find(ps, "sensor") ? params_find(ps, "sensor")->loc : f->loc;
    f->whitebalance_loc =
        params_find(ps, "whitebalance") ? params_find(ps, "whitebalance")->loc : f->loc;
    /* The EXR is always float32 (prismfarm's spectral layers); pbrt-v4's default is half. */
    if (params_find(ps, "savefp16") && fp16 &&
        film_warn(P, ps, "savefp16",
                  "\"bool savefp16\" is not simulated: the EXR is written as float32") != 0)
        return -1;
    param_t *cw, *pb;
    if (params_get_array(ps, "cropwindow", PARAM_FLOAT, &cw, P->err) != 0 ||
        params_get_array(ps, "pixelbounds", PARAM_INTEGER, &pb, P->err) != 0)
        return -1;
    if (cw && cw->count != 4)
        return pbrt_error(P->err, cw->loc,
                          "\"float cropwindow\" needs 4 values (x0 x1 y0 y1), got %zu", cw->count);
    if (pb && pb->count != 4)
        return pbrt_error(P->err, pb->loc,
                          "\"integer pixelbounds\" needs 4 values (x0 x1 y0 y1), got %zu",
                          pb->count);
    f->has_crop = cw != NULL;
    f->has_pixelbounds = pb != NULL;
    for (int i = 0; i < 4; i++) {
        if (cw)
            f->cropwindow[i] = cw->numbers[i];
        if (pb) {
            if (!(fabs(pb->numbers[i]) <= 65536.0))
                return pbrt_error(P->err, pb->loc,
                                  "\"integer pixelbounds\" value %g is out of range",
                                  pb->numbers[i]);
            f->pixelbounds[i] = (int)pb->numbers[i];
        }
    }
    if (cw && pb &&
        film_warn(P, ps, "pixelbounds",
                  "both \"pixelbounds\" and \"cropwindow\" are given: the crop window is used "
                  "(pbrt-v4)") != 0)
        return -1;
    f->crop_loc = cw ? cw->loc : pb ? pb->loc : f->loc;
    return 0;
}

/* PixelFilter "type" (pbrt-v4 filters.cpp: xradius, yradius and each filter's own). */
int pbrt_options_pixelfilter(parser_t *P, params_t *ps, const str_arg_t *type, pbrt_loc_t loc)
{
    static const pbrt_name_t FILTERS[] = {
        {"box", 0}, {"gaussian", 1}, {"mitchell", 2}, {"sinc", 3}, {"triangle", 4}};
    static const double RADIUS[] = {0.5, 1.5, 2.0, 4.0, 2.0};
    int k;
    if (pbrt_state_lookup(P, "unsupported filter", type->s, type->loc, FILTERS, COUNT_OF(FILTERS),
                          &k) != 0)
        return -1;
    scene_filter_t *f = &P->scene->filter;
    f->type = FILTERS[k].name;
    f->loc = loc;
    if (params_get_float(ps, "xradius", RADIUS[k], &f->xradius, P->err) != 0 ||
        params_get_float(ps, "yradius", RADIUS[k], &f->yradius, P->err) != 0 ||
        pbrt_state_check_range(P, ps, "xradius", f->xradius, 1e-3, 64.0) != 0 ||
        pbrt_state_check_range(P, ps, "yradius", f->yradius, 1e-3, 64.0) != 0)
        return -1;
    if (!strcmp(f->type, "gaussian"))
        return params_get_float(ps, "sigma", 0.5, &f->sigma, P->err) ||
               pbrt_state_check_positive(P, ps, "sigma", f->sigma);
    if (!strcmp(f->type, "mitchell"))
        return params_get_float(ps, "B", 1.0 / 3.0, &f->b, P->err) ||
               params_get_float(ps, "C", 1.0 / 3.0, &f->c, P->err);
    if (!strcmp(f->type, "sinc"))
        return params_get_float(ps, "tau", 3.0, &f->tau, P->err) ||
               pbrt_state_check_positive(P, ps, "tau", f->tau);
    return 0;
}

int pbrt_options_film(parser_t *P, params_t *ps, const str_arg_t *type, pbrt_loc_t loc)
{
    scene_film_t *f = &P->scene->film;
    int nb_def;
    double lmin_def, lmax_def;
    enum { FILM_RGB, FILM_GBUFFER, FILM_SPECTRAL };
    static const pbrt_name_t TYPES[] = {
        {"rgb", FILM_RGB}, {"gbuffer", FILM_GBUFFER}, {"spectral", FILM_SPECTRAL}};
    int k;
    if (pbrt_state_lookup(P, "unsupported film", type->s, type->loc, TYPES, COUNT_OF(TYPES), &k) !=
        0)
        return -1;
    if (k == FILM_RGB) {
        f->type = SCENE_FILM_RGB;
        nb_def = SCENE_RGB_NBUCKETS_DEFAULT;
        lmin_def = SCENE_RGB_LAMBDA_MIN_DEFAULT;
        lmax_def = SCENE_RGB_LAMBDA_MAX_DEFAULT;
    } else if (k == FILM_GBUFFER) {
        /* pbrt-v4's GBufferFilm is an RGB film plus albedo, normal and depth layers. */
        f->type = SCENE_FILM_RGB;
        nb_def = SCENE_RGB_NBUCKETS_DEFAULT;
        lmin_def = SCENE_RGB_LAMBDA_MIN_DEFAULT;
        lmax_def = SCENE_RGB_LAMBDA_MAX_DEFAULT;
        const char *cs;
        if (params_get_string(ps, "coordinatesystem", "camera", &cs, P->err) != 0)
            return -1;
        if (warnings_add(P->scene->warnings, type->loc,
                         "Film \"gbuffer\" is rendered as \"rgb\": its albedo, normal and depth "
                         "layers are not written") != 0)
            return err_set(P->err, "out of memory");
    } else {
        f->type = SCENE_FILM_SPECTRAL;
        nb_def = SCENE_SPECTRAL_NBUCKETS_DEFAULT;
        lmin_def = SCENE_SPECTRAL_LAMBDA_MIN_DEFAULT;
        lmax_def = SCENE_SPECTRAL_LAMBDA_MAX_DEFAULT;
    }
    f->loc = loc;
    const char *filename;
    if (params_get_int(ps, "xresolution", SCENE_FILM_XRES_DEFAULT, &f->xres, P->err) != 0 ||
        params_get_int(ps, "yresolution", SCENE_FILM_YRES_DEFAULT, &f->yres, P->err) != 0 ||
        params_get_string(ps, "filename", "pbrt.exr", &filename, P->err) != 0 ||
        params_get_int(ps, "nbuckets", nb_def, &f->nbuckets, P->err) != 0 ||
        params_get_float(ps, "lambdamin", lmin_def, &f->lambda_min, P->err) != 0 ||
        params_get_float(ps, "lambdamax", lmax_def, &f->lambda_max, P->err) != 0)
        return -1;
    if (pbrt_state_check_range(P, ps, "xresolution", f->xres, 1, 65536) != 0 ||
        pbrt_state_check_range(P, ps, "yresolution", f->yres, 1, 65536) != 0 ||
        pbrt_state_check_range(P, ps, "nbuckets", f->nbuckets, 1, 1024) != 0 ||
        pbrt_state_check_range(P, ps, "lambdamin", f->lambda_min, 1.0, 100000.0) != 0 ||
        pbrt_state_check_range(P, ps, "lambdamax", f->lambda_max, 1.0, 100000.0) != 0)
        return -1;
    if (!(f->lambda_min < f->lambda_max))
        return pbrt_error(P->err, loc, "Film: \"lambdamin\" (%g) must be below \"lambdamax\" (%g)",
                          f->lambda_min, f->lambda_max);
    f->filename = scene_desc_strdup(P->scene, filename, P->err);
    if (!f->filename || do_film_sensor(P, ps, f) != 0 ||
        params_get_bool(ps, "stokes", false, &f->stokes, P->err) != 0)
        return -1;
    return 0;
}

int pbrt_options_sampler(parser_t *P, params_t *ps, const str_arg_t *type, pbrt_loc_t loc)
{
    scene_sampler_t *s = &P->scene->sampler;
    int k;
    if (pbrt_state_lookup(P, "unsupported sampler", type->s, type->loc, SAMPLERS,
                          COUNT_OF(SAMPLERS), &k) != 0)
        return -1;
    s->type = scene_desc_strdup(P->scene, type->s, P->err);
    if (!s->type)
        return -1;
    s->loc = loc;
    P->sampler_seed_given = params_find(ps, "seed") != NULL;
    if (params_get_int(ps, "seed", 0, &s->seed, P->err) != 0)
        return -1;
    if (!strcmp(type->s, "stratified")) {
        /* pbrt-v4's stratified sampler takes a grid of xsamples * ysamples samples per
         * pixel (sampler.c lays its 2D strata out as the squarest grid of that many). */
        int xs, ys;
        bool jitter;
        if (params_get_int(ps, "xsamples", 4, &xs, P->err) != 0 ||
            params_get_int(ps, "ysamples", 4, &ys, P->err) != 0 ||
            params_get_bool(ps, "jitter", true, &jitter, P->err) != 0 ||
            pbrt_state_check_range(P, ps, "xsamples", xs, 1, 65536) != 0 ||
            pbrt_state_check_range(P, ps, "ysamples", ys, 1, 65536) != 0)
            return -1;
        if ((long long)xs * ys > INT_MAX)
            return pbrt_error(P->err, loc, "Sampler: xsamples * ysamples is too large");
        s->pixelsamples = xs * ys;
        return 0;
    }
    if (params_get_int(ps, "pixelsamples", 16, &s->pixelsamples, P->err) != 0 ||
        pbrt_state_check_range(P, ps, "pixelsamples", s->pixelsamples, 1, INT_MAX) != 0)
        return -1;
    return 0;
}

/* pbrt-v4's rendering options (its Options struct), as `Option "name" value` sets them; kind
 * says what value each takes. Only "seed" changes prismfarm's image; the others are debugging
 * or output switches of pbrt-v4 (or, for forcediffuse and the jitter switches, deliberate
 * departures from the scene) that are checked and warned. */
typedef enum { OPT_BOOL, OPT_FLOAT, OPT_STRING, OPT_INT } option_kind_t;

static const struct {
    const char *name;
    option_kind_t kind;
    const char *why; /* NULL: simulated */
} OPTIONS[] = {
    {"seed", OPT_INT, NULL},
    {"disablepixeljitter", OPT_BOOL, "samples stay jittered within their pixel"},
    {"disablewavelengthjitter", OPT_BOOL, "wavelengths stay jittered"},
    {"disabletexturefiltering", OPT_BOOL, "textures stay filtered"},
    {"forcediffuse", OPT_BOOL, "materials keep their own BSDFs"},
    {"displacementedgescale", OPT_FLOAT, "displacement is not simulated"},
    {"msereferenceimage", OPT_STRING, "use bench_accuracy_diff to compare with a reference"},
    {"msereferenceout", OPT_STRING, "use bench_accuracy_diff to compare with a reference"},
    {"rendercoordsys", OPT_STRING, "prismfarm renders in world space"},
    {"pixelstats", OPT_BOOL, "no per-pixel statistics images"},
    {"wavefront", OPT_BOOL, "prismfarm has one CPU renderer"},
};

/* Integrator "type": a name integrators.h knows, refused with its reason or kept with its raw
 * parameters, which the renderer checks (it knows what it uses). On success the scene owns
 * ps. */
int pbrt_options_integrator(parser_t *P, params_t *ps, const str_arg_t *type, pbrt_loc_t loc)
{
    const integrator_name_t *named = integrators_find(type->s);
    if (!named) {
        char names[INTEGRATORS_LIST_MAX];
        integrators_list(false, names, sizeof names);
        const char *best = integrators_suggest(type->s);
        if (best)
            return pbrt_error(P->err, type->loc,
                              "unsupported integrator \"%s\" (did you mean \"%s\"? %s)", type->s,
                              best, names);
        return pbrt_error(P->err, type->loc, "unsupported integrator \"%s\" (%s)", type->s, names);
    }
    if (named->refused)
        return pbrt_error(P->err, type->loc, "unsupported integrator \"%s\": %s", type->s,
                          named->refused);
    scene_integrator_t *in = &P->scene->integrator;
    in->type = scene_desc_strdup(P->scene, type->s, P->err);
    if (!in->type)
        return -1;
    in->loc = loc;
    params_destroy(&in->params);
    in->params = ps;
    return 0;
}

/* Option "name" value (pbrt-v4: a bare true/false, a number or a quoted string). */
int pbrt_options_option(parser_t *P, pbrt_loc_t loc)
{
    str_arg_t name;
    if (pbrt_state_read_string(P, "Option", loc, "option name", &name) != 0)
        return -1;
    pbrt_name_t names[COUNT_OF(OPTIONS)];
    for (size_t i = 0; i < COUNT_OF(OPTIONS); i++)
        names[i] = (pbrt_name_t){OPTIONS[i].name, (int)i};
    int k;
    if (pbrt_state_lookup(P, "unknown option", name.s, name.loc, names, COUNT_OF(names), &k) != 0)
        return -1;
    pbrt_token_t t;
    if (pbrt_lexer_next(P->lex, &t, P->err) != 0)
        return -1;
    pbrt_loc_t vloc = t.kind == PBRT_TOKEN_EOF ? name.loc : t.loc;
    char *end = NULL;
    double v = 0.0;
    switch (OPTIONS[k].kind) {
    case OPT_BOOL:
        if (t.kind != PBRT_TOKEN_WORD || (strcmp(t.text, "true") && strcmp(t.text, "false")))
            return pbrt_error(P->err, vloc, "Option \"%s\" expects true or false", name.s);
        break;
    case OPT_STRING:
        if (t.kind != PBRT_TOKEN_STRING)
            return pbrt_error(P->err, vloc, "Option \"%s\" expects a quoted string", name.s);
        if (!strcmp(name.s, "rendercoordsys")) {
            static const pbrt_name_t SYSTEMS[] = {{"camera", 0}, {"cameraworld", 1}, {"world", 2}};
            int sys;
            if (pbrt_state_lookup(P, "Option \"rendercoordsys\": unknown coordinate system",
                                  t.text, vloc, SYSTEMS, COUNT_OF(SYSTEMS), &sys) != 0)
                return -1;
        }
        break;
    case OPT_FLOAT:
    case OPT_INT:
        if (t.kind == PBRT_TOKEN_WORD)
            v = strtod(t.text, &end);
        if (t.kind != PBRT_TOKEN_WORD || end == t.text || *end || !isfinite(v) ||
            (OPTIONS[k].kind == OPT_INT && (v != floor(v) || fabs(v) > 2147483647.0)))
            return pbrt_error(P->err, vloc, "Option \"%s\" expects %s", name.s,
                              OPTIONS[k].kind == OPT_INT ? "an integer" : "a number");
        break;
    }
    if (!OPTIONS[k].why) { /* seed */
        P->option_seed_set = true;
        P->option_seed = (int)v;
        return 0;
    }
    /* Switching a debugging option off is what prismfarm does anyway: no warning. */
    if (OPTIONS[k].kind == OPT_BOOL && !strcmp(t.text, "false"))
        return 0;
    return warnings_add(P->scene->warnings, loc, "Option \"%s\" is not simulated (%s)", name.s,
                        OPTIONS[k].why)
               ? err_set(P->err, "out of memory")
               : 0;
}
