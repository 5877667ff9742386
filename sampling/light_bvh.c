#include "light_bvh.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

/* A node as the draws read it, 64 bytes (a cache line): boxes, axes and cosines in single
 * precision, each rounded outward (boxes grow, cosines fall, the cone widens by a margin that
 * covers the axis's rounding), so that a node's stored bounds still hold everything below it and no
 * emitter gets importance 0 where its exact bounds would have given it some. */
typedef struct node {
    double phi;
    float lo[3], hi[3], w[3];
    float cos_o, cos_e;
    float sin_o;    /* of the stored cos_o */
    uint32_t child; /* interior: the second child (the first is the next node); leaf: item */
    uint32_t flags; /* NODE_LEAF, NODE_TWOSIDED */
} node_t;

enum { NODE_LEAF = 1, NODE_TWOSIDED = 2 };

struct light_bvh {
    node_t *nodes;
    size_t nnodes;
    size_t nitems;
    /* Per item: the branch taken at each level from the root (bit k: the second child at depth
     * k) and how many levels; depth 0xFF: the item is not in the tree. */
    uint64_t *trail;
    uint8_t *depth;
    int max_depth;
};

/* One emitter during the build. */
typedef struct item {
    light_bounds_t b;
    vec3_t centroid;
    double key; /* the centroid along the axis of a median split */
    uint32_t id;
} item_t;

typedef struct builder {
    light_bvh_t *bvh;
    item_t *items;
} builder_t;

static const double ONE_MINUS_EPS = 0x1.fffffffffffffp-1;

/* cos(max(0, a - b)) and sin(max(0, a - b)) from the angles' sines and cosines (a, b in
 * [0, pi]): the angle between a direction at a and the nearest direction within b. */
static double cos_sub_clamped(double sin_a, double cos_a, double sin_b, double cos_b)
{
    return cos_a > cos_b ? 1.0 : cos_a * cos_b + sin_a * sin_b;
}

static double sin_sub_clamped(double sin_a, double cos_a, double sin_b, double cos_b)
{
    return cos_a > cos_b ? 0.0 : sin_a * cos_b - cos_a * sin_b;
}

static double safe_sqrt(double x)
{
    return x > 0.0 ? sqrt(x) : 0.0;
}

/* The importance function on plain numbers, shared by light_bounds_t and the stored nodes.
 * Conty Estevez & Kulla 2018 eq. 3, as pbrt-v4 writes it (LightBounds::Importance): with
 * theta_w the angle between the cone's axis and the direction from the box's centre to p,
 * theta_b the half-angle of the box's bounding sphere seen from p, the nearest emitting normal
 * makes theta' = max(0, theta_w - theta_o - theta_b) with the direction to p; no emitter
 * reaches p when theta' > theta_e. The distance is clamped below at the bounding sphere's
 * radius (pbrt-v4 clamps d^2 at half the diagonal's length, which mixes units; the squared
 * radius keeps the importance a power over an area). */
static double importance(vec3_t lo, vec3_t hi, vec3_t w, double phi, double cos_o, double sin_o,
                         double cos_e, int twosided, vec3_t p, vec3_t n)
{
    if (!(phi > 0.0))
        return 0.0;
    vec3_t pc = vec3_scale(vec3_add(lo, hi), 0.5);
    vec3_t diag = vec3_sub(hi, lo);
    double r2 = 0.25 * vec3_dot(diag, diag);
    vec3_t d = vec3_sub(p, pc);
    double d2 = vec3_dot(d, d);
    if (!(d2 > r2)) {
        /* p is inside the bounding sphere: the box may surround it, every direction and
         * every normal are possible. At a point light itself (r2 = d2 = 0) nothing can be
         * sampled (lights.c refuses a zero distance): importance 0. */
        if (!(r2 > 0.0))
            return 0.0;
        return fmin(phi / r2, 0x1p1000);
    }
    vec3_t wi = vec3_scale(d, 1.0 / sqrt(d2));
    double sin2_b = r2 / d2;
    double cos_b = safe_sqrt(1.0 - sin2_b), sin_b = sqrt(sin2_b);
    double cos_w = vec3_dot(w, wi);
    if (twosided)
        cos_w = fabs(cos_w);
    /* Inside the normal cone (always for a point light's): theta' = 0, no sines needed. */
    double cos_p = 1.0;
    if (!(cos_w > cos_o)) {
        double sin_w = safe_sqrt(1.0 - cos_w * cos_w);
        double cos_x = cos_sub_clamped(sin_w, cos_w, sin_o, cos_o);
        double sin_x = sin_sub_clamped(sin_w, cos_w, sin_o, cos_o);
        cos_p = cos_sub_clamped(sin_x, cos_x, sin_b, cos_b);
    }
    if (cos_p < cos_e)
        return 0.0;
    double imp = phi * cos_p / d2;
    if (n.x != 0.0 || n.y != 0.0 || n.z != 0.0) {
        double cos_i = fabs(vec3_dot(wi, n));
        double sin_i = safe_sqrt(1.0 - cos_i * cos_i);
        imp *= cos_sub_clamped(sin_i, cos_i, sin_b, cos_b);
    }
    /* Bounded so that two children's importances always sum to a finite number. */
    return imp > 0.0 ? fmin(imp, 0x1p1000) : 0.0;
}

double light_bounds_importance(const light_bounds_t *b, vec3_t p, vec3_t n)
{
    return importance(b->lo, b->hi, b->w, b->phi, b->cos_o, safe_sqrt(1.0 - b->cos_o * b->cos_o),
                      b->cos_e, b->twosided, p, n);
}

static double node_importance(const node_t *nd, vec3_t p, vec3_t n)
{
    return importance(vec3_make(nd->lo[0], nd->lo[1], nd->lo[2]),
                      vec3_make(nd->hi[0], nd->hi[1], nd->hi[2]),
                      vec3_make(nd->w[0], nd->w[1], nd->w[2]), nd->phi, nd->cos_o, nd->sin_o,
                      nd->cos_e, (nd->flags & NODE_TWOSIDED) != 0, p, n);
}

static double clamp_cos(double c)
{
    return c > 1.0 ? 1.0 : c < -1.0 ? -1.0 : c;
}

/* A vector orthogonal to unit a in the plane of a and b, turned from a toward b; the zero
 * vector when they are (anti)parallel. */
static vec3_t toward(vec3_t a, vec3_t b)
{
    vec3_t t = vec3_sub(b, vec3_scale(a, vec3_dot(a, b)));
    double len = vec3_length(t);
    return len > 1e-300 ? vec3_scale(t, 1.0 / len) : vec3_make(0, 0, 0);
}

/* The smallest cone holding cones (wa, theta_a) and (wb, theta_b) (pbrt-v4 DirectionCone
 * Union, PBR 4th ed. §3.8.4): if one holds the other, that one; else the cone whose edges
 * touch both, its half-angle (theta_a + theta_d + theta_b) / 2, its axis turned from wa toward
 * wb by that minus theta_a; the whole sphere once that reaches pi. */
static void cone_union(vec3_t wa, double cos_a, vec3_t wb, double cos_b, vec3_t *w, double *cos_o)
{
    double ta = acos(clamp_cos(cos_a)), tb = acos(clamp_cos(cos_b));
    double td = acos(clamp_cos(vec3_dot(wa, wb)));
    if (fmin(td + tb, PI) <= ta) {
        *w = wa;
        *cos_o = cos_a;
        return;
    }
    if (fmin(td + ta, PI) <= tb) {
        *w = wb;
        *cos_o = cos_b;
        return;
    }
    double to = 0.5 * (ta + td + tb);
    vec3_t t = toward(wa, wb);
    if (to >= PI || !(vec3_dot(t, t) > 0.5)) {
        *w = wa;
        *cos_o = -1.0;
        return;
    }
    double tr = to - ta;
    *w = vec3_normalize(vec3_add(vec3_scale(wa, cos(tr)), vec3_scale(t, sin(tr))));
    *cos_o = cos(to);
}

light_bounds_t light_bounds_union(const light_bounds_t *a, const light_bounds_t *b)
{
    if (!(a->phi > 0.0))
        return *b;
    if (!(b->phi > 0.0))
        return *a;
    light_bounds_t u;
    u.lo = vec3_make(fmin(a->lo.x, b->lo.x), fmin(a->lo.y, b->lo.y), fmin(a->lo.z, b->lo.z));
    u.hi = vec3_make(fmax(a->hi.x, b->hi.x), fmax(a->hi.y, b->hi.y), fmax(a->hi.z, b->hi.z));
    cone_union(a->w, a->cos_o, b->w, b->cos_o, &u.w, &u.cos_o);
    u.phi = a->phi + b->phi;
    u.cos_e = fmin(a->cos_e, b->cos_e);
    u.twosided = a->twosided || b->twosided;
    return u;
}

static float float_down(double x)
{
    float f = (float)x;
    return (double)f > x ? nextafterf(f, -INFINITY) : f;
}

static float float_up(double x)
{
    float f = (float)x;
    return (double)f < x ? nextafterf(f, INFINITY) : f;
}

/* The stored node for bounds b: outward rounding, and the cone widened by 1e-6 rad, well over
 * the angle by which a single-precision unit axis can be off (about 1e-7). */
static void node_store(node_t *nd, const light_bounds_t *b)
{
    double lo[3] = {b->lo.x, b->lo.y, b->lo.z}, hi[3] = {b->hi.x, b->hi.y, b->hi.z};
    double w[3] = {b->w.x, b->w.y, b->w.z};
    for (int k = 0; k < 3; k++) {
        nd->lo[k] = float_down(lo[k]);
        nd->hi[k] = float_up(hi[k]);
        nd->w[k] = (float)w[k];
    }
    double to = acos(clamp_cos(b->cos_o)) + 1e-6;
    nd->cos_o = to >= PI ? -1.0f : float_down(cos(to));
    nd->sin_o = (float)safe_sqrt(1.0 - (double)nd->cos_o * nd->cos_o);
    nd->cos_e = float_down(clamp_cos(b->cos_e));
    nd->phi = b->phi;
    nd->flags = b->twosided ? NODE_TWOSIDED : 0;
}

static double box_area(vec3_t lo, vec3_t hi)
{
    vec3_t d = vec3_sub(hi, lo);
    return 2.0 * (d.x * d.y + d.y * d.z + d.z * d.x);
}

static double vcomp(vec3_t v, int k)
{
    return k == 0 ? v.x : k == 1 ? v.y : v.z;
}

/* pbrt-v4's split cost (BVHLightSampler::EvaluateCost, after Conty Estevez & Kulla 2018 §4.1):
 * power times the orientation measure M_omega of the cone widened by theta_e, times the box's
 * surface area, times Kr (the node's longest extent over its extent along the split axis, which
 * favours cutting long boxes across). */
static double split_cost(const light_bounds_t *b, double kr)
{
    if (!(b->phi > 0.0))
        return 0.0;
    double to = acos(clamp_cos(b->cos_o)), te = acos(clamp_cos(b->cos_e));
    double tw = fmin(to + te, PI);
    double so = safe_sqrt(1.0 - b->cos_o * b->cos_o);
    double m = 2.0 * PI * (1.0 - b->cos_o) +
               PI / 2.0 * (2.0 * tw * so - cos(to - 2.0 * tw) - 2.0 * to * so + b->cos_o);
    return b->phi * m * kr * box_area(b->lo, b->hi);
}

enum { NBUCKETS = 12 };

static int bucket_of(double c, double cmin, double cmax)
{
    int k = (int)(NBUCKETS * ((c - cmin) / (cmax - cmin)));
    return k < 0 ? 0 : k >= NBUCKETS ? NBUCKETS - 1 : k;
}

static int ceil_log2(size_t n)
{
    int k = 0;
    while (((size_t)1 << k) < n)
        k++;
    return k;
}

static int cmp_key(const void *a, const void *b)
{
    double x = ((const item_t *)a)->key, y = ((const item_t *)b)->key;
    if (x < y)
        return -1;
    if (x > y)
        return 1;
    uint32_t i = ((const item_t *)a)->id, j = ((const item_t *)b)->id;
    return i < j ? -1 : i > j;
}

/* Splits items[start, end) (at least two) and returns the first index of the second half:
 * the bucket boundary of least split_cost over the three axes, or, when no split has a
 * positive cost (points, or every centroid in one place) or the tree would grow too deep, the
 * median along the centroids' longest extent (ties by item index, so the build is
 * deterministic). */
static size_t split(builder_t *B, size_t start, size_t end, int depth)
{
    item_t *it = B->items;
    vec3_t lo = it[start].b.lo, hi = it[start].b.hi, cmin = it[start].centroid, cmax = cmin;
    for (size_t i = start; i < end; i++) {
        vec3_t a = it[i].b.lo, b = it[i].b.hi, c = it[i].centroid;
        lo = vec3_make(fmin(lo.x, a.x), fmin(lo.y, a.y), fmin(lo.z, a.z));
        hi = vec3_make(fmax(hi.x, b.x), fmax(hi.y, b.y), fmax(hi.z, b.z));
        cmin = vec3_make(fmin(cmin.x, c.x), fmin(cmin.y, c.y), fmin(cmin.z, c.z));
        cmax = vec3_make(fmax(cmax.x, c.x), fmax(cmax.y, c.y), fmax(cmax.z, c.z));
    }
    vec3_t ext = vec3_sub(hi, lo);
    double longest = fmax(ext.x, fmax(ext.y, ext.z));
    double best = INFINITY;
    int best_dim = -1, best_bucket = -1;
    /* Deep enough that only halving is sure to stay within LIGHT_BVH_MAX_DEPTH. */
    int halve = depth + ceil_log2(end - start) >= LIGHT_BVH_MAX_DEPTH - 12;
    for (int k = 0; k < 3 && !halve; k++) {
        double c0 = vcomp(cmin, k), c1 = vcomp(cmax, k);
        if (!(c1 > c0))
            continue;
        light_bounds_t bucket[NBUCKETS];
        memset(bucket, 0, sizeof bucket);
        for (size_t i = start; i < end; i++) {
            int j = bucket_of(vcomp(it[i].centroid, k), c0, c1);
            bucket[j] = light_bounds_union(&bucket[j], &it[i].b);
        }
        /* Prefix and suffix unions, so that each boundary's cost is O(1). */
        light_bounds_t below[NBUCKETS], above[NBUCKETS];
        below[0] = bucket[0];
        for (int j = 1; j < NBUCKETS; j++)
            below[j] = light_bounds_union(&below[j - 1], &bucket[j]);
        above[NBUCKETS - 1] = bucket[NBUCKETS - 1];
        for (int j = NBUCKETS - 2; j >= 0; j--)
            above[j] = light_bounds_union(&above[j + 1], &bucket[j]);
        double kr = vcomp(ext, k) > 0.0 ? longest / vcomp(ext, k) : 1.0;
        for (int j = 0; j < NBUCKETS - 1; j++) {
            double cost = split_cost(&below[j], kr) + split_cost(&above[j + 1], kr);
            if (cost > 0.0 && cost < best) {
                best = cost;
                best_dim = k;
                best_bucket = j;
            }
        }
    }
    if (best_dim >= 0) {
        double c0 = vcomp(cmin, best_dim), c1 = vcomp(cmax, best_dim);
        size_t mid = start;
        for (size_t i = start; i < end; i++)
            if (bucket_of(vcomp(it[i].centroid, best_dim), c0, c1) <= best_bucket) {
                item_t t = it[i];
                it[i] = it[mid];
                it[mid++] = t;
            }
        if (mid > start && mid < end)
            return mid;
    }
    vec3_t cext = vec3_sub(cmax, cmin);
    int dim = cext.x >= cext.y && cext.x >= cext.z ? 0 : cext.y >= cext.z ? 1 : 2;
    for (size_t i = start; i < end; i++)
        it[i].key = vcomp(it[i].centroid, dim);
    qsort(it + start, end - start, sizeof *it, cmp_key);
    return start + (end - start) / 2;
}

/* Builds the subtree of items[start, end) at node index *next (its nodes follow in depth-first
 * order, the first child right after its parent); its bounds in *out. */
static void build(builder_t *B, size_t start, size_t end, uint64_t trail, int depth,
                  light_bounds_t *out)
{
    light_bvh_t *bvh = B->bvh;
    size_t at = bvh->nnodes++;
    node_t *nd = &bvh->nodes[at];
    if (depth > bvh->max_depth)
        bvh->max_depth = depth;
    if (end - start == 1) {
        const item_t *it = &B->items[start];
        *out = it->b;
        node_store(nd, &it->b);
        nd->child = it->id;
        nd->flags |= NODE_LEAF;
        bvh->trail[it->id] = trail;
        bvh->depth[it->id] = (uint8_t)depth;
        return;
    }
    size_t mid = split(B, start, end, depth);
    light_bounds_t b0, b1;
    build(B, start, mid, trail, depth + 1, &b0);
    uint32_t second = (uint32_t)bvh->nnodes;
    build(B, mid, end, trail | (uint64_t)1 << depth, depth + 1, &b1);
    *out = light_bounds_union(&b0, &b1);
    nd = &bvh->nodes[at];
    node_store(nd, out);
    nd->child = second;
}

light_bvh_t *light_bvh_new(const light_bounds_t *items, size_t n, err_t *err)
{
    if (n > ((size_t)1 << 31)) {
        err_set(err, "%zu emitters are more than the light BVH holds (2^31)", n);
        return NULL;
    }
    light_bvh_t *bvh = calloc(1, sizeof *bvh);
    if (!bvh) {
        err_set(err, "out of memory");
        return NULL;
    }
    bvh->nitems = n;
    bvh->trail = calloc(n ? n : 1, sizeof *bvh->trail);
    bvh->depth = malloc(n ? n : 1);
    if (!bvh->trail || !bvh->depth)
        goto oom;
    memset(bvh->depth, 0xFF, n ? n : 1);
    /* Powers as fractions of the largest, so that sums of importances stay finite. */
    double top = 0.0;
    size_t m = 0;
    for (size_t i = 0; i < n; i++)
        if (items[i].phi > 0.0 && isfinite(items[i].phi)) {
            top = fmax(top, items[i].phi);
            m++;
        }
    if (m == 0)
        return bvh;
    builder_t B = {bvh, malloc(m * sizeof *B.items)};
    bvh->nodes = malloc((2 * m - 1) * sizeof *bvh->nodes);
    if (!B.items || !bvh->nodes) {
        free(B.items);
        goto oom;
    }
    m = 0;
    for (size_t i = 0; i < n; i++)
        if (items[i].phi > 0.0 && isfinite(items[i].phi)) {
            item_t *it = &B.items[m++];
            it->b = items[i];
            it->b.phi = items[i].phi / top;
            it->centroid = vec3_scale(vec3_add(it->b.lo, it->b.hi), 0.5);
            it->id = (uint32_t)i;
        }
    light_bounds_t all;
    build(&B, 0, m, 0, 0, &all);
    free(B.items);
    return bvh;
oom:
    light_bvh_destroy(&bvh);
    err_set(err, "out of memory building the light BVH over %zu emitters", n);
    return NULL;
}

void light_bvh_destroy(light_bvh_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    light_bvh_t *self = *self_p;
    free(self->nodes);
    free(self->trail);
    free(self->depth);
    free(self);
    *self_p = NULL;
}

int light_bvh_empty(const light_bvh_t *self)
{
    return !self || self->nnodes == 0;
}

int light_bvh_depth(const light_bvh_t *self)
{
    return self ? self->max_depth : 0;
}

int light_bvh_sample(const light_bvh_t *self, vec3_t p, vec3_t n, double u, size_t *item,
                     double *pmf)
{
    if (light_bvh_empty(self))
        return 0;
    const node_t *nodes = self->nodes;
    size_t at = 0;
    double prob = 1.0;
    u = fmin(fmax(u, 0.0), ONE_MINUS_EPS);
    if (nodes[0].flags & NODE_LEAF) {
        if (!(node_importance(&nodes[0], p, n) > 0.0))
            return 0;
    }
    while (!(nodes[at].flags & NODE_LEAF)) {
        size_t c[2] = {at + 1, nodes[at].child};
        double ci[2] = {node_importance(&nodes[c[0]], p, n), node_importance(&nodes[c[1]], p, n)};
        double sum = ci[0] + ci[1];
        if (!(sum > 0.0))
            return 0;
        /* The chosen child's share, as light_bvh_pmf computes it; u is rescaled within the
         * chosen interval so that one number serves every level. */
        double p0 = ci[0] / sum;
        if (u < p0) {
            prob *= ci[0] / sum;
            u = u / p0;
            at = c[0];
        } else {
            prob *= ci[1] / sum;
            u = (u - p0) / (1.0 - p0);
            at = c[1];
        }
        u = fmin(u, ONE_MINUS_EPS);
    }
    *item = nodes[at].child;
    *pmf = prob;
    return prob > 0.0;
}

double light_bvh_pmf(const light_bvh_t *self, size_t item, vec3_t p, vec3_t n)
{
    if (light_bvh_empty(self) || item >= self->nitems || self->depth[item] == 0xFF)
        return 0.0;
    const node_t *nodes = self->nodes;
    if (nodes[0].flags & NODE_LEAF)
        return node_importance(&nodes[0], p, n) > 0.0 ? 1.0 : 0.0;
    uint64_t trail = self->trail[item];
    size_t at = 0;
    double prob = 1.0;
    for (int k = 0; k < self->depth[item]; k++) {
        size_t c[2] = {at + 1, self->nodes[at].child};
        double ci[2] = {node_importance(&nodes[c[0]], p, n), node_importance(&nodes[c[1]], p, n)};
        double sum = ci[0] + ci[1];
        int b = (int)(trail >> k & 1);
        if (!(ci[b] > 0.0))
            return 0.0;
        prob *= ci[b] / sum;
        at = c[b];
    }
    return prob;
}
