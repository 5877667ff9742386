#include "lights.h"

#include "emitters.h"
#include "polar_frame.h"
#include "sample.h"

#include <math.h>

static double light_value(const light_t *l, double lambda)
{
    return l->scale * spectrum_eval(l->spectrum, lambda);
}

/* The unit vector along c, or the zero vector when c has no direction. vec3_normalize alone
 * fails for a sliver triangle: with components below 1e-154 the squares underflow, the
 * length is 0 and c comes back unnormalised (a 1e-300-wide emitter then launched photons along
 * a tiny, tangent "normal"). Scaling by the largest component first keeps the squares in
 * range. */
static vec3_t unit_or_zero(vec3_t c)
{
    double m = fmax(fabs(c.x), fmax(fabs(c.y), fabs(c.z)));
    if (!(m > 0.0) || !isfinite(m))
        return vec3_make(0.0, 0.0, 0.0);
    return vec3_normalize(vec3_scale(c, 1.0 / m));
}

/* The texture coordinates scene_surface gives a hit at point p of analytic shape s (world
 * space): pbrt-v4's u = phi / 2 pi and, for a sphere, v = 1 - theta / pi, for a disk
 * v = 1 - rho / r (geometry.c analytic_surface). */
static void analytic_uv(const shape_t *s, vec3_t p, double uv[2])
{
    transform_t from_world = transform_inverse(s->to_world);
    vec3_t q = transform_point(&from_world, p);
    double phi = atan2(q.y, q.x);
    if (phi < 0.0)
        phi += 2.0 * PF_PI;
    uv[0] = phi / (2.0 * PF_PI);
    if (s->kind == SHAPE_SPHERE) {
        double len = sqrt(vec3_dot(q, q));
        double ct = len > 0.0 ? fmax(-1.0, fmin(1.0, q.z / len)) : 1.0;
        uv[1] = 1.0 - acos(ct) / PF_PI;
    } else {
        uv[1] = s->radius > 0.0 ? 1.0 - sqrt(q.x * q.x + q.y * q.y) / s->radius : 0.0;
    }
}

/* A mesh's texture coordinates at barycentrics (b1, b2) of triangle t, pbrt-v4's defaults
 * (0, 0), (1, 0), (1, 1) without "uv", as scene_surface interpolates them. */
static void mesh_uv(const shape_t *s, size_t t, double b1, double b2, double uv[2])
{
    double c[3][2] = {{0, 0}, {1, 0}, {1, 1}};
    if (s->uvs)
        for (int k = 0; k < 3; k++) {
            c[k][0] = s->uvs[2 * (size_t)s->indices[3 * t + k]];
            c[k][1] = s->uvs[2 * (size_t)s->indices[3 * t + k] + 1];
        }
    double b0 = 1.0 - b1 - b2;
    uv[0] = b0 * c[0][0] + b1 * c[1][0] + b2 * c[2][0];
    uv[1] = b0 * c[0][1] + b1 * c[1][1] + b2 * c[2][1];
}

/* A uniform point on shape s by area with (u1, u2) -- on its triangle t for a mesh -- with
 * lights_sample_shape's orientation and texture coordinates. */
static int sample_on_shape(const shape_t *s, size_t t, double u1, double u2, vec3_t *p, vec3_t *n,
                           double uv[2])
{
    vec3_t ns = vec3_make(0, 0, 0);
    if (s->kind == SHAPE_MESH) {
        const double *a = s->positions + 3 * s->indices[3 * t];
        const double *b = s->positions + 3 * s->indices[3 * t + 1];
        const double *c = s->positions + 3 * s->indices[3 * t + 2];
        vec3_t p0 = vec3_make(a[0], a[1], a[2]), p1 = vec3_make(b[0], b[1], b[2]),
               p2 = vec3_make(c[0], c[1], c[2]);
        sample_bary_t bc = sample_uniform_triangle(u1, u2);
        *p = vec3_add(vec3_add(vec3_scale(p0, bc.b0), vec3_scale(p1, bc.b1)), vec3_scale(p2, bc.b2));
        *n = unit_or_zero(vec3_cross(vec3_sub(p1, p0), vec3_sub(p2, p0)));
        if (!(vec3_dot(*n, *n) > 0.5))
            return 0; /* a triangle with no area (the alias table never picks one, but a
                       * sliver whose area is below what its vertices can resolve) */
        ns = scene_mesh_normal(s, (uint32_t)t, bc.b1, bc.b2);
        if (uv)
            mesh_uv(s, t, bc.b1, bc.b2, uv);
    } else if (s->kind == SHAPE_SPHERE) {
        vec3_t q = sample_uniform_sphere(u1, u2);
        *p = transform_point(&s->to_world, vec3_scale(q, s->radius));
        *n = vec3_normalize(transform_normal(&s->to_world, q));
    } else {
        vec3_t q = vec3_scale(sample_concentric_disk(u1, u2), s->radius);
        q.z = s->height;
        *p = transform_point(&s->to_world, q);
        *n = vec3_normalize(transform_normal(&s->to_world, vec3_make(0, 0, 1)));
    }
    if (uv && s->kind != SHAPE_MESH)
        analytic_uv(s, *p, uv);
    if (s->flip)
        *n = vec3_neg(*n);
    if (vec3_dot(*n, ns) < 0.0)
        *n = vec3_neg(*n);
    return 1;
}

int lights_sample_shape(const shape_t *s, double u0, double u1, double u2, vec3_t *p, vec3_t *n,
                        double uv[2])
{
    if (!(s->area > 0.0))
        return 0;
    size_t t = s->kind == SHAPE_MESH ? alias_sample(s->triangles, u0, NULL) : 0;
    return sample_on_shape(s, t, u1, u2, p, n, uv);
}

/* The area over which a point on light l's emitter tri is drawn: the triangle's for a mesh,
 * the shape's otherwise. */
static double emitter_area(const shape_t *s, size_t tri)
{
    return s->kind == SHAPE_MESH ? emitters_triangle_area(s, tri) : s->area;
}

/* A sphere light's world centre and radius (the loader admits only similarity transforms on
 * sphere lights, scene.c), and whether p lies outside it, by a margin: a point on the sphere
 * itself (a hit on the light, whose single-precision position may lie either side) sees it as
 * a plane, where the cone degenerates to the point itself, so it keeps area sampling, as
 * pbrt-v4's origin offset toward the centre makes it do. Either choice is unbiased, and
 * lights_pdf makes the same one. */
static int sphere_outside(const shape_t *s, vec3_t p, vec3_t *centre, double *radius, double *d2)
{
    *centre = transform_point(&s->to_world, vec3_make(0, 0, 0));
    *radius = s->radius * vec3_length(transform_vector(&s->to_world, vec3_make(1, 0, 0)));
    vec3_t d = vec3_sub(*centre, p);
    *d2 = vec3_dot(d, d);
    return *d2 > *radius * *radius * (1.0 + 1e-4);
}

/* 1 - cos(theta_max) of the cone a sphere of radius r subtends at squared distance d2 > r^2,
 * with pbrt-v4's small-angle form below sin^2 = 0.00068523 (1.5 degrees), where 1 - cos loses
 * its digits. */
static double cone_one_minus_cos(double r, double d2, double *sin2_max)
{
    double s2 = r * r / d2;
    *sin2_max = s2;
    return s2 < 0.00068523 ? 0.5 * s2 : 1.0 - sqrt(fmax(0.0, 1.0 - s2));
}

/* pbrt-v4 Sphere::Sample(ctx, u) (PBR 4th ed. §6.2.4): cos(theta) uniform in [cos theta_max, 1]
 * about the axis toward the centre, then the point on the sphere that direction reaches first,
 * found through the angle alpha at the centre: cos(alpha) = sin^2(theta) / sin(theta_max) +
 * cos(theta) sqrt(1 - sin^2(theta) / sin^2(theta_max)). The pdf is 1 / (2 pi (1 - cos theta_max))
 * in solid angle. */
static int sample_sphere_cone(const shape_t *s, vec3_t p, vec3_t c, double r, double d2, double u0,
                              double u1, vec3_t *q, vec3_t *n, double *pdf)
{
    double sin2_max;
    double omc = cone_one_minus_cos(r, d2, &sin2_max);
    double sin_max = sqrt(sin2_max);
    double cos_t, sin2_t;
    if (sin2_max < 0.00068523) {
        sin2_t = sin2_max * u0;
        cos_t = sqrt(1.0 - sin2_t);
    } else {
        cos_t = 1.0 - omc * u0;
        sin2_t = 1.0 - cos_t * cos_t;
    }
    double cos_a = sin2_t / sin_max + cos_t * sqrt(fmax(0.0, 1.0 - sin2_t / sin2_max));
    double sin_a = sqrt(fmax(0.0, 1.0 - cos_a * cos_a));
    double phi = 2.0 * PF_PI * u1;
    /* The point's direction from the centre: alpha away from the axis back toward p. */
    vec3_t axis = vec3_scale(vec3_sub(p, c), 1.0 / sqrt(d2));
    vec3_t local = vec3_make(sin_a * cos(phi), sin_a * sin(phi), cos_a);
    vec3_t m = vec3_normalize(sample_local_to_world(local, axis));
    *q = vec3_fma(c, m, r);
    *n = s->flip ? vec3_neg(m) : m;
    *pdf = 1.0 / (2.0 * PF_PI * omc);
    return isfinite(*pdf) && *pdf > 0.0;
}

/* pbrt-v4's BVHLightSampler beside its infinite lights: each of the ninfinite distant and
 * infinite lights is chosen with probability 1 / (ninfinite + 1), the BVH (when it holds
 * anything) with the rest. */
static double infinite_share(const scene_t *scene, int *bvh)
{
    *bvh = !light_bvh_empty(scene->light_bvh);
    size_t k = scene->ninfinite + (size_t)*bvh;
    return k ? (double)scene->ninfinite / (double)k : 0.0;
}

static int is_mesh_light(const scene_t *scene, const light_t *l)
{
    return l->kind == LIGHT_AREA && scene->shapes[l->shape].kind == SHAPE_MESH;
}

/* Chooses an emitter with u0 (and u1 for a mesh light's triangle under "power"): its light,
 * triangle and probability, lights_pmf's numbers. */
static int choose_emitter(const scene_t *scene, const lights_at_t *at, double u0, double u1,
                          int *light, size_t *tri, double *pmf)
{
    *tri = 0;
    switch (scene->settings.light_sampler) {
    case LIGHT_SAMPLER_POWER: {
        if (!scene->light_power)
            return 0;
        size_t i = alias_sample(scene->light_power, u0, NULL);
        const light_t *l = &scene->lights[i];
        *light = (int)i;
        *pmf = alias_pmf(scene->light_power, i);
        if (is_mesh_light(scene, l)) {
            const alias_t *tris = scene->shapes[l->shape].triangles;
            if (!tris)
                return 0;
            *tri = alias_sample(tris, u1, NULL);
            *pmf *= alias_pmf(tris, *tri);
        }
        return *pmf > 0.0;
    }
    case LIGHT_SAMPLER_UNIFORM: {
        size_t n = scene->nemitters;
        if (n == 0)
            return 0;
        size_t e = (size_t)(u0 * (double)n);
        *light = emitters_light(scene, e < n ? e : n - 1, tri);
        *pmf = 1.0 / (double)n;
        return 1;
    }
    case LIGHT_SAMPLER_BVH:
        break;
    }
    int bvh;
    double p_inf = infinite_share(scene, &bvh);
    if (u0 < p_inf) {
        size_t k = (size_t)(u0 / p_inf * (double)scene->ninfinite);
        *light = scene->infinite_lights[k < scene->ninfinite ? k : scene->ninfinite - 1];
        *pmf = 1.0 / (double)(scene->ninfinite + (size_t)bvh);
        return 1;
    }
    if (!bvh)
        return 0;
    size_t e;
    double bvh_pmf;
    if (!light_bvh_sample(scene->light_bvh, at->p, at->n, (u0 - p_inf) / (1.0 - p_inf), &e,
                          &bvh_pmf))
        return 0;
    *light = emitters_light(scene, e, tri);
    *pmf = (1.0 - p_inf) * bvh_pmf;
    return *pmf > 0.0;
}

double lights_pmf(const scene_t *scene, const lights_at_t *at, int light, size_t tri)
{
    if (light < 0 || (size_t)light >= scene->nlights)
        return 0.0;
    const light_t *l = &scene->lights[light];
    const int mesh = is_mesh_light(scene, l);
    if (mesh && tri >= scene->shapes[l->shape].ntris)
        return 0.0;
    switch (scene->settings.light_sampler) {
    case LIGHT_SAMPLER_POWER: {
        if (!scene->light_power)
            return 0.0;
        double pmf = alias_pmf(scene->light_power, (size_t)light);
        if (mesh) {
            const alias_t *tris = scene->shapes[l->shape].triangles;
            pmf = tris ? pmf * alias_pmf(tris, tri) : 0.0;
        }
        return pmf;
    }
    case LIGHT_SAMPLER_UNIFORM:
        return scene->nemitters ? 1.0 / (double)scene->nemitters : 0.0;
    case LIGHT_SAMPLER_BVH:
        break;
    }
    int bvh;
    double p_inf = infinite_share(scene, &bvh);
    if (l->kind == LIGHT_DISTANT || l->kind == LIGHT_INFINITE)
        return 1.0 / (double)(scene->ninfinite + (size_t)bvh);
    if (!bvh)
        return 0.0;
    size_t e = emitters_index(scene, light, tri);
    return (1.0 - p_inf) * light_bvh_pmf(scene->light_bvh, e, at->p, at->n);
}

int lights_sample(const scene_t *scene, const lights_at_t *at, const double u[4], light_sample_t *out)
{
    int i;
    size_t tri;
    double pmf;
    if (!choose_emitter(scene, at, u[0], u[1], &i, &tri, &pmf))
        return 0;
    const vec3_t p = at->p;
    const light_t *l = &scene->lights[i];
    out->light = i;
    out->tri = tri;
    out->is_delta = 0;
    switch (l->kind) {
    case LIGHT_AREA: {
        const shape_t *s = &scene->shapes[l->shape];
        vec3_t q, n, c;
        double r, cd2, cone_pdf;
        if (s->kind == SHAPE_SPHERE && sphere_outside(s, p, &c, &r, &cd2)) {
            if (!sample_sphere_cone(s, p, c, r, cd2, u[2], u[3], &q, &n, &cone_pdf))
                return 0;
            vec3_t d = vec3_sub(q, p);
            double dist = vec3_length(d);
            if (!(dist > 0.0))
                return 0;
            out->wi = vec3_scale(d, 1.0 / dist);
            out->dist = dist;
            out->p_light = q;
            out->n_light = n;
            out->pdf = pmf * cone_pdf;
            if (l->area_image)
                analytic_uv(s, q, out->uv);
            return isfinite(out->pdf);
        }
        if (!(s->area > 0.0) ||
            !sample_on_shape(s, tri, u[2], u[3], &q, &n, l->area_image ? out->uv : NULL))
            return 0;
        vec3_t d = vec3_sub(q, p);
        double d2 = vec3_dot(d, d);
        if (!(d2 > 0.0))
            return 0;
        double dist = sqrt(d2);
        vec3_t wi = vec3_scale(d, 1.0 / dist);
        double cos_l = fabs(vec3_dot(n, wi));
        if (!(cos_l > 1e-12))
            return 0;
        out->wi = wi;
        out->dist = dist;
        out->p_light = q;
        out->n_light = n;
        out->pdf = pmf * d2 / (cos_l * emitter_area(s, tri));
        return isfinite(out->pdf);
    }
    case LIGHT_POINT:
    case LIGHT_SPOT:
    case LIGHT_GONIOMETRIC:
    case LIGHT_PROJECTION: {
        vec3_t d = vec3_sub(l->position, p);
        double dist = vec3_length(d);
        if (!(dist > 0.0))
            return 0;
        out->wi = vec3_scale(d, 1.0 / dist);
        out->dist = dist;
        out->pdf = pmf;
        out->is_delta = 1;
        if (l->kind == LIGHT_POINT || l->kind == LIGHT_SPOT)
            return 1;
        out->texel = lights_image_texel(l, vec3_neg(out->wi));
        /* Outside a projection's frustum nothing arrives: no shadow ray for it. */
        return out->texel != PROJMAP_OUTSIDE;
    }
    case LIGHT_DISTANT:
        out->wi = vec3_neg(l->direction);
        out->dist = INFINITY;
        out->pdf = pmf;
        out->is_delta = 1;
        return 1;
    case LIGHT_INFINITE:
        out->dist = INFINITY;
        if (l->envmap) {
            double pdf;
            vec3_t wl = envmap_sample_as(l->envmap, at->mis, u[2], u[3], &out->texel, &pdf);
            out->wi = vec3_normalize(transform_vector(&l->from_light, wl));
            out->pdf = pmf * pdf;
            return pdf > 0.0 && isfinite(out->pdf);
        }
        out->wi = sample_uniform_sphere(u[2], u[3]);
        out->pdf = pmf * sample_uniform_sphere_pdf();
        return 1;
    case LIGHT_COLLIMATED:
        return 0;
    }
    return 0;
}

double lights_value(const light_t *l, double lambda)
{
    return light_value(l, lambda);
}

void lights_stokes(const light_t *l, vec3_t k, vec3_t x, double s[4])
{
    s[0] = 1.0;
    s[1] = s[2] = s[3] = 0.0;
    if (!(l->polarisation > 0.0))
        return;
    const vec3_t e = polar_frame_perp(l->polarisation_axis, k);
    const double c = vec3_dot(e, x), sn = vec3_dot(e, vec3_cross(k, x));
    /* cos 2psi and sin 2psi from the unit (c, sn) = (cos psi, sin psi). */
    s[1] = l->polarisation * (c * c - sn * sn);
    s[2] = l->polarisation * 2.0 * c * sn;
}

int lights_area_faces(const light_t *l, vec3_t ng, vec3_t wo)
{
    return l->kind == LIGHT_AREA && (l->twosided || !(vec3_dot(ng, wo) <= 0.0));
}

double lights_sample_emission_of(const scene_t *scene, const light_sample_t *s, double value,
                                 double lambda)
{
    const light_t *l = &scene->lights[s->light];
    switch (l->kind) {
    case LIGHT_AREA:
        return lights_area_faces(l, s->n_light, vec3_neg(s->wi))
                   ? value * lights_area_image(l, s->uv[0], s->uv[1], lambda)
                   : 0.0;
    case LIGHT_POINT:
        return value / (s->dist * s->dist);
    case LIGHT_SPOT:
        return lights_spot_falloff(l, vec3_dot(vec3_neg(s->wi), l->direction)) * value /
               (s->dist * s->dist);
    case LIGHT_INFINITE:
        return l->envmap ? lights_envmap_radiance(l, s->texel, value, lambda) : value;
    case LIGHT_GONIOMETRIC:
    case LIGHT_PROJECTION:
        return lights_image_value(l, s->texel, lambda) * value / (s->dist * s->dist);
    case LIGHT_DISTANT:
        return value;
    case LIGHT_COLLIMATED:
        return 0.0;
    }
    return 0.0;
}

size_t lights_envmap_texel(const light_t *l, vec3_t wi)
{
    return envmap_texel(l->envmap, transform_vector(&l->to_light, wi));
}

double lights_envmap_radiance(const light_t *l, size_t texel, double value, double lambda)
{
    return value * envmap_texel_value(l->envmap, texel, lambda);
}

double lights_area_image(const light_t *l, double u, double v, double lambda)
{
    return l->area_image ? texture_eval(l->area_image, u, v, lambda) : 1.0;
}

size_t lights_image_texel(const light_t *l, vec3_t w)
{
    vec3_t wl = transform_vector(&l->to_light, w);
    if (l->kind == LIGHT_GONIOMETRIC)
        return envmap_texel(l->gonio, wl);
    return projmap_texel(l->projmap, wl);
}

double lights_image_value(const light_t *l, size_t texel, double lambda)
{
    if (l->kind == LIGHT_GONIOMETRIC)
        return envmap_texel_value(l->gonio, texel, lambda);
    return projmap_texel_value(l->projmap, texel, lambda);
}

double lights_spot_falloff(const light_t *l, double cos_theta)
{
    /* pbrt-v4 SpotLight: smoothstep falloff between the cone's inner and outer cosines. */
    double a = l->cos_total_width, b = l->cos_falloff_start;
    if (cos_theta >= b)
        return 1.0;
    if (cos_theta <= a)
        return 0.0;
    double t = (cos_theta - a) / (b - a);
    return t * t * (3.0 - 2.0 * t);
}

double lights_environment(const scene_t *scene, double lambda)
{
    double sum = 0.0;
    for (size_t i = 0; i < scene->nlights; i++)
        if (scene->lights[i].kind == LIGHT_INFINITE && !scene->lights[i].envmap)
            sum += light_value(&scene->lights[i], lambda);
    return sum;
}

double lights_pdf(const scene_t *scene, const lights_at_t *at, int light, size_t tri, vec3_t wi,
                  vec3_t p_light, vec3_t ng)
{
    double pmf = lights_pmf(scene, at, light, tri);
    if (!(pmf > 0.0))
        return 0.0;
    const light_t *l = &scene->lights[light];
    if (l->kind == LIGHT_INFINITE)
        return pmf * (l->envmap
                          ? envmap_pdf_as(l->envmap, at->mis, transform_vector(&l->to_light, wi))
                          : sample_uniform_sphere_pdf());
    if (l->kind != LIGHT_AREA)
        return 0.0;
    const shape_t *s = &scene->shapes[l->shape];
    vec3_t c;
    double r, cd2, sin2_max;
    if (s->kind == SHAPE_SPHERE && sphere_outside(s, at->p, &c, &r, &cd2))
        return pmf * (1.0 / (2.0 * PF_PI * cone_one_minus_cos(r, cd2, &sin2_max)));
    vec3_t d = vec3_sub(p_light, at->p);
    double d2 = vec3_dot(d, d);
    double cos_l = fabs(vec3_dot(ng, wi));
    if (!(cos_l > 1e-12) || !(s->area > 0.0))
        return 0.0;
    return pmf * d2 / (cos_l * emitter_area(s, tri));
}

void lights_probes_make(const scene_t *scene, lights_probes_t *out)
{
    out->n = 0;
    for (size_t i = 0; i < scene->nlights; i++) {
        const light_t *l = &scene->lights[i];
        if (l->kind != LIGHT_AREA)
            continue;
        const shape_t *s = &scene->shapes[l->shape];
        if (s->kind != SHAPE_SPHERE)
            continue;
        /* A sphere light in an object, with an alpha texture, or past the set's size: off. */
        if (s->object >= 0 || s->alpha || out->n == LIGHTS_PROBE_MAX) {
            out->n = 0;
            return;
        }
        vec3_t c;
        double r, d2;
        sphere_outside(s, vec3_make(0, 0, 0), &c, &r, &d2);
        const double rw = r * (1.0 + 1e-3);
        out->light[out->n] = (int)i;
        out->centre[out->n] = c;
        out->r2[out->n] = rw * rw;
        out->n++;
    }
}

int lights_probes_has(const lights_probes_t *pr, int light)
{
    for (int i = 0; i < pr->n; i++)
        if (pr->light[i] == light)
            return 1;
    return 0;
}

int lights_probes_may_hit(const lights_probes_t *pr, vec3_t o, vec3_t d)
{
    for (int i = 0; i < pr->n; i++) {
        /* The ray's closest approach to the centre, ahead of o (or o inside the sphere). */
        const vec3_t oc = vec3_sub(pr->centre[i], o);
        const double t = vec3_dot(oc, d), oc2 = vec3_dot(oc, oc);
        if (oc2 <= pr->r2[i])
            return 1;
        if (t > 0.0 && oc2 - t * t <= pr->r2[i])
            return 1;
    }
    return 0;
}

int lights_probes_in_cone(const lights_probes_t *pr, vec3_t o, vec3_t axis, double half)
{
    for (int i = 0; i < pr->n; i++) {
        const vec3_t oc = vec3_sub(pr->centre[i], o);
        const double d2 = vec3_dot(oc, oc);
        if (d2 <= pr->r2[i])
            return 1;
        const double d = sqrt(d2);
        const double angle = acos(fmax(-1.0, fmin(1.0, vec3_dot(oc, axis) / d)));
        /* The sphere's angular radius seen from o, and a margin for rounding. */
        if (angle <= half + asin(fmin(1.0, sqrt(pr->r2[i]) / d)) + 1e-6)
            return 1;
    }
    return 0;
}
