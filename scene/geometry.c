#include "geometry.h"

#include <embree3/rtcore.h>
#include <float.h>
#include <math.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>

typedef enum { ANALYTIC_SPHERE, ANALYTIC_DISK } analytic_kind_t;

typedef struct analytic {
    analytic_kind_t kind;
    transform_t to_world, to_object; /* object space to the space of its group */
    double radius, height;
} analytic_t;

/* A placed object: the group it instances and its transform, kept in double so that hits on
 * instanced spheres and disks are refined as accurately as world ones. */
typedef struct instance {
    int group;
    uint32_t id;
    transform_t to_world, to_object;
    int swaps; /* to_world swaps handedness */
} instance_t;

typedef enum { GEOM_MESH, GEOM_ANALYTIC, GEOM_INSTANCE, GEOM_CURVES } geom_kind_t;

/* A mesh's view of Embree's own vertex and index buffers (owned by the Embree geometry, which
 * its scene keeps alive): hit points are rebuilt from barycentrics, and the filter functions
 * decide in double which side of a triangle a ray starts on. Allocated one by one, as Embree's
 * user data pointer to it must not move. */
/* First members of the user data of meshes and curves: a context filter sees the user data of
 * whatever geometry a candidate lies on. */
#define MESH_TAG 0x6D657368u   /* "mesh" */
#define CURVES_TAG 0x63757276u /* "curv" */

typedef struct mesh {
    uint32_t tag; /* MESH_TAG: what mesh_context_filter tells a mesh's user data by */
    const float *verts;
    const unsigned *tris;
    int world; /* in the world's scene: checked by geometry_intersect and _occluded, not by a
                * geometry filter (see mesh_context_filter) */
} mesh_t;

/* Where an Embree primitive of a split curve lies on the caller's segment: u from j / m to
 * (j + 1) / m of segment seg. */
typedef struct curve_piece {
    uint32_t seg;
    uint16_t j, m;
} curve_piece_t;

/* Curves' view of Embree's vertex buffer (x, y, z, radius; 4 per primitive, primitive k's first
 * at 4 k: the index buffer is 0, 4, 8, ...), where each primitive is one of the caller's
 * segments or, where a segment was split (curve_splits), a piece of one (piece says which);
 * and, for ribbons, each of the caller's segments' two end normals in double (6 numbers per
 * segment), which the shading normal slerps between exactly. */
typedef struct curves {
    uint32_t tag; /* CURVES_TAG */
    const float *verts;
    int ribbon;
    const curve_piece_t *piece; /* by primitive; NULL when no segment was split */
    double n[];                 /* 6 per segment when ribbon, then the pieces when split */
} curves_t;

/* What one Embree geometry id of a group is. Analytic shapes and instances are allocated one
 * by one because Embree keeps a pointer to each analytic shape as user data: they must not
 * move when the array grows. */
typedef struct geom_info {
    geom_kind_t kind;
    uint32_t shape;
    int flip;
    analytic_t *analytic;
    instance_t *instance;
    mesh_t *mesh;
    curves_t *curves;
} geom_info_t;

/* An Embree scene: group 0 is the world, group k > 0 is object k - 1. */
typedef struct group {
    RTCScene scene;
    int committed;
    size_t nshapes;
    geom_info_t *info; /* by geomID */
    size_t ngeoms, cap;
    vec3_t lo, hi;
} group_t;

struct geometry {
    RTCDevice device;
    char device_error[256];
    atomic_llong memory; /* bytes, from Embree's memory monitor (called from build threads) */
    group_t *groups;
    size_t ngroups, cap_groups;
    /* The query hook (geometry_set_query_hook), NULL in normal use. */
    geometry_query_fn query_hook;
    void *query_user;
};

static void on_device_error(void *user, enum RTCError code, const char *str)
{
    geometry_t *self = user;
    snprintf(self->device_error, sizeof self->device_error, "Embree error %d: %s", (int)code,
             str ? str : "(no message)");
}

/* Embree calls this before each allocation with +bytes and after each release with -bytes
 * (rtcSetDeviceMemoryMonitorFunction(3)); the running sum is what it holds. */
static bool on_memory(void *user, ssize_t bytes, bool post)
{
    (void)post;
    geometry_t *self = user;
    atomic_fetch_add(&self->memory, (long long)bytes);
    return true;
}

static int check_device(geometry_t *self, const char *what, err_t *err)
{
    enum RTCError code = rtcGetDeviceError(self->device);
    if (code == RTC_ERROR_NONE && !self->device_error[0])
        return 0;
    int r =
        err_set(err, "%s: %s", what, self->device_error[0] ? self->device_error : "Embree error");
    self->device_error[0] = 0;
    return r;
}

static vec3_t empty_lo(void)
{
    return vec3_make(INFINITY, INFINITY, INFINITY);
}
static vec3_t empty_hi(void)
{
    return vec3_make(-INFINITY, -INFINITY, -INFINITY);
}

/* Appends a group with a new Embree scene; returns its index or -1. */
static int new_group(geometry_t *self, err_t *err)
{
    if (self->ngroups == self->cap_groups) {
        size_t cap = self->cap_groups ? 2 * self->cap_groups : 4;
        group_t *g = realloc(self->groups, cap * sizeof *g);
        if (!g)
            return err_set(err, "out of memory");
        self->groups = g;
        self->cap_groups = cap;
    }
    group_t *g = &self->groups[self->ngroups];
    memset(g, 0, sizeof *g);
    g->lo = empty_lo();
    g->hi = empty_hi();
    g->scene = rtcNewScene(self->device);
    if (!g->scene)
        return check_device(self, "creating an Embree scene", err)
                   ? -1
                   : err_set(err, "Embree: rtcNewScene failed");
    self->ngroups++;
    rtcSetSceneFlags(g->scene, RTC_SCENE_FLAG_ROBUST | RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);
    rtcSetSceneBuildQuality(g->scene, RTC_BUILD_QUALITY_HIGH);
    if (check_device(self, "creating an Embree scene", err))
        return -1;
    return (int)(self->ngroups - 1);
}

geometry_t *geometry_new(int nthreads, err_t *err)
{
    geometry_t *self = calloc(1, sizeof *self);
    if (!self) {
        err_set(err, "out of memory");
        return NULL;
    }
    atomic_init(&self->memory, 0);
    char config[64];
    snprintf(config, sizeof config, "threads=%d", nthreads > 0 ? nthreads : 0);
    self->device = rtcNewDevice(config);
    if (!self->device) {
        err_set(err, "Embree: rtcNewDevice(\"%s\") failed (error %d)", config,
                (int)rtcGetDeviceError(NULL));
        free(self);
        return NULL;
    }
    rtcSetDeviceErrorFunction(self->device, on_device_error, self);
    rtcSetDeviceMemoryMonitorFunction(self->device, on_memory, self);
    if (new_group(self, err) < 0) {
        geometry_destroy(&self);
        return NULL;
    }
    return self;
}

void geometry_destroy(geometry_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    geometry_t *self = *self_p;
    /* The world (which references the objects' scenes through instances) goes first. */
    for (size_t k = 0; k < self->ngroups; k++) {
        group_t *g = &self->groups[k];
        if (g->scene)
            rtcReleaseScene(g->scene);
        for (size_t i = 0; i < g->ngeoms; i++) {
            free(g->info[i].analytic);
            free(g->info[i].instance);
            free(g->info[i].mesh);
            free(g->info[i].curves);
        }
        free(g->info);
    }
    free(self->groups);
    if (self->device)
        rtcReleaseDevice(self->device);
    free(self);
    *self_p = NULL;
}

static void grow_bounds(vec3_t *lo, vec3_t *hi, vec3_t p)
{
    *lo = vec3_make(fmin(lo->x, p.x), fmin(lo->y, p.y), fmin(lo->z, p.z));
    *hi = vec3_make(fmax(hi->x, p.x), fmax(hi->y, p.y), fmax(hi->z, p.z));
}

static int record(group_t *g, unsigned id, geom_info_t info, err_t *err)
{
    if (id >= g->cap) {
        size_t cap = g->cap ? g->cap * 2 : 16;
        while (cap <= id)
            cap *= 2;
        geom_info_t *ni = realloc(g->info, cap * sizeof *ni);
        if (!ni)
            return err_set(err, "out of memory adding shape %u", info.shape);
        memset(ni + g->cap, 0, (cap - g->cap) * sizeof *ni);
        g->info = ni;
        g->cap = cap;
    }
    g->info[id] = info;
    if (id + 1 > g->ngeoms)
        g->ngeoms = id + 1;
    return 0;
}

/* The group a shape goes to, or NULL (with err) when the object is unknown or already placed. */
static group_t *target(geometry_t *self, int object, uint32_t shape, err_t *err)
{
    if (object < GEOMETRY_WORLD || (size_t)(object + 1) >= self->ngroups) {
        err_set(err, "shape %u: there is no object %d", shape, object);
        return NULL;
    }
    group_t *g = &self->groups[object + 1];
    if (g->committed) {
        if (object == GEOMETRY_WORLD)
            err_set(err, "shape %u added after the scene was committed", shape);
        else
            err_set(err, "shape %u added to object %d after it was instanced", shape, object);
        return NULL;
    }
    return g;
}

int geometry_object_new(geometry_t *self, err_t *err)
{
    if (self->groups[0].committed)
        return err_set(err, "object added after the scene was committed");
    int k = new_group(self, err);
    return k < 0 ? -1 : k - 1;
}

/* Embree intersects triangles in float, relative to the ray origin: for a ray that starts on
 * a triangle (offset by geometry_offset) the sign of its tiny distance to the plane is lost in
 * the rounding of vertex - origin when the vertices are far from the origin compared with the
 * offset (a 200-unit ground plane seen near its centre gave 0.47 instead of 0.5 in a furnace,
 * a 2e4-unit one 0.33). So every candidate hit is checked again in double: a ray can cross the
 * plane of a triangle at t > 0 only if its origin lies strictly on one side and it travels
 * toward the other. The float vertices and the float ray are what Embree intersected, and
 * their differences and the cross product are exact or nearly so in double, so this rejects
 * exactly the false hits and never a true one. Rays and hits come in Embree's SOA layout
 * (rtcore_ray.h): org x, y, z at 0N, 1N, 2N, dir at 4N, 5N, 6N; primID at 5N of the hit. */
static int mesh_accepts(const mesh_t *m, unsigned prim, const float org[3], const float dir[3])
{
    const unsigned *tri = m->tris + 3 * (size_t)prim;
    const float *a = m->verts + 3 * (size_t)tri[0], *b = m->verts + 3 * (size_t)tri[1],
                *c = m->verts + 3 * (size_t)tri[2];
    vec3_t e1 = vec3_make((double)b[0] - a[0], (double)b[1] - a[1], (double)b[2] - a[2]);
    vec3_t e2 = vec3_make((double)c[0] - a[0], (double)c[1] - a[1], (double)c[2] - a[2]);
    vec3_t n = vec3_cross(e1, e2);
    vec3_t o = vec3_make((double)org[0] - a[0], (double)org[1] - a[1], (double)org[2] - a[2]);
    vec3_t d = vec3_make(dir[0], dir[1], dir[2]);
    double side = vec3_dot(o, n), toward = vec3_dot(d, n);
    return (side > 0.0 && toward < 0.0) || (side < 0.0 && toward > 0.0);
}

/* mesh_accepts on every valid candidate of a packet; only_world: leave the candidates of
 * meshes that are not in the world's scene alone (their geometry filter has judged them). */
static void filter_candidates(const struct RTCFilterFunctionNArguments *args, int only_world)
{
    const mesh_t *m = args->geometryUserPtr;
    if (!m || m->tag != MESH_TAG || (only_world && !m->world))
        return;
    const float *ray = (const float *)args->ray;
    const unsigned *hit = (const unsigned *)args->hit;
    const unsigned N = args->N;
    for (unsigned i = 0; i < N; i++) {
        if (!args->valid[i])
            continue;
        const float org[3] = {ray[0 * N + i], ray[1 * N + i], ray[2 * N + i]};
        const float dir[3] = {ray[4 * N + i], ray[5 * N + i], ray[6 * N + i]};
        if (!mesh_accepts(m, hit[5 * N + i], org, dir))
            args->valid[i] = 0;
    }
}

/* The geometry filter of the meshes of objects (instanced): Embree hands it the ray in the
 * object's space, as Embree itself transformed it in float, which only a filter sees. */
static void mesh_filter(const struct RTCFilterFunctionNArguments *args)
{
    filter_candidates(args, 0);
}

/* The world's meshes carry no geometry filter: a filter on every candidate costs Embree its
 * fast path (6-7 % of the CPU of caustic-glass, 2.4 % of its instructions; docs/performance.md).
 * geometry_intersect traces without a filter and checks only the nearest candidate with
 * mesh_accepts; should it refuse it (a false self-hit: rare), it traces again with this context
 * filter, which judges every candidate of a world mesh as the geometry filter did. Either way
 * the hit returned is the nearest candidate that passes mesh_accepts, the hit the filtered
 * trace found before, so the guarantee above (and the furnace on a 2e4-unit plane:
 * tests/unit/test_numeric_hard.c) holds for every hit, and the pixels are the same.
 * geometry_occluded likewise: no candidate without the filter means none with it, and a
 * candidate is confirmed by the filtered trace. Embree calls a context filter only in scenes
 * with RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION (new_group sets it). */
static void mesh_context_filter(const struct RTCFilterFunctionNArguments *args)
{
    filter_candidates(args, 1);
}

int geometry_object_add_mesh(geometry_t *self, int object, const double *positions, size_t nverts,
                             const uint32_t *indices, size_t ntris, uint32_t shape, int flip,
                             err_t *err)
{
    group_t *grp = target(self, object, shape, err);
    if (!grp)
        return -1;
    if (nverts == 0 || ntris == 0)
        return err_set(err, "shape %u: a mesh needs vertices and triangles", shape);
    for (size_t i = 0; i < 3 * ntris; i++)
        if (indices[i] >= nverts)
            return err_set(err, "shape %u: triangle %zu uses vertex %u of %zu", shape, i / 3,
                           indices[i], nverts);
    for (size_t i = 0; i < 3 * nverts; i++)
        if (!isfinite(positions[i]))
            return err_set(err, "shape %u: vertex %zu is not finite", shape, i / 3);
    RTCGeometry g = rtcNewGeometry(self->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    if (!g)
        return check_device(self, "creating a mesh", err)
                   ? -1
                   : err_set(err, "Embree: rtcNewGeometry failed");
    /* rtcSetNewGeometryBuffer pads the buffer as Embree's SSE loads require. */
    float *v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                       3 * sizeof(float), nverts);
    unsigned *ix = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                           3 * sizeof(unsigned), ntris);
    if (!v || !ix) {
        rtcReleaseGeometry(g);
        return check_device(self, "allocating mesh buffers", err) ? -1
                                                                  : err_set(err, "out of memory");
    }
    vec3_t lo = grp->lo, hi = grp->hi;
    for (size_t i = 0; i < nverts; i++) {
        v[3 * i + 0] = (float)positions[3 * i + 0];
        v[3 * i + 1] = (float)positions[3 * i + 1];
        v[3 * i + 2] = (float)positions[3 * i + 2];
        grow_bounds(&lo, &hi,
                    vec3_make(positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]));
    }
    memcpy(ix, indices, 3 * ntris * sizeof(unsigned));
    mesh_t *m = malloc(sizeof *m);
    if (!m) {
        rtcReleaseGeometry(g);
        return err_set(err, "out of memory");
    }
    *m = (mesh_t){.tag = MESH_TAG, .verts = v, .tris = ix, .world = object == GEOMETRY_WORLD};
    rtcSetGeometryUserData(g, m);
    if (!m->world) {
        rtcSetGeometryIntersectFilterFunction(g, mesh_filter);
        rtcSetGeometryOccludedFilterFunction(g, mesh_filter);
    }
    rtcCommitGeometry(g);
    unsigned id = rtcAttachGeometry(grp->scene, g);
    rtcReleaseGeometry(g);
    if (check_device(self, "adding a mesh", err) ||
        record(grp, id, (geom_info_t){.kind = GEOM_MESH, .shape = shape, .flip = flip, .mesh = m},
               err)) {
        free(m);
        return -1;
    }
    grp->lo = lo;
    grp->hi = hi;
    grp->nshapes++;
    return 0;
}

void geometry_bezier(const double *cp, double u, vec3_t *p, vec3_t *dpdu)
{
    double s = 1.0 - u;
    double b[4] = {s * s * s, 3.0 * s * s * u, 3.0 * s * u * u, u * u * u};
    double d[4] = {-3.0 * s * s, 3.0 * s * s - 6.0 * s * u, 6.0 * s * u - 3.0 * u * u, 3.0 * u * u};
    vec3_t q = {0, 0, 0}, t = {0, 0, 0};
    for (int k = 0; k < 4; k++) {
        vec3_t c = vec3_make(cp[3 * k], cp[3 * k + 1], cp[3 * k + 2]);
        q = vec3_fma(q, c, b[k]);
        t = vec3_fma(t, c, d[k]);
    }
    *p = q;
    *dpdu = t;
}

/* The radius of segment prim of a curve set at u (a cubic Bezier of the control radii). */
static double curve_radius(const curves_t *c, unsigned prim, double u)
{
    const float *v = c->verts + 16 * (size_t)prim;
    double s = 1.0 - u;
    return s * s * s * v[3] + 3.0 * s * s * u * v[7] + 3.0 * s * u * u * v[11] + u * u * u * v[15];
}

/* Drops a curve hit nearer the ray's origin than 2.5 radii (geometry.h). A ray leaving a fibre
 * starts within a radius of its centre line, and the ribbon that faces it crosses its path
 * within another, so its own fibre is always dropped. Layouts as in mesh_filter; tfar holds
 * the candidate's distance, u is at 3N of the hit. */
static void curve_filter(const struct RTCFilterFunctionNArguments *args)
{
    const curves_t *c = args->geometryUserPtr;
    const float *ray = (const float *)args->ray, *hitf = (const float *)args->hit;
    const unsigned *hit = (const unsigned *)args->hit;
    const unsigned N = args->N;
    for (unsigned i = 0; i < N; i++) {
        if (!args->valid[i])
            continue;
        vec3_t d = vec3_make(ray[4 * N + i], ray[5 * N + i], ray[6 * N + i]);
        double dist = (double)ray[8 * N + i] * vec3_length(d);
        if (dist < 2.5 * curve_radius(c, hit[5 * N + i], hitf[3 * N + i]))
            args->valid[i] = 0;
    }
}

/* How many straight pieces Embree cuts each segment of a curve set into (its tessellation
 * rate; Embree's default is 4). Embree intersects flat and normal-oriented curves as those
 * pieces, so the strip it finds lies off the true centre line by up to the chord's sagitta,
 * and a hit's h, measured from the true centre line, is off by that over the radius. A cubic
 * Bezier cut into n equal steps of u departs from its chords by at most
 * max|B''| / (8 n^2) <= 6 L0 / (8 n^2), L0 the largest second difference of its control
 * points; pbrt-v4 refines until that is under a twentieth of the width (Curve::IntersectRay's
 * eps), and so does this, n = sqrt(7.5 sqrt(3) L0 / r_min) (L0 per coordinate), up to
 * Embree 3's limit of 16 pieces (it clamps the rate there), which a segment that wants more
 * never reaches: it is split first (curve_splits). The wavy hairs of hair-eumel-2's
 * substitute (width 0.02-0.035) ask for 5-26 pieces (median 14), where Embree's default 4
 * left the strip up to 2 radii off its centre line: grazing h, whose Fresnel reflects most,
 * came up too often and the image was 4 % bright (docs/compatibility.md). */
static float curve_tessellation(const double *cp, const double *radii, size_t nseg)
{
    double l0 = 0.0, rmin = INFINITY;
    for (size_t k = 0; k < nseg; k++) {
        const double *q = cp + 12 * k;
        for (int i = 0; i < 2; i++)
            for (int j = 0; j < 3; j++)
                l0 = fmax(l0, fabs(q[3 * i + j] - 2.0 * q[3 * (i + 1) + j] + q[3 * (i + 2) + j]));
        for (int i = 0; i < 4; i++)
            rmin = fmin(rmin, radii[4 * k + i]);
    }
    double n = ceil(sqrt(7.5 * l0 * sqrt(3.0) / rmin));
    return (float)fmin(16.0, fmax(4.0, isfinite(n) ? n : 16.0));
}

/* Embree 3's most pieces per segment, and the most sub-segments one segment is split into
 * (so at most 256 pieces: a curve thinner still for its bend keeps (n / 256)^2 / 10 radii of
 * error rather than costing unbounded memory; pbrt-v4 bounds its own refinement too, at 2^10
 * steps of each eighth of a segment). */
#define CURVE_PIECES_MAX 16
#define CURVE_SPLITS_MAX 16

/* Into how many sub-segments, at equal steps of u, one segment (4 control points q, radii r)
 * is split so that each wants at most 16 pieces by curve_tessellation's rule: its own
 * n = sqrt(7.5 sqrt(3) L0 / r_min) over 16, rounded up. A piece of 1/m of the segment has
 * second differences at most L0 / m^2 (B'' is linear in u with control values 6 x the
 * second differences, and the piece's are B'' / (6 m^2) at its ends) and no smaller radius,
 * so it wants at most n / m <= 16 pieces. 1 (no split) wherever the rule wants 16 or fewer,
 * so such curves go to Embree as before, bit for bit. */
static unsigned curve_splits(const double *q, const double *r)
{
    double l0 = 0.0, rmin = INFINITY;
    for (int i = 0; i < 2; i++)
        for (int j = 0; j < 3; j++)
            l0 = fmax(l0, fabs(q[3 * i + j] - 2.0 * q[3 * (i + 1) + j] + q[3 * (i + 2) + j]));
    for (int i = 0; i < 4; i++)
        rmin = fmin(rmin, r[i]);
    double n = ceil(sqrt(7.5 * l0 * sqrt(3.0) / rmin));
    if (n <= CURVE_PIECES_MAX)
        return 1;
    double m = ceil(n / CURVE_PIECES_MAX);
    return isfinite(m) && m < CURVE_SPLITS_MAX ? (unsigned)m : CURVE_SPLITS_MAX;
}

/* The blossom (polar form) of a cubic Bezier with control values c[0], c[s], c[2s], c[3s] at
 * (t1, t2, t3): de Casteljau's steps, each at its own parameter. The cubic on [a, b] has the
 * control values f(a,a,a), f(a,a,b), f(a,b,b), f(b,b,b) (Ramshaw 1989, "Blossoms are polar
 * forms"), the same curve exactly: for a = 0, b = 1/2 they are de Casteljau's left half. Each
 * step is (1 - t) x + t y, so f(a,a,a) is exactly the point at a that the previous piece ends
 * on. */
static double bezier_blossom(const double *c, size_t s, double t1, double t2, double t3)
{
    double p[4] = {c[0], c[s], c[2 * s], c[3 * s]};
    const double t[3] = {t1, t2, t3};
    for (int level = 0; level < 3; level++)
        for (int k = 0; k < 3 - level; k++)
            p[k] = (1.0 - t[level]) * p[k] + t[level] * p[k + 1];
    return p[0];
}

/* Piece j of m of segment q (control points, radii r, ribbon normals nrm or NULL): its
 * control points, radii (the blossom of the segment's, so linear radii, pbrt-v4's lerp of the
 * width, stay linear) and end normals (pbrt-v4's slerp at its two ends, so the slerp between
 * them is the segment's over that span). */
static vec3_t ribbon_normal(const double *n, double u);
static void curve_piece(const double *q, const double *r, const double *nrm, unsigned j, unsigned m,
                        double *q_out, double *r_out, double *n_out)
{
    double a = (double)j / m, b = (double)(j + 1) / m;
    const double t[4][3] = {{a, a, a}, {a, a, b}, {a, b, b}, {b, b, b}};
    for (int i = 0; i < 4; i++) {
        for (int k = 0; k < 3; k++)
            q_out[3 * i + k] = bezier_blossom(q + k, 3, t[i][0], t[i][1], t[i][2]);
        r_out[i] = bezier_blossom(r, 1, t[i][0], t[i][1], t[i][2]);
    }
    if (nrm) {
        vec3_t n0 = ribbon_normal(nrm, a), n1 = ribbon_normal(nrm, b);
        const double v[6] = {n0.x, n0.y, n0.z, n1.x, n1.y, n1.z};
        memcpy(n_out, v, sizeof v);
    }
}

/* A ribbon segment's normals for Embree, which interpolates them with the Bezier basis of the
 * points: the quarter-circle rule's cubic through the great arc from n0 to n1 (control points
 * n0, n0 + k T0, n1 - k T1 with the arc's unit tangents T at its ends and
 * k = 4/3 tan(theta / 4)). Embree normalises the normal it interpolates, and this cubic stays
 * within 2.7e-4 of the unit sphere for a quarter turn, so the ribbon turns along the great arc
 * as pbrt-v4's slerp does, at a pace within a degree of the slerp's for theta up to 90 degrees
 * (tests/unit/test_curves.c measures the ribbon's turn). */
static void ribbon_normal_cp(const double *n0, const double *n1, float *out)
{
    double c = fmax(-1.0, fmin(1.0, n0[0] * n1[0] + n0[1] * n1[1] + n0[2] * n1[2]));
    double theta = acos(c), s = sin(theta);
    double k = s > 1e-9 ? 4.0 / 3.0 * tan(0.25 * theta) / s : 0.0;
    for (int j = 0; j < 3; j++) {
        double t0 = n1[j] - c * n0[j], t1 = c * n1[j] - n0[j]; /* the tangents times sin theta */
        out[j] = (float)n0[j];
        out[3 + j] = (float)(n0[j] + k * t0);
        out[6 + j] = (float)(n1[j] - k * t1);
        out[9 + j] = (float)n1[j];
    }
}

/* The primitives Embree gets for a curve set: the caller's segments, or, where one wants more
 * than 16 pieces, its pieces (curve_splits, curve_piece), with the map back in piece. The
 * arrays are the caller's when nothing is split; else the pieces', in one allocation (own). */
typedef struct curve_prims {
    const double *cp, *radii, *normals;
    size_t n;
    double *own; /* cp, radii and normals of the pieces in one allocation, or NULL */
} curve_prims_t;

static int curve_prims_make(const double *cp, const double *radii, const double *normals,
                            size_t nseg, curve_prims_t *out, curve_piece_t *piece, err_t *err)
{
    *out = (curve_prims_t){.cp = cp, .radii = radii, .normals = normals, .n = nseg};
    if (!piece)
        return 0;
    size_t per = 16 + (normals ? 6 : 0), n = out->n;
    for (size_t k = 0; k < nseg; k++)
        n += curve_splits(cp + 12 * k, radii + 4 * k) - 1;
    double *own = malloc(per * n * sizeof *own);
    if (!own)
        return err_set(err, "out of memory splitting a curve into %zu pieces", n);
    double *q = own, *r = own + 12 * n, *nn = normals ? own + 16 * n : NULL;
    size_t i = 0;
    for (size_t k = 0; k < nseg; k++) {
        unsigned m = curve_splits(cp + 12 * k, radii + 4 * k);
        for (unsigned j = 0; j < m; j++, i++) {
            curve_piece(cp + 12 * k, radii + 4 * k, normals ? normals + 6 * k : NULL, j, m,
                        q + 12 * i, r + 4 * i, nn ? nn + 6 * i : NULL);
            piece[i] = (curve_piece_t){.seg = (uint32_t)k, .j = (uint16_t)j, .m = (uint16_t)m};
        }
    }
    *out = (curve_prims_t){.cp = q, .radii = r, .normals = nn, .n = n, .own = own};
    return 0;
}

int geometry_object_add_curves(geometry_t *self, int object, const double *cp, const double *radii,
                               const double *normals, size_t nseg, uint32_t shape, int flip,
                               err_t *err)
{
    group_t *grp = target(self, object, shape, err);
    if (!grp)
        return -1;
    if (nseg == 0 || nseg > UINT32_MAX / 4)
        return err_set(err, "shape %u: a curve needs 1 to %u segments", shape, UINT32_MAX / 4);
    for (size_t i = 0; i < 12 * nseg; i++)
        if (!isfinite(cp[i]))
            return err_set(err, "shape %u: control point %zu is not finite", shape, i / 3);
    for (size_t i = 0; i < 4 * nseg; i++)
        if (!(radii[i] > 0.0) || !isfinite(radii[i]))
            return err_set(err, "shape %u: radius %zu is not positive", shape, i);
    if (normals)
        for (size_t i = 0; i < 6 * nseg; i++)
            if (!isfinite(normals[i]))
                return err_set(err, "shape %u: ribbon normal %zu is not finite", shape, i / 3);
    size_t nprim = 0;
    for (size_t k = 0; k < nseg; k++)
        nprim += curve_splits(cp + 12 * k, radii + 4 * k);
    if (nprim > UINT32_MAX / 4)
        return err_set(err, "shape %u: a curve of %zu segments split into %zu pieces, over %u",
                       shape, nseg, nprim, UINT32_MAX / 4);
    int split = nprim > nseg;
    RTCGeometry g =
        rtcNewGeometry(self->device, normals ? RTC_GEOMETRY_TYPE_NORMAL_ORIENTED_BEZIER_CURVE
                                             : RTC_GEOMETRY_TYPE_FLAT_BEZIER_CURVE);
    if (!g)
        return check_device(self, "creating a curve", err)
                   ? -1
                   : err_set(err, "Embree: rtcNewGeometry failed");
    float *v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4,
                                       4 * sizeof(float), 4 * nprim);
    unsigned *ix = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT,
                                           sizeof(unsigned), nprim);
    float *nv = normals ? rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_NORMAL, 0, RTC_FORMAT_FLOAT3,
                                                  3 * sizeof(float), 4 * nprim)
                        : NULL;
    size_t nbytes = (normals ? 6 * nseg * sizeof(double) : 0);
    curves_t *c = v && ix && (nv || !normals)
                      ? malloc(sizeof *c + nbytes + (split ? nprim * sizeof(curve_piece_t) : 0))
                      : NULL;
    if (!c) {
        rtcReleaseGeometry(g);
        return check_device(self, "allocating curve buffers", err) ? -1
                                                                   : err_set(err, "out of memory");
    }
    curve_piece_t *piece = split ? (curve_piece_t *)((char *)c->n + nbytes) : NULL;
    curve_prims_t pr;
    if (curve_prims_make(cp, radii, normals, nseg, &pr, piece, err)) {
        free(c);
        rtcReleaseGeometry(g);
        return -1;
    }
    /* The bounds are the caller's control points' (the pieces' lie within them). */
    vec3_t lo = grp->lo, hi = grp->hi;
    for (size_t i = 0; i < 4 * nseg; i++) {
        double r = radii[i];
        grow_bounds(&lo, &hi, vec3_make(cp[3 * i] - r, cp[3 * i + 1] - r, cp[3 * i + 2] - r));
        grow_bounds(&lo, &hi, vec3_make(cp[3 * i] + r, cp[3 * i + 1] + r, cp[3 * i + 2] + r));
    }
    for (size_t i = 0; i < 4 * nprim; i++) {
        for (int k = 0; k < 3; k++)
            v[4 * i + k] = (float)pr.cp[3 * i + k];
        v[4 * i + 3] = (float)pr.radii[i];
    }
    for (size_t k = 0; k < nprim; k++)
        ix[k] = (unsigned)(4 * k);
    c->tag = CURVES_TAG;
    c->verts = v;
    c->ribbon = normals != NULL;
    c->piece = piece;
    if (normals) {
        memcpy(c->n, normals, 6 * nseg * sizeof(double));
        for (size_t k = 0; k < nprim; k++)
            ribbon_normal_cp(pr.normals + 6 * k, pr.normals + 6 * k + 3, nv + 12 * k);
    }
    rtcSetGeometryTessellationRate(g, curve_tessellation(pr.cp, pr.radii, nprim));
    free(pr.own);
    rtcSetGeometryUserData(g, c);
    rtcSetGeometryIntersectFilterFunction(g, curve_filter);
    rtcSetGeometryOccludedFilterFunction(g, curve_filter);
    rtcCommitGeometry(g);
    unsigned id = rtcAttachGeometry(grp->scene, g);
    rtcReleaseGeometry(g);
    if (check_device(self, "adding a curve", err) ||
        record(grp, id,
               (geom_info_t){.kind = GEOM_CURVES, .shape = shape, .flip = flip, .curves = c},
               err)) {
        free(c);
        return -1;
    }
    grp->lo = lo;
    grp->hi = hi;
    grp->nshapes++;
    return 0;
}

/* A ribbon segment's normal at u: pbrt-v4's slerp from its first end normal to its second. */
static vec3_t ribbon_normal(const double *n, double u)
{
    vec3_t a = vec3_make(n[0], n[1], n[2]), b = vec3_make(n[3], n[4], n[5]);
    double theta = acos(fmax(-1.0, fmin(1.0, vec3_dot(a, b)))), s = sin(theta);
    if (!(s > 1e-9))
        return a;
    return vec3_add(vec3_scale(a, sin((1.0 - u) * theta) / s), vec3_scale(b, sin(u * theta) / s));
}

/* A curve hit in the group's space (org, dir there too): the point along the ray (a flat
 * ribbon is no surface to refine against), h across the ribbon, the normal facing the ray;
 * a ribbon's normal is its own (the slerped normal made perpendicular to the curve, as
 * pbrt-v4's dp/du x (n x dp/du)), and its h is pbrt-v4's: the distance across in the plane
 * seen from the ray over the ribbon's narrowed half width r |n . d|. */
static void curve_surface(const curves_t *c, unsigned prim, vec3_t org, vec3_t dir, hit_t *out,
                          vec3_t *p, vec3_t *n)
{
    const float *f = c->verts + 16 * (size_t)prim;
    double cp[12];
    for (int k = 0; k < 4; k++)
        for (int j = 0; j < 3; j++)
            cp[3 * k + j] = f[4 * k + j];
    /* u along Embree's primitive; a piece's hit reports its segment and u along that, which
     * runs on across the pieces' ends: piece j ends at (j + 1) / m exactly where piece j + 1
     * starts. */
    double u = fmin(1.0, fmax(0.0, out->u)), useg = u;
    uint32_t seg = prim;
    if (c->piece) {
        const curve_piece_t *q = &c->piece[prim];
        seg = q->seg;
        out->prim = q->seg;
        out->u = (q->j + out->u) / q->m;
        useg = (q->j + u) / q->m;
    }
    vec3_t centre, t;
    geometry_bezier(cp, u, &centre, &t);
    *p = vec3_fma(org, dir, out->t);
    vec3_t tn = vec3_normalize(t), d = vec3_normalize(dir);
    vec3_t across = vec3_cross(d, tn);
    double len = vec3_length(across);
    vec3_t x, y;
    if (!(len > 1e-12) || !isfinite(len)) {
        /* The ray runs along the fibre: any perpendicular will do. */
        vec3_basis(tn, &x, &y);
        across = x;
        *n = y;
    } else {
        across = vec3_scale(across, 1.0 / len);
        *n = vec3_cross(tn, across); /* = -(d - (d.t) t) / |...|: toward the ray's origin */
    }
    double r = curve_radius(c, prim, u);
    if (c->ribbon) {
        vec3_t nr = ribbon_normal(c->n + 6 * (size_t)seg, useg);
        vec3_t perp = vec3_sub(nr, vec3_scale(tn, vec3_dot(nr, tn)));
        double lp = vec3_length(perp);
        if (lp > 1e-12 && isfinite(lp))
            *n = vec3_scale(perp, 1.0 / lp);
        r *= fabs(vec3_dot(nr, d));
    }
    double h = r > 0.0 ? vec3_dot(vec3_sub(*p, centre), across) / r : 0.0;
    h = isfinite(h) ? fmin(1.0, fmax(-1.0, h)) : 0.0;
    out->v = 0.5 * (h + 1.0);
}

int geometry_add_mesh(geometry_t *self, const double *positions, size_t nverts,
                      const uint32_t *indices, size_t ntris, uint32_t shape, int flip, err_t *err)
{
    return geometry_object_add_mesh(self, GEOMETRY_WORLD, positions, nverts, indices, ntris, shape,
                                    flip, err);
}

/* Ray-sphere and ray-disk intersection in object space (double precision). The object-space
 * ray direction is not normalised, so t is the same parameter as in world space. */
static int analytic_hit(const analytic_t *a, vec3_t o, vec3_t d, double tmin, double tmax,
                        double *t_out)
{
    if (a->kind == ANALYTIC_SPHERE) {
        /* Numerically stable quadratic (pbrt-v4 §6.8.1 idea): compute b² - 4ac as
         * 4a(r² - |o - (o·d/|d|²) d|²) to avoid cancellation for distant spheres. */
        double A = vec3_dot(d, d);
        double B = 2.0 * vec3_dot(o, d);
        if (A == 0.0)
            return 0;
        vec3_t f = vec3_sub(o, vec3_scale(d, vec3_dot(o, d) / A));
        double disc = 4.0 * A * (a->radius * a->radius - vec3_dot(f, f));
        if (disc < 0.0)
            return 0;
        double root = sqrt(disc);
        double q = B < 0 ? -0.5 * (B - root) : -0.5 * (B + root);
        double C = vec3_dot(o, o) - a->radius * a->radius;
        double t0 = q / A, t1 = q != 0.0 ? C / q : t0;
        if (t0 > t1) {
            double s = t0;
            t0 = t1;
            t1 = s;
        }
        if (t0 > tmin && t0 < tmax) {
            *t_out = t0;
            return 1;
        }
        if (t1 > tmin && t1 < tmax) {
            *t_out = t1;
            return 1;
        }
        return 0;
    }
    if (d.z == 0.0)
        return 0;
    double t = (a->height - o.z) / d.z;
    if (!(t > tmin && t < tmax))
        return 0;
    double x = o.x + t * d.x, y = o.y + t * d.y;
    if (x * x + y * y > a->radius * a->radius)
        return 0;
    *t_out = t;
    return 1;
}

/* The ray Embree hands a user geometry is in the space of the geometry's group (already
 * mapped by the instance, if any). */
static void analytic_ray(const analytic_t *a, const struct RTCRay *ray, vec3_t *o, vec3_t *d)
{
    *o = transform_point(&a->to_object, vec3_make(ray->org_x, ray->org_y, ray->org_z));
    *d = transform_vector(&a->to_object, vec3_make(ray->dir_x, ray->dir_y, ray->dir_z));
}

static void box_corners_bounds(const transform_t *t, vec3_t lo_in, vec3_t hi_in, vec3_t *lo,
                               vec3_t *hi)
{
    *lo = empty_lo();
    *hi = empty_hi();
    for (int c = 0; c < 8; c++) {
        vec3_t p =
            transform_point(t, vec3_make(c & 1 ? hi_in.x : lo_in.x, c & 2 ? hi_in.y : lo_in.y,
                                         c & 4 ? hi_in.z : lo_in.z));
        grow_bounds(lo, hi, p);
    }
}

static void analytic_box(const analytic_t *a, vec3_t *lo, vec3_t *hi)
{
    double r = a->radius;
    double zlo = a->kind == ANALYTIC_SPHERE ? -r : a->height;
    double zhi = a->kind == ANALYTIC_SPHERE ? r : a->height;
    box_corners_bounds(&a->to_world, vec3_make(-r, -r, zlo), vec3_make(r, r, zhi), lo, hi);
}

static void analytic_bounds(const struct RTCBoundsFunctionArguments *args)
{
    const analytic_t *a = args->geometryUserPtr;
    vec3_t lo, hi;
    analytic_box(a, &lo, &hi);
    /* Float rounding of the bounds must never cut off a hit. */
    double pad =
        1e-6 * fmax(1.0, fmax(fmax(fabs(lo.x), fabs(hi.x)),
                              fmax(fmax(fabs(lo.y), fabs(hi.y)), fmax(fabs(lo.z), fabs(hi.z)))));
    *args->bounds_o =
        (struct RTCBounds){(float)(lo.x - pad), (float)(lo.y - pad), (float)(lo.z - pad), 0,
                           (float)(hi.x + pad), (float)(hi.y + pad), (float)(hi.z + pad), 0};
}

/* rtcIntersect1/rtcOccluded1 call user geometry with N = 1, so the ray packet is a plain
 * struct RTCRayHit / RTCRay (Embree 3 API documentation, RTC_GEOMETRY_TYPE_USER). */
static void analytic_intersect(const struct RTCIntersectFunctionNArguments *args)
{
    if (args->N != 1 || !args->valid[0])
        return;
    const analytic_t *a = args->geometryUserPtr;
    struct RTCRayHit *rh = (struct RTCRayHit *)args->rayhit;
    vec3_t o, d;
    analytic_ray(a, &rh->ray, &o, &d);
    double t;
    if (!analytic_hit(a, o, d, rh->ray.tnear, rh->ray.tfar, &t))
        return;
    rh->ray.tfar = (float)t;
    /* The normal and surface parameters are computed again in double by geometry_intersect,
     * so only a non-zero placeholder normal is stored here. */
    rh->hit.u = 0;
    rh->hit.v = 0;
    rh->hit.Ng_x = 0;
    rh->hit.Ng_y = 0;
    rh->hit.Ng_z = 1;
    rh->hit.primID = args->primID;
    rh->hit.geomID = args->geomID;
    rh->hit.instID[0] = args->context->instID[0];
}

static void analytic_occluded(const struct RTCOccludedFunctionNArguments *args)
{
    if (args->N != 1 || !args->valid[0])
        return;
    const analytic_t *a = args->geometryUserPtr;
    struct RTCRay *ray = (struct RTCRay *)args->ray;
    vec3_t o, d;
    analytic_ray(a, ray, &o, &d);
    double t;
    if (analytic_hit(a, o, d, ray->tnear, ray->tfar, &t))
        ray->tfar = -INFINITY;
}

static int transform_usable(const transform_t *t)
{
    return !t->singular && transform_is_affine(t) && transform_is_finite(t);
}

static int add_analytic(geometry_t *self, int object, analytic_t proto, uint32_t shape, int flip,
                        err_t *err)
{
    group_t *grp = target(self, object, shape, err);
    if (!grp)
        return -1;
    if (!(proto.radius > 0.0) || !isfinite(proto.radius) || !isfinite(proto.height))
        return err_set(err, "shape %u: radius must be positive and finite, got %g", shape,
                       proto.radius);
    if (!transform_usable(&proto.to_world))
        return err_set(err, "shape %u: its transform is singular or not affine", shape);
    proto.to_object = transform_inverse(proto.to_world);
    analytic_t *a = malloc(sizeof *a);
    if (!a)
        return err_set(err, "out of memory");
    *a = proto;
    RTCGeometry g = rtcNewGeometry(self->device, RTC_GEOMETRY_TYPE_USER);
    if (!g) {
        free(a);
        return check_device(self, "creating an analytic shape", err)
                   ? -1
                   : err_set(err, "Embree: rtcNewGeometry failed");
    }
    rtcSetGeometryUserPrimitiveCount(g, 1);
    rtcSetGeometryUserData(g, a);
    rtcSetGeometryBoundsFunction(g, analytic_bounds, NULL);
    rtcSetGeometryIntersectFunction(g, analytic_intersect);
    rtcSetGeometryOccludedFunction(g, analytic_occluded);
    rtcCommitGeometry(g);
    unsigned id = rtcAttachGeometry(grp->scene, g);
    rtcReleaseGeometry(g);
    if (check_device(self, "adding an analytic shape", err) ||
        record(grp, id,
               (geom_info_t){.kind = GEOM_ANALYTIC, .shape = shape, .flip = flip, .analytic = a},
               err)) {
        free(a);
        return -1;
    }
    vec3_t lo, hi;
    analytic_box(a, &lo, &hi);
    grow_bounds(&grp->lo, &grp->hi, lo);
    grow_bounds(&grp->lo, &grp->hi, hi);
    grp->nshapes++;
    return 0;
}

int geometry_object_add_sphere(geometry_t *self, int object, const transform_t *to_world,
                               double radius, uint32_t shape, int flip, err_t *err)
{
    return add_analytic(
        self, object,
        (analytic_t){.kind = ANALYTIC_SPHERE, .to_world = *to_world, .radius = radius}, shape, flip,
        err);
}

int geometry_object_add_disk(geometry_t *self, int object, const transform_t *to_world,
                             double radius, double height, uint32_t shape, int flip, err_t *err)
{
    return add_analytic(
        self, object,
        (analytic_t){
            .kind = ANALYTIC_DISK, .to_world = *to_world, .radius = radius, .height = height},
        shape, flip, err);
}

int geometry_add_sphere(geometry_t *self, const transform_t *to_world, double radius,
                        uint32_t shape, int flip, err_t *err)
{
    return geometry_object_add_sphere(self, GEOMETRY_WORLD, to_world, radius, shape, flip, err);
}

int geometry_add_disk(geometry_t *self, const transform_t *to_world, double radius, double height,
                      uint32_t shape, int flip, err_t *err)
{
    return geometry_object_add_disk(self, GEOMETRY_WORLD, to_world, radius, height, shape, flip,
                                    err);
}

int geometry_add_instance(geometry_t *self, int object, const transform_t *to_world,
                          uint32_t instance, err_t *err)
{
    group_t *world = &self->groups[0];
    if (world->committed)
        return err_set(err, "instance %u added after the scene was committed", instance);
    if (object < 0 || (size_t)(object + 1) >= self->ngroups)
        return err_set(err, "instance %u: there is no object %d", instance, object);
    if (!transform_usable(to_world))
        return err_set(err, "instance %u: its transform is singular or not affine", instance);
    int k = object + 1;
    if (self->groups[k].nshapes == 0)
        return err_set(err, "instance %u: object %d has no shapes", instance, object);
    /* Embree needs the instanced scene committed before the instance that refers to it. */
    if (!self->groups[k].committed) {
        rtcCommitScene(self->groups[k].scene);
        if (check_device(self, "building an object's BVH", err))
            return -1;
        self->groups[k].committed = 1;
    }
    instance_t *in = malloc(sizeof *in);
    if (!in)
        return err_set(err, "out of memory");
    *in = (instance_t){.group = k,
                       .id = instance,
                       .to_world = *to_world,
                       .to_object = transform_inverse(*to_world),
                       .swaps = transform_swaps_handedness(to_world)};
    /* RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR: the three columns of the linear part, then the
     * translation. */
    float xfm[12];
    for (int c = 0; c < 4; c++)
        for (int r = 0; r < 3; r++)
            xfm[3 * c + r] = (float)to_world->m[r][c];
    RTCGeometry g = rtcNewGeometry(self->device, RTC_GEOMETRY_TYPE_INSTANCE);
    if (!g) {
        free(in);
        return check_device(self, "creating an instance", err)
                   ? -1
                   : err_set(err, "Embree: rtcNewGeometry failed");
    }
    rtcSetGeometryInstancedScene(g, self->groups[k].scene);
    rtcSetGeometryTimeStepCount(g, 1);
    rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, xfm);
    rtcCommitGeometry(g);
    unsigned id = rtcAttachGeometry(world->scene, g);
    rtcReleaseGeometry(g);
    if (check_device(self, "adding an instance", err) ||
        record(world, id, (geom_info_t){.kind = GEOM_INSTANCE, .shape = instance, .instance = in},
               err)) {
        free(in);
        return -1;
    }
    vec3_t lo, hi;
    box_corners_bounds(to_world, self->groups[k].lo, self->groups[k].hi, &lo, &hi);
    grow_bounds(&world->lo, &world->hi, lo);
    grow_bounds(&world->lo, &world->hi, hi);
    return 0;
}

int geometry_commit(geometry_t *self, err_t *err)
{
    /* Objects never instanced are committed too, so that the device holds no half-built
     * scene; they cost nothing in the world's BVH. */
    for (size_t k = 1; k < self->ngroups; k++)
        if (!self->groups[k].committed) {
            rtcCommitScene(self->groups[k].scene);
            self->groups[k].committed = 1;
        }
    rtcCommitScene(self->groups[0].scene);
    if (check_device(self, "building the scene's BVH", err))
        return -1;
    self->groups[0].committed = 1;
    return 0;
}

void geometry_set_query_hook(geometry_t *self, geometry_query_fn fn, void *user)
{
    self->query_hook = fn;
    self->query_user = user;
}

struct RTCSceneTy *geometry_embree_scene(const geometry_t *self)
{
    return self->groups[0].committed ? self->groups[0].scene : NULL;
}

/* Out of line, so that the queries' hot path carries only the pointer test. */
static void report_query(const geometry_t *self, const struct RTCRay *r, int occluded)
{
    geometry_query_t q = {.org = {r->org_x, r->org_y, r->org_z},
                          .tnear = r->tnear,
                          .dir = {r->dir_x, r->dir_y, r->dir_z},
                          .tfar = r->tfar,
                          .occluded = occluded};
    self->query_hook(self->query_user, &q);
}

static struct RTCRay make_ray(vec3_t org, vec3_t dir, double tmin, double tmax)
{
    return (struct RTCRay){.org_x = (float)org.x,
                           .org_y = (float)org.y,
                           .org_z = (float)org.z,
                           .tnear = (float)tmin,
                           .dir_x = (float)dir.x,
                           .dir_y = (float)dir.y,
                           .dir_z = (float)dir.z,
                           .tfar = (float)fmin(tmax, FLT_MAX),
                           .mask = 0xFFFFFFFFu,
                           .flags = 0};
}

/* Refines an analytic hit in double and fills its point (in the group's space), surface
 * parameters and normal (in the group's space, not normalised). org and dir are in the
 * group's space too. */
static void analytic_surface(const analytic_t *a, vec3_t org, vec3_t dir, double tmin, hit_t *out,
                             vec3_t *p, vec3_t *n)
{
    /* Embree found the shape in float; find the same root again in double so that hit
     * points stay accurate on large and tiny scenes. */
    vec3_t o = transform_point(&a->to_object, org), d = transform_vector(&a->to_object, dir);
    double t;
    if (analytic_hit(a, o, d, tmin, out->t * (1.0 + 1e-4) + 1e-300, &t))
        out->t = t;
    vec3_t po = vec3_fma(o, d, out->t);
    vec3_t n_obj;
    double phi = atan2(po.y, po.x);
    if (phi < 0)
        phi += 2.0 * PF_PI;
    out->u = phi / (2.0 * PF_PI);
    if (a->kind == ANALYTIC_SPHERE) {
        n_obj = po;
        /* pbrt-v4 Sphere: v runs from 0 at z = -r (theta = pi) to 1 at z = +r. */
        double ct = fmax(-1.0, fmin(1.0, po.z / a->radius));
        out->v = 1.0 - acos(ct) / PF_PI;
        po = vec3_scale(vec3_normalize(po), a->radius);
    } else {
        n_obj = vec3_make(0, 0, 1);
        out->v = 1.0 - sqrt(po.x * po.x + po.y * po.y) / a->radius;
        po.z = a->height;
    }
    *n = transform_normal(&a->to_world, n_obj);
    *p = transform_point(&a->to_world, po);
}

int geometry_intersect(const geometry_t *self, vec3_t org, vec3_t dir, double tmin, double tmax,
                       hit_t *out)
{
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRayHit rh = {.ray = make_ray(org, dir, tmin, tmax)};
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    if (self->query_hook)
        report_query(self, &rh.ray, 0);
    const struct RTCRay ray = rh.ray;
    rtcIntersect1(self->groups[0].scene, &ctx, &rh);
    unsigned id = rh.hit.geomID;
    if (id == RTC_INVALID_GEOMETRY_ID)
        return 0;
    const group_t *grp = &self->groups[0];
    if (rh.hit.instID[0] == RTC_INVALID_GEOMETRY_ID && id < grp->ngeoms &&
        grp->info[id].kind == GEOM_MESH) {
        const float o[3] = {ray.org_x, ray.org_y, ray.org_z},
                    d[3] = {ray.dir_x, ray.dir_y, ray.dir_z};
        if (!mesh_accepts(grp->info[id].mesh, rh.hit.primID, o, d)) {
            /* A false self-hit: trace again judging every candidate (mesh_context_filter). */
            rh = (struct RTCRayHit){.ray = ray};
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
            ctx.filter = mesh_context_filter;
            rtcIntersect1(self->groups[0].scene, &ctx, &rh);
            id = rh.hit.geomID;
            if (id == RTC_INVALID_GEOMETRY_ID)
                return 0;
        }
    }
    const instance_t *in = NULL;
    if (rh.hit.instID[0] != RTC_INVALID_GEOMETRY_ID) {
        unsigned iid = rh.hit.instID[0];
        if (iid >= grp->ngeoms || grp->info[iid].kind != GEOM_INSTANCE)
            return 0;
        in = grp->info[iid].instance;
        grp = &self->groups[in->group];
    }
    if (id >= grp->ngeoms || grp->info[id].kind == GEOM_INSTANCE)
        return 0;
    const geom_info_t *info = &grp->info[id];
    out->t = rh.ray.tfar;
    out->shape = info->shape;
    out->prim = rh.hit.primID;
    out->instance = in ? in->id : GEOMETRY_NO_INSTANCE;
    /* Embree reports an instanced hit's normal in the object's space; the ray parameter t is
     * the same in both spaces because the instance maps the direction without normalising. */
    vec3_t ng;
    int flip = info->flip;
    if (info->kind == GEOM_MESH) {
        /* Embree's triangle normal has pbrt's orientation, (p0 - p2) x (p1 - p2)
         * (tests/unit/test_geometry.c checks it). Mapped by an instance as a normal it keeps the
         * orientation the flattened triangle (whose cross product would turn with a
         * handedness swap, and whose flip would undo it) has. */
        ng = vec3_make(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
        out->u = rh.hit.u;
        out->v = rh.hit.v;
        /* The point from the barycentrics, in double, not org + t dir: Embree's float t is off
         * by about 2^-24 t along the ray, which for a ray from far away (a camera 100 units
         * from a unit object) puts the point farther off the surface than geometry_offset
         * moves it, and the next ray hits the same triangle (shadow acne: a diffuse quad in a
         * furnace read 0.38 instead of 0.5 from 1000 units). An affine combination of the
         * triangle's vertices lies on its plane up to double rounding, whatever t was. */
        const mesh_t *m = info->mesh;
        const unsigned *tri = m->tris + 3 * (size_t)rh.hit.primID;
        const float *a = m->verts + 3 * (size_t)tri[0], *b = m->verts + 3 * (size_t)tri[1],
                    *c = m->verts + 3 * (size_t)tri[2];
        double b1 = rh.hit.u, b2 = rh.hit.v, b0 = 1.0 - b1 - b2;
        vec3_t p = vec3_make(b0 * a[0] + b1 * b[0] + b2 * c[0], b0 * a[1] + b1 * b[1] + b2 * c[1],
                             b0 * a[2] + b1 * b[2] + b2 * c[2]);
        out->p = in ? transform_point(&in->to_world, p) : p;
        if (in)
            ng = transform_normal(&in->to_world, ng);
    } else if (info->kind == GEOM_CURVES) {
        vec3_t p;
        out->u = rh.hit.u;
        if (in) {
            vec3_t o = transform_point(&in->to_object, org),
                   d = transform_vector(&in->to_object, dir);
            curve_surface(info->curves, rh.hit.primID, o, d, out, &p, &ng);
            out->p = transform_point(&in->to_world, p);
            ng = transform_normal(&in->to_world, ng);
        } else {
            curve_surface(info->curves, rh.hit.primID, org, dir, out, &p, &ng);
            out->p = p;
        }
        if (!info->curves->ribbon)
            flip = 0; /* a ribbon that faces the ray has no outside */
    } else {
        vec3_t p;
        if (in) {
            vec3_t o = transform_point(&in->to_object, org),
                   d = transform_vector(&in->to_object, dir);
            analytic_surface(info->analytic, o, d, tmin, out, &p, &ng);
            out->p = transform_point(&in->to_world, p);
            ng = transform_normal(&in->to_world, ng);
            /* A quadric's normal is mapped, not recomputed, so like a flattened one (whose
             * flip includes the swap) it flips when the instance swaps handedness. */
            flip ^= in->swaps;
        } else {
            analytic_surface(info->analytic, org, dir, tmin, out, &p, &ng);
            out->p = p;
        }
    }
    ng = vec3_normalize(ng);
    if (flip)
        ng = vec3_neg(ng);
    out->ng = ng;
    return 1;
}

int geometry_occluded(const geometry_t *self, vec3_t org, vec3_t dir, double tmin, double tmax)
{
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRay ray = make_ray(org, dir, tmin, tmax);
    if (self->query_hook)
        report_query(self, &ray, 1);
    /* No candidate without the filter: none with it. A candidate is confirmed by the filtered
     * trace (mesh_context_filter), which most blocked shadow rays pass at their first leaf. */
    const struct RTCRay ray0 = ray;
    rtcOccluded1(self->groups[0].scene, &ctx, &ray);
    if (ray.tfar != -INFINITY)
        return 0;
    ray = ray0;
    ctx.filter = mesh_context_filter;
    rtcOccluded1(self->groups[0].scene, &ctx, &ray);
    return ray.tfar == -INFINITY;
}

void geometry_bounds(const geometry_t *self, vec3_t *lo, vec3_t *hi)
{
    *lo = self->groups[0].lo;
    *hi = self->groups[0].hi;
}

size_t geometry_memory_bytes(const geometry_t *self)
{
    long long m = atomic_load(&((geometry_t *)self)->memory);
    return m > 0 ? (size_t)m : 0;
}

/* fmax(|x|, fmax(|y|, |z|)) as libm's fmax gives it (a NaN argument yields the other; of
 * equal ones the first), inline: gcc calls libm for fmax, and this runs for every ray. */
static inline double fmax_inline(double a, double b)
{
    return (a >= b || isnan(b)) ? a : b;
}

static inline double max_abs3(vec3_t p)
{
    return fmax_inline(fabs(p.x), fmax_inline(fabs(p.y), fabs(p.z)));
}

vec3_t geometry_offset(vec3_t p, vec3_t ng, vec3_t dir)
{
    /* Embree traces rays in float, so the new origin must stay on dir's side of the surface
     * after rounding to float (half an ulp, 2^-24 relative, per coordinate): 4e-6 of the
     * largest coordinate is 34 float ulps. Nothing else needs a margin: hit points are exact
     * to double rounding (analytic shapes are refined in double, triangle points rebuilt from
     * barycentrics), and mesh_filter decides in double which side of a triangle a ray starts
     * on. The offset is purely relative, so a scene and its copy scaled by 1e-3 or 1e5 take
     * the same paths (an absolute floor of 1e-7 let a glass sphere of radius 1e-3 release 0.3 %
     * of grazing light that the same sphere of radius 1 kept trapped); the 1e-30 floor only moves a
     * point at the origin itself off its surface, and is still a normal float. */
    double mag = max_abs3(p);
    double eps = 4e-6 * mag + 1e-30;
    double side = vec3_dot(dir, ng) >= 0.0 ? 1.0 : -1.0;
    return vec3_fma(p, ng, side * eps);
}
