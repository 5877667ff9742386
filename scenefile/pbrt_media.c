#define _XOPEN_SOURCE 700 /* strdup */

#include "pbrt_media.h"

#include "medium_presets.h"
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

/* MakeNamedMedium "name" "string type" ... (pbrt-v4 media.cpp): "homogeneous" and
 * "uniformgrid" are read with pbrt-v4's parameters and defaults, "nanovdb" names its file and
 * grids (the loader reads them); "rgbgrid" and "cloud" are accepted with a warning and render
 * as vacuum. Whether media are simulated at
 * all depends on the integrator (the loader says so). */
static int read_medium_common(parser_t *P, params_t *ps, scene_medium_t *m)
{
    pbrt_loc_t at = m->loc;
    m->sigma_a = pbrt_inputs_constant(1.0, at);
    m->sigma_s = pbrt_inputs_constant(1.0, at);
    const char *preset = NULL;
    if (m->type == SCENE_MEDIUM_HOMOGENEOUS &&
        params_get_string(ps, "preset", NULL, &preset, P->err) != 0)
        return -1;
    bool have_preset = false;
    if (preset && preset[0]) {
        double ss[3], sa[3];
        if (medium_preset_find(preset, ss, sa)) {
            have_preset = true;
            m->sigma_a = (scene_spectrum_t){.kind = SCENE_SPECTRUM_RGB,
                                            .rgb = {sa[0], sa[1], sa[2]},
                                            .loc = params_find(ps, "preset")->loc};
            m->sigma_s = (scene_spectrum_t){.kind = SCENE_SPECTRUM_RGB,
                                            .rgb = {ss[0], ss[1], ss[2]},
                                            .loc = params_find(ps, "preset")->loc};
        } else if (warnings_add(
                       P->scene->warnings, params_find(ps, "preset")->loc,
                       "medium preset \"%s\" is not known (pbrt-v4's table of measured media); "
                       "\"sigma_a\" and \"sigma_s\" apply",
                       preset)) {
            return err_set(P->err, "out of memory");
        }
    }
    if (!have_preset &&
        (pbrt_inputs_spectrum(P, ps, "sigma_a", m->sigma_a, SPECTRUM_ANY, &m->sigma_a) != 0 ||
         pbrt_inputs_spectrum(P, ps, "sigma_s", m->sigma_s, SPECTRUM_ANY, &m->sigma_s) != 0))
        return -1;
    if (have_preset) {
        /* pbrt-v4 reads the preset instead: the two spectra are not looked at. */
        param_t *q;
        if ((q = params_find(ps, "sigma_a")))
            q->used = true;
        if ((q = params_find(ps, "sigma_s")))
            q->used = true;
    }
    if (params_get_float(ps, "scale", 1.0, &m->scale, P->err) != 0 ||
        pbrt_state_check_range(P, ps, "scale", m->scale, 0.0, INFINITY) != 0 ||
        params_get_float(ps, "g", 0.0, &m->g, P->err) != 0)
        return -1;
    if (!(m->g > -1.0 && m->g < 1.0)) {
        param_t *q = params_find(ps, "g");
        return pbrt_error(P->err, q ? q->loc : at, "\"float g\" must be in (-1, 1), got %g", m->g);
    }
    if (m->type != SCENE_MEDIUM_NANOVDB && params_find(ps, "Le")) {
        m->has_Le = true;
        if (pbrt_inputs_spectrum(P, ps, "Le", pbrt_inputs_constant(0.0, at), SPECTRUM_ANY,
                                 &m->Le) != 0)
            return -1;
    }
    m->Le_scale = 1.0;
    if (m->type == SCENE_MEDIUM_HOMOGENEOUS &&
        (params_get_float(ps, "Lescale", 1.0, &m->Le_scale, P->err) != 0 ||
         pbrt_state_check_range(P, ps, "Lescale", m->Le_scale, 0.0, INFINITY) != 0))
        return -1;
    return 0;
}

/* "nanovdb" (pbrt-v4 NanoVDBMedium::Create): the file is a data file of the scene (noted, so
 * that bundles carry it and `check` lists it when missing; opened and read by the loader),
 * the grids are named by "gridname" and "temperaturename", the emission set by "Lescale",
 * "temperatureoffset" (or "temperaturecutoff") and "temperaturescale". */
static int read_medium_nanovdb(parser_t *P, params_t *ps, scene_medium_t *m)
{
    const char *filename;
    if (params_get_string(ps, "filename", NULL, &filename, P->err) != 0)
        return -1;
    if (!filename || !filename[0])
        return pbrt_error(P->err, m->loc, "MakeNamedMedium \"nanovdb\" needs \"string filename\"");
    const param_t *fp = params_find(ps, "filename");
    m->filename_loc = fp->loc;
    if (pbrt_inputs_data_file(P, fp, filename, "the nanovdb medium's file", SCENE_FILE_VOLUME, &m->filename) != 0)
        return -1;
    const char *gridname, *tempname;
    double cutoff;
    if (params_get_string(ps, "gridname", "density", &gridname, P->err) != 0 ||
        params_get_string(ps, "temperaturename", "temperature", &tempname, P->err) != 0 ||
        params_get_float(ps, "Lescale", 1.0, &m->Le_scale, P->err) != 0 ||
        pbrt_state_check_range(P, ps, "Lescale", m->Le_scale, 0.0, INFINITY) != 0 ||
        params_get_float(ps, "temperaturecutoff", 0.0, &cutoff, P->err) != 0 ||
        params_get_float(ps, "temperatureoffset", cutoff, &m->temperature_offset, P->err) != 0 ||
        params_get_float(ps, "temperaturescale", 1.0, &m->temperature_scale, P->err) != 0)
        return -1;
    if (!(m->gridname = scene_desc_strdup(P->scene, gridname, P->err)) ||
        !(m->temperaturename = scene_desc_strdup(P->scene, tempname, P->err)))
        return -1;
    return 0;
}

static int read_medium_grid(parser_t *P, params_t *ps, scene_medium_t *m)
{
    param_t *d = NULL, *temp = NULL, *les = NULL;
    if (params_get_array(ps, "density", PARAM_FLOAT, &d, P->err) != 0 ||
        params_get_array(ps, "temperature", PARAM_FLOAT, &temp, P->err) != 0 ||
        params_get_array(ps, "Lescale", PARAM_FLOAT, &les, P->err) != 0 ||
        params_get_int(ps, "nx", 1, &m->nx, P->err) != 0 ||
        params_get_int(ps, "ny", 1, &m->ny, P->err) != 0 ||
        params_get_int(ps, "nz", 1, &m->nz, P->err) != 0 ||
        params_get_point3(ps, "p0", vec3_make(0, 0, 0), &m->p0, P->err) != 0 ||
        params_get_point3(ps, "p1", vec3_make(1, 1, 1), &m->p1, P->err) != 0)
        return -1;
    if (!d)
        return pbrt_error(
            P->err, m->loc,
            "MakeNamedMedium \"%s\": a \"uniformgrid\" medium needs \"float density\" values",
            m->name);
    if (m->nx < 1 || m->ny < 1 || m->nz < 1)
        return pbrt_error(
            P->err, m->loc,
            "MakeNamedMedium \"%s\": \"nx\", \"ny\" and \"nz\" must be at least 1, got %d %d %d",
            m->name, m->nx, m->ny, m->nz);
    if ((double)m->nx * m->ny * m->nz != (double)d->count)
        return pbrt_error(
            P->err, d->loc,
            "MakeNamedMedium \"%s\": %zu \"density\" values, expected nx*ny*nz = %d*%d*%d", m->name,
            d->count, m->nx, m->ny, m->nz);
    for (size_t i = 0; i < d->count; i++)
        if (!(d->numbers[i] >= 0.0) || !isfinite(d->numbers[i]))
            return pbrt_error(
                P->err, d->loc,
                "MakeNamedMedium \"%s\": \"density\" value %zu is %g, expected a finite value >= 0",
                m->name, i, d->numbers[i]);
    if (!(m->p1.x > m->p0.x && m->p1.y > m->p0.y && m->p1.z > m->p0.z))
        return pbrt_error(P->err, m->loc,
                          "MakeNamedMedium \"%s\": \"p1\" must exceed \"p0\" on every axis",
                          m->name);
    if (!(m->density = pbrt_state_copy_doubles(P, d->numbers, d->count)))
        return -1;
    if (temp) {
        /* pbrt-v4 emits blackbody light from a temperature grid; prismfarm does not. */
        const char *extra[] = {"temperaturecutoff", "temperatureoffset", "temperaturescale"};
        for (size_t i = 0; i < COUNT_OF(extra); i++) {
            param_t *q = params_find(ps, extra[i]);
            if (q)
                q->used = true;
        }
        if (warnings_add(
                P->scene->warnings, temp->loc,
                "the \"temperature\" grid of medium \"%s\" is not simulated: its blackbody "
                "emission is missing from the image",
                m->name))
            return err_set(P->err, "out of memory");
    }
    if (les && les->count == 1) {
        m->Le_scale = les->numbers[0];
    } else if (les) {
        if (warnings_add(P->scene->warnings, les->loc,
                         "the per-voxel \"Lescale\" of medium \"%s\" is not simulated: the medium "
                         "does not emit",
                         m->name))
            return err_set(P->err, "out of memory");
        m->has_Le = false;
    }
    if (!(m->Le_scale >= 0.0) || !isfinite(m->Le_scale))
        return pbrt_error(P->err, les->loc, "\"float Lescale\" must be finite and >= 0, got %g",
                          m->Le_scale);
    return 0;
}

int pbrt_media_read(parser_t *P, pbrt_loc_t loc)
{
    str_arg_t name;
    if (pbrt_state_read_string(P, "MakeNamedMedium", loc, "medium name", &name) != 0)
        return -1;
    params_t *ps = pbrt_state_read_params(P, "MakeNamedMedium");
    if (!ps)
        return -1;
    const char *type = NULL;
    int rc = pbrt_state_attr_apply(P, ps, ATTR_MEDIUM);
    if (rc == 0)
        rc = params_get_string(ps, "type", NULL, &type, P->err);
    if (rc == 0 && !type)
        rc = pbrt_error(P->err, loc, "MakeNamedMedium \"%s\" needs \"string type\"", name.s);
    if (rc == 0 && scene_desc_find_medium(P->scene, name.s) >= 0)
        rc = pbrt_error(P->err, name.loc, "medium \"%s\" is already defined", name.s);
    scene_medium_type_t kind = SCENE_MEDIUM_IGNORED;
    if (rc == 0) {
        static const pbrt_name_t TYPES[] = {{"homogeneous", SCENE_MEDIUM_HOMOGENEOUS},
                                            {"uniformgrid", SCENE_MEDIUM_GRID},
                                            {"rgbgrid", SCENE_MEDIUM_IGNORED},
                                            {"cloud", SCENE_MEDIUM_IGNORED},
                                            {"nanovdb", SCENE_MEDIUM_NANOVDB}};
        int k;
        rc = pbrt_state_lookup(P, "unknown medium type", type, params_find(ps, "type")->loc, TYPES,
                               COUNT_OF(TYPES), &k);
        kind = (scene_medium_type_t)k;
    }
    if (rc == 0 && (kind == SCENE_MEDIUM_GRID || kind == SCENE_MEDIUM_NANOVDB) &&
        pbrt_state_check_transform(P, &P->gs.ctm, kind == SCENE_MEDIUM_GRID ? "MakeNamedMedium \"uniformgrid\""
                                                                           : "MakeNamedMedium \"nanovdb\"",
                                   loc) != 0)
        rc = -1;
    int idx = rc == 0 ? scene_desc_add_medium(P->scene, P->err) : -1;
    if (rc == 0 && idx < 0)
        rc = -1;
    if (rc == 0) {
        scene_medium_t *m = &P->scene->media[idx];
        m->type = kind;
        m->loc = loc;
        m->to_world = P->gs.ctm;
        if (!(m->name = scene_desc_strdup(P->scene, name.s, P->err)) ||
            !(m->type_name = scene_desc_strdup(P->scene, type, P->err)))
            rc = -1;
        if (!P->scene->media_loc.file)
            P->scene->media_loc = loc;
        if (rc == 0 && kind == SCENE_MEDIUM_IGNORED) {
            params_accept_all(ps);
            if (warnings_add(P->scene->warnings, loc,
                             "\"%s\" media are not simulated: medium \"%s\" renders as vacuum "
                             "(empty space), so the image lacks it",
                             type, name.s))
                rc = err_set(P->err, "out of memory");
        } else if (rc == 0) {
            rc = read_medium_common(P, ps, m);
            if (rc == 0 && kind == SCENE_MEDIUM_GRID)
                rc = read_medium_grid(P, ps, m);
            if (rc == 0 && kind == SCENE_MEDIUM_NANOVDB)
                rc = read_medium_nanovdb(P, ps, m);
            if (rc == 0)
                rc = params_check_unused(ps, P->err);
        }
    }
    params_destroy(&ps);
    return rc;
}

/* MediumInterface "inside" ["outside"] (one name: both): the media that shapes from here on
 * separate, and the camera's (the outside one) at Camera. "" is vacuum. */
int pbrt_media_interface(parser_t *P, pbrt_loc_t loc)
{
    str_arg_t names[2];
    if (pbrt_state_read_string(P, "MediumInterface", loc, "medium name", &names[0]) != 0)
        return -1;
    int n = 1;
    pbrt_token_t t;
    if (pbrt_lexer_peek(P->lex, &t, P->err) != 0)
        return -1;
    if (t.kind == PBRT_TOKEN_STRING) {
        if (pbrt_state_read_string(P, "MediumInterface", loc, "medium name", &names[1]) != 0)
            return -1;
        n = 2;
    }
    int idx[2] = {-1, -1};
    for (int i = 0; i < n; i++)
        if (names[i].s[0] && (idx[i] = scene_desc_find_medium(P->scene, names[i].s)) < 0)
            return pbrt_error(P->err, names[i].loc,
                              "medium \"%s\" is not defined (MakeNamedMedium must come before its "
                              "use)",
                              names[i].s);
    P->gs.inside_medium = idx[0];
    P->gs.outside_medium = n == 2 ? idx[1] : idx[0];
    return 0;
}
