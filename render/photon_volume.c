#include "photon_volume.h"

#include "geometry.h"
#include "phase_hg.h"

#include <math.h>
#include <string.h>

/* Surfaces a probe passes before it gives up on a direction. */
#define PROBE_HOPS 64

/* The medium on org's side of the first boundary along dir, or -2 when the ray meets none. */
static int probe(const scene_t *s, vec3_t org, vec3_t dir)
{
    vec3_t o = org;
    for (int i = 0; i < PROBE_HOPS; i++) {
        hit_t h;
        if (!geometry_intersect(s->geometry, o, dir, 0.0, INFINITY, &h))
            return -2;
        surface_t sf;
        scene_surface(s, &h, &sf);
        if (sf.shape->medium_inside != sf.shape->medium_outside)
            /* Arriving against the outward normal: the ray was outside. */
            return vec3_dot(dir, sf.ng) < 0.0 ? sf.shape->medium_outside : sf.shape->medium_inside;
        o = geometry_offset(sf.p, sf.ng, dir);
    }
    return -2;
}

int photon_volume_medium_at(const scene_t *scene, vec3_t org, vec3_t dir)
{
    if (!scene->has_medium_boundary)
        return scene->camera_medium;
    const vec3_t dirs[8] = {vec3_neg(dir),      dir,
                            vec3_make(1, 0, 0), vec3_make(-1, 0, 0),
                            vec3_make(0, 1, 0), vec3_make(0, -1, 0),
                            vec3_make(0, 0, 1), vec3_make(0, 0, -1)};
    for (int i = vec3_dot(dir, dir) > 0.0 ? 0 : 2; i < 8; i++) {
        int m = probe(scene, org, dirs[i]);
        if (m != -2)
            return m;
    }
    return scene->camera_medium;
}

#define MAX_BUCKETS 64

typedef struct gather {
    vec3_t wo;
    double g;
    double sum[MAX_BUCKETS];
    const int *want; /* per bucket: some lane needs it */
} gather_t;

static void visit(void *user, vec3_t dir, int bucket, double power)
{
    gather_t *ga = user;
    if (bucket < 0 || bucket >= MAX_BUCKETS || !ga->want[bucket])
        return;
    /* The photon's light arrives from -dir; pbrt-v4's convention puts both directions away
     * from the point. */
    ga->sum[bucket] += phase_hg_eval(ga->wo, vec3_neg(dir), ga->g) * power;
}

int photon_volume_radiance(const photon_store_t *store, vec3_t x, vec3_t wo, double g, int n,
                           const int *bucket, double *L)
{
    int want[MAX_BUCKETS] = {0};
    for (int j = 0; j < n; j++) {
        L[j] = 0.0;
        if (bucket[j] >= 0 && bucket[j] < MAX_BUCKETS)
            want[bucket[j]] = 1;
    }
    gather_t ga = {.wo = wo, .g = g, .want = want};
    double scale;
    if (!photon_store_volume_gather(store, x, visit, &ga, &scale) || !(scale > 0.0))
        return 0;
    for (int j = 0; j < n; j++)
        if (bucket[j] >= 0 && bucket[j] < MAX_BUCKETS)
            L[j] = ga.sum[bucket[j]] * scale;
    return 1;
}
