#define _XOPEN_SOURCE 700 /* strdup */

#include "pbrt_shapes.h"

#include "pbrt_confine.h"
#include "pbrt_inputs.h"
#include "pbrt_meshes.h"
#include "shape_tess.h"

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

/* trianglemesh (3 indices per triangle) or bilinearmesh (4 per patch: p00 p10 p01 p11, made
 * into triangles by shape_tess: a planar patch into (p00 p10 p11) and (p00 p11 p01), which
 * keeps pbrt-v4's normal cross(p10-p00, p01-p00) equal to the triangles' cross(p0-p2,
 * p1-p2); a twisted one into a grid that follows its curve). */
static int mesh_from_params(parser_t *P, params_t *ps, scene_shape_t *s, bool bilinear,
                            pbrt_loc_t loc)
{
    param_t *pp, *pi, *pn, *puv;
    if (params_get_array(ps, "P", PARAM_POINT3, &pp, P->err) != 0)
        return -1;
    if (!pp)
        return pbrt_error(P->err, loc, "Shape \"%s\" needs \"point3 P\"", s->kind);
    size_t nv = pp->count / 3;
    if (nv >= UINT32_MAX)
        return pbrt_error(P->err, pp->loc, "too many points in \"point3 P\"");
    if (params_get_array(ps, "indices", PARAM_INTEGER, &pi, P->err) != 0)
        return -1;
    size_t per = bilinear ? 4 : 3;
    size_t nprims;
    if (!pi) {
        /* pbrt-v4 allows omitting indices for a single triangle or patch. */
        if (nv != per)
            return pbrt_error(P->err, loc,
                              "Shape \"%s\" without \"integer indices\" needs exactly "
                              "%zu points in \"point3 P\", got %zu",
                              s->kind, per, nv);
        nprims = 1;
    } else {
        if (pi->count % per != 0)
            return pbrt_error(P->err, pi->loc,
                              "expected a multiple of %zu numbers after \"%s "
                              "%s\", got %zu",
                              per, pi->type_name, pi->name, pi->count);
        for (size_t i = 0; i < pi->count; i++)
            if (pi->numbers[i] < 0 || pi->numbers[i] >= (double)nv)
                return pbrt_error(P->err, pi->loc,
                                  "index %.0f (entry %zu of \"integer indices\") "
                                  "is out of range: \"point3 P\" has %zu points",
                                  pi->numbers[i], i + 1, nv);
        nprims = pi->count / per;
    }
    if (params_get_array(ps, "N", PARAM_NORMAL3, &pn, P->err) != 0 ||
        params_get_array(ps, "uv", PARAM_POINT2, &puv, P->err) != 0)
        return -1;
    if (pn && pn->count / 3 != nv)
        return pbrt_error(P->err, pn->loc,
                          "\"%s N\" has %zu normals but \"point3 P\" has %zu "
                          "points",
                          pn->type_name, pn->count / 3, nv);
    if (puv && puv->count / 2 != nv)
        return pbrt_error(P->err, puv->loc,
                          "\"%s uv\" has %zu entries but \"point3 P\" has %zu "
                          "points",
                          puv->type_name, puv->count / 2, nv);
    if (bilinear) {
        uint32_t *quads = malloc(4 * nprims * sizeof *quads);
        if (!quads)
            return pbrt_error(P->err, loc, "out of memory");
        for (size_t i = 0; i < 4 * nprims; i++)
            quads[i] = pi ? (uint32_t)pi->numbers[i] : (uint32_t)i;
        mesh_data_t md;
        err_t e;
        int rc = shape_tess_bilinear(pp->numbers, nv, quads, nprims, puv ? puv->numbers : NULL,
                                     pn ? pn->numbers : NULL, &md, &e);
        free(quads);
        if (rc != 0)
            return pbrt_error(P->err, loc, "Shape \"bilinearmesh\": %s", e.msg);
        return pbrt_meshes_adopt(P, s, &md);
    }
    scene_mesh_t *m = &s->mesh;
    m->nvertices = nv;
    m->P = pbrt_state_copy_doubles(P, pp->numbers, pp->count);
    if (!m->P)
        return -1;
    if (pn && !(m->N = pbrt_state_copy_doubles(P, pn->numbers, pn->count)))
        return -1;
    if (puv && !(m->uv = pbrt_state_copy_doubles(P, puv->numbers, puv->count)))
        return -1;
    m->ntriangles = bilinear ? 2 * nprims : nprims;
    if (pbrt_meshes_budget_triangles(P, m->ntriangles, loc) != 0)
        return -1;
    uint32_t *idx = scene_desc_alloc(P->scene, m->ntriangles * 3 * sizeof *idx, P->err);
    if (!idx)
        return -1;
    for (size_t i = 0; i < nprims; i++) {
        uint32_t v[4];
        for (size_t k = 0; k < per; k++)
            v[k] = pi ? (uint32_t)pi->numbers[per * i + k] : (uint32_t)k;
        if (bilinear) {
            uint32_t *t = &idx[6 * i];
            t[0] = v[0], t[1] = v[1], t[2] = v[3];
            t[3] = v[0], t[4] = v[3], t[5] = v[2];
        } else {
            idx[3 * i] = v[0], idx[3 * i + 1] = v[1], idx[3 * i + 2] = v[2];
        }
    }
    m->indices = idx;
    return 0;
}

static int mesh_from_ply(parser_t *P, params_t *ps, scene_shape_t *s, pbrt_loc_t loc)
{
    const char *filename;
    if (params_get_string(ps, "filename", NULL, &filename, P->err) != 0)
        return -1;
    if (!filename)
        return pbrt_error(P->err, loc, "Shape \"plymesh\" needs \"string filename\"");
    param_t *fp = params_find(ps, "filename");
    const char *path = pbrt_confine_scene_path(P, filename, fp->loc);
    if (!path)
        return -1;
    /* A confined parse reads the file here, in file order, so that the bytes it charges and
     * the files it refuses are the same whatever the threads; the decoding is queued. */
    mesh_job_t j = {.kind = MESH_JOB_PLY_FILE, .loc = fp->loc, .path = path};
    if (P->root_real) {
        size_t len;
        char *real = pbrt_confine_check(P, path, filename, &fp->loc, "PLY file");
        char *buf =
            real ? pbrt_confine_read(P, real, filename, path, &fp->loc, "PLY file", &len) : NULL;
        free(real);
        err_t over;
        if (buf && scene_budget_charge_ply_file(P->budget, &P->used, buf, len, path, &over)) {
            free(buf);
            return pbrt_state_fail_at(P, &fp->loc, "%s", over.msg);
        }
        if (!buf || pbrt_confine_inflate(P, &buf, &len, MESH_PLY_BYTES_MAX, path, &fp->loc) != 0) {
            free(buf);
            return -1;
        }
        j.kind = MESH_JOB_PLY_MEMORY;
        j.buf = buf;
        j.len = len;
    }
    /* Listed here, in file order; in check mode (made at once) only once it is made, as a
     * refused directive adds nothing to the scene. */
    if (!P->errors && pbrt_inputs_note_file(P, SCENE_FILE_PLY, path, filename, fp->loc) != 0) {
        pbrt_meshes_job_free(&j);
        return -1;
    }
    if (pbrt_meshes_queue(P, s, &j) != 0)
        return -1;
    return P->errors ? pbrt_inputs_note_file(P, SCENE_FILE_PLY, path, filename, fp->loc) : 0;
}

/* pbrt-v4 Cylinder, tessellated (shape_tess.h): a mesh needs no new intersection, area
 * sampling or instancing code in scene/, and 512 segments a turn keep its area and silhouette
 * within 2.5e-5 of the analytic surface, far below a render's noise. */
static int cylinder_shape(parser_t *P, params_t *ps, scene_shape_t *s, pbrt_loc_t loc)
{
    double r, zmin, zmax, phimax;
    if (params_get_float(ps, "radius", 1.0, &r, P->err) != 0 ||
        pbrt_state_check_positive(P, ps, "radius", r) != 0 ||
        params_get_float(ps, "zmin", -1.0, &zmin, P->err) != 0 ||
        params_get_float(ps, "zmax", 1.0, &zmax, P->err) != 0 ||
        params_get_float(ps, "phimax", 360.0, &phimax, P->err) != 0 ||
        pbrt_state_check_range(P, ps, "phimax", phimax, 1e-6, 360.0) != 0)
        return -1;
    if (zmin == zmax)
        return pbrt_error(P->err, loc, "Shape \"cylinder\": zmin and zmax are both %g (no height)",
                          zmin);
    mesh_data_t md;
    err_t e;
    if (shape_tess_cylinder(r, zmin, zmax, phimax, &md, &e) != 0)
        return pbrt_error(P->err, loc, "Shape \"cylinder\": %s", e.msg);
    s->radius = r;
    return pbrt_meshes_adopt(P, s, &md);
}

/* pbrt-v4 "loopsubdiv": "integer levels" (3), "point3 P", "integer indices" (3 per control
 * triangle), subdivided here into the mesh pbrt-v4 renders (loopsubdiv.h). */
static int loopsubdiv_shape(parser_t *P, params_t *ps, scene_shape_t *s, pbrt_loc_t loc)
{
    param_t *pp, *pi;
    int levels;
    if (params_get_int(ps, "levels", 3, &levels, P->err) != 0 ||
        pbrt_state_check_range(P, ps, "levels", levels, 0.0, 12.0) != 0 ||
        params_get_array(ps, "P", PARAM_POINT3, &pp, P->err) != 0 ||
        params_get_array(ps, "indices", PARAM_INTEGER, &pi, P->err) != 0)
        return -1;
    if (!pp)
        return pbrt_error(P->err, loc, "Shape \"loopsubdiv\" needs \"point3 P\"");
    if (!pi)
        return pbrt_error(P->err, loc, "Shape \"loopsubdiv\" needs \"integer indices\"");
    size_t nv = pp->count / 3;
    if (nv >= UINT32_MAX)
        return pbrt_error(P->err, pp->loc, "too many points in \"point3 P\"");
    if (pi->count % 3 != 0 || pi->count == 0)
        return pbrt_error(P->err, pi->loc,
                          "expected a non-zero multiple of 3 numbers after \"%s %s\", got %zu",
                          pi->type_name, pi->name, pi->count);
    uint32_t *idx = malloc(pi->count * sizeof *idx);
    if (!idx)
        return pbrt_error(P->err, loc, "out of memory");
    for (size_t i = 0; i < pi->count; i++) {
        if (pi->numbers[i] < 0 || pi->numbers[i] >= (double)nv) {
            free(idx);
            return pbrt_error(P->err, pi->loc,
                              "index %.0f (entry %zu of \"integer indices\") is out of range: "
                              "\"point3 P\" has %zu points",
                              pi->numbers[i], i + 1, nv);
        }
        idx[i] = (uint32_t)pi->numbers[i];
    }
    /* Each level makes four triangles of one: counted before anything is subdivided. */
    uint64_t after = pi->count / 3;
    for (int l = 0; l < levels && after <= UINT64_MAX / 4; l++)
        after *= 4;
    if (P->budget && P->budget->triangles) {
        /* Queued meshes not yet made count as none: the bound is a lower one, so a refusal
         * here is right, and pbrt_meshes_finish finds whether one of them failed first. */
        uint64_t lower = P->ntriangles + P->ntriangles_ahead;
        if (lower < P->ntriangles || lower > P->budget->triangles ||
            after > P->budget->triangles - lower) {
            free(idx);
            if (P->njobs > 0 && pbrt_meshes_note_count(P, -1, after, loc) != 0)
                return -1;
            return pbrt_meshes_budget_refuse(P, after, loc);
        }
    }
    mesh_job_t j = {.kind = MESH_JOB_LOOP,
                    .loc = loc,
                    .idx = idx,
                    .nv = nv,
                    .nt = pi->count / 3,
                    .levels = levels};
    if (!(j.P = malloc(pp->count * sizeof *j.P))) {
        free(idx);
        return pbrt_error(P->err, loc, "out of memory");
    }
    memcpy(j.P, pp->numbers, pp->count * sizeof *j.P);
    return pbrt_meshes_queue(P, s, &j);
}

/* One segment's cubic Bezier control points from pbrt-v4's bases (shapes.cpp Curve::Create):
 * a quadratic Bezier raised to a cubic, and a uniform B-spline's span as a Bezier (its knot
 * averages, the blossoms at 0..3). q holds degree + 1 points, b gets 4. */
static void curve_to_bezier(const double *q, int degree, bool bspline, double *b)
{
    for (int c = 0; c < 3; c++) {
        double p0 = q[c], p1 = q[3 + c], p2 = q[6 + c];
        if (degree == 3 && !bspline) {
            b[c] = p0, b[3 + c] = p1, b[6 + c] = p2, b[9 + c] = q[9 + c];
            continue;
        }
        if (degree == 3) {
            double p3 = q[9 + c];
            b[c] = (p0 + 4.0 * p1 + p2) / 6.0;
            b[3 + c] = (2.0 * p1 + p2) / 3.0;
            b[6 + c] = (p1 + 2.0 * p2) / 3.0;
            b[9 + c] = (p1 + 4.0 * p2 + p3) / 6.0;
            continue;
        }
        if (bspline) { /* the quadratic B-spline's span as a quadratic Bezier */
            double a = 0.5 * (p0 + p1), e = 0.5 * (p1 + p2);
            p0 = a;
            p2 = e;
        }
        b[c] = p0;
        b[3 + c] = p0 + 2.0 / 3.0 * (p1 - p0);
        b[6 + c] = p2 + 2.0 / 3.0 * (p1 - p2);
        b[9 + c] = p2;
    }
}

/* A ribbon's normals (pn: nseg + 1 of them) as each segment's two ends, normalised (6 numbers
 * per segment, in the scene's memory). Refused: a wrong count, a zero or non-finite normal,
 * and a segment whose two normals are opposite (pbrt-v4's slerp divides by sin of their angle,
 * which is then 0, and no plane of rotation is preferred). */
static int curve_normals(parser_t *P, const param_t *pn, size_t nseg, double **out)
{
    if (pn->count / 3 != nseg + 1)
        return pbrt_error(P->err, pn->loc,
                          "Shape \"curve\": a ribbon of %zu segments needs %zu normals in "
                          "\"normal N\", got %zu",
                          nseg, nseg + 1, pn->count / 3);
    double *n = scene_desc_alloc(P->scene, 6 * nseg * sizeof *n, P->err);
    if (!n)
        return -1;
    for (size_t k = 0; k <= nseg; k++) {
        const double *q = pn->numbers + 3 * k;
        double len = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
        if (!(len > 0.0) || !isfinite(len))
            return pbrt_error(P->err, pn->loc,
                              "Shape \"curve\": normal %zu of \"normal N\" is zero or not finite",
                              k);
        for (int c = 0; c < 3; c++) {
            if (k < nseg)
                n[6 * k + c] = q[c] / len;
            if (k > 0)
                n[6 * (k - 1) + 3 + c] = q[c] / len;
        }
        if (k > 0) {
            const double *a = n + 6 * (k - 1);
            if (a[0] * a[3] + a[1] * a[4] + a[2] * a[5] < -1.0 + 1e-12)
                return pbrt_error(P->err, pn->loc,
                                  "Shape \"curve\": normals %zu and %zu of \"normal N\" are "
                                  "opposite: a ribbon cannot turn half a turn in one segment",
                                  k - 1, k);
        }
    }
    *out = n;
    return 0;
}

/* pbrt-v4 "curve": "point3 P", "string basis" ("bezier", "bspline"), "integer degree" (3 or 2),
 * "string type" ("flat", "cylinder", "ribbon"), "normal N" (a ribbon's: one per segment end,
 * segment k from N[k] to N[k + 1], as pbrt-v4's Curve::Create; ignored by the other types, as
 * pbrt-v4 does after a warning), "float width" (1) or "width0"/"width1" (pbrt-v4 lerps them
 * over the whole curve), "integer splitdepth" (read; Embree needs no splitting). */
static int curve_shape(parser_t *P, params_t *ps, scene_shape_t *s, pbrt_loc_t loc)
{
    double width, w0, w1;
    int degree, split;
    const char *basis, *type;
    param_t *pp;
    if (params_get_float(ps, "width", 1.0, &width, P->err) != 0 ||
        params_get_float(ps, "width0", width, &w0, P->err) != 0 ||
        params_get_float(ps, "width1", width, &w1, P->err) != 0 ||
        params_get_int(ps, "degree", 3, &degree, P->err) != 0 ||
        params_get_int(ps, "splitdepth", 3, &split, P->err) != 0 ||
        params_get_string(ps, "basis", "bezier", &basis, P->err) != 0 ||
        params_get_string(ps, "type", "flat", &type, P->err) != 0 ||
        params_get_array(ps, "P", PARAM_POINT3, &pp, P->err) != 0)
        return -1;
    if (!(w0 > 0.0) || !(w1 > 0.0) || !isfinite(w0 + w1))
        return pbrt_error(P->err, loc, "Shape \"curve\": widths must be positive, got %g and %g",
                          w0, w1);
    if (degree != 2 && degree != 3)
        return pbrt_error(P->err, params_find(ps, "degree")->loc,
                          "Shape \"curve\": \"integer degree\" must be 2 or 3, got %d", degree);
    static const pbrt_name_t BASES[] = {{"bezier", 0}, {"bspline", 1}};
    static const pbrt_name_t TYPES[] = {{"flat", 0}, {"cylinder", 1}, {"ribbon", 2}};
    int bspline, kind;
    if (pbrt_state_lookup(P, "Shape \"curve\": unsupported basis", basis,
                          params_find(ps, "basis") ? params_find(ps, "basis")->loc : loc, BASES,
                          COUNT_OF(BASES), &bspline) != 0)
        return -1;
    if (pbrt_state_lookup(P, "Shape \"curve\": unsupported type", type,
                          params_find(ps, "type") ? params_find(ps, "type")->loc : loc, TYPES,
                          COUNT_OF(TYPES), &kind) != 0)
        return -1;
    param_t *pn;
    if (params_get_array(ps, "N", PARAM_NORMAL3, &pn, P->err) != 0)
        return -1;
    if (kind == 2 && !pn)
        return pbrt_error(P->err, loc,
                          "Shape \"curve\": a \"ribbon\" needs \"normal N\" at its segments' ends");
    if (!pp)
        return pbrt_error(P->err, loc, "Shape \"curve\" needs \"point3 P\"");
    size_t np = pp->count / 3, nseg;
    if (!bspline) {
        if (np < (size_t)degree + 1 || (np - 1) % (size_t)degree != 0)
            return pbrt_error(P->err, pp->loc,
                              "Shape \"curve\": a degree-%d Bezier curve needs %d + n * %d points "
                              "in \"point3 P\", got %zu",
                              degree, degree + 1, degree, np);
        nseg = (np - 1) / (size_t)degree;
    } else {
        if (np < (size_t)degree + 1)
            return pbrt_error(P->err, pp->loc,
                              "Shape \"curve\": a degree-%d B-spline needs at least %d points in "
                              "\"point3 P\", got %zu",
                              degree, degree + 1, np);
        nseg = np - (size_t)degree;
    }
    for (size_t i = 0; i < pp->count; i++)
        if (!isfinite(pp->numbers[i]))
            return pbrt_error(P->err, pp->loc, "Shape \"curve\": point %zu is not finite", i / 3);
    double *n = NULL;
    if (kind == 2 && curve_normals(P, pn, nseg, &n) != 0)
        return -1;
    if (pbrt_meshes_budget_triangles(P, nseg, loc) != 0)
        return -1;
    double *cp = scene_desc_alloc(P->scene, 12 * nseg * sizeof *cp, P->err);
    double *w = scene_desc_alloc(P->scene, 2 * nseg * sizeof *w, P->err);
    if (!cp || !w)
        return -1;
    for (size_t k = 0; k < nseg; k++) {
        size_t first = bspline ? k : k * (size_t)degree;
        curve_to_bezier(pp->numbers + 3 * first, degree, bspline, cp + 12 * k);
        w[2 * k] = w0 + (w1 - w0) * (double)k / (double)nseg;
        w[2 * k + 1] = w0 + (w1 - w0) * (double)(k + 1) / (double)nseg;
    }
    s->curve_segments = nseg;
    s->curve_cp = cp;
    s->curve_width = w;
    s->curve_normals = n;
    s->curve_cylinder = kind == 1;
    return 0;
}

int pbrt_shapes_read(parser_t *P, params_t *ps, const str_arg_t *type, pbrt_loc_t loc)
{
    /* Each shape's name and what it becomes (the value: the index into TYPES). */
    static const pbrt_name_t KINDS[] = {{"sphere", 0},       {"disk", 1},    {"cylinder", 2},
                                        {"trianglemesh", 3}, {"plymesh", 4}, {"bilinearmesh", 5},
                                        {"loopsubdiv", 6},   {"curve", 7}};
    static const scene_shape_type_t TYPES[] = {
        SCENE_SHAPE_SPHERE, SCENE_SHAPE_DISK, SCENE_SHAPE_MESH, SCENE_SHAPE_MESH,
        SCENE_SHAPE_MESH,   SCENE_SHAPE_MESH, SCENE_SHAPE_MESH, SCENE_SHAPE_CURVE};
    int ki;
    if (pbrt_state_lookup(P, "unsupported shape", type->s, type->loc, KINDS, COUNT_OF(KINDS),
                          &ki) != 0 ||
        pbrt_state_check_transform(P, &P->gs.ctm, "Shape", loc) != 0)
        return -1;
    bool in_object = P->object >= 0;
    if (in_object && P->gs.area_light >= 0)
        return pbrt_error(P->err, loc,
                          "area lights are not supported inside ObjectBegin "
                          "(AreaLightSource at line %d)",
                          P->scene->area_lights[P->gs.area_light].loc.line);
    if (pbrt_meshes_budget_shape(P, "Shape", loc) != 0)
        return -1;
    int idx = scene_desc_add_shape(P->scene, in_object, P->err);
    if (idx < 0)
        return -1;
    scene_shape_t *s = in_object ? &P->scene->object_shapes[idx] : &P->scene->shapes[idx];
    s->type = TYPES[ki];
    s->kind = KINDS[ki].name;
    s->loc = loc;
    s->to_world = P->gs.ctm;
    s->reverse_orientation = P->gs.reverse;
    s->swaps_handedness = transform_swaps_handedness(&P->gs.ctm);
    s->flip_normals = s->reverse_orientation != s->swaps_handedness;
    s->material = P->gs.material;
    s->area_light = P->gs.area_light;
    s->inside_medium = P->gs.inside_medium;
    s->outside_medium = P->gs.outside_medium;
    if (pbrt_inputs_float(P, ps, "alpha", 1.0, &s->alpha) != 0)
        return -1;
    s->has_alpha = s->alpha.texture >= 0 || s->alpha.value < 1.0;
    /* pbrt-v4 displaces triangle meshes by a texture at load time; prismfarm does not. */
    param_t *disp = params_find(ps, "displacement");
    if (disp) {
        (void)params_find(ps, "edgelength");
        if (warnings_add(P->scene->warnings, disp->loc,
                         "Shape \"%s\": \"displacement\" is not simulated (the surface is "
                         "rendered undisplaced)",
                         s->kind) != 0)
            return pbrt_error(P->err, disp->loc, "out of memory");
    }
    switch (s->type) {
    case SCENE_SHAPE_SPHERE: {
        double zmin, zmax, phimax;
        if (params_get_float(ps, "radius", 1.0, &s->radius, P->err) != 0 ||
            pbrt_state_check_positive(P, ps, "radius", s->radius) != 0 ||
            params_get_float(ps, "zmin", -s->radius, &zmin, P->err) != 0 ||
            params_get_float(ps, "zmax", s->radius, &zmax, P->err) != 0 ||
            params_get_float(ps, "phimax", 360.0, &phimax, P->err) != 0 ||
            pbrt_state_check_range(P, ps, "phimax", phimax, 1e-6, 360.0) != 0)
            return -1;
        if (fmin(zmin, zmax) <= -s->radius && fmax(zmin, zmax) >= s->radius && phimax >= 360.0)
            return 0; /* the whole sphere: analytic in Embree */
        if (fmin(fmax(zmin, zmax), s->radius) <= fmax(fmin(zmin, zmax), -s->radius))
            return pbrt_error(P->err, loc,
                              "Shape \"sphere\": zmin %g and zmax %g leave nothing "
                              "of a sphere of radius %g",
                              zmin, zmax, s->radius);
        mesh_data_t md;
        err_t e;
        if (shape_tess_sphere(s->radius, zmin, zmax, phimax, &md, &e) != 0)
            return pbrt_error(P->err, loc, "Shape \"sphere\": %s", e.msg);
        s->type = SCENE_SHAPE_MESH;
        return pbrt_meshes_adopt(P, s, &md);
    }
    case SCENE_SHAPE_DISK: {
        double inner;
        if (params_get_float(ps, "radius", 1.0, &s->radius, P->err) != 0 ||
            params_get_float(ps, "height", 0.0, &s->height, P->err) != 0 ||
            params_get_float(ps, "innerradius", 0.0, &inner, P->err) != 0 ||
            pbrt_state_check_positive(P, ps, "radius", s->radius) != 0)
            return -1;
        if (inner != 0.0)
            return pbrt_error(P->err, params_find(ps, "innerradius")->loc,
                              "unsupported parameter value: \"float innerradius\" must be 0 "
                              "(annuli are not supported)");
        return 0;
    }
    case SCENE_SHAPE_MESH:
        if (!strcmp(s->kind, "plymesh"))
            return mesh_from_ply(P, ps, s, loc);
        if (!strcmp(s->kind, "cylinder"))
            return cylinder_shape(P, ps, s, loc);
        if (!strcmp(s->kind, "loopsubdiv"))
            return loopsubdiv_shape(P, ps, s, loc);
        return mesh_from_params(P, ps, s, !strcmp(s->kind, "bilinearmesh"), loc);
    case SCENE_SHAPE_CURVE:
        if (s->area_light >= 0)
            return pbrt_error(P->err, loc,
                              "an area light on a \"curve\" is not supported (pbrt-v4 cannot "
                              "sample curves either)");
        return curve_shape(P, ps, s, loc);
    }
    return 0;
}
