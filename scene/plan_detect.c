#include "plan_detect.h"

#include "material_subsurface.h"

#include "rng.h"
#include "sample.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static double grid_lambda(spectral_grid_t g, int k, int n)
{
    return g.lambda_min + (g.lambda_max - g.lambda_min) * (double)k / (double)(n - 1);
}

static int values_vary(double lo, double hi)
{
    return hi - lo > PLAN_SPECTRAL_EPSILON * fmax(fabs(lo), fabs(hi));
}

int plan_detect_spectrum_varies(const spectrum_t *sp, spectral_grid_t g)
{
    if (!sp)
        return 0;
    double lo = INFINITY, hi = -INFINITY;
    for (int k = 0; k < PLAN_SPECTRAL_SAMPLES; k++) {
        double v = spectrum_eval(sp, grid_lambda(g, k, PLAN_SPECTRAL_SAMPLES));
        lo = fmin(lo, v);
        hi = fmax(hi, v);
    }
    return values_vary(lo, hi);
}

int plan_detect_texture_varies(const texture_t *t, spectral_grid_t g)
{
    if (!t)
        return 0;
    static const double UV[3] = {0.1, 0.5, 0.9};
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) {
            double lo = INFINITY, hi = -INFINITY;
            for (int k = 0; k < PLAN_SPECTRAL_SAMPLES; k++) {
                double v = texture_eval(t, UV[a], UV[b], grid_lambda(g, k, PLAN_SPECTRAL_SAMPLES));
                lo = fmin(lo, v);
                hi = fmax(hi, v);
            }
            if (values_vary(lo, hi))
                return 1;
        }
    return 0;
}

/* A smooth mirror or glass: what carries a caustic (and what the photon pass follows). */
static int is_specular(const material_t *m)
{
    return (m->kind == MATERIAL_CONDUCTOR || m->kind == MATERIAL_DIELECTRIC) && !m->rough &&
           !material_subsurface_table(
               m); /* light entering a subsurface material is diffused beneath */
}

/* A surface that receives a caustic: a diffuse surface that reflects some light at the hit
 * (a black light fixture does not: a photon stored there would carry nothing to the camera),
 * or a glossy one -- any non-delta surface that is not Lambertian (coated, rough conductor or
 * dielectric, diffuse transmission; not a thin dielectric, all delta, nor a polarising sheet,
 * which ends photons), which the plan's photon map stores photons on with their directions
 * (render/photon.h). */
static int receives(const surface_t *sf, spectral_grid_t g)
{
    const material_t *m = sf->material;
    if (m->kind != MATERIAL_DIFFUSE)
        return m->kind != MATERIAL_INTERFACE && m->kind != MATERIAL_MIX &&
               m->kind != MATERIAL_THIN_DIELECTRIC && !material_is_sheet(m->kind) &&
               !is_specular(m);
    if (!m->reflectance)
        return 1;
    for (int k = 0; k < 8; k++)
        if (texture_eval(m->reflectance, sf->u, sf->v, grid_lambda(g, k, 8)) > 0.0)
            return 1;
    return 0;
}

/* A uniform point on a shape by area (u[0] picks a mesh's triangle: by the light's alias table,
 * else by cdf, the cumulative triangle areas, else uniformly) and its unit normal, oriented as
 * scene_surface orients a hit there (the flip flag; a mesh's vertex normals), placed in the
 * world by inst when the shape belongs to an object. 0 for a shape with nothing to sample. */
static int shape_point(const shape_t *sh, const double *cdf, const transform_t *inst,
                       const double u[3], vec3_t *p, vec3_t *n)
{
    vec3_t ns = vec3_make(0, 0, 0);
    if (sh->kind == SHAPE_CURVE)
        return 0; /* a ribbon that faces each ray has no normal of its own to place */
    if (sh->kind == SHAPE_MESH) {
        if (sh->ntris == 0)
            return 0;
        size_t t;
        double pmf;
        if (sh->triangles) {
            t = alias_sample(sh->triangles, u[0], &pmf);
        } else if (cdf && cdf[sh->ntris - 1] > 0.0) {
            double x = u[0] * cdf[sh->ntris - 1];
            size_t a = 0, b = sh->ntris - 1;
            while (a < b) {
                size_t m = a + (b - a) / 2;
                if (cdf[m] > x)
                    b = m;
                else
                    a = m + 1;
            }
            t = a;
        } else {
            t = (size_t)fmin((double)(sh->ntris - 1), floor(u[0] * (double)sh->ntris));
        }
        const double *a = sh->positions + 3 * (size_t)sh->indices[3 * t];
        const double *b = sh->positions + 3 * (size_t)sh->indices[3 * t + 1];
        const double *c = sh->positions + 3 * (size_t)sh->indices[3 * t + 2];
        vec3_t p0 = vec3_make(a[0], a[1], a[2]), p1 = vec3_make(b[0], b[1], b[2]),
               p2 = vec3_make(c[0], c[1], c[2]);
        *p = sample_triangle_point(p0, p1, p2, u[1], u[2]);
        *n = vec3_normalize(vec3_cross(vec3_sub(p1, p0), vec3_sub(p2, p0)));
        sample_bary_t bc = sample_uniform_triangle(u[1], u[2]);
        ns = scene_mesh_normal(sh, (uint32_t)t, bc.b1, bc.b2);
    } else if (sh->kind == SHAPE_SPHERE) {
        if (!(sh->radius > 0.0))
            return 0;
        vec3_t q = sample_uniform_sphere(u[1], u[2]);
        *p = transform_point(&sh->to_world, vec3_scale(q, sh->radius));
        *n = vec3_normalize(transform_normal(&sh->to_world, q));
    } else {
        if (!(sh->radius > 0.0))
            return 0;
        vec3_t q = vec3_scale(sample_concentric_disk(u[1], u[2]), sh->radius);
        q.z = sh->height;
        *p = transform_point(&sh->to_world, q);
        *n = vec3_normalize(transform_normal(&sh->to_world, vec3_make(0, 0, 1)));
    }
    if (sh->flip)
        *n = vec3_neg(*n);
    if (vec3_dot(*n, ns) < 0.0)
        *n = vec3_neg(*n);
    if (inst) {
        *p = transform_point(inst, *p);
        *n = vec3_normalize(transform_normal(inst, *n));
    }
    return vec3_dot(*n, *n) > 0.5;
}

/* Cumulative triangle areas of a mesh in its own space (NULL on out of memory). */
static double *mesh_cdf(const shape_t *sh)
{
    double *cdf = malloc((sh->ntris ? sh->ntris : 1) * sizeof *cdf);
    if (!cdf)
        return NULL;
    double total = 0.0;
    for (size_t t = 0; t < sh->ntris; t++) {
        const uint32_t *ix = sh->indices + 3 * t;
        vec3_t v[3];
        for (int k = 0; k < 3; k++) {
            const double *q = sh->positions + 3 * (size_t)ix[k];
            v[k] = vec3_make(q[0], q[1], q[2]);
        }
        double a = 0.5 * vec3_length(vec3_cross(vec3_sub(v[1], v[0]), vec3_sub(v[2], v[0])));
        total += isfinite(a) ? a : 0.0;
        cdf[t] = total;
    }
    return cdf;
}

static void box_grow(vec3_t *lo, vec3_t *hi, vec3_t q)
{
    *lo = vec3_make(fmin(lo->x, q.x), fmin(lo->y, q.y), fmin(lo->z, q.z));
    *hi = vec3_make(fmax(hi->x, q.x), fmax(hi->y, q.y), fmax(hi->z, q.z));
}

/* Grows lo..hi by a shape's world-space box (inst places an object's shape). */
static void shape_box(const shape_t *sh, const transform_t *inst, vec3_t *lo, vec3_t *hi)
{
    if (sh->kind == SHAPE_MESH || sh->kind == SHAPE_CURVE) { /* a curve: its control points */
        for (size_t v = 0; v < sh->nverts; v++) {
            vec3_t q =
                vec3_make(sh->positions[3 * v], sh->positions[3 * v + 1], sh->positions[3 * v + 2]);
            box_grow(lo, hi, inst ? transform_point(inst, q) : q);
        }
        return;
    }
    double r = sh->radius;
    double zlo = sh->kind == SHAPE_SPHERE ? -r : sh->height;
    double zhi = sh->kind == SHAPE_SPHERE ? r : sh->height;
    for (int c = 0; c < 8; c++) {
        vec3_t q = vec3_make(c & 1 ? r : -r, c & 2 ? r : -r, c & 4 ? zhi : zlo);
        q = transform_point(&sh->to_world, q);
        box_grow(lo, hi, inst ? transform_point(inst, q) : q);
    }
}

static const transform_t *placement_transform(const scene_t *s, const placement_t *pl)
{
    return pl->instance >= 0 ? &s->instances[pl->instance].to_world : NULL;
}

long plan_detect_placements(const scene_t *s, placement_t **out, double **cdfs, vec3_t *lo,
                            vec3_t *hi)
{
    *lo = vec3_make(INFINITY, INFINITY, INFINITY);
    *hi = vec3_neg(*lo);
    placement_t *pl = NULL;
    size_t n = 0, cap = 0;
    for (size_t i = 0; i < s->nshapes && n < PLAN_PLACEMENTS_MAX; i++) {
        const shape_t *sh = &s->shapes[i];
        if (!is_specular(&s->materials[sh->material]))
            continue;
        if (sh->kind == SHAPE_MESH && !(cdfs[i] = mesh_cdf(sh))) {
            free(pl);
            return -1;
        }
        for (size_t k = 0; n < PLAN_PLACEMENTS_MAX && k < (sh->object < 0 ? 1 : s->ninstances);
             k++) {
            if (sh->object >= 0 && s->instances[k].object != sh->object)
                continue;
            if (n == cap) {
                cap = cap ? 2 * cap : 16;
                placement_t *g = realloc(pl, cap * sizeof *g);
                if (!g) {
                    free(pl);
                    return -1;
                }
                pl = g;
            }
            placement_t p = {
                .shape = (int)i, .instance = sh->object < 0 ? -1 : (int)k, .cdf = cdfs[i]};
            vec3_t blo = vec3_make(INFINITY, INFINITY, INFINITY), bhi = vec3_neg(blo);
            shape_box(sh, placement_transform(s, &p), &blo, &bhi);
            if (!(blo.x <= bhi.x))
                continue;
            p.centre = vec3_scale(vec3_add(blo, bhi), 0.5);
            box_grow(lo, hi, blo);
            box_grow(lo, hi, bhi);
            pl[n++] = p;
        }
    }
    *out = pl;
    return (long)n;
}

/* The first surface along the ray that is not an "interface" (rays pass through those). */
static int first_surface(tracer_t *t, vec3_t org, vec3_t dir, surface_t *sf)
{
    for (int k = 0; k <= PLAN_PASSTHROUGH_MAX; k++) {
        hit_t h;
        t->rays++;
        if (!geometry_intersect(t->s->geometry, org, dir, 0.0, INFINITY, &h))
            return 0;
        scene_surface(t->s, &h, sf);
        if (sf->material->kind != MATERIAL_INTERFACE)
            return 1;
        org = geometry_offset(sf->p, sf->ng, dir);
    }
    return 0;
}

static int material_index(const scene_t *s, const material_t *m)
{
    return (int)(m - s->materials);
}

/* Queues the arrival of light travelling along dir at a specular hit, unless its shape has
 * had its share of arrivals in this search or the queue is full. */
static void enqueue(tracer_t *t, int *n, const surface_t *sf, vec3_t dir, int hops, int root)
{
    int shape = (int)(sf->shape - t->s->shapes);
    if (*n >= PLAN_QUEUE_MAX)
        return;
    if (t->stamp[shape] != t->gen) {
        t->stamp[shape] = t->gen;
        t->visits[shape] = 0;
    }
    if (t->visits[shape] >= PLAN_ARRIVALS_PER_SHAPE)
        return;
    t->visits[shape]++;
    t->queue[(*n)++] = (arrival_t){
        .p = sf->p, .ng = sf->ng, .din = dir, .shape = shape, .hops = hops, .root_material = root};
}

/* From the queued arrivals (and the arrivals they lead to, up to max_hops specular events),
 * looks for a receiver (receives: diffuse or glossy) that sees the side of the specular surface
 * the light leaves from: a mirror sends it back to the side it came from, glass to both.
 * Returns 1 when one is found (an L S+ D or L S+ G path: *f names the first specular material
 * and the receiver), 0 when none is, -1 when the ray budget ran out first. */
static int follow(tracer_t *t, int n, uint64_t key, spectral_grid_t g, found_t *f)
{
    const scene_t *s = t->s;
    for (int i = 0; i < n; i++) {
        arrival_t a = t->queue[i];
        const material_t *m = &s->materials[s->shapes[a.shape].material];
        vec3_t side = vec3_dot(a.din, a.ng) < 0.0 ? a.ng : vec3_neg(a.ng);
        rng_stream_t r = rng_stream_make(PLAN_SEED + 1, key, (uint32_t)i);
        for (int k = 0; k < PLAN_DIRECTIONS; k++) {
            if (t->rays >= t->budget)
                return -1;
            double u1 = rng_stream_next(&r), u2 = rng_stream_next(&r);
            vec3_t dir = m->kind == MATERIAL_CONDUCTOR
                             ? sample_local_to_world(sample_uniform_hemisphere(u1, u2), side)
                             : sample_uniform_sphere(u1, u2);
            surface_t sf;
            if (!first_surface(t, geometry_offset(a.p, a.ng, dir), dir, &sf))
                continue;
            if (receives(&sf, g)) {
                f->glass_material = a.root_material;
                f->receiver_material = material_index(s, sf.material);
                return 1;
            }
            if (is_specular(sf.material) && a.hops < t->max_hops)
                enqueue(t, &n, &sf, dir, a.hops + 1, a.root_material);
        }
    }
    return 0;
}

/* Whether a point-like light (point, spot, goniometric, projection) sends any light along
 * world direction dir (unit): inside a spot's cone, toward a goniometric image's non-black
 * texel, through a projection image's non-black texel. */
static int emits_toward(const light_t *l, vec3_t dir)
{
    switch (l->kind) {
    case LIGHT_SPOT:
        return vec3_dot(dir, l->direction) >= l->cos_total_width;
    case LIGHT_GONIOMETRIC: {
        size_t texel = envmap_texel(l->gonio, transform_vector(&l->to_light, dir));
        return envmap_texel_value(l->gonio, texel, 550.0) > 0.0; /* a grey: any wavelength */
    }
    case LIGHT_PROJECTION: {
        size_t texel = projmap_texel(l->projmap, transform_vector(&l->to_light, dir));
        if (texel == PROJMAP_OUTSIDE)
            return 0;
        for (double lambda = 360.0; lambda <= 830.0; lambda += 10.0)
            if (projmap_texel_value(l->projmap, texel, lambda) > 0.0)
                return 1;
        return 0;
    }
    default:
        return 1;
    }
}

/* Rays from light li toward uniform points of placement j; the specular surfaces they reach
 * first are followed (follow). Returns follow's result; *reached is set when a ray reached a
 * mirror or glass. */
static int light_to_placement(tracer_t *t, int li, const placement_t *pl, int j, spectral_grid_t g,
                              int *reached, found_t *f)
{
    const scene_t *s = t->s;
    const light_t *l = &s->lights[li];
    const shape_t *target = &s->shapes[pl->shape];
    const transform_t *inst = placement_transform(s, pl);
    vec3_t scene_centre = vec3_scale(vec3_add(s->bounds_lo, s->bounds_hi), 0.5);
    uint64_t key = ((uint64_t)(uint32_t)li << 32) | (uint32_t)j;
    rng_stream_t r = rng_stream_make(PLAN_SEED, key, 0);
    t->gen++;
    int n = 0;
    for (int q = 0; q < PLAN_TARGET_RAYS; q++) {
        if (t->rays >= t->budget)
            return -1;
        double u[6];
        for (int k = 0; k < 6; k++)
            u[k] = rng_stream_next(&r);
        vec3_t tp, tn;
        if (!shape_point(target, pl->cdf, inst, u, &tp, &tn))
            return 0;
        vec3_t org, dir;
        if (l->kind == LIGHT_DISTANT) {
            /* From upstream of the scene's bounding sphere along the light's direction. */
            dir = l->direction;
            double back = vec3_dot(vec3_sub(tp, scene_centre), dir) + 1.05 * s->scene_radius;
            org = vec3_fma(tp, dir, -back);
        } else if (l->kind == LIGHT_POINT || l->kind == LIGHT_SPOT ||
                   l->kind == LIGHT_GONIOMETRIC || l->kind == LIGHT_PROJECTION) {
            vec3_t d = vec3_sub(tp, l->position);
            double len = vec3_length(d);
            if (!(len > 0.0))
                continue;
            dir = vec3_scale(d, 1.0 / len);
            if (!emits_toward(l, dir))
                continue;
            org = l->position;
        } else {
            vec3_t lp, ln;
            if (!shape_point(&s->shapes[l->shape], NULL, NULL, u + 3, &lp, &ln))
                return 0;
            vec3_t d = vec3_sub(tp, lp);
            double len = vec3_length(d);
            if (!(len > 0.0))
                continue;
            dir = vec3_scale(d, 1.0 / len);
            double c = vec3_dot(dir, ln);
            if (!(c > 0.0 || (l->twosided && c < 0.0)))
                continue;
            org = geometry_offset(lp, ln, dir);
        }
        surface_t sf;
        if (!first_surface(t, org, dir, &sf) || !is_specular(sf.material))
            continue;
        *reached = 1;
        enqueue(t, &n, &sf, dir, 1, material_index(s, sf.material));
    }
    return n > 0 ? follow(t, n, key, g, f) : 0;
}

/* A collimated light's beam: rays along its normal from uniform points of its shape. Sets
 * *direct when the beam lights a receiver itself (L D or L G, which only photons carry) and
 * returns follow's result for what it lights through mirrors and glass. */
static int beam(tracer_t *t, int li, spectral_grid_t g, int *reached, int *direct, int *receiver,
                found_t *f)
{
    const scene_t *s = t->s;
    const light_t *l = &s->lights[li];
    rng_stream_t r = rng_stream_make(PLAN_SEED + 2, (uint64_t)li, 0);
    t->gen++;
    int n = 0;
    for (int q = 0; q < PLAN_BEAM_RAYS; q++) {
        if (t->rays >= t->budget)
            return -1;
        double u[3];
        for (int k = 0; k < 3; k++)
            u[k] = rng_stream_next(&r);
        vec3_t lp, ln;
        if (!shape_point(&s->shapes[l->shape], NULL, NULL, u, &lp, &ln))
            return 0;
        surface_t sf;
        if (!first_surface(t, geometry_offset(lp, ln, ln), ln, &sf))
            continue;
        if (receives(&sf, g)) {
            if (!*direct)
                *receiver = material_index(s, sf.material);
            *direct = 1;
        } else if (is_specular(sf.material)) {
            *reached = 1;
            enqueue(t, &n, &sf, ln, 1, material_index(s, sf.material));
        }
    }
    return n > 0 ? follow(t, n, (uint64_t)li << 32 | 0xffffffffu, g, f) : 0;
}

/* Solid angle (sr) an area light subtends from point c: (A / P) sum max(0, cos_l) / d^2 over
 * P uniform points of it (|cos_l| when two-sided), at most 2 pi. */
static double solid_angle_from(const scene_t *s, const light_t *l, vec3_t c, const vec3_t *pts,
                               const vec3_t *nrm, int np)
{
    if (np == 0)
        return 0.0;
    double sum = 0.0;
    for (int i = 0; i < np; i++) {
        vec3_t d = vec3_sub(c, pts[i]);
        double d2 = vec3_dot(d, d);
        if (!(d2 > 0.0))
            return 2.0 * PF_PI;
        double cs = vec3_dot(nrm[i], d) / sqrt(d2);
        if (l->twosided)
            cs = fabs(cs);
        if (cs > 0.0)
            sum += cs / d2;
    }
    return fmin(2.0 * PF_PI, sum * s->shapes[l->shape].area / np);
}

void plan_detect_light(tracer_t *t, plan_light_t *pl, const placement_t *pls, size_t npl,
                       double total_power, spectral_grid_t g)
{
    const scene_t *s = t->s;
    const light_t *l = &s->lights[pl->index];
    uint64_t rays0 = t->rays;
    pl->kind = l->kind;
    pl->shape = l->kind == LIGHT_AREA || l->kind == LIGHT_COLLIMATED ? l->shape : -1;
    pl->power_share = total_power > 0.0 ? scene_light_power(s, l) / total_power : 0.0;
    pl->spectral = plan_detect_spectrum_varies(l->spectrum, g);
    pl->solid_angle = -1.0;
    pl->glass_material = pl->receiver_material = -1;
    pl->verdict = PLAN_LIGHT_NOT_NEEDED;
    pl->bright = pl->power_share >= PLAN_BRIGHT_SHARE;
    found_t f = {-1, -1};
    int r = 0;
    switch (l->kind) {
    case LIGHT_INFINITE:
        return; /* emits no photons (photon.h): its light through glass is path traced */
    case LIGHT_COLLIMATED:
        r = beam(t, pl->index, g, &pl->reaches_specular, &pl->direct, &pl->receiver_material, &f);
        break;
    case LIGHT_POINT:
    case LIGHT_SPOT:
    case LIGHT_GONIOMETRIC:
    case LIGHT_PROJECTION:
    case LIGHT_DISTANT:
        for (size_t j = 0; j < npl && r == 0; j++)
            r = light_to_placement(t, pl->index, &pls[j], (int)j, g, &pl->reaches_specular, &f);
        break;
    case LIGHT_AREA: {
        vec3_t pts[PLAN_LIGHT_POINTS], nrm[PLAN_LIGHT_POINTS];
        int np = 0;
        rng_stream_t rs = rng_stream_make(PLAN_SEED + 3, (uint64_t)pl->index, 0);
        for (int i = 0; i < PLAN_LIGHT_POINTS; i++) {
            double u[3] = {rng_stream_next(&rs), rng_stream_next(&rs), rng_stream_next(&rs)};
            if (shape_point(&s->shapes[l->shape], NULL, NULL, u, &pts[np], &nrm[np]))
                np++;
        }
        /* The smallest solid angle it subtends from a placement it faces; traced only toward
         * placements from which it is small, and only when it is bright. */
        for (size_t j = 0; j < npl; j++) {
            double om = solid_angle_from(s, l, pls[j].centre, pts, nrm, np);
            if (om > 0.0 && (pl->solid_angle < 0.0 || om < pl->solid_angle))
                pl->solid_angle = om;
        }
        pl->small = pl->solid_angle >= 0.0 && pl->solid_angle < PLAN_SMALL_SOLID_ANGLE;
        if (!pl->small || !pl->bright)
            break;
        for (size_t j = 0; j < npl && r == 0; j++) {
            double om = solid_angle_from(s, l, pls[j].centre, pts, nrm, np);
            if (om > 0.0 && om < PLAN_SMALL_SOLID_ANGLE)
                r = light_to_placement(t, pl->index, &pls[j], (int)j, g, &pl->reaches_specular, &f);
        }
        break;
    }
    }
    pl->rays = t->rays - rays0;
    if (r != 0) {
        pl->caustic = r > 0;
        pl->undecided = r < 0;
        pl->glass_material = f.glass_material;
        if (f.receiver_material >= 0)
            pl->receiver_material = f.receiver_material;
    }
    if (pl->caustic || pl->undecided || pl->direct)
        pl->verdict = l->kind == LIGHT_AREA ? PLAN_LIGHT_ADVISED : PLAN_LIGHT_NEEDED;
}
