#include "plan.h"

#include "rng.h"
#include "sample.h"

#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

/* Every random number of the plan is keyed by this seed (and a light, a placement, an
 * arrival), never by the job's seed: the same scene gets the same plan whatever it renders
 * with. "plan" in ASCII. */
#define PLAN_SEED 0x706c616eull

/* Visibility sampling. A light sends PLAN_TARGET_RAYS rays at uniform points of each mirror
 * or glass placement (a collimated light PLAN_BEAM_RAYS rays along its normal); every specular
 * surface a ray reaches becomes an "arrival", from which PLAN_DIRECTIONS uniform directions
 * look for a diffuse surface (in the hemisphere the light was reflected into for a mirror, the
 * whole sphere for glass). At most PLAN_ARRIVALS_PER_SHAPE arrivals per shape are followed per
 * light and placement, so a diffuse surface covering more than about 4 pi / (16 * 64) sr
 * around the glass is found (docs/plan.md). */
#define PLAN_TARGET_RAYS 64
#define PLAN_BEAM_RAYS 256
#define PLAN_LIGHT_POINTS 64
#define PLAN_DIRECTIONS 64
#define PLAN_ARRIVALS_PER_SHAPE 16
#define PLAN_QUEUE_MAX 1024
#define PLAN_MAX_HOPS 8
#define PLAN_PASSTHROUGH_MAX 64
#define PLAN_PLACEMENTS_MAX 4096
/* Rays for the whole plan (a few tenths of a second at worst); a light still undecided when
 * they run out is assumed to need photons (missing light is worse than wasted time). */
#define PLAN_RAY_BUDGET (1u << 21)

/* "Varies over the film's range": sampled at this many wavelengths, by more than this
 * fraction of the largest value (the same 1e-6 as IOR_DISPERSIVE_EPSILON). */
#define PLAN_SPECTRAL_SAMPLES 35
#define PLAN_SPECTRAL_EPSILON 1e-6

/* Photon parameters (docs/plan.md): the gather disk is PLAN_GATHER_PIXELS pixel footprints
 * in radius at the specular surfaces' distance from the camera (one: a density estimate blurs
 * a caustic's edge over its disk, and on caustic-glass at 179x256 two footprints left the 4x4
 * RMSE against pbrt-v4's bdpt 1.3 times what noise explains and one brings it to 1.2 for 13 %
 * more CPU, docs/accuracy.md "Photon gather radius"); the count gives about
 * PLAN_PHOTONS_PER_BUCKET photons per bucket in a gather disk if the caustic spreads over the
 * specular surfaces' own cross-section, with PLAN_STORED_FRACTION of the emitted photons
 * stored (45 % measured in prism_beam, docs/rendering.md). */
#define PLAN_GATHER_PIXELS 1.0
#define PLAN_PHOTONS_PER_BUCKET 16.0
#define PLAN_STORED_FRACTION 0.5
#define PLAN_PHOTONS_MIN 100000.0
#define PLAN_PHOTONS_MAX 4000000.0
#define PLAN_PHOTONS_ROUND 10000.0
/* The radius stays within these fractions of the scene's bounding radius. */
#define PLAN_RADIUS_MIN 1e-3
#define PLAN_RADIUS_MAX 0.05

static const char *const EFFECT_NAMES[PLAN_EFFECT_COUNT] = {
    "wavelength splitting", "spectral colour",   "dispersion strategy",
    "photon pass",          "photon parameters", "integrator",
    "polarisation",
};

/* ---- a growing string ---- */

typedef struct text {
    char *s;
    size_t len, cap;
    int failed;
} text_t;

__attribute__((format(printf, 2, 3))) static void text_add(text_t *t, const char *fmt, ...)
{
    if (t->failed)
        return;
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    if (n < 0) {
        t->failed = 1;
        return;
    }
    if (t->len + (size_t)n + 1 > t->cap) {
        size_t cap = t->cap ? t->cap : 256;
        while (cap < t->len + (size_t)n + 1)
            cap *= 2;
        char *s = realloc(t->s, cap);
        if (!s) {
            t->failed = 1;
            return;
        }
        t->s = s;
        t->cap = cap;
    }
    va_start(ap, fmt);
    vsnprintf(t->s + t->len, t->cap - t->len, fmt, ap);
    va_end(ap);
    t->len += (size_t)n;
}

/* The string (owned by the caller), or NULL when building it failed. */
static char *text_take(text_t *t)
{
    if (t->failed || !t->s) {
        free(t->s);
        return t->failed ? NULL : strdup("");
    }
    return t->s;
}

/* ---- the plan ---- */

struct plan {
    plan_request_t req;
    plan_decision_t decisions[PLAN_EFFECT_COUNT];
    char *strings[2 * PLAN_EFFECT_COUNT];
    plan_material_t *materials;
    size_t nmaterials;
    plan_light_t *lights;
    size_t nlights;
    plan_choice_t choice;
    uint64_t rays;
    size_t nplacements; /* mirror and glass placements looked at */
    /* What the scene renders with now, for the report. */
    integrator_kind_t current_integrator;
    int current_media; /* the camera pass simulates media ("volpath") */
    dispersion_kind_t current_dispersion;
    photon_settings_t current_photon;
    spectral_grid_t grid;
};

/* A mirror or glass shape where it stands: a world shape (instance -1) or an object's shape
 * placed by an instance. */
typedef struct placement {
    int shape;
    int instance;
    vec3_t centre;
    const double *cdf; /* meshes: cumulative triangle areas (owned by the placements' list) */
} placement_t;

/* Light reaching a mirror or glass surface: where, from which direction, which shape, after
 * how many specular events, and the material of the path's first specular surface. */
typedef struct arrival {
    vec3_t p, ng, din;
    int shape;
    int hops;
    int root_material;
} arrival_t;

typedef struct tracer {
    const scene_t *s;
    int max_hops;
    uint64_t rays;
    uint64_t budget;
    /* Arrivals followed per shape in the current search (reset by bumping gen). */
    unsigned *stamp;
    int *visits;
    unsigned gen;
    arrival_t *queue;
} tracer_t;

typedef struct found {
    int glass_material;
    int receiver_material;
} found_t;


const char *plan_light_kind_name(light_kind_t kind)
{
    switch (kind) {
    case LIGHT_AREA:
        return "area";
    case LIGHT_COLLIMATED:
        return "collimated";
    case LIGHT_POINT:
        return "point";
    case LIGHT_SPOT:
        return "spot";
    case LIGHT_DISTANT:
        return "distant";
    case LIGHT_INFINITE:
        return "infinite";
    case LIGHT_GONIOMETRIC:
        return "goniometric";
    case LIGHT_PROJECTION:
        return "projection";
    }
    return "?";
}

const char *plan_material_kind_name(material_kind_t kind)
{
    switch (kind) {
    case MATERIAL_DIFFUSE:
        return "diffuse";
    case MATERIAL_CONDUCTOR:
        return "conductor";
    case MATERIAL_DIELECTRIC:
        return "dielectric";
    case MATERIAL_INTERFACE:
        return "interface";
    case MATERIAL_THIN_DIELECTRIC:
        return "thindielectric";
    case MATERIAL_DIFFUSE_TRANSMISSION:
        return "diffusetransmission";
    case MATERIAL_COATED_DIFFUSE:
        return "coateddiffuse";
    case MATERIAL_COATED_CONDUCTOR:
        return "coatedconductor";
    case MATERIAL_MIX:
        return "mix";
    case MATERIAL_POLARISER:
        return "polarizer";
    case MATERIAL_RETARDER:
        return "retarder";
    case MATERIAL_MEASURED:
        return "measured";
    case MATERIAL_HAIR:
        return "hair";
    }
    return "?";
}

const char *plan_verdict_name(plan_verdict_t verdict)
{
    switch (verdict) {
    case PLAN_LIGHT_NOT_NEEDED:
        return "not needed";
    case PLAN_LIGHT_NEEDED:
        return "needed";
    case PLAN_LIGHT_ADVISED:
        return "advised";
    }
    return "?";
}


static void copy_word(char *dst, size_t n, const char *src)
{
    snprintf(dst, n, "%s", src ? src : "");
}

plan_request_t plan_request_make(const scene_desc_t *desc, const scene_overrides_t *ov)
{
    plan_request_t r;
    memset(&r, 0, sizeof r);
    const scene_integrator_t *in = &desc->integrator;
    r.integrator_named = in->loc.line > 0;
    r.overridden = ov && ov->integrator;
    copy_word(r.integrator, sizeof r.integrator, r.overridden ? ov->integrator : in->type);
    if (ov && ov->dispersion) {
        copy_word(r.dispersion, sizeof r.dispersion, ov->dispersion);
        r.dispersion_overridden = 1;
    } else {
        /* Looked up without params_find, which would mark the parameter used. */
        for (size_t i = 0; in->params && i < params_count(in->params); i++) {
            const param_t *p = params_at(in->params, i);
            if (!strcmp(p->name, "dispersion") && p->values == PARAM_VALUES_STRINGS &&
                p->count == 1)
                copy_word(r.dispersion, sizeof r.dispersion, p->strings[0]);
        }
    }
    return r;
}

/* "'name'" for a named material, "#i" for an unnamed one. */
static void material_label(const scene_t *s, int i, char *buf, size_t n)
{
    if (i < 0 || (size_t)i >= s->nmaterials) {
        snprintf(buf, n, "(none)");
        return;
    }
    const char *name = s->materials[i].name;
    if (!name[0] || !strcmp(name, "(unnamed)"))
        snprintf(buf, n, "#%d", i);
    else if (!s->materials[i].named) /* where the file made it: jewel.pbrt:57 */
        snprintf(buf, n, "%.60s", name);
    else
        snprintf(buf, n, "'%.60s'", name);
}

static void light_label(const scene_t *s, int i, char *buf, size_t n)
{
    const light_t *l = &s->lights[i];
    if (l->kind == LIGHT_AREA || l->kind == LIGHT_COLLIMATED)
        snprintf(buf, n, "light %d (%s, shape %d)", i, plan_light_kind_name(l->kind), l->shape);
    else
        snprintf(buf, n, "light %d (%s)", i, plan_light_kind_name(l->kind));
}

static double grid_lambda(spectral_grid_t g, int k, int n)
{
    return g.lambda_min + (g.lambda_max - g.lambda_min) * (double)k / (double)(n - 1);
}

static int values_vary(double lo, double hi)
{
    return hi - lo > PLAN_SPECTRAL_EPSILON * fmax(fabs(lo), fabs(hi));
}

static int spectrum_varies(const spectrum_t *sp, spectral_grid_t g)
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

/* A texture varies with wavelength somewhere: checked at a 3 x 3 grid of texture
 * coordinates (a checkerboard's squares, an image's texels). */
static int texture_varies(const texture_t *t, spectral_grid_t g)
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
    return (m->kind == MATERIAL_CONDUCTOR || m->kind == MATERIAL_DIELECTRIC) && !m->rough;
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

/* Every mirror and glass shape where it stands, in shape order (at most PLAN_PLACEMENTS_MAX),
 * and the box around all of them; cdfs[shape] receives each specular mesh's cumulative
 * triangle areas. Returns the count, or -1 on out of memory. */
static long specular_placements(const scene_t *s, placement_t **out, double **cdfs, vec3_t *lo,
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
        } else if (l->kind == LIGHT_POINT || l->kind == LIGHT_SPOT || l->kind == LIGHT_GONIOMETRIC ||
                   l->kind == LIGHT_PROJECTION) {
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

/* Decides whether light li needs photons. */
static void plan_one_light(tracer_t *t, plan_light_t *pl, const placement_t *pls, size_t npl,
                           double total_power, spectral_grid_t g)
{
    const scene_t *s = t->s;
    const light_t *l = &s->lights[pl->index];
    uint64_t rays0 = t->rays;
    pl->kind = l->kind;
    pl->shape = l->kind == LIGHT_AREA || l->kind == LIGHT_COLLIMATED ? l->shape : -1;
    pl->power_share = total_power > 0.0 ? scene_light_power(s, l) / total_power : 0.0;
    pl->spectral = spectrum_varies(l->spectrum, g);
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

/* ---- decisions ---- */

static int set_decision(plan_t *p, plan_effect_t e, int on, text_t *choice, text_t *reason)
{
    char *c = text_take(choice), *r = text_take(reason);
    p->strings[2 * e] = c;
    p->strings[2 * e + 1] = r;
    p->decisions[e] = (plan_decision_t){
        .effect = e, .effect_name = EFFECT_NAMES[e], .on = on, .choice = c, .reason = r};
    return c && r ? 0 : -1;
}

static void plan_materials(plan_t *p, const scene_t *s)
{
    spectral_grid_t g = s->settings.grid;
    double mid = 0.5 * (g.lambda_min + g.lambda_max);
    for (size_t i = 0; i < s->nmaterials; i++) {
        const material_t *m = &s->materials[i];
        plan_material_t *pm = &p->materials[i];
        pm->index = (int)i;
        material_label(s, (int)i, pm->name, sizeof pm->name);
        pm->kind = m->kind;
        pm->dispersive = m->dispersive;
        if (m->kind == MATERIAL_DIFFUSE)
            pm->spectral = texture_varies(m->reflectance, g);
        else if (m->kind == MATERIAL_CONDUCTOR)
            pm->spectral = m->eta ? spectrum_varies(m->eta, g) || spectrum_varies(m->k, g)
                                  : texture_varies(m->reflectance, g);
        if (material_has_ior(m->kind)) {
            pm->n_lo = ior_eval(&m->ior, g.lambda_min);
            pm->n_hi = ior_eval(&m->ior, g.lambda_max);
            pm->n_mid = ior_eval(&m->ior, mid);
            double dn = pm->n_lo - pm->n_hi;
            pm->v_film = m->dispersive && dn != 0.0 ? (pm->n_mid - 1.0) / dn : 0.0;
            pm->n_d = ior_eval(&m->ior, IOR_LAMBDA_D_NM);
            pm->has_v_d = ior_abbe_number(&m->ior, &pm->v_d);
        }
    }
}

static void describe_dielectric(text_t *t, const plan_material_t *m, spectral_grid_t g)
{
    if (!m->dispersive) {
        text_add(t, "%s (n %.4f)", m->name, m->n_mid);
        return;
    }
    text_add(t, "%s: n %.4f at %g nm to %.4f at %g nm (dn %.4f, Abbe-like v over the film %.1f",
             m->name, m->n_lo, g.lambda_min, m->n_hi, g.lambda_max, m->n_lo - m->n_hi, m->v_film);
    if (m->has_v_d)
        text_add(t, "; n_d %.5f, v_d %.2f", m->n_d, m->v_d);
    text_add(t, ")");
}

/* A realistic camera whose lens glasses disperse: each camera ray is traced through the lens at
 * its own wavelength (render.c lens_ray), which splits a path's wavelengths as a dispersive
 * interface does, before the scene is reached. Appends the reason and returns 1 when it does. */
static int describe_lens(text_t *r, const scene_t *s, spectral_grid_t g, int first)
{
    const camera_t *cam = &s->camera;
    if (cam->kind != CAMERA_REALISTIC || !cam->lens || !cam->lens_dispersive)
        return 0;
    text_add(r, "%sthe realistic camera's lens disperses: ", first ? "" : " And ");
    int k = 0;
    for (int i = 0; i < lens_system_count(cam->lens); i++) {
        const lens_element_t *e = lens_system_element(cam->lens, i);
        if (!e->glass)
            continue;
        double lo = ior_eval(&e->ior, g.lambda_min) + e->ior_shift;
        double hi = ior_eval(&e->ior, g.lambda_max) + e->ior_shift;
        text_add(r, "%selement %d %s n %.4f at %g nm to %.4f at %g nm", k++ ? "; " : "", i + 1,
                 e->glass_name[0] ? e->glass_name : "(default glass)", lo, g.lambda_min, hi,
                 g.lambda_max);
    }
    text_add(r,
             ". Each camera ray is traced through the lens at its own wavelength (hero: the "
             "secondaries end at the film; fan-out: one lane goes on), so the lens's axial and "
             "lateral colour -- fringes at the image's edges, a focus that moves with "
             "wavelength -- come out of its glasses.");
    return 1;
}

static int decide_splitting(plan_t *p, const scene_t *s)
{
    text_t c = {0}, r = {0};
    spectral_grid_t g = s->settings.grid;
    int ndisp = 0, nconst = 0;
    for (size_t i = 0; i < p->nmaterials; i++)
        if (material_has_ior(p->materials[i].kind)) {
            if (p->materials[i].dispersive)
                ndisp++;
            else
                nconst++;
        }
    if (ndisp > 0) {
        text_add(&c, "at dispersive refraction");
        text_add(&r, "%d material%s disperse%s over %g-%g nm: ", ndisp, ndisp > 1 ? "s" : "",
                 ndisp > 1 ? "" : "s", g.lambda_min, g.lambda_max);
        int k = 0;
        for (size_t i = 0; i < p->nmaterials; i++)
            if (p->materials[i].dispersive) {
                text_add(&r, "%s", k++ ? "; " : "");
                describe_dielectric(&r, &p->materials[i], g);
            }
        text_add(&r,
                 ". A refraction there sends each wavelength its own way, so a path's "
                 "wavelengths split (hero: the secondaries end; fan-out: %d monochrome rays).",
                 g.n);
        int nrough = 0;
        for (size_t i = 0; i < s->nmaterials; i++)
            nrough += s->materials[i].dispersive &&
                      (s->materials[i].rough || s->materials[i].uroughness || s->materials[i].vroughness);
        if (nrough > 0)
            text_add(&r,
                     " %d of them %s rough: there each wavelength has its own refraction lobe, "
                     "and %s.",
                     nrough, nrough > 1 ? "are" : "is",
                     s->settings.spectral_mis
                         ? "spectral MIS keeps the 4 hero wavelengths, each weighted by its own lobe "
                           "(\"bool spectralmis\" true, docs/physics.md §11)"
                         : "the secondaries end as at smooth glass (\"bool spectralmis\" false)");
        if (nconst > 0) {
            text_add(&r, " Constant-index glass does not split: ");
            k = 0;
            for (size_t i = 0; i < p->nmaterials; i++)
                if (material_has_ior(p->materials[i].kind) && !p->materials[i].dispersive) {
                    text_add(&r, "%s", k++ ? ", " : "");
                    describe_dielectric(&r, &p->materials[i], g);
                }
            text_add(&r, ".");
        }
        describe_lens(&r, s, g, 0);
    } else if (s->camera.kind == CAMERA_REALISTIC && s->camera.lens_dispersive) {
        text_add(&c, "in the camera's lens");
        describe_lens(&r, s, g, 1);
        text_add(&r, " No material in the scene disperses.");
        ndisp = 1; /* the effect is on: the lens splits every camera path */
    } else {
        text_add(&c, "off");
        text_add(&r, "no material's index varies by more than %g over %g-%g nm",
                 IOR_DISPERSIVE_EPSILON, g.lambda_min, g.lambda_max);
        if (nconst > 0) {
            text_add(&r, " (constant: ");
            int k = 0;
            for (size_t i = 0; i < p->nmaterials; i++)
                if (material_has_ior(p->materials[i].kind)) {
                    text_add(&r, "%s", k++ ? ", " : "");
                    describe_dielectric(&r, &p->materials[i], g);
                }
            text_add(&r, ")");
        } else {
            text_add(&r, " (no glass)");
        }
        text_add(&r,
                 ": every refraction sends all wavelengths the same way, so no path ever "
                 "splits its wavelengths. The %d buckets are still rendered.",
                 g.n);
    }
    return set_decision(p, PLAN_SPLITTING, ndisp > 0, &c, &r);
}

/* Polarised transport (docs/physics.md §14) is carried only where the scene tells polarisations
 * apart: a polariser or retarder sheet, the camera's analyser, or a Stokes output (scene_finish
 * turns render_settings_t.polarised on for them, scene_load for the output; this says which and
 * why), and lights that emit polarised light. A uniaxial crystal does not turn it on by itself:
 * its o and e images are polarised across each other, which an intensity camera does not see
 * (only where light meets a later polarising interface, by a few per cent); with polarisation
 * on for another reason, it applies its Mueller matrices (docs/physics.md §15). Without any of them
 * the smooth glass and mirrors still polarise what they reflect and transmit, but a camera that
 * records intensity only sees it where light meets a second polarising surface (a glass seen in
 * a window, light inside a gem): the intensity ignoring it is off by up to a few per cent there
 * (a slab at 60 degrees transmits 0.836 unpolarised against 0.848 polarised: test_polar_render's
 * oracle), which the plan names; where the polarisation pilot ran (render/polar_pilot.h, before
 * the plan) this states its figure and, above its target, advises Integrator "bool polarized"
 * true: the pilot only advises, since its figure may differ between builds and CPUs. */
static int decide_polarisation(plan_t *p, const scene_t *s)
{
    text_t c = {0}, r = {0};
    int sheets = 0, glass = 0, crystals = 0;
    for (size_t i = 0; i < s->nmaterials; i++) {
        const material_t *m = &s->materials[i];
        sheets += material_is_sheet(m->kind);
        crystals += m->uniaxial != 0;
        glass += (m->kind == MATERIAL_DIELECTRIC || m->kind == MATERIAL_CONDUCTOR) && !m->rough &&
                 !m->uniaxial;
    }
    const render_settings_t *rs = &s->settings;
    const int on = rs->polarised;
    if (on) {
        text_add(&c, "Stokes carriers%s", rs->stokes ? " + S0-S3 output" : "");
        int k = 0;
        text_add(&r, "carried because ");
        if (sheets) {
            text_add(&r, "of polarising sheets: ");
            for (size_t i = 0; i < s->nmaterials; i++)
                if (material_is_sheet(s->materials[i].kind))
                    text_add(&r, "%s%s (%s)", k++ ? ", " : "", p->materials[i].name,
                             plan_material_kind_name(s->materials[i].kind));
            text_add(&r, "; ");
        }
        if (s->camera.analyser)
            text_add(&r, "the camera has an analyser at %g degrees; ",
                     s->camera.analyser_angle * 180.0 / PF_PI);
        if (s->polarised_lights) {
            int area = 0;
            for (size_t i = 0; i < s->nlights; i++)
                area += s->lights[i].polarisation > 0.0 && s->lights[i].kind == LIGHT_AREA;
            text_add(&r, "%d light%s emit%s polarised light", s->polarised_lights,
                     s->polarised_lights > 1 ? "s" : "", s->polarised_lights > 1 ? "" : "s");
            if (area)
                text_add(&r, " (%d area light%s: seen directly and through smooth surfaces)", area,
                         area > 1 ? "s" : "");
            if (area < s->polarised_lights)
                text_add(&r,
                         " (%d point, spot or distant: reached only by next-event estimation, "
                         "which still takes their light as unpolarised, so their polarisation "
                         "changes no pixel yet)",
                         s->polarised_lights - area);
            text_add(&r, "; ");
        }
        if (rs->stokes)
            text_add(&r, "the film writes the Stokes layers S1-S3; ");
        if (rs->polarised_asked)
            text_add(&r, "the file asks for it (Integrator \"bool polarized\" true); ");
        if (rs->polar_pilot.run)
            text_add(&r,
                     "a pilot (render/polar_pilot.h: the same samples with and without it) "
                     "measured that ignoring it changes the image by %.2f %% (RMS per pixel over "
                     "the mean luminance; up to %.2f %% at two standard errors); its renders "
                     "took %.2f s against %.2f s; ",
                     100.0 * rs->polar_pilot.change, 100.0 * rs->polar_pilot.change_hi,
                     rs->polar_pilot.seconds_polarised, rs->polar_pilot.seconds_plain);
        if (!sheets && !s->camera.analyser && !rs->stokes && !rs->polarised_asked &&
            !s->polarised_lights)
            text_add(&r, "the caller asked for it; ");
        text_add(&r, "a 4x4 Mueller matrix per lane at every glass and metal interface (smooth or "
                     "rough) and sheet; diffuse, thin and layered surfaces depolarise. ");
        if (crystals)
            text_add(&r,
                     "The %d uniaxial crystal material%s split%s light into o and e waves "
                     "polarised across each other (magnitudes only, no retardance); crystals "
                     "alone do not turn polarisation on. ",
                     crystals, crystals > 1 ? "s" : "", crystals > 1 ? "" : "s");
        text_add(&r, "Images without any of these are left unpolarised, bit for bit as before.");
    } else {
        text_add(&c, "off");
        text_add(&r, "nothing tells polarisations apart (no polariser or retarder sheet, no "
                     "analyser, no Stokes output, no polarised light)");
        if (glass)
            text_add(&r,
                     "; the %d smooth glass and mirror material%s polarise what they reflect, "
                     "which changes intensities only where light meets a second polarising "
                     "surface (a few per cent: a slab at 60 degrees transmits 0.836 "
                     "unpolarised, 0.848 polarised)",
                     glass, glass > 1 ? "s" : "");
        if (rs->polar_pilot.run)
            text_add(&r,
                     "; a pilot (render/polar_pilot.h: the same samples with and without "
                     "polarisation) measured that ignoring it changes the image by %.2f %% (RMS "
                     "per pixel over the mean luminance; at most %.2f %% at two standard "
                     "errors), %s the %g %% target%s",
                     100.0 * rs->polar_pilot.change, 100.0 * rs->polar_pilot.change_hi,
                     rs->polar_pilot.change_hi > rs->polar_pilot.target ? "above" : "within",
                     100.0 * rs->polar_pilot.target,
                     rs->polar_pilot.change_hi > rs->polar_pilot.target
                         ? ": carry it with Integrator \"bool polarized\" true (the pilot "
                           "advises, it does not decide: its figure may differ between builds "
                           "and CPUs, and a farm's workers must render alike)"
                         : "");
        if (crystals)
            text_add(&r,
                     "; uniaxial crystals (%d material%s) do not turn it on by themselves: "
                     "their o and e images are polarised across each other, which a camera "
                     "without an analyser does not tell apart",
                     crystals, crystals > 1 ? "s" : "");
        text_add(&r, ".");
    }
    return set_decision(p, PLAN_POLARISATION, on, &c, &r);
}

static int decide_colour(plan_t *p, const scene_t *s)
{
    text_t c = {0}, r = {0};
    spectral_grid_t g = s->settings.grid;
    int nl = 0, nm = 0;
    for (size_t i = 0; i < p->nlights; i++)
        nl += p->lights[i].spectral;
    for (size_t i = 0; i < p->nmaterials; i++)
        nm += p->materials[i].spectral;
    char buf[96];
    if (nl + nm > 0) {
        text_add(&c, "%d buckets", g.n);
        if (nl) {
            text_add(&r, "emission varies over %g-%g nm: ", g.lambda_min, g.lambda_max);
            int k = 0;
            for (size_t i = 0; i < p->nlights; i++)
                if (p->lights[i].spectral) {
                    light_label(s, (int)i, buf, sizeof buf);
                    text_add(&r, "%s%s", k++ ? ", " : "", buf);
                }
            text_add(&r, "%s", nm ? "; " : ". ");
        }
        if (nm) {
            text_add(&r, "reflectance varies: ");
            int k = 0;
            for (size_t i = 0; i < p->nmaterials; i++)
                if (p->materials[i].spectral)
                    text_add(&r, "%s%s", k++ ? ", " : "", p->materials[i].name);
            text_add(&r, ". ");
        }
        text_add(&r,
                 "Colour rides on every path's wavelengths (4 hero or %d fan-out lanes) at no "
                 "extra rays; the %d buckets are always rendered, so nothing is switched off "
                 "here.",
                 g.n, g.n);
    } else {
        text_add(&c, "flat");
        text_add(&r,
                 "every emission and reflectance is flat over %g-%g nm: all %d buckets hold "
                 "the same image up to noise. They are still rendered (nothing to split).",
                 g.lambda_min, g.lambda_max, g.n);
    }
    return set_decision(p, PLAN_COLOUR, nl + nm > 0, &c, &r);
}

static int decide_strategy(plan_t *p, const scene_t *s)
{
    text_t c = {0}, r = {0};
    int n = s->settings.grid.n;
    int asked = p->req.dispersion[0] != 0;
    dispersion_kind_t d = DISPERSION_HERO;
    if (asked && !integrators_dispersion_find(p->req.dispersion, &d))
        d = DISPERSION_HERO; /* the loader refused any other name already */
    p->choice.dispersion = d;
    text_add(&c, "%s", integrators_dispersion_name(d));
    if (asked)
        text_add(&r, "\"%s\" is asked for by the %s. ", p->req.dispersion,
                 p->req.dispersion_overridden ? "command line" : "scene");
    if (s->has_dispersion) {
        if (d == DISPERSION_HERO)
            text_add(&r,
                     "hero wavelengths (Wilkie et al. 2014): 4 continuous wavelengths per "
                     "path, no dispersive aliasing; at a dispersive refraction the 3 "
                     "secondaries end and the hero goes on alone (fan-out would follow %d "
                     "monochrome rays at the path's first one). Measured (docs/accuracy.md): "
                     "where light crosses glass once or twice (a prism, a lens) fan-out "
                     "lowers colour noise 3-4 times faster per CPU second at the same "
                     "luminance cost, so --dispersion fanout suits colour-critical renders; "
                     "in a gem's long internal chains it buys no colour and needs twice the "
                     "time for the same luminance error, which is why hero stays the default.",
                     n);
        else
            text_add(&r,
                     "fan-out (thesis 5.3-5.4): %d lanes per path at the bucket centres; the "
                     "first dispersive refraction follows %d monochrome rays, later ones one "
                     "chosen at random.",
                     n, n);
    } else if (s->camera.kind == CAMERA_REALISTIC && s->camera.lens_dispersive) {
        text_add(&r,
                 "only the camera's lens disperses: hero traces each camera ray at its hero "
                 "wavelength and ends the 3 secondaries there (one wavelength per path), "
                 "fan-out follows one of its %d lanes, picked at random and weighted by %d.",
                 n, n);
    } else {
        text_add(&r,
                 "no material disperses, so neither strategy ever splits: hero's 4 "
                 "wavelengths stay together on every path (never terminated) and fan-out's "
                 "%d lanes are never fanned out. The strategy changes time and colour noise "
                 "(and a bucket's average, hero, against its centre value, fan-out), "
                 "nothing else; hero carries 4 lanes per path instead of %d.",
                 n, n);
    }
    return set_decision(p, PLAN_STRATEGY,
                        s->has_dispersion ||
                            (s->camera.kind == CAMERA_REALISTIC && s->camera.lens_dispersive),
                        &c, &r);
}

static void light_reason(text_t *r, const scene_t *s, const plan_light_t *pl, size_t npl)
{
    char lab[96], glass[80], recv[80];
    light_label(s, pl->index, lab, sizeof lab);
    material_label(s, pl->glass_material, glass, sizeof glass);
    material_label(s, pl->receiver_material, recv, sizeof recv);
    text_add(r, "%s", lab);
    if (pl->undecided) {
        text_add(r, " was not decided within the plan's ray budget: assumed to need photons");
        return;
    }
    switch (pl->kind) {
    case LIGHT_INFINITE:
        text_add(r, " emits no photons (its light through glass is path traced)");
        return;
    case LIGHT_COLLIMATED:
        if (pl->direct)
            text_add(r,
                     " lights %s directly, and no camera path or light sample can find a "
                     "collimated light",
                     recv);
        if (pl->caustic)
            text_add(r, "%s reaches %s, which %s sees (L S+ D or G)", pl->direct ? ";" : "", glass,
                     recv);
        if (!pl->direct && !pl->caustic)
            text_add(r, " lights no diffuse or glossy surface, directly or through mirrors and glass");
        return;
    case LIGHT_POINT:
    case LIGHT_SPOT:
    case LIGHT_GONIOMETRIC:
    case LIGHT_PROJECTION:
    case LIGHT_DISTANT:
        if (npl == 0)
            text_add(r, ": the scene has no mirror or glass");
        else if (pl->caustic)
            text_add(r,
                     " reaches %s, which %s sees: an L S+ D or L S+ G path from a delta light, "
                     "which path tracing finds with probability zero",
                     glass, recv);
        else if (pl->reaches_specular)
            text_add(r, " reaches mirrors or glass, but no diffuse or glossy surface sees where it "
                        "arrives");
        else
            text_add(r, " reaches no mirror or glass");
        return;
    case LIGHT_AREA:
        if (npl == 0) {
            text_add(r, ": the scene has no mirror or glass");
            return;
        }
        if (pl->solid_angle < 0.0) {
            text_add(r, " faces no mirror or glass");
            return;
        }
        if (!pl->small) {
            text_add(r,
                     " subtends at least %.3g sr (>= %.3g) from every mirror and glass: "
                     "path tracing finds its caustics",
                     pl->solid_angle, PLAN_SMALL_SOLID_ANGLE);
            return;
        }
        if (!pl->bright) {
            text_add(r,
                     " is small (%.3g sr) but carries %.1f%% (< %.0f%%) of the light: its "
                     "caustic is faint",
                     pl->solid_angle, 100.0 * pl->power_share, 100.0 * PLAN_BRIGHT_SHARE);
            return;
        }
        if (pl->caustic)
            text_add(r,
                     " is small (%.3g sr < %.3g from the glass) and bright (%.1f%% of the "
                     "light) and reaches %s, which %s sees: path tracing would find this "
                     "caustic in fewer than 1 of 64 bounces (fireflies)",
                     pl->solid_angle, PLAN_SMALL_SOLID_ANGLE, 100.0 * pl->power_share, glass, recv);
        else
            text_add(r, " is small and bright, but no diffuse or glossy surface sees where it "
                        "reaches mirrors or glass");
        return;
    }
}

static int decide_photon(plan_t *p, const scene_t *s)
{
    text_t c = {0}, r = {0};
    int needed = 0, advised = 0;
    for (size_t i = 0; i < p->nlights; i++) {
        needed += p->lights[i].verdict == PLAN_LIGHT_NEEDED;
        advised += p->lights[i].verdict == PLAN_LIGHT_ADVISED;
    }
    int on = needed + advised > 0;
    /* The photon pass carries no participating media (its photons would cross fog without
     * attenuation and store nothing in it), so where the scene's media are simulated the
     * camera pass keeps them (volpath: delta tracking with next-event estimation) and the
     * pass stays off: the medium changes every pixel, a missing caustic only some. */
    if (on && p->current_media) {
        p->choice.photon_off_for_media = needed + advised;
        on = 0;
    }
    p->choice.photon = on;
    if (p->choice.photon_off_for_media)
        text_add(&c, "off (the media are carried by the camera pass)");
    else
        text_add(&c, "%s", on ? (needed ? "on (needed)" : "on (advised)") : "off");
    if (p->nlights == 0)
        text_add(&r, "the scene has no lights.");
    int k = 0;
    for (int pass = 0; pass < 2; pass++)
        for (size_t i = 0; i < p->nlights; i++) {
            int counts = p->lights[i].verdict != PLAN_LIGHT_NOT_NEEDED;
            if (counts != (pass == 0))
                continue;
            if (pass == 1 && on && k == needed + advised)
                text_add(&r, ". Other lights: ");
            else if (k > 0)
                text_add(&r, "; ");
            light_reason(&r, s, &p->lights[i], p->nplacements);
            k++;
        }
    if (p->nlights > 0)
        text_add(&r, ".");
    if (p->choice.photon_off_for_media)
        text_add(&r,
                 " The scene's participating media are simulated, and the photon pass carries no "
                 "media (its photons would cross the fog unattenuated and store nothing in it), so "
                 "the camera pass (volpath: delta tracking, next-event estimation in the medium) "
                 "carries the medium and the pass is off. Lost: the caustics that only light paths "
                 "find -- those of point, spot, distant and projection lights through smooth glass "
                 "and mirrors, on surfaces and in the medium (the volumetric caustic) -- are missing, "
                 "as in pbrt-v4's volpath; an area light's, its volumetric caustic included, are "
                 "path traced (the same mean, more noise).");
    else if (on)
        text_add(&r, " The photon pass stores these paths (docs/rendering.md).");
    else
        text_add(&r, " No light needs photons, so the pass is off: where no L S+ D or G path exists "
                     "it would store nothing and change no pixel; a large or faint light's "
                     "caustic is left to the path tracer.");
    return set_decision(p, PLAN_PHOTON, on, &c, &r);
}

static int decide_photon_params(plan_t *p, const scene_t *s, vec3_t lo, vec3_t hi, size_t npl)
{
    text_t c = {0}, r = {0};
    const render_settings_t *rs = &s->settings;
    if (!p->choice.photon || npl == 0) {
        if (p->choice.photon) {
            /* Only a collimated light's direct beam: no specular surfaces to size against. */
            p->choice.photons = (uint64_t)PLAN_PHOTONS_MIN;
            p->choice.radius = 0.01 * s->scene_radius;
            text_add(&c, "%llu photons, radius %.4g", (unsigned long long)p->choice.photons,
                     p->choice.radius);
            text_add(&r,
                     "no mirror or glass: the fewest photons (%.0f) and a hundredth of the "
                     "scene's bounding radius %.4g.",
                     PLAN_PHOTONS_MIN, s->scene_radius);
            return set_decision(p, PLAN_PHOTON_PARAMS, 1, &c, &r);
        }
        text_add(&c, "-");
        text_add(&r, "no photon pass.");
        return set_decision(p, PLAN_PHOTON_PARAMS, 0, &c, &r);
    }
    vec3_t centre = vec3_scale(vec3_add(lo, hi), 0.5);
    double aim = 0.5 * vec3_length(vec3_sub(hi, lo));
    vec3_t eye = transform_point(&s->camera.camera_to_world, vec3_make(0, 0, 0));
    double d = fmax(vec3_length(vec3_sub(centre, eye)), aim);
    int short_side = rs->xres < rs->yres ? rs->xres : rs->yres;
    double footprint = 2.0 * d * tan(0.5 * s->camera.fov_deg * PF_PI / 180.0) / short_side;
    double radius = PLAN_GATHER_PIXELS * footprint;
    double rmin = PLAN_RADIUS_MIN * s->scene_radius, rmax = PLAN_RADIUS_MAX * s->scene_radius;
    radius = fmin(rmax, fmax(rmin, radius));
    double ratio = aim > 0.0 ? aim / radius : 1.0;
    double n = PLAN_PHOTONS_PER_BUCKET * rs->grid.n * ratio * ratio / PLAN_STORED_FRACTION;
    n = fmin(PLAN_PHOTONS_MAX, fmax(PLAN_PHOTONS_MIN, n));
    n = ceil(n / PLAN_PHOTONS_ROUND) * PLAN_PHOTONS_ROUND;
    p->choice.photons = (uint64_t)n;
    p->choice.radius = radius;
    text_add(&c, "%llu photons, radius %.4g", (unsigned long long)p->choice.photons, radius);
    text_add(&r,
             "gather radius = %.0f pixel footprint(s) at the mirrors' and glasses' distance "
             "from the camera (%.3g, fov %g deg over %d pixels: footprint %.3g), kept within "
             "%g-%g of the scene's radius %.3g; photons = %.0f per bucket x %d buckets per "
             "gather disk over the specular surfaces' cross-section (bounding radius %.3g), "
             "%.0f%% of them stored: %.0f x %d x (%.3g / %.3g)^2 / %.1f, rounded up to %.0f "
             "and kept within %.0f-%.0f.",
             PLAN_GATHER_PIXELS, d, s->camera.fov_deg, short_side, footprint, PLAN_RADIUS_MIN,
             PLAN_RADIUS_MAX, s->scene_radius, PLAN_PHOTONS_PER_BUCKET, rs->grid.n, aim,
             100.0 * PLAN_STORED_FRACTION, PLAN_PHOTONS_PER_BUCKET, rs->grid.n, aim, radius,
             PLAN_STORED_FRACTION, PLAN_PHOTONS_ROUND, PLAN_PHOTONS_MIN, PLAN_PHOTONS_MAX);
    if (p->current_photon.enabled)
        text_add(&r, " The scene asks for %llu photons and radius %s%.4g.",
                 (unsigned long long)p->current_photon.photons,
                 p->current_photon.radius > 0.0 ? "" : "automatic, ",
                 p->current_photon.radius > 0.0 ? p->current_photon.radius
                                                : 0.01 * s->scene_radius);
    return set_decision(p, PLAN_PHOTON_PARAMS, 1, &c, &r);
}

static int decide_integrator(plan_t *p)
{
    text_t c = {0}, r = {0};
    const plan_request_t *q = &p->req;
    p->choice.integrator = INTEGRATOR_PATH;
    const char *chosen = p->choice.photon ? "photon (path gather)" : "path";
    int is_auto = !strcmp(q->integrator, "auto");
    text_add(&c, "%s", chosen);
    if (is_auto) {
        text_add(&r, "%s: integrator \"auto\" follows the plan. ",
                 q->overridden         ? "the command line asks for \"auto\""
                 : q->integrator_named ? "the scene names Integrator \"auto\""
                                       : "the scene names no Integrator");
    } else if (plan_follows_photons(q)) {
        text_add(&r,
                 "the %s asks for pbrt-v4's \"%s\", which traces paths from the lights: "
                 "prismfarm renders it with the path tracer and takes the plan's photon pass "
                 "for the caustics only light paths find. ",
                 q->overridden ? "command line" : "scene", q->integrator);
    } else {
        int asked_photon = !strcmp(q->integrator, "photon");
        int asked_path = !strcmp(q->integrator, "path");
        p->choice.differs = asked_photon ? !p->choice.photon : asked_path ? p->choice.photon : 1;
        text_add(&r,
                 "the %s asks for \"%s\", which is kept (explicit integrators are never "
                 "changed); ",
                 q->overridden ? "command line" : "scene", q->integrator);
        if (p->choice.differs) {
            text_add(&c, " (the %s keeps \"%s\")", q->overridden ? "command line" : "scene",
                     q->integrator);
            text_add(&r, "the plan would choose %s instead (mismatch). ", chosen);
        } else
            text_add(&r, "the plan agrees. ");
    }
    if (p->choice.photon)
        text_add(&r, "A photon pass is called for, gathered by the path tracer (next-event "
                     "estimation with MIS for everything else).");
    else if (p->choice.photon_off_for_media)
        text_add(&r, "The scene's media are carried by the camera pass (volpath's delta tracking "
                     "and next-event estimation); the photon pass, which cannot carry them, is off "
                     "(see the photon pass).");
    else
        text_add(&r, "No photon pass is called for: the path tracer (next-event estimation with "
                     "MIS) finds every light path this scene has.");
    return set_decision(p, PLAN_INTEGRATOR, 1, &c, &r);
}

plan_t *plan_new(const scene_t *scene, const plan_request_t *req, err_t *err)
{
    plan_t *p = calloc(1, sizeof *p);
    if (!p) {
        err_set(err, "out of memory");
        return NULL;
    }
    p->req = *req;
    p->grid = scene->settings.grid;
    p->current_integrator = scene->settings.integrator;
    p->current_media = scene->settings.media;
    p->current_dispersion = scene->settings.dispersion;
    p->current_photon = scene->settings.photon;
    p->nmaterials = scene->nmaterials;
    p->nlights = scene->nlights;
    p->materials = calloc(p->nmaterials ? p->nmaterials : 1, sizeof *p->materials);
    p->lights = calloc(p->nlights ? p->nlights : 1, sizeof *p->lights);
    placement_t *pls = NULL;
    vec3_t lo, hi;
    long npl = -1;
    tracer_t t = {.s = scene, .budget = PLAN_RAY_BUDGET};
    t.max_hops =
        scene->settings.maxdepth < PLAN_MAX_HOPS ? scene->settings.maxdepth : PLAN_MAX_HOPS;
    t.stamp = calloc(scene->nshapes ? scene->nshapes : 1, sizeof *t.stamp);
    t.visits = calloc(scene->nshapes ? scene->nshapes : 1, sizeof *t.visits);
    t.queue = malloc(PLAN_QUEUE_MAX * sizeof *t.queue);
    double **cdfs = calloc(scene->nshapes ? scene->nshapes : 1, sizeof *cdfs);
    if (p->materials && p->lights && t.stamp && t.visits && t.queue && cdfs)
        npl = specular_placements(scene, &pls, cdfs, &lo, &hi);
    int rc = npl < 0 ? -1 : 0;
    if (!rc) {
        plan_materials(p, scene);
        double total = 0.0;
        for (size_t i = 0; i < scene->nlights; i++)
            total += scene_light_power(scene, &scene->lights[i]);
        for (size_t i = 0; i < scene->nlights; i++) {
            p->lights[i].index = (int)i;
            /* max_hops 0: no scattering, so no caustic; a beam's direct light still counts. */
            plan_one_light(&t, &p->lights[i], pls, t.max_hops > 0 ? (size_t)npl : 0, total,
                           scene->settings.grid);
        }
        p->rays = t.rays;
        p->nplacements = t.max_hops > 0 ? (size_t)npl : 0;
        rc = decide_splitting(p, scene) || decide_colour(p, scene) || decide_strategy(p, scene) ||
             decide_photon(p, scene) || decide_photon_params(p, scene, lo, hi, (size_t)npl) ||
             decide_integrator(p) || decide_polarisation(p, scene);
    }
    free(pls);
    for (size_t i = 0; cdfs && i < scene->nshapes; i++)
        free(cdfs[i]);
    free(cdfs);
    free(t.stamp);
    free(t.visits);
    free(t.queue);
    if (rc) {
        plan_destroy(&p);
        err_set(err, "out of memory");
        return NULL;
    }
    return p;
}

void plan_destroy(plan_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    plan_t *p = *self_p;
    for (size_t i = 0; i < 2 * PLAN_EFFECT_COUNT; i++)
        free(p->strings[i]);
    free(p->materials);
    free(p->lights);
    free(p);
    *self_p = NULL;
}

size_t plan_decision_count(const plan_t *self)
{
    (void)self;
    return PLAN_EFFECT_COUNT;
}

const plan_decision_t *plan_decision_at(const plan_t *self, size_t i)
{
    return i < PLAN_EFFECT_COUNT ? &self->decisions[i] : NULL;
}

const plan_decision_t *plan_decision_of(const plan_t *self, plan_effect_t effect)
{
    return plan_decision_at(self, (size_t)effect);
}

size_t plan_material_count(const plan_t *self)
{
    return self->nmaterials;
}

const plan_material_t *plan_material_at(const plan_t *self, size_t i)
{
    return i < self->nmaterials ? &self->materials[i] : NULL;
}

size_t plan_light_count(const plan_t *self)
{
    return self->nlights;
}

const plan_light_t *plan_light_at(const plan_t *self, size_t i)
{
    return i < self->nlights ? &self->lights[i] : NULL;
}

plan_choice_t plan_choice(const plan_t *self)
{
    return self->choice;
}

const plan_request_t *plan_request(const plan_t *self)
{
    return &self->req;
}

uint64_t plan_rays(const plan_t *self)
{
    return self->rays;
}

void plan_apply(const plan_t *self, render_settings_t *rs)
{
    rs->integrator = self->choice.integrator;
    if (!self->req.dispersion[0])
        rs->dispersion = self->choice.dispersion;
    /* The photon integrator's defaults (render_settings_default) with the plan's count and
     * radius; both passes share maxdepth, as with Integrator "photon". */
    photon_settings_t ph = render_settings_default().photon;
    if (self->choice.photon) {
        ph.enabled = 1;
        ph.store = PHOTON_STORE_PHOTONMAP;
        ph.photons = self->choice.photons;
        ph.radius = self->choice.radius;
        ph.maxdepth = rs->maxdepth;
    }
    rs->photon = ph;
}

int plan_follows_photons(const plan_request_t *req)
{
    const integrator_name_t *in = integrators_find(req->integrator);
    return in && in->plan_photons;
}

int plan_apply_auto(scene_t *scene, const scene_desc_t *desc, const scene_overrides_t *ov,
                    err_t *err)
{
    plan_request_t req = plan_request_make(desc, ov);
    const int is_auto = !strcmp(req.integrator, "auto");
    if (!is_auto && !plan_follows_photons(&req))
        return 0;
    plan_t *p = plan_new(scene, &req, err);
    if (!p)
        return -1;
    int rc = 0;
    const int off = plan_choice(p).photon_off_for_media;
    if (off && warnings_add(scene->warnings, desc->media_loc,
                            "the scene's media are kept, so the plan's photon pass is off for the %d "
                            "light%s whose caustics called for it (its photons cannot cross media): "
                            "their caustics through smooth glass and mirrors, which only light paths "
                            "find, are path traced for area lights and missing for point, spot and "
                            "distant lights (`prismfarm plan` says which)",
                            off, off == 1 ? "" : "s"))
        rc = err_set(err, "out of memory");
    if (is_auto) {
        plan_apply(p, &scene->settings);
    } else {
        /* bdpt, mlt, lightpath: only the photon pass is the plan's; the integrator, its depth
         * and the dispersion strategy stay as the file's mapping set them. */
        render_settings_t rs = scene->settings;
        plan_apply(p, &rs);
        scene->settings.photon = rs.photon;
    }
    plan_destroy(&p);
    return rc;
}

/* ---- the report ---- */

/* Writes text wrapped at width columns, each line indented by indent spaces. */
static void write_wrapped(FILE *out, const char *text, int indent, int width)
{
    const char *s = text;
    while (*s) {
        while (*s == ' ')
            s++;
        if (!*s)
            break;
        int room = width - indent;
        int len = (int)strlen(s);
        int cut = len;
        if (len > room) {
            cut = room;
            while (cut > 0 && s[cut] != ' ')
                cut--;
            if (cut == 0) {
                cut = room;
                while (s[cut] && s[cut] != ' ')
                    cut++;
            }
        }
        fprintf(out, "%*s%.*s\n", indent, "", cut, s);
        s += cut;
    }
}

static void current_settings(const plan_t *p, char *buf, size_t n)
{
    if (p->current_photon.enabled)
        snprintf(buf, n, "photon (%s gather, %llu photons), %s",
                 integrators_kind_name(p->current_integrator),
                 (unsigned long long)p->current_photon.photons,
                 integrators_dispersion_name(p->current_dispersion));
    else
        snprintf(buf, n, "%s, %s",
                 integrators_used_name(p->current_integrator, false, p->current_media),
                 integrators_dispersion_name(p->current_dispersion));
}

int plan_write_text(const plan_t *p, FILE *out)
{
    char cur[160];
    current_settings(p, cur, sizeof cur);
    fprintf(out, "integrator asked: %s (%s)\nrenders with:     %s\n\n", p->req.integrator,
            p->req.overridden         ? "command line"
            : p->req.integrator_named ? "Integrator directive"
                                      : "no Integrator directive",
            cur);
    fprintf(out, "%-22s %-4s %s\n", "EFFECT", "ON", "CHOICE");
    for (size_t i = 0; i < PLAN_EFFECT_COUNT; i++) {
        const plan_decision_t *d = &p->decisions[i];
        fprintf(out, "%-22s %-4s %s\n", d->effect_name, d->on ? "yes" : "no", d->choice);
        write_wrapped(out, d->reason, 4, 100);
    }
    int any = 0;
    for (size_t i = 0; i < p->nmaterials; i++)
        any |= material_has_ior(p->materials[i].kind) || p->materials[i].kind == MATERIAL_CONDUCTOR ||
               p->materials[i].kind == MATERIAL_COATED_CONDUCTOR;
    if (any) {
        /* The name column fits the longest name (file:line labels run past 16). */
        int w = 16;
        for (size_t i = 0; i < p->nmaterials; i++)
            if ((int)strlen(p->materials[i].name) > w)
                w = (int)strlen(p->materials[i].name);
        fprintf(out, "\nMIRRORS AND GLASS\n%-*s %-11s %-6s %-9s %-9s %-8s %-9s %s\n", w,
                "material", "kind", "disp.", "n_lo", "n_hi", "dn", "n_d", "v_d");
        for (size_t i = 0; i < p->nmaterials; i++) {
            const plan_material_t *m = &p->materials[i];
            if (m->kind == MATERIAL_CONDUCTOR)
                fprintf(out, "%-*s %-11s %-6s\n", w, m->name, "conductor", "-");
            if (!material_has_ior(m->kind))
                continue;
            fprintf(out, "%-*s %-11s %-6s %-9.5f %-9.5f %-8.5f %-9.5f ", w, m->name,
                    plan_material_kind_name(m->kind),
                    m->dispersive ? "yes" : "no", m->n_lo, m->n_hi, m->n_lo - m->n_hi, m->n_d);
            if (m->has_v_d)
                fprintf(out, "%.2f\n", m->v_d);
            else
                fprintf(out, "inf\n");
        }
    }
    if (p->nlights > 0) {
        fprintf(out, "\nLIGHTS\n%-3s %-11s %-6s %-7s %-9s %-7s %-7s %-7s %-12s %s\n", "#", "kind",
                "shape", "power", "omega sr", "small", "bright", "caustic", "receiver", "photons");
        for (size_t i = 0; i < p->nlights; i++) {
            const plan_light_t *l = &p->lights[i];
            char shape[16] = "-", omega[16] = "-", recv[64] = "-";
            if (l->shape >= 0)
                snprintf(shape, sizeof shape, "%d", l->shape);
            if (l->solid_angle >= 0.0)
                snprintf(omega, sizeof omega, "%.4f", l->solid_angle);
            if (l->receiver_material >= 0)
                snprintf(recv, sizeof recv, "%s", p->materials[l->receiver_material].name);
            fprintf(out, "%-3d %-11s %-6s %-7.3f %-9s %-7s %-7s %-7s %-12s %s\n", l->index,
                    plan_light_kind_name(l->kind), shape, l->power_share, omega,
                    l->kind == LIGHT_AREA ? (l->small ? "yes" : "no") : "-",
                    l->bright ? "yes" : "no",
                    l->caustic  ? "yes"
                    : l->direct ? "direct"
                                : "no",
                    recv, plan_verdict_name(l->verdict));
        }
    }
    fprintf(out, "\nSWITCHED OFF\n");
    int off = 0;
    for (size_t i = 0; i < PLAN_EFFECT_COUNT; i++) {
        const plan_decision_t *d = &p->decisions[i];
        if (d->on)
            continue;
        const char *why = "";
        switch (d->effect) {
        case PLAN_SPLITTING:
            why = "no material disperses";
            break;
        case PLAN_COLOUR:
            why = "every spectrum is flat (buckets still rendered)";
            break;
        case PLAN_STRATEGY:
            why = "nothing disperses: the strategy never splits (time and colour noise only)";
            break;
        case PLAN_PHOTON:
            why = "no light needs photons";
            break;
        case PLAN_PHOTON_PARAMS:
            why = "no photon pass";
            break;
        case PLAN_POLARISATION:
            why = "nothing polarising is seen or asked for (intensities only)";
            break;
        default:
            break;
        }
        fprintf(out, "  %-22s %s\n", d->effect_name, why);
        off++;
    }
    if (!off)
        fprintf(out, "  nothing: every effect the renderer has is called for\n");
    fprintf(out, "\n(%llu visibility rays)\n", (unsigned long long)p->rays);
    return ferror(out) ? -1 : 0;
}
