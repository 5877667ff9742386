#include "load_shapes.h"

#include "load_lights.h"
#include "load_materials.h"

#include <math.h>
#include <stdlib.h>

/* pbrt-v4 "curve": its Bezier segments placed by the shape's transform; the widths scale by
 * the transform's mean linear scale (pbrt-v4 intersects in the curve's own space, so a
 * non-uniform scale widens it unevenly there), and a segment's radius is linear in u from half
 * its first width to half its last, as pbrt-v4 lerps the width. */
static int load_curve(loader_t *L, const scene_shape_t *s, int object, int material, err_t *err)
{
    const transform_t *m = &s->to_world;
    vec3_t ex = transform_vector(m, vec3_make(1, 0, 0)),
           ey = transform_vector(m, vec3_make(0, 1, 0)),
           ez = transform_vector(m, vec3_make(0, 0, 1));
    double scale = cbrt(fabs(vec3_dot(vec3_cross(ex, ey), ez)));
    size_t n = s->curve_segments;
    double *cp = malloc(12 * n * sizeof *cp), *radii = malloc(4 * n * sizeof *radii);
    double *normals = s->curve_normals ? malloc(6 * n * sizeof *normals) : NULL;
    if (!cp || !radii || (s->curve_normals && !normals)) {
        free(cp);
        free(radii);
        free(normals);
        return err_set(err, "out of memory for a curve of %zu segments", n);
    }
    /* A ribbon's normals map as normals (pbrt-v4 maps the hit's dp/du and dp/dv, whose cross
     * product then points along the inverse transpose's image of the object-space normal). */
    for (size_t i = 0; normals && i < 2 * n; i++) {
        vec3_t q = vec3_normalize(
            transform_normal(m, vec3_make(s->curve_normals[3 * i], s->curve_normals[3 * i + 1],
                                          s->curve_normals[3 * i + 2])));
        normals[3 * i] = q.x;
        normals[3 * i + 1] = q.y;
        normals[3 * i + 2] = q.z;
    }
    for (size_t i = 0; i < 4 * n; i++) {
        vec3_t p = transform_point(
            m, vec3_make(s->curve_cp[3 * i], s->curve_cp[3 * i + 1], s->curve_cp[3 * i + 2]));
        cp[3 * i] = p.x;
        cp[3 * i + 1] = p.y;
        cp[3 * i + 2] = p.z;
        const double *w = s->curve_width + 2 * (i / 4);
        radii[i] = 0.5 * scale * (w[0] + (w[1] - w[0]) * (double)(i % 4) / 3.0);
    }
    int r = scene_add_curves(L->sc, object, cp, radii, normals, n, s->curve_cylinder,
                             s->flip_normals, material, err);
    free(cp);
    free(radii);
    free(normals);
    return r;
}

int load_shapes_add(loader_t *L, const scene_shape_t *s, int object, err_t *err)
{
    const scene_desc_t *d = L->desc;
    int light;
    if (load_lights_area(L, s, object, &light, err))
        return -1;
    const transform_t *to_world = &s->to_world;
    int flip = s->flip_normals;
    const int material = load_materials_for_shape(L, s->material, to_world, err);
    if (material < 0 && s->material >= 0)
        return -1;
    int r;
    if (s->type == SCENE_SHAPE_SPHERE) {
        r = object < 0
                ? scene_add_sphere(L->sc, to_world, s->radius, material, light, flip, err)
                : scene_add_object_sphere(L->sc, object, to_world, s->radius, material, flip, err);
    } else if (s->type == SCENE_SHAPE_DISK) {
        r = object < 0
                ? scene_add_disk(L->sc, to_world, s->radius, s->height, material, light, flip, err)
                : scene_add_object_disk(L->sc, object, to_world, s->radius, s->height, material,
                                        flip, err);
    } else if (s->type == SCENE_SHAPE_CURVE) {
        r = load_curve(L, s, object, material, err);
    } else {
        const scene_mesh_t *m = &s->mesh;
        double *P = malloc(3 * m->nvertices * sizeof *P);
        double *N = m->N ? malloc(3 * m->nvertices * sizeof *N) : NULL;
        if (!P || (m->N && !N)) {
            free(P);
            free(N);
            return err_set(err, "out of memory for a mesh of %zu vertices", m->nvertices);
        }
        /* pbrt-v4 TriangleMesh: vertex normals map as normals and turn with
         * ReverseOrientation (not with a handedness swap). */
        double nsign = s->reverse_orientation ? -1.0 : 1.0;
        for (size_t v = 0; v < m->nvertices; v++) {
            vec3_t p =
                transform_point(to_world, vec3_make(m->P[3 * v], m->P[3 * v + 1], m->P[3 * v + 2]));
            P[3 * v] = p.x;
            P[3 * v + 1] = p.y;
            P[3 * v + 2] = p.z;
            if (N) {
                vec3_t n = vec3_normalize(transform_normal(
                    to_world, vec3_make(m->N[3 * v], m->N[3 * v + 1], m->N[3 * v + 2])));
                N[3 * v] = nsign * n.x;
                N[3 * v + 1] = nsign * n.y;
                N[3 * v + 2] = nsign * n.z;
            }
        }
        r = object < 0 ? scene_add_mesh(L->sc, P, m->nvertices, m->indices, m->ntriangles, N, m->uv,
                                        material, light, flip, err)
                       : scene_add_object_mesh(L->sc, object, P, m->nvertices, m->indices,
                                               m->ntriangles, N, m->uv, material, flip, err);
        free(P);
        free(N);
    }
    if (r < 0)
        return err_prefix(err, "%s:%d:%d: Shape \"%s\": ", s->loc.file, s->loc.line, s->loc.col,
                          s->kind);
    L->sc->shapes[r].medium_inside = s->inside_medium;
    L->sc->shapes[r].medium_outside = s->outside_medium;
    if (s->has_alpha) {
        if (!(L->sc->shapes[r].alpha = loader_float_input(L, &s->alpha, err)))
            return -1;
        L->sc->has_alpha = 1;
    }
    if (light >= 0 && d->area_lights[s->area_light].power > 0.0)
        return load_lights_area_power(L, &d->area_lights[s->area_light], &L->sc->shapes[r],
                                      &L->sc->lights[light], err);
    return 0;
}

int load_shapes(loader_t *L, err_t *err)
{
    for (size_t i = 0; i < L->desc->nshapes; i++)
        if (load_shapes_add(L, &L->desc->shapes[i], -1, err))
            return -1;
    return 0;
}
