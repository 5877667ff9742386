#define _XOPEN_SOURCE 700 /* strdup */

#include "pbrt_lights.h"

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

/* Partially linearly polarised emission (docs/physics.md §14.2): the degree 0..1 and the
 * angle of the plane of polarisation in degrees in the light's (or the shape's) x-y plane. */
static int get_polarisation(parser_t *P, params_t *ps, double *degree, double *angle)
{
    return params_get_float(ps, "polarization", 0.0, degree, P->err) != 0 ||
                   pbrt_state_check_range(P, ps, "polarization", *degree, 0.0, 1.0) != 0 ||
                   params_get_float(ps, "polarizationangle", 0.0, angle, P->err) != 0 ||
                   pbrt_state_check_range(P, ps, "polarizationangle", *angle, -360.0, 360.0) != 0
               ? -1
               : 0;
}

int pbrt_lights_read_area(parser_t *P, params_t *ps, const str_arg_t *type, pbrt_loc_t loc)
{
    static const pbrt_name_t TYPES[] = {{"diffuse", SCENE_AREA_DIFFUSE},
                                        {"collimated", SCENE_AREA_COLLIMATED}};
    int k;
    if (pbrt_state_lookup(P, "unsupported area light", type->s, type->loc, TYPES, COUNT_OF(TYPES),
                          &k) != 0)
        return -1;
    scene_area_light_type_t at = (scene_area_light_type_t)k;
    int idx = scene_desc_add_area_light(P->scene, P->err);
    if (idx < 0)
        return -1;
    scene_area_light_t *a = &P->scene->area_lights[idx];
    a->type = at;
    a->loc = loc;
    /* pbrt-v4 lights default to the colour space's illuminant (D65 for sRGB). */
    if (pbrt_inputs_spectrum(P, ps, "L", pbrt_inputs_named("stdillum-D65", loc), SPECTRUM_ANY,
                             &a->L) != 0 ||
        params_get_float(ps, "scale", 1.0, &a->scale, P->err) != 0 ||
        pbrt_state_check_range(P, ps, "scale", a->scale, 0.0, INFINITY) != 0 ||
        params_get_float(ps, "power", -1.0, &a->power, P->err) != 0)
        return -1;
    /* Polarised emission (§14.2); a collimated light's reaches the photons only (§14.3). */
    if (get_polarisation(P, ps, &a->polarization, &a->polarization_angle) != 0)
        return -1;
    if (at == SCENE_AREA_DIFFUSE &&
        params_get_bool(ps, "twosided", false, &a->twosided, P->err) != 0)
        return -1;
    const char *filename = NULL;
    if (at == SCENE_AREA_DIFFUSE && params_get_string(ps, "filename", NULL, &filename, P->err) != 0)
        return -1;
    if (filename && filename[0]) {
        /* pbrt-v4 DiffuseAreaLight::Create refuses both. */
        if (params_find(ps, "L"))
            return pbrt_error(
                P->err, params_find(ps, "L")->loc,
                "AreaLightSource \"diffuse\": cannot have both \"L\" and \"filename\" "
                "(pbrt-v4 refuses it too)");
        param_t *fp = params_find(ps, "filename");
        if (pbrt_inputs_image_file(P, fp, filename, &a->filename) != 0)
            return -1;
        a->filename_loc = fp->loc;
    }
    P->gs.area_light = idx;
    return 0;
}

/* LightSource "infinite": "string filename" names an equal-area environment image (read by
 * scene_load, which checks that it is square), "point3 portal" is accepted with a warning
 * (portals only guide sampling in pbrt-v4; sampling without them is unbiased). As in pbrt-v4
 * lights.cpp, "L" together with "filename" is an error. */
static int infinite_light_image(parser_t *P, params_t *ps, scene_light_t *l)
{
    const char *filename;
    param_t *portal;
    if (params_get_string(ps, "filename", NULL, &filename, P->err) != 0 ||
        params_get_array(ps, "portal", PARAM_POINT3, &portal, P->err) != 0)
        return -1;
    if (portal && warnings_add(P->scene->warnings, portal->loc,
                               "LightSource \"infinite\": \"portal\" is not used (the light is "
                               "sampled without it, which is unbiased but noisier indoors)"))
        return pbrt_error(P->err, portal->loc, "out of memory");
    if (!filename)
        return 0;
    param_t *fp = params_find(ps, "filename");
    if (params_find(ps, "L"))
        return pbrt_error(P->err, params_find(ps, "L")->loc,
                          "LightSource \"infinite\": cannot have both \"L\" and \"filename\" "
                          "(pbrt-v4 refuses it too)");
    const char *path = pbrt_confine_scene_path(P, filename, fp->loc);
    if (!path)
        return -1;
    if (P->root_real) {
        char *real = pbrt_confine_check(P, path, filename, &fp->loc, "image");
        if (!real)
            return -1;
        size_t size;
        int fd = pbrt_confine_open(P, real, filename, path, &fp->loc, "image", &size);
        int rc = fd < 0 ? -1 : pbrt_confine_charge(P, size, &fp->loc);
        if (fd >= 0)
            close(fd);
        l->filename = rc == 0 ? scene_desc_strdup(P->scene, real, P->err) : NULL;
        free(real);
        if (!l->filename)
            return -1;
    } else {
        const char *kind;
        char why[96];
        FILE *f = pbrt_confine_open_regular(path, &kind);
        if (!f)
            return pbrt_error(P->err, fp->loc, "cannot open image \"%s\": %s", path,
                              pbrt_confine_open_failure(kind, why, sizeof why));
        fclose(f);
        l->filename = path;
    }
    l->filename_loc = fp->loc;
    return pbrt_inputs_note_file(P, SCENE_FILE_IMAGE, path, filename, fp->loc);
}

/* LightSource "goniometric" and "projection": "string filename" is required (pbrt-v4 refuses
 * a projection light without one; a goniometric light without one it warns about and renders
 * black, which prismfarm refuses as a likely mistake). The light sits at the CTM's origin; a
 * projection light's "float fov" (90) is the angle of the image's shorter axis, in (0, 180).
 * scene_load reads the image (and checks a goniometric one is square). */
static int image_light(parser_t *P, params_t *ps, scene_light_t *l, const char *kind,
                       pbrt_loc_t loc)
{
    const char *filename;
    if (params_get_string(ps, "filename", NULL, &filename, P->err) != 0)
        return -1;
    if (l->type == SCENE_LIGHT_PROJECTION) {
        if (params_get_float(ps, "fov", 90.0, &l->fov, P->err) != 0)
            return -1;
        if (!(l->fov > 0.0 && l->fov < 180.0)) {
            param_t *fp = params_find(ps, "fov");
            return pbrt_error(P->err, fp ? fp->loc : loc,
                              "\"float fov\" must be strictly between 0 and 180 degrees, got %g",
                              l->fov);
        }
    }
    if (!filename || !filename[0])
        return pbrt_error(P->err, loc, "LightSource \"%s\" needs \"string filename\" (its image)",
                          kind);
    param_t *fp = params_find(ps, "filename");
    if (pbrt_inputs_image_file(P, fp, filename, &l->filename) != 0)
        return -1;
    l->filename_loc = fp->loc;
    return 0;
}

int pbrt_lights_read(parser_t *P, params_t *ps, const str_arg_t *type, pbrt_loc_t loc)
{
    static const pbrt_name_t TYPES[] = {{"point", SCENE_LIGHT_POINT},
                                        {"spot", SCENE_LIGHT_SPOT},
                                        {"distant", SCENE_LIGHT_DISTANT},
                                        {"infinite", SCENE_LIGHT_INFINITE},
                                        {"goniometric", SCENE_LIGHT_GONIOMETRIC},
                                        {"projection", SCENE_LIGHT_PROJECTION}};
    int lt;
    if (pbrt_state_lookup(P, "unsupported light", type->s, type->loc, TYPES, COUNT_OF(TYPES),
                          &lt) != 0 ||
        pbrt_state_check_transform(P, &P->gs.ctm, "LightSource", loc) != 0)
        return -1;
    int idx = scene_desc_add_light(P->scene, P->err);
    if (idx < 0)
        return -1;
    scene_light_t *l = &P->scene->lights[idx];
    l->type = (scene_light_type_t)lt;
    l->loc = loc;
    l->to_world = P->gs.ctm;
    const int positional = l->type != SCENE_LIGHT_DISTANT && l->type != SCENE_LIGHT_INFINITE;
    const char *sname = positional ? "I" : "L";
    /* pbrt-v4 lights.cpp: point, spot, goniometric and projection lights take "power", distant
     * and infinite lights "illuminance"; a value <= 0 means "not given". */
    const char *pname = positional ? "power" : "illuminance";
    /* A projection light has no spectrum parameter: its image's colours are RGB illuminant
     * spectra of the colour space (pbrt-v4 ProjectionLight::Create reads no "I"). */
    if (l->type == SCENE_LIGHT_PROJECTION)
        l->spectrum = pbrt_inputs_named("stdillum-D65", loc);
    else if (pbrt_inputs_spectrum(P, ps, sname, pbrt_inputs_named("stdillum-D65", loc),
                                  SPECTRUM_ANY, &l->spectrum) != 0)
        return -1;
    if (params_get_float(ps, "scale", 1.0, &l->scale, P->err) != 0 ||
        pbrt_state_check_range(P, ps, "scale", l->scale, 0.0, INFINITY) != 0 ||
        params_get_float(ps, pname, -1.0, &l->power, P->err) != 0)
        return -1;
    /* Point, spot and distant lights may emit polarised light; environments and image lights
     * do not (yet). */
    if ((l->type == SCENE_LIGHT_POINT || l->type == SCENE_LIGHT_SPOT ||
         l->type == SCENE_LIGHT_DISTANT) &&
        get_polarisation(P, ps, &l->polarization, &l->polarization_angle) != 0)
        return -1;
    if (l->type == SCENE_LIGHT_INFINITE)
        return infinite_light_image(P, ps, l);
    if (l->type == SCENE_LIGHT_GONIOMETRIC || l->type == SCENE_LIGHT_PROJECTION)
        return image_light(P, ps, l, type->s, loc);
    if (params_get_point3(ps, "from", vec3_make(0, 0, 0), &l->from, P->err) != 0)
        return -1;
    if (l->type == SCENE_LIGHT_POINT)
        return 0;
    if (params_get_point3(ps, "to", vec3_make(0, 0, 1), &l->to, P->err) != 0)
        return -1;
    if (vec3_length(vec3_sub(l->to, l->from)) == 0.0)
        return pbrt_error(P->err, loc, "LightSource \"%s\": \"from\" and \"to\" are the same point",
                          type->s);
    if (l->type == SCENE_LIGHT_DISTANT)
        return 0;
    if (params_get_float(ps, "coneangle", 30.0, &l->coneangle, P->err) != 0 ||
        params_get_float(ps, "conedeltaangle", 5.0, &l->conedeltaangle, P->err) != 0 ||
        pbrt_state_check_range(P, ps, "coneangle", l->coneangle, 0.0, 180.0) != 0 ||
        pbrt_state_check_range(P, ps, "conedeltaangle", l->conedeltaangle, 0.0, l->coneangle) != 0)
        return -1;
    return 0;
}
