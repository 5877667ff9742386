#include "geometry.h"

#include <embree3/rtcore.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef enum { ANALYTIC_SPHERE, ANALYTIC_DISK } analytic_kind_t;

typedef struct analytic {
    analytic_kind_t kind;
    transform_t to_world, to_object;
    double radius, height;
    uint32_t shape;
    int flip;
} analytic_t;

typedef struct mesh_info {
    uint32_t shape;
    int flip;
} mesh_info_t;

struct geometry {
    RTCDevice device;
    RTCScene scene;
    char device_error[256];
    int committed;
    /* Per Embree geometry id: what it is. Analytic shapes live in their own array because
     * Embree keeps a pointer to each as user data, so they must not move. */
    analytic_t **analytic; /* by geomID, NULL for meshes */
    mesh_info_t *mesh;      /* by geomID */
    size_t ngeoms, cap;
    vec3_t lo, hi;
};

static void on_device_error(void *user, enum RTCError code, const char *str)
{
    geometry_t *self = user;
    snprintf(self->device_error, sizeof self->device_error, "Embree error %d: %s", (int)code,
             str ? str : "(no message)");
}

static int check_device(geometry_t *self, const char *what, err_t *err)
{
    enum RTCError code = rtcGetDeviceError(self->device);
    if (code == RTC_ERROR_NONE && !self->device_error[0])
        return 0;
    int r = err_set(err, "%s: %s", what, self->device_error[0] ? self->device_error : "Embree error");
    self->device_error[0] = 0;
    return r;
}

geometry_t *geometry_new(int nthreads, err_t *err)
{
    geometry_t *self = calloc(1, sizeof *self);
    if (!self) {
        err_set(err, "out of memory");
        return NULL;
    }
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
    self->scene = rtcNewScene(self->device);
    rtcSetSceneFlags(self->scene, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(self->scene, RTC_BUILD_QUALITY_HIGH);
    self->lo = vec3_make(INFINITY, INFINITY, INFINITY);
    self->hi = vec3_make(-INFINITY, -INFINITY, -INFINITY);
    if (check_device(self, "creating the Embree scene", err)) {
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
    if (self->scene)
        rtcReleaseScene(self->scene);
    if (self->device)
        rtcReleaseDevice(self->device);
    for (size_t i = 0; i < self->ngeoms; i++)
        free(self->analytic[i]);
    free(self->analytic);
    free(self->mesh);
    free(self);
    *self_p = NULL;
}

static void grow_bounds(geometry_t *self, vec3_t p)
{
    self->lo = vec3_make(fmin(self->lo.x, p.x), fmin(self->lo.y, p.y), fmin(self->lo.z, p.z));
    self->hi = vec3_make(fmax(self->hi.x, p.x), fmax(self->hi.y, p.y), fmax(self->hi.z, p.z));
}

static int record(geometry_t *self, unsigned id, analytic_t *a, uint32_t shape, int flip, err_t *err)
{
    if (id >= self->cap) {
        size_t cap = self->cap ? self->cap * 2 : 16;
        while (cap <= id)
            cap *= 2;
        analytic_t **na = realloc(self->analytic, cap * sizeof *na);
        if (na)
            self->analytic = na;
        mesh_info_t *nm = realloc(self->mesh, cap * sizeof *nm);
        if (nm)
            self->mesh = nm;
        if (!na || !nm)
            return err_set(err, "out of memory adding shape %u", shape);
        for (size_t i = self->cap; i < cap; i++) {
            self->analytic[i] = NULL;
            self->mesh[i] = (mesh_info_t){0, 0};
        }
        self->cap = cap;
    }
    self->analytic[id] = a;
    self->mesh[id] = (mesh_info_t){shape, flip};
    if (id + 1 > self->ngeoms)
        self->ngeoms = id + 1;
    return 0;
}

int geometry_add_mesh(geometry_t *self, const double *positions, size_t nverts,
                      const uint32_t *indices, size_t ntris, uint32_t shape, int flip, err_t *err)
{
    if (self->committed)
        return err_set(err, "shape %u added after the scene was committed", shape);
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
    for (size_t i = 0; i < nverts; i++) {
        v[3 * i + 0] = (float)positions[3 * i + 0];
        v[3 * i + 1] = (float)positions[3 * i + 1];
        v[3 * i + 2] = (float)positions[3 * i + 2];
        grow_bounds(self, vec3_make(positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]));
    }
    memcpy(ix, indices, 3 * ntris * sizeof(unsigned));
    rtcCommitGeometry(g);
    unsigned id = rtcAttachGeometry(self->scene, g);
    rtcReleaseGeometry(g);
    if (check_device(self, "adding a mesh", err))
        return -1;
    return record(self, id, NULL, shape, flip, err);
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
        vec3_t f = vec3_sub(o, vec3_scale(d, vec3_dot(o, d) / A));
        double disc = 4.0 * A * (a->radius * a->radius - vec3_dot(f, f));
        if (disc < 0.0 || A == 0.0)
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

static void analytic_ray(const analytic_t *a, const struct RTCRay *ray, vec3_t *o, vec3_t *d)
{
    *o = transform_point(&a->to_object, vec3_make(ray->org_x, ray->org_y, ray->org_z));
    *d = transform_vector(&a->to_object, vec3_make(ray->dir_x, ray->dir_y, ray->dir_z));
}

static void analytic_bounds(const struct RTCBoundsFunctionArguments *args)
{
    const analytic_t *a = args->geometryUserPtr;
    double r = a->radius;
    double zlo = a->kind == ANALYTIC_SPHERE ? -r : a->height;
    double zhi = a->kind == ANALYTIC_SPHERE ? r : a->height;
    vec3_t lo = vec3_make(INFINITY, INFINITY, INFINITY), hi = vec3_scale(lo, -1.0);
    for (int c = 0; c < 8; c++) {
        vec3_t p = transform_point(&a->to_world, vec3_make(c & 1 ? r : -r, c & 2 ? r : -r, c & 4 ? zhi : zlo));
        lo = vec3_make(fmin(lo.x, p.x), fmin(lo.y, p.y), fmin(lo.z, p.z));
        hi = vec3_make(fmax(hi.x, p.x), fmax(hi.y, p.y), fmax(hi.z, p.z));
    }
    /* Float rounding of the bounds must never cut off a hit. */
    double pad = 1e-6 * fmax(1.0, fmax(fmax(fabs(lo.x), fabs(hi.x)), fmax(fmax(fabs(lo.y), fabs(hi.y)),
                                                                           fmax(fabs(lo.z), fabs(hi.z)))));
    *args->bounds_o = (struct RTCBounds){(float)(lo.x - pad), (float)(lo.y - pad), (float)(lo.z - pad), 0,
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
    /* Object-space parameters; the geometry normal is computed again in double by
     * geometry_intersect, so only a non-zero placeholder is stored here. */
    vec3_t p = vec3_fma(o, d, t);
    rh->hit.u = (float)p.x;
    rh->hit.v = (float)p.y;
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

static int add_analytic(geometry_t *self, analytic_t proto, err_t *err)
{
    if (self->committed)
        return err_set(err, "shape %u added after the scene was committed", proto.shape);
    if (!(proto.radius > 0.0) || !isfinite(proto.radius) || !isfinite(proto.height))
        return err_set(err, "shape %u: radius must be positive and finite, got %g", proto.shape,
                       proto.radius);
    if (proto.to_world.singular || !transform_is_affine(&proto.to_world) ||
        !transform_is_finite(&proto.to_world))
        return err_set(err, "shape %u: its transform is singular or not affine", proto.shape);
    proto.to_object = transform_inverse(proto.to_world);
    analytic_t *a = malloc(sizeof *a);
    if (!a)
        return err_set(err, "out of memory");
    *a = proto;
    RTCGeometry g = rtcNewGeometry(self->device, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(g, 1);
    rtcSetGeometryUserData(g, a);
    rtcSetGeometryBoundsFunction(g, analytic_bounds, NULL);
    rtcSetGeometryIntersectFunction(g, analytic_intersect);
    rtcSetGeometryOccludedFunction(g, analytic_occluded);
    rtcCommitGeometry(g);
    unsigned id = rtcAttachGeometry(self->scene, g);
    rtcReleaseGeometry(g);
    if (check_device(self, "adding an analytic shape", err) || record(self, id, a, a->shape, a->flip, err)) {
        free(a);
        return -1;
    }
    struct RTCBounds b;
    struct RTCBoundsFunctionArguments args = {.geometryUserPtr = a, .bounds_o = &b};
    analytic_bounds(&args);
    grow_bounds(self, vec3_make(b.lower_x, b.lower_y, b.lower_z));
    grow_bounds(self, vec3_make(b.upper_x, b.upper_y, b.upper_z));
    return 0;
}

int geometry_add_sphere(geometry_t *self, const transform_t *to_world, double radius, uint32_t shape,
                        int flip, err_t *err)
{
    return add_analytic(self, (analytic_t){.kind = ANALYTIC_SPHERE, .to_world = *to_world,
                                           .radius = radius, .shape = shape, .flip = flip}, err);
}

int geometry_add_disk(geometry_t *self, const transform_t *to_world, double radius, double height,
                      uint32_t shape, int flip, err_t *err)
{
    return add_analytic(self, (analytic_t){.kind = ANALYTIC_DISK, .to_world = *to_world,
                                           .radius = radius, .height = height, .shape = shape,
                                           .flip = flip}, err);
}

int geometry_commit(geometry_t *self, err_t *err)
{
    rtcCommitScene(self->scene);
    if (check_device(self, "building the scene's BVH", err))
        return -1;
    self->committed = 1;
    return 0;
}

static struct RTCRay make_ray(vec3_t org, vec3_t dir, double tmin, double tmax)
{
    return (struct RTCRay){.org_x = (float)org.x, .org_y = (float)org.y, .org_z = (float)org.z,
                           .tnear = (float)tmin, .dir_x = (float)dir.x, .dir_y = (float)dir.y,
                           .dir_z = (float)dir.z, .tfar = (float)fmin(tmax, FLT_MAX),
                           .mask = 0xFFFFFFFFu, .flags = 0};
}

int geometry_intersect(const geometry_t *self, vec3_t org, vec3_t dir, double tmin, double tmax,
                       hit_t *out)
{
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRayHit rh = {.ray = make_ray(org, dir, tmin, tmax)};
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(self->scene, &ctx, &rh);
    unsigned id = rh.hit.geomID;
    if (id == RTC_INVALID_GEOMETRY_ID || id >= self->ngeoms)
        return 0;
    const analytic_t *a = self->analytic[id];
    out->t = rh.ray.tfar;
    out->p = vec3_fma(org, dir, out->t);
    out->shape = self->mesh[id].shape;
    out->prim = rh.hit.primID;
    vec3_t ng;
    if (!a) {
        /* Embree's triangle normal has pbrt's orientation, (p0 - p2) x (p1 - p2)
         * (tests/test_geometry.c checks it). */
        ng = vec3_make(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
        out->u = rh.hit.u;
        out->v = rh.hit.v;
    } else {
        /* Embree found the shape in float; find the same root again in double so that hit
         * points stay accurate on large and tiny scenes. */
        vec3_t o = transform_point(&a->to_object, org), d = transform_vector(&a->to_object, dir);
        double t;
        if (analytic_hit(a, o, d, tmin, out->t * (1.0 + 1e-4) + 1e-300, &t)) {
            out->t = t;
            out->p = vec3_fma(org, dir, t);
        }
        vec3_t po = vec3_fma(o, d, out->t);
        vec3_t n_obj;
        if (a->kind == ANALYTIC_SPHERE) {
            n_obj = po;
            double phi = atan2(po.y, po.x);
            if (phi < 0)
                phi += 2.0 * PF_PI;
            double ct = fmax(-1.0, fmin(1.0, po.z / a->radius));
            out->u = phi / (2.0 * PF_PI);
            out->v = acos(ct) / PF_PI;
        } else {
            n_obj = vec3_make(0, 0, 1);
            double phi = atan2(po.y, po.x);
            if (phi < 0)
                phi += 2.0 * PF_PI;
            out->u = phi / (2.0 * PF_PI);
            out->v = 1.0 - sqrt(po.x * po.x + po.y * po.y) / a->radius;
        }
        ng = transform_normal(&a->to_world, n_obj);
        out->p = transform_point(&a->to_world, a->kind == ANALYTIC_SPHERE
                                                ? vec3_scale(vec3_normalize(po), a->radius)
                                                : vec3_make(po.x, po.y, a->height));
    }
    ng = vec3_normalize(ng);
    if (self->mesh[id].flip)
        ng = vec3_neg(ng);
    out->ng = ng;
    return 1;
}

int geometry_occluded(const geometry_t *self, vec3_t org, vec3_t dir, double tmin, double tmax)
{
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRay ray = make_ray(org, dir, tmin, tmax);
    rtcOccluded1(self->scene, &ctx, &ray);
    return ray.tfar == -INFINITY;
}

void geometry_bounds(const geometry_t *self, vec3_t *lo, vec3_t *hi)
{
    *lo = self->lo;
    *hi = self->hi;
}

vec3_t geometry_offset(vec3_t p, vec3_t ng, vec3_t dir)
{
    /* Embree stores positions in float: the error of a hit point grows with its magnitude
     * (about 2^-23 relative). Offset by a few ulps of the largest coordinate, plus an absolute
     * floor for points near the origin. */
    double mag = fmax(fabs(p.x), fmax(fabs(p.y), fabs(p.z)));
    double eps = 1e-6 * mag + 1e-7;
    double side = vec3_dot(dir, ng) >= 0.0 ? 1.0 : -1.0;
    return vec3_fma(p, ng, side * eps * 4.0);
}
