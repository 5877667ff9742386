#include "emitters.h"

#include <math.h>
#include <stdlib.h>

static int on_mesh(const scene_t *self, const light_t *l)
{
    return (l->kind == LIGHT_AREA || l->kind == LIGHT_COLLIMATED) && l->shape >= 0 &&
           self->shapes[l->shape].kind == SHAPE_MESH;
}

static vec3_t vertex(const shape_t *s, size_t t, int k)
{
    const double *a = s->positions + 3 * (size_t)s->indices[3 * t + k];
    return vec3_make(a[0], a[1], a[2]);
}

double emitters_triangle_area(const shape_t *s, size_t t)
{
    vec3_t p0 = vertex(s, t, 0);
    return 0.5 *
           vec3_length(vec3_cross(vec3_sub(vertex(s, t, 1), p0), vec3_sub(vertex(s, t, 2), p0)));
}

int emitters_light(const scene_t *self, size_t e, size_t *tri)
{
    /* The last light whose first emitter is at or before e (lights without emitters share
     * their successor's start and are skipped). */
    size_t lo = 0, hi = self->nlights;
    while (hi - lo > 1) {
        size_t mid = lo + (hi - lo) / 2;
        if (self->light_emitter0[mid] <= e)
            lo = mid;
        else
            hi = mid;
    }
    *tri = e - self->light_emitter0[lo];
    return (int)lo;
}

size_t emitters_index(const scene_t *self, int l, size_t tri)
{
    return self->light_emitter0[l] + (on_mesh(self, &self->lights[l]) ? tri : 0);
}

static void point_box(light_bounds_t *b, vec3_t p)
{
    b->lo = b->hi = p;
}

static void grow(light_bounds_t *b, vec3_t p)
{
    b->lo = vec3_make(fmin(b->lo.x, p.x), fmin(b->lo.y, p.y), fmin(b->lo.z, p.z));
    b->hi = vec3_make(fmax(b->hi.x, p.x), fmax(b->hi.y, p.y), fmax(b->hi.z, p.z));
}

/* The unit vector along c, or zero (lights.c's unit_or_zero: a sliver's cross product). */
static vec3_t unit_or_zero(vec3_t c)
{
    double m = fmax(fabs(c.x), fmax(fabs(c.y), fabs(c.z)));
    if (!(m > 0.0) || !isfinite(m))
        return vec3_make(0.0, 0.0, 0.0);
    return vec3_normalize(vec3_scale(c, 1.0 / m));
}

/* A mesh triangle of an area light: its box, its face normal on the side lights.c's sampling
 * (and scene_surface) orient it -- the flip flag, then the vertex normals' side where the
 * triangle has them -- and two-sided where those normals disagree across it (the side then
 * changes inside the triangle). */
static void triangle_bounds(const scene_t *self, const light_t *l, size_t t, light_bounds_t *b)
{
    const shape_t *s = &self->shapes[l->shape];
    vec3_t p0 = vertex(s, t, 0), p1 = vertex(s, t, 1), p2 = vertex(s, t, 2);
    point_box(b, p0);
    grow(b, p1);
    grow(b, p2);
    vec3_t n = unit_or_zero(vec3_cross(vec3_sub(p1, p0), vec3_sub(p2, p0)));
    if (!(vec3_dot(n, n) > 0.5)) {
        b->phi = 0.0; /* lights.c samples no point on it */
        return;
    }
    if (s->flip)
        n = vec3_neg(n);
    if (s->normals) {
        const double bary[3][2] = {{0, 0}, {1, 0}, {0, 1}};
        int neg = 0;
        for (int k = 0; k < 3; k++) {
            double d = vec3_dot(n, scene_mesh_normal(s, (uint32_t)t, bary[k][0], bary[k][1]));
            neg += d < 0.0;
        }
        if (neg == 3)
            n = vec3_neg(n);
        else if (neg > 0)
            b->twosided = 1;
    }
    b->w = n;
    b->cos_o = 1.0;
    b->cos_e = 0.0;
    double power = scene_light_power(self, l);
    b->phi = s->area > 0.0 ? power * (emitters_triangle_area(s, t) / s->area) : 0.0;
    if (l->twosided)
        b->phi *= 0.5; /* pbrt-v4's phi is one side's: the importance sees one side */
}

/* A sphere or disk area light: the box of the sphere, or of the square around the disk; a
 * sphere's normals point everywhere, a disk's along its (flipped) axis. */
static void analytic_bounds(const scene_t *self, const light_t *l, light_bounds_t *b)
{
    const shape_t *s = &self->shapes[l->shape];
    if (s->kind == SHAPE_SPHERE) {
        vec3_t c = transform_point(&s->to_world, vec3_make(0, 0, 0));
        double r = s->radius * vec3_length(transform_vector(&s->to_world, vec3_make(1, 0, 0)));
        b->lo = vec3_sub(c, vec3_make(r, r, r));
        b->hi = vec3_add(c, vec3_make(r, r, r));
        b->w = vec3_make(0, 0, 1);
        b->cos_o = -1.0;
    } else {
        double r = s->radius;
        for (int k = 0; k < 4; k++) {
            vec3_t q =
                transform_point(&s->to_world, vec3_make(k & 1 ? r : -r, k & 2 ? r : -r, s->height));
            if (k == 0)
                point_box(b, q);
            else
                grow(b, q);
        }
        vec3_t n = vec3_normalize(transform_normal(&s->to_world, vec3_make(0, 0, 1)));
        b->w = s->flip ? vec3_neg(n) : n;
        b->cos_o = 1.0;
    }
    b->cos_e = 0.0;
    b->phi = scene_light_power(self, l) * (l->twosided ? 0.5 : 1.0);
}

void emitters_bounds(const scene_t *self, size_t e, light_bounds_t *b)
{
    size_t tri;
    const light_t *l = &self->lights[emitters_light(self, e, &tri)];
    *b = (light_bounds_t){.w = vec3_make(0, 0, 1), .cos_o = -1.0, .cos_e = 0.0};
    b->twosided = l->twosided;
    const double y = scene_light_luminance(l);
    switch (l->kind) {
    case LIGHT_AREA:
        if (self->shapes[l->shape].kind == SHAPE_MESH)
            triangle_bounds(self, l, tri, b);
        else
            analytic_bounds(self, l, b);
        break;
    case LIGHT_POINT:
    case LIGHT_GONIOMETRIC:
        /* Bounded as isotropic points (pbrt-v4 bounds a goniometric light so too). */
        point_box(b, l->position);
        b->phi = scene_light_power(self, l);
        break;
    case LIGHT_SPOT: {
        /* Normals within the inner cone, spreading out to the outer one (pbrt-v4 SpotLight
         * Bounds: theta_e = theta_total - theta_start). */
        point_box(b, l->position);
        b->w = l->direction;
        b->cos_o = l->cos_falloff_start;
        double te = acos(fmax(-1.0, fmin(1.0, l->cos_total_width))) -
                    acos(fmax(-1.0, fmin(1.0, l->cos_falloff_start)));
        b->cos_e = cos(fmax(0.0, te));
        b->phi = y * 4.0 * PF_PI;
        break;
    }
    case LIGHT_PROJECTION: {
        /* A cone about the projection's axis out to the image's farthest corner: the frustum
         * is the cone spanned by the four corner rays, so their largest angle to the axis
         * bounds it in world space too (any linear map keeps the corners extreme). */
        point_box(b, l->position);
        double X, Y;
        projmap_extent(l->projmap, &X, &Y);
        vec3_t axis = vec3_normalize(transform_vector(&l->from_light, vec3_make(0, 0, 1)));
        double c = 1.0;
        for (int k = 0; k < 4; k++) {
            vec3_t d =
                transform_vector(&l->from_light, vec3_make(k & 1 ? X : -X, k & 2 ? Y : -Y, 1));
            c = fmin(c, vec3_dot(axis, vec3_normalize(d)));
        }
        b->w = axis;
        b->cos_o = 1.0;
        b->cos_e = c;
        double omega = projmap_solid_angle(l->projmap);
        b->phi = omega > 0.0 ? y * 4.0 * PF_PI * projmap_power(l->projmap) / omega : 0.0;
        break;
    }
    case LIGHT_COLLIMATED:
    case LIGHT_DISTANT:
    case LIGHT_INFINITE:
        b->phi = 0.0;
        break;
    }
    if (!(b->phi > 0.0) || !isfinite(b->phi))
        b->phi = 0.0;
}

int scene_emitters_build(scene_t *self, err_t *err)
{
    free(self->light_emitter0);
    free(self->infinite_lights);
    light_bvh_destroy(&self->light_bvh);
    self->light_emitter0 = NULL;
    self->infinite_lights = NULL;
    self->nemitters = self->ninfinite = 0;
    self->light_emitter0 = malloc((self->nlights + 1) * sizeof *self->light_emitter0);
    self->infinite_lights =
        malloc((self->nlights ? self->nlights : 1) * sizeof *self->infinite_lights);
    if (!self->light_emitter0 || !self->infinite_lights)
        return err_set(err, "out of memory");
    size_t n = 0;
    for (size_t i = 0; i < self->nlights; i++) {
        const light_t *l = &self->lights[i];
        self->light_emitter0[i] = n;
        n += on_mesh(self, l) ? self->shapes[l->shape].ntris : 1;
        if (l->kind == LIGHT_DISTANT || l->kind == LIGHT_INFINITE)
            self->infinite_lights[self->ninfinite++] = (int)i;
    }
    self->light_emitter0[self->nlights] = n;
    self->nemitters = n;
    light_bounds_t *b = malloc((n ? n : 1) * sizeof *b);
    if (!b)
        return err_set(err, "out of memory for the bounds of %zu emitters", n);
    for (size_t e = 0; e < n; e++)
        emitters_bounds(self, e, &b[e]);
    self->light_bvh = light_bvh_new(b, n, err);
    free(b);
    return self->light_bvh ? 0 : -1;
}
