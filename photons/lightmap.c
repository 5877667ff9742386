#include "lightmap.h"

#include "le_bytes.h"

#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

/* ---------------------------------------------------------------------------------------------
 * Exact, order-independent texel sums.
 *
 * Why not a double (or a Kahan sum): a texel of a bright caustic takes up to ~1e9 deposits.
 * Summed in a double, each addition rounds to half an ulp of the running sum, and with deposits
 * of one size the roundings do not cancel: 1e8 additions of 0.1 end ~1e-9 relative off (test
 * 7 shows it). A compensated (Kahan-Neumaier) sum would be accurate, but still depends on the
 * order and grouping of additions, so a map merged from 10 batches would differ in the last bit
 * from the same photons traced in one pass, and the farm's images from a local render's.
 *
 * So each texel and bucket holds a binned fixed-point sum (the idea of Demmel and Nguyen's
 * reproducible summation, ReproBLAS): bin j of the absolute binary scale holds the digits of
 * weight 2^(24 j) .. 2^(24 j + 23) of the deposits. An accumulator keeps ACC_BINS = 4 bins below
 * and including `top`, the highest bin any of its deposits reached, each bin an unsigned 64-bit
 * sum of 24-bit digits (so 2^40 deposits cannot overflow it; more is an error). Every bin is an
 * exact integer sum, and the bins kept depend only on the largest deposit, so the state is a
 * function of the multiset of deposits: merging is associative and commutative, bit for bit.
 * A deposit within 2^-20 of the bin scale of the largest (about 2^-44 of it) is kept exactly;
 * the bits of a smaller one below 2^-72 of the top bin are dropped, the same bits whatever the
 * order (relative error below n 2^-72 after n deposits). */
#define ACC_BITS 24
#define ACC_BINS 4
#define ACC_MASK ((UINT64_C(1) << ACC_BITS) - 1)
/* Bins a double can reach: 2^-1074 is in bin floor(-1074 / 24) = -45; sums of at most 2^40
 * deposits of at most FLT_MAX stay below 2^168 (bin 7); a decoded sum must be finite. */
#define ACC_TOP_MIN (-45)
#define ACC_TOP_MAX 42

static int floor_div(int a, int b)
{
    return a >= 0 ? a / b : -((-a + b - 1) / b);
}

/* Splits x > 0 (finite) into its top bin and the digits of bins top, top - 1, ... A double has
 * 53 significant bits, so it spans at most ACC_BINS bins of 24 and is represented exactly. */
static int acc_digits(double x, uint64_t d[ACC_BINS])
{
    int e;
    double f = frexp(x, &e);                /* x = f 2^e, f in [0.5, 1) */
    uint64_t mant = (uint64_t)ldexp(f, 53); /* x = mant 2^(e - 53), exactly */
    int low = e - 53;
    int top = floor_div(low + 52, ACC_BITS);
    for (int k = 0; k < ACC_BINS; k++) {
        int s = (top - k) * ACC_BITS - low; /* bit of mant at the bin's lowest position */
        if (s >= 64)
            d[k] = 0;
        else if (s >= 0)
            d[k] = (mant >> s) & ACC_MASK;
        else
            d[k] = -s >= ACC_BITS ? 0 : (mant << -s) & ACC_MASK;
    }
    return top;
}

/* a += b, both states (bins, top); an empty state has a[0] == 0. -1 (a unchanged) when a bin
 * would overflow. */
static int acc_merge(uint64_t a[ACC_BINS], int8_t *ta, const uint64_t b[ACC_BINS], int tb)
{
    if (b[0] == 0)
        return 0;
    if (a[0] == 0) {
        memcpy(a, b, ACC_BINS * sizeof *a);
        *ta = (int8_t)tb;
        return 0;
    }
    int t = *ta > tb ? *ta : tb;
    uint64_t r[ACC_BINS];
    for (int k = 0; k < ACC_BINS; k++) {
        /* New bin k is absolute bin t - k, which is a's bin k - (t - ta) and b's k - (t - tb);
         * bins above a state's top are 0, bins below the new window are dropped. */
        int ka = k - (t - *ta), kb = k - (t - tb);
        uint64_t va = ka >= 0 ? a[ka] : 0, vb = kb >= 0 ? b[kb] : 0;
        if (va > UINT64_MAX - vb)
            return -1;
        r[k] = va + vb;
    }
    memcpy(a, r, sizeof r);
    *ta = (int8_t)t;
    return 0;
}

static double acc_value(const uint64_t a[ACC_BINS], int top)
{
    double v = 0.0;
    for (int k = ACC_BINS - 1; k >= 0; k--)
        v += ldexp((double)a[k], (top - k) * ACC_BITS);
    return v;
}

/* ---------------------------------------------------------------------------------------------
 * Storage: tiles of TILE x TILE texels of one surface, found by a hash of their key; within a
 * tile, one chunk of accumulators per bucket, allocated when the bucket first gets power there
 * (a dispersed caustic puts few buckets on each texel). Tiles and chunks come from an arena. */
#define TILE 4
#define TILE_TEXELS (TILE * TILE)

typedef struct chunk {
    uint64_t acc[TILE_TEXELS][ACC_BINS];
    int8_t top[TILE_TEXELS];
} chunk_t;

typedef struct tile_key {
    uint32_t instance, shape, prim, side;
    uint64_t tile;
} tile_key_t;

typedef struct tile {
    tile_key_t key;
    uint16_t used;    /* texels holding power */
    chunk_t *chunk[]; /* per bucket, NULL until the bucket gets power in this tile */
} tile_t;

typedef struct slab {
    struct slab *next;
    size_t size, used;
    max_align_t data[];
} slab_t;

#define SLAB_MIN ((size_t)16 << 10)
#define SLAB_MAX ((size_t)1 << 20)

struct lightmap {
    const scene_t *scene;
    double density;
    spectral_grid_t grid;
    uint64_t emitted;
    tile_t **table; /* open addressing, linear probing; NULL slots are empty */
    size_t cap, ntiles;
    size_t texels_used;
    slab_t *slabs;
    size_t slab_bytes, next_slab;
};

static void *arena_alloc(lightmap_t *self, size_t n)
{
    n = (n + sizeof(max_align_t) - 1) / sizeof(max_align_t) * sizeof(max_align_t);
    slab_t *s = self->slabs;
    if (!s || s->size - s->used < n) {
        size_t size = n > self->next_slab ? n : self->next_slab;
        s = malloc(sizeof *s + size);
        if (!s)
            return NULL;
        s->next = self->slabs;
        s->size = size;
        s->used = 0;
        self->slabs = s;
        self->slab_bytes += sizeof *s + size;
        if (self->next_slab < SLAB_MAX)
            self->next_slab *= 2;
    }
    void *p = (char *)s->data + s->used;
    s->used += n;
    memset(p, 0, n);
    return p;
}

static uint64_t mix64(uint64_t z)
{
    /* splitmix64's finaliser (Steele, Lea and Flood 2014) */
    z = (z ^ (z >> 30)) * UINT64_C(0xbf58476d1ce4e5b9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94d049bb133111eb);
    return z ^ (z >> 31);
}

static uint64_t key_hash(const tile_key_t *k)
{
    uint64_t h = mix64(((uint64_t)k->instance << 32 | k->shape) ^ UINT64_C(0x9e3779b97f4a7c15));
    h = mix64(h ^ ((uint64_t)k->prim << 1 | k->side));
    return mix64(h ^ k->tile);
}

static int key_cmp(const tile_key_t *a, const tile_key_t *b)
{
    if (a->instance != b->instance)
        return a->instance < b->instance ? -1 : 1;
    if (a->shape != b->shape)
        return a->shape < b->shape ? -1 : 1;
    if (a->prim != b->prim)
        return a->prim < b->prim ? -1 : 1;
    if (a->side != b->side)
        return a->side < b->side ? -1 : 1;
    if (a->tile != b->tile)
        return a->tile < b->tile ? -1 : 1;
    return 0;
}

static int same_surface(const tile_key_t *a, const tile_key_t *b)
{
    return a->instance == b->instance && a->shape == b->shape && a->prim == b->prim &&
           a->side == b->side;
}

static tile_t *tile_find(const lightmap_t *self, const tile_key_t *k)
{
    if (!self->cap)
        return NULL;
    for (size_t i = key_hash(k) & (self->cap - 1);; i = (i + 1) & (self->cap - 1)) {
        tile_t *t = self->table[i];
        if (!t || !key_cmp(&t->key, k))
            return t;
    }
}

static int table_grow(lightmap_t *self)
{
    size_t cap = self->cap ? 2 * self->cap : 64;
    tile_t **table = calloc(cap, sizeof *table);
    if (!table)
        return -1;
    for (size_t j = 0; j < self->cap; j++) {
        tile_t *t = self->table[j];
        if (!t)
            continue;
        size_t i = key_hash(&t->key) & (cap - 1);
        while (table[i])
            i = (i + 1) & (cap - 1);
        table[i] = t;
    }
    free(self->table);
    self->table = table;
    self->cap = cap;
    return 0;
}

static tile_t *tile_get(lightmap_t *self, const tile_key_t *k, err_t *err)
{
    tile_t *t = tile_find(self, k);
    if (t)
        return t;
    /* load factor at most 1/2 */
    if (2 * (self->ntiles + 1) > self->cap && table_grow(self)) {
        err_set(err, "light map: out of memory growing the tile table");
        return NULL;
    }
    t = arena_alloc(self, sizeof *t + (size_t)self->grid.n * sizeof(chunk_t *));
    if (!t) {
        err_set(err, "light map: out of memory for a tile");
        return NULL;
    }
    t->key = *k;
    size_t i = key_hash(k) & (self->cap - 1);
    while (self->table[i])
        i = (i + 1) & (self->cap - 1);
    self->table[i] = t;
    self->ntiles++;
    return t;
}

static chunk_t *chunk_get(lightmap_t *self, tile_t *t, int b, err_t *err)
{
    if (!t->chunk[b] && !(t->chunk[b] = arena_alloc(self, sizeof(chunk_t))))
        err_set(err, "light map: out of memory for texels");
    return t->chunk[b];
}

/* ---------------------------------------------------------------------------------------------
 * Surfaces and their texel grids. */

typedef struct grid_info {
    shape_kind_t kind;
    uint64_t nx, ny;
    /* Meshes and disks: every texel's world area. Spheres: the object-space area of a texel
     * (world areas come from `to_world` at the texel centre). */
    double texel_area;
    double radius;
    transform_t to_world; /* spheres and disks: object (shape) space to world */
    double det;           /* spheres: |det| of to_world's linear part */
} grid_info_t;

/* Texels along a side for `want` of them (a real), capped. */
static uint64_t side_count(double want)
{
    if (!(want > 1.0))
        return 1;
    if (want >= (double)LIGHTMAP_MAX_SIDE)
        return LIGHTMAP_MAX_SIDE;
    return (uint64_t)ceil(want);
}

static double det3(const transform_t *t)
{
    const double(*m)[4] = t->m;
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
           m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
           m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

static vec3_t mesh_vertex(const shape_t *s, uint32_t v)
{
    const double *p = s->positions + 3 * (size_t)v;
    return vec3_make(p[0], p[1], p[2]);
}

/* Checks that (instance, shape, prim) names a surface of the scene and fills its grid. */
static int grid_of(const lightmap_t *self, uint32_t instance, uint32_t shape, uint32_t prim,
                   grid_info_t *g, err_t *err)
{
    const scene_t *sc = self->scene;
    if (shape >= sc->nshapes)
        return err_set(err, "shape %u does not exist (the scene has %zu)", shape, sc->nshapes);
    const shape_t *s = &sc->shapes[shape];
    const instance_t *in = NULL;
    if (instance == GEOMETRY_NO_INSTANCE) {
        if (s->object != -1)
            return err_set(err, "shape %u belongs to object %d, but no instance is named", shape,
                           s->object);
    } else {
        if (instance >= sc->ninstances)
            return err_set(err, "instance %u does not exist (the scene has %zu)", instance,
                           sc->ninstances);
        in = &sc->instances[instance];
        if (in->object != s->object)
            return err_set(err, "shape %u is not part of instance %u's object %d", shape, instance,
                           in->object);
    }
    g->kind = s->kind;
    g->radius = s->radius;
    const double d = self->density;
    if (s->kind == SHAPE_MESH) {
        if (prim >= s->ntris)
            return err_set(err, "triangle %u of shape %u does not exist (it has %zu)", prim, shape,
                           s->ntris);
        const uint32_t *ix = s->indices + 3 * (size_t)prim;
        vec3_t p[3];
        for (int k = 0; k < 3; k++) {
            p[k] = mesh_vertex(s, ix[k]);
            if (in)
                p[k] = transform_point(&in->to_world, p[k]);
        }
        double area = 0.5 * vec3_length(vec3_cross(vec3_sub(p[1], p[0]), vec3_sub(p[2], p[0])));
        if (!isfinite(area))
            area = 0.0;
        uint64_t m = side_count(sqrt(area * d));
        g->nx = g->ny = m;
        g->texel_area = area / ((double)m * (double)m);
        return 0;
    }
    if (prim != 0)
        return err_set(err, "shape %u is a %s: its prim must be 0, got %u", shape,
                       s->kind == SHAPE_SPHERE ? "sphere" : "disk", prim);
    g->to_world = in ? transform_compose(in->to_world, s->to_world) : s->to_world;
    if (s->kind == SHAPE_DISK) {
        /* A plane's area scales by |L ex x L ey| under the linear part L, everywhere. */
        double f = vec3_length(vec3_cross(transform_vector(&g->to_world, vec3_make(1, 0, 0)),
                                          transform_vector(&g->to_world, vec3_make(0, 1, 0))));
        double area = PF_PI * s->radius * s->radius * f;
        uint64_t n = side_count(sqrt(area * d));
        g->nx = g->ny = n;
        g->texel_area = area / ((double)n * (double)n);
        return 0;
    }
    g->det = fabs(det3(&g->to_world));
    /* The texel count only needs the area roughly: exact for a similarity, the volume-matched
     * sphere's for an ellipsoid. */
    double area_obj = 4.0 * PF_PI * s->radius * s->radius;
    double want = ceil(area_obj * pow(g->det, 2.0 / 3.0) * d);
    if (!(want >= 1.0))
        want = 1.0;
    uint64_t nz = side_count(floor(sqrt(want / PF_PI) + 0.5));
    uint64_t nphi = side_count(want / (double)nz);
    g->nx = nphi;
    g->ny = nz;
    g->texel_area = area_obj / ((double)nphi * (double)nz);
    return 0;
}

static double texel_area_xy(const grid_info_t *g, uint64_t x, uint64_t y)
{
    if (g->kind != SHAPE_SPHERE)
        return g->texel_area;
    /* Nanson's formula: an object-space area element dA with unit normal n maps to
     * |det L| |L^-T n| dA in world space; taken at the texel centre (midpoint rule), exact when
     * L is a similarity. On the unit sphere the normal is the point itself. */
    double phi = ((double)x + 0.5) * (2.0 * PF_PI / (double)g->nx);
    double z = -1.0 + ((double)y + 0.5) * (2.0 / (double)g->ny);
    double rho = sqrt(fmax(0.0, 1.0 - z * z));
    vec3_t n = vec3_make(rho * cos(phi), rho * sin(phi), z);
    return g->texel_area * g->det * vec3_length(transform_normal(&g->to_world, n));
}

static uint64_t clamp_index(double v, uint64_t n)
{
    if (!(v > 0.0))
        return 0;
    if (v >= (double)n)
        return n - 1;
    uint64_t i = (uint64_t)v;
    return i < n ? i : n - 1;
}

/* Grid cell (x, y) of a hit on the surface g describes. */
static void hit_cell(const grid_info_t *g, const hit_t *hit, uint64_t *x, uint64_t *y)
{
    if (g->kind == SHAPE_MESH) {
        /* Sub-triangle (i, j) of barycentric cell i <= u m < i + 1, j <= v m < j + 1 is "up"
         * when the fractional parts sum below 1, else "down" (which exists for i + j <= m - 2).
         * The m (m + 1) / 2 up triangles fill the grid's half x + y <= m - 1 as (i, j), the
         * m (m - 1) / 2 down ones the other half as (m - 1 - i, m - 1 - j). */
        uint64_t m = g->nx;
        double u = fmin(1.0, fmax(0.0, hit->u)), v = fmin(1.0, fmax(0.0, hit->v));
        if (u + v > 1.0) {
            double s = u + v;
            u /= s;
            v /= s;
        }
        double su = u * (double)m, sv = v * (double)m;
        uint64_t i = clamp_index(su, m), j = clamp_index(sv, m);
        int down = 0;
        if (i + j > m - 1)
            i = m - 1 - j; /* on the far edge: the up triangle there */
        else
            down = i + j < m - 1 && (su - (double)i) + (sv - (double)j) > 1.0;
        *x = down ? m - 1 - i : i;
        *y = down ? m - 1 - j : j;
        return;
    }
    transform_t inv = transform_inverse(g->to_world);
    vec3_t po = transform_point(&inv, hit->p);
    if (g->kind == SHAPE_SPHERE) {
        double len = vec3_length(po);
        double z = len > 0.0 ? fmin(1.0, fmax(-1.0, po.z / len)) : 0.0;
        double phi = atan2(po.y, po.x);
        if (phi < 0.0)
            phi += 2.0 * PF_PI;
        *x = clamp_index(phi / (2.0 * PF_PI) * (double)g->nx, g->nx);
        *y = clamp_index((z + 1.0) * 0.5 * (double)g->ny, g->ny);
        return;
    }
    /* Disk: the inverse of Shirley and Chiu's concentric map (1997), which takes the square
     * [-1, 1]^2 to the unit disk preserving fractional area. For |a| > |b| the map is
     * r = a, phi = (pi / 4) (b / a), so a = +-r and b = a (4 / pi) atan(y / x); else
     * r = b, phi = pi / 2 - (pi / 4) (a / b), so b = +-r and a = b (4 / pi) atan(x / y). */
    double px = po.x / g->radius, py = po.y / g->radius;
    double r = sqrt(px * px + py * py);
    double a = 0.0, b = 0.0;
    if (r > 0.0) {
        double rr = fmin(r, 1.0);
        if (fabs(px) >= fabs(py)) {
            a = px > 0.0 ? rr : -rr;
            b = a * (4.0 / PF_PI) * atan(py / px);
        } else {
            b = py > 0.0 ? rr : -rr;
            a = b * (4.0 / PF_PI) * atan(px / py);
        }
    }
    *x = clamp_index((a + 1.0) * 0.5 * (double)g->nx, g->nx);
    *y = clamp_index((b + 1.0) * 0.5 * (double)g->ny, g->ny);
}

static uint64_t tiles_across(const grid_info_t *g)
{
    return (g->nx + TILE - 1) / TILE;
}

typedef struct where {
    grid_info_t g;
    tile_key_t key;
    uint64_t x, y;
    int slot;
} where_t;

static int locate(const lightmap_t *self, const hit_t *hit, vec3_t n, where_t *w, err_t *err)
{
    if (grid_of(self, hit->instance, hit->shape, hit->prim, &w->g, err))
        return err_prefix(err, "light map: hit: ");
    hit_cell(&w->g, hit, &w->x, &w->y);
    w->key = (tile_key_t){.instance = hit->instance,
                          .shape = hit->shape,
                          .prim = hit->prim,
                          .side = vec3_dot(n, hit->ng) < 0.0 ? 1u : 0u,
                          .tile = (w->y / TILE) * tiles_across(&w->g) + w->x / TILE};
    w->slot = (int)((w->y % TILE) * TILE + w->x % TILE);
    return 0;
}

/* A texel given by key and index, checked. */
static int where_texel(const lightmap_t *self, lightmap_texel_t t, where_t *w, err_t *err)
{
    if (grid_of(self, t.instance, t.shape, t.prim, &w->g, err))
        return -1;
    if (t.side != 0 && t.side != 1)
        return err_set(err, "side %d is neither 0 nor 1", t.side);
    if (t.index / w->g.nx >= w->g.ny)
        return err_set(err, "texel %llu is outside the grid", (unsigned long long)t.index);
    w->x = t.index % w->g.nx;
    w->y = t.index / w->g.nx;
    w->key = (tile_key_t){.instance = t.instance,
                          .shape = t.shape,
                          .prim = t.prim,
                          .side = (uint32_t)t.side,
                          .tile = (w->y / TILE) * tiles_across(&w->g) + w->x / TILE};
    w->slot = (int)((w->y % TILE) * TILE + w->x % TILE);
    return 0;
}

/* ---------------------------------------------------------------------------------------------
 * The map. */

lightmap_t *lightmap_new(const scene_t *scene, double density, spectral_grid_t grid, err_t *err)
{
    if (!scene) {
        err_set(err, "light map: no scene");
        return NULL;
    }
    if (!(density > 0.0 && density <= LIGHTMAP_MAX_DENSITY)) {
        err_set(err, "light map: density must be in (0, %g] texels per unit area, got %g",
                LIGHTMAP_MAX_DENSITY, density);
        return NULL;
    }
    if (spectral_grid_validate(grid, err)) {
        err_prefix(err, "light map: ");
        return NULL;
    }
    lightmap_t *self = calloc(1, sizeof *self);
    if (!self) {
        err_set(err, "light map: out of memory");
        return NULL;
    }
    self->scene = scene;
    self->density = density;
    self->grid = grid;
    self->next_slab = SLAB_MIN;
    return self;
}

void lightmap_destroy(lightmap_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    lightmap_t *self = *self_p;
    for (slab_t *s = self->slabs, *next; s; s = next) {
        next = s->next;
        free(s);
    }
    free(self->table);
    free(self);
    *self_p = NULL;
}

/* Adds the state (d, top) to texel `slot` of bucket b of the tile. */
static int texel_add(lightmap_t *self, tile_t *t, int b, int slot, const uint64_t d[ACC_BINS],
                     int top, err_t *err)
{
    chunk_t *c = chunk_get(self, t, b, err);
    if (!c)
        return -1;
    if (acc_merge(c->acc[slot], &c->top[slot], d, top))
        return err_set(err, "light map: a texel's sum overflowed (more than 2^%d deposits)",
                       64 - ACC_BITS);
    if (!(t->used & (1u << slot))) {
        t->used |= (uint16_t)(1u << slot);
        self->texels_used++;
    }
    return 0;
}

int lightmap_deposit(lightmap_t *self, const hit_t *hit, vec3_t n, double lambda, double power,
                     err_t *err)
{
    if (!isfinite(lambda))
        return err_set(err, "light map: deposit at a non-finite wavelength");
    if (!(power >= 0.0 && power <= FLT_MAX))
        return err_set(err, "light map: deposit of power %g (must be finite, >= 0 and <= %g)",
                       power, (double)FLT_MAX);
    int b = spectral_grid_index(self->grid, lambda);
    if (b < 0 || power == 0.0)
        return 0;
    where_t w;
    if (locate(self, hit, n, &w, err))
        return -1;
    tile_t *t = tile_get(self, &w.key, err);
    if (!t)
        return -1;
    uint64_t d[ACC_BINS];
    int top = acc_digits(power, d);
    return texel_add(self, t, b, w.slot, d, top, err);
}

void lightmap_add_emitted(lightmap_t *self, uint64_t n)
{
    self->emitted += n;
}

uint64_t lightmap_emitted(const lightmap_t *self)
{
    return self->emitted;
}

static int same_setup(const lightmap_t *a, const lightmap_t *b)
{
    return a->scene == b->scene && a->density == b->density && a->grid.n == b->grid.n &&
           a->grid.lambda_min == b->grid.lambda_min && a->grid.lambda_max == b->grid.lambda_max;
}

int lightmap_merge(lightmap_t *dst, const lightmap_t *src, err_t *err)
{
    if (dst == src)
        return err_set(err, "light map: cannot merge a map into itself");
    if (!same_setup(dst, src))
        return err_set(err, "light map: cannot merge maps of different scenes, densities or grids");
    /* Each texel is added to once, and texel sums are exact, so the order tiles are visited in
     * does not show in the result. */
    for (size_t i = 0; i < src->cap; i++) {
        const tile_t *s = src->table[i];
        if (!s)
            continue;
        tile_t *t = tile_get(dst, &s->key, err);
        if (!t)
            return -1;
        for (int b = 0; b < src->grid.n; b++) {
            const chunk_t *c = s->chunk[b];
            for (int k = 0; c && k < TILE_TEXELS; k++)
                if (c->acc[k][0] && texel_add(dst, t, b, k, c->acc[k], c->top[k], err))
                    return -1;
        }
    }
    dst->emitted += src->emitted;
    return 0;
}

static void zero(double *E, int n)
{
    for (int b = 0; b < n; b++)
        E[b] = 0.0;
}

int lightmap_irradiance(const lightmap_t *self, const hit_t *hit, vec3_t n, double *E)
{
    zero(E, self->grid.n);
    where_t w;
    if (locate(self, hit, n, &w, NULL))
        return 0;
    const tile_t *t = tile_find(self, &w.key);
    if (!t || !(t->used & (1u << w.slot)) || self->emitted == 0)
        return 0;
    double area = texel_area_xy(&w.g, w.x, w.y);
    double denom = (double)self->emitted * area * spectral_grid_width(self->grid);
    if (!(denom > 0.0) || !isfinite(denom))
        return 0;
    int any = 0;
    for (int b = 0; b < self->grid.n; b++) {
        const chunk_t *c = t->chunk[b];
        if (!c || !c->acc[w.slot][0])
            continue;
        double e = acc_value(c->acc[w.slot], c->top[w.slot]) / denom;
        /* A texel of denormal area could overflow: no Inf leaves the store. */
        if (isfinite(e) && e > 0.0) {
            E[b] = e;
            any = 1;
        }
    }
    return any;
}

int lightmap_locate(const lightmap_t *self, const hit_t *hit, vec3_t n, lightmap_texel_t *out,
                    err_t *err)
{
    where_t w;
    if (locate(self, hit, n, &w, err))
        return -1;
    *out = (lightmap_texel_t){.instance = hit->instance,
                              .shape = hit->shape,
                              .prim = hit->prim,
                              .side = (int)w.key.side,
                              .index = w.y * w.g.nx + w.x};
    return 0;
}

int lightmap_surface_texels(const lightmap_t *self, uint32_t instance, uint32_t shape,
                            uint32_t prim, uint64_t *count, err_t *err)
{
    grid_info_t g;
    if (grid_of(self, instance, shape, prim, &g, err))
        return err_prefix(err, "light map: ");
    *count = g.nx * g.ny;
    return 0;
}

double lightmap_texel_area(const lightmap_t *self, lightmap_texel_t t)
{
    where_t w;
    if (where_texel(self, t, &w, NULL))
        return 0.0;
    return texel_area_xy(&w.g, w.x, w.y);
}

int lightmap_texel_power(const lightmap_t *self, lightmap_texel_t t, double *power)
{
    zero(power, self->grid.n);
    where_t w;
    if (where_texel(self, t, &w, NULL))
        return 0;
    const tile_t *tl = tile_find(self, &w.key);
    if (!tl || !(tl->used & (1u << w.slot)))
        return 0;
    for (int b = 0; b < self->grid.n; b++) {
        const chunk_t *c = tl->chunk[b];
        if (c && c->acc[w.slot][0])
            power[b] = acc_value(c->acc[w.slot], c->top[w.slot]);
    }
    return 1;
}

size_t lightmap_texels_used(const lightmap_t *self)
{
    return self->texels_used;
}

size_t lightmap_memory_bytes(const lightmap_t *self)
{
    return sizeof *self + self->cap * sizeof *self->table + self->slab_bytes;
}

double lightmap_power_sum(const lightmap_t *self)
{
    /* The texel values, themselves summed exactly, so the result does not depend on the
     * table's order. */
    uint64_t sum[ACC_BINS] = {0};
    int8_t top = 0;
    for (size_t i = 0; i < self->cap; i++) {
        const tile_t *t = self->table[i];
        for (int b = 0; t && b < self->grid.n; b++) {
            const chunk_t *c = t->chunk[b];
            for (int k = 0; c && k < TILE_TEXELS; k++) {
                if (!c->acc[k][0])
                    continue;
                uint64_t d[ACC_BINS];
                double v = acc_value(c->acc[k], c->top[k]);
                if (v > 0.0 && acc_merge(sum, &top, d, acc_digits(v, d)))
                    return INFINITY; /* 2^40 texels: unreachable in memory */
            }
        }
    }
    return acc_value(sum, top);
}

spectral_grid_t lightmap_grid(const lightmap_t *self)
{
    return self->grid;
}

double lightmap_density(const lightmap_t *self)
{
    return self->density;
}

/* ---------------------------------------------------------------------------------------------
 * Wire form. */

#define WIRE_MAGIC UINT32_C(0x4d4c4650) /* "PFLM" little endian */
#define WIRE_OUTER 16                   /* magic, version, raw length */
#define WIRE_HEAD 48                    /* the raw payload's header */
#define WIRE_SURFACE 24
#define WIRE_TEXEL (1 + 8 * ACC_BINS)

static int cmp_tiles(const void *a, const void *b)
{
    return key_cmp(&(*(tile_t *const *)a)->key, &(*(tile_t *const *)b)->key);
}

/* The tiles in key order (malloc'ed; NULL when there are none or memory ran out). */
static tile_t **sorted_tiles(const lightmap_t *self, int *failed)
{
    *failed = 0;
    if (!self->ntiles)
        return NULL;
    tile_t **v = malloc(self->ntiles * sizeof *v);
    if (!v) {
        *failed = 1;
        return NULL;
    }
    size_t n = 0;
    for (size_t i = 0; i < self->cap; i++)
        if (self->table[i])
            v[n++] = self->table[i];
    qsort(v, n, sizeof *v, cmp_tiles);
    return v;
}

static uint16_t chunk_mask(const chunk_t *c)
{
    uint16_t m = 0;
    for (int k = 0; k < TILE_TEXELS; k++)
        if (c->acc[k][0])
            m |= (uint16_t)(1u << k);
    return m;
}

static int popcount16(uint16_t m)
{
    int n = 0;
    for (; m; m &= (uint16_t)(m - 1))
        n++;
    return n;
}

int lightmap_encode(const lightmap_t *self, uint8_t **out, size_t *out_len, err_t *err)
{
    int failed;
    tile_t **tiles = sorted_tiles(self, &failed);
    if (failed)
        return err_set(err, "light map: out of memory encoding");
    const int nb = self->grid.n, mask_bytes = (nb + 7) / 8;
    /* Sizes first, so the payload is written in one buffer. */
    size_t raw_len = WIRE_HEAD, nsurf = 0;
    for (size_t i = 0; i < self->ntiles; i++) {
        if (i == 0 || !same_surface(&tiles[i]->key, &tiles[i - 1]->key)) {
            nsurf++;
            raw_len += WIRE_SURFACE;
        }
        raw_len += 8 + (size_t)mask_bytes;
        for (int b = 0; b < nb; b++)
            if (tiles[i]->chunk[b])
                raw_len += 2 + (size_t)popcount16(chunk_mask(tiles[i]->chunk[b])) * WIRE_TEXEL;
    }
    uint8_t *raw = malloc(raw_len);
    uLong bound = compressBound((uLong)raw_len);
    uint8_t *buf = raw ? malloc(WIRE_OUTER + (size_t)bound) : NULL;
    if (!buf) {
        free(raw);
        free(tiles);
        return err_set(err, "light map: out of memory encoding %zu bytes", raw_len);
    }
    uint8_t *p = raw;
    le_put_u32(p, (uint32_t)nb);
    le_put_u32(p + 4, 0);
    le_put_f64(p + 8, self->grid.lambda_min);
    le_put_f64(p + 16, self->grid.lambda_max);
    le_put_f64(p + 24, self->density);
    le_put_u64(p + 32, self->emitted);
    le_put_u64(p + 40, nsurf);
    p += WIRE_HEAD;
    for (size_t i = 0; i < self->ntiles;) {
        size_t j = i;
        while (j < self->ntiles && same_surface(&tiles[j]->key, &tiles[i]->key))
            j++;
        const tile_key_t *k = &tiles[i]->key;
        le_put_u32(p, k->instance);
        le_put_u32(p + 4, k->shape);
        le_put_u32(p + 8, k->prim);
        le_put_u32(p + 12, k->side);
        le_put_u64(p + 16, j - i);
        p += WIRE_SURFACE;
        for (; i < j; i++) {
            const tile_t *t = tiles[i];
            le_put_u64(p, t->key.tile);
            p += 8;
            memset(p, 0, (size_t)mask_bytes);
            for (int b = 0; b < nb; b++)
                if (t->chunk[b])
                    p[b / 8] |= (uint8_t)(1u << (b % 8));
            p += mask_bytes;
            for (int b = 0; b < nb; b++) {
                const chunk_t *c = t->chunk[b];
                if (!c)
                    continue;
                uint16_t m = chunk_mask(c);
                le_put_u16(p, m);
                p += 2;
                for (int s = 0; s < TILE_TEXELS; s++) {
                    if (!(m & (1u << s)))
                        continue;
                    *p++ = (uint8_t)c->top[s];
                    for (int q = 0; q < ACC_BINS; q++, p += 8)
                        le_put_u64(p, c->acc[s][q]);
                }
            }
        }
    }
    free(tiles);
    uLongf clen = bound;
    int zr = compress2(buf + WIRE_OUTER, &clen, raw, (uLong)raw_len, Z_DEFAULT_COMPRESSION);
    free(raw);
    if (zr != Z_OK) {
        free(buf);
        return err_set(err, "light map: zlib compress2 failed (%d)", zr);
    }
    le_put_u32(buf, WIRE_MAGIC);
    le_put_u32(buf + 4, LIGHTMAP_WIRE_VERSION);
    le_put_u64(buf + 8, raw_len);
    *out_len = WIRE_OUTER + (size_t)clen;
    uint8_t *shrunk = realloc(buf, *out_len);
    *out = shrunk ? shrunk : buf;
    return 0;
}

/* Inflates the payload into a new buffer of exactly raw_len bytes. */
static uint8_t *inflate_payload(const uint8_t *data, size_t len, size_t raw_len, err_t *err)
{
    if (len > UINT_MAX || raw_len > UINT_MAX) {
        err_set(err, "light map data: larger than 4 GiB");
        return NULL;
    }
    uint8_t *raw = malloc(raw_len ? raw_len : 1);
    if (!raw) {
        err_set(err, "light map data: out of memory for %zu bytes", raw_len);
        return NULL;
    }
    z_stream zs;
    memset(&zs, 0, sizeof zs);
    if (inflateInit(&zs) != Z_OK) {
        free(raw);
        err_set(err, "light map data: zlib inflateInit failed");
        return NULL;
    }
    zs.next_in = (Bytef *)data;
    zs.avail_in = (uInt)len;
    zs.next_out = raw;
    zs.avail_out = (uInt)raw_len;
    int zr = inflate(&zs, Z_FINISH);
    const char *zmsg = zs.msg ? zs.msg : "no detail";
    if (zr == Z_STREAM_END && zs.total_out == raw_len && zs.avail_in == 0) {
        inflateEnd(&zs);
        return raw;
    }
    if (zr == Z_STREAM_END && zs.total_out != raw_len)
        err_set(err, "light map data: inflates to %lu bytes, its header says %zu", zs.total_out,
                raw_len);
    else if (zr == Z_STREAM_END)
        err_set(err, "light map data: %u bytes after the end of the compressed stream",
                zs.avail_in);
    else if (zr == Z_BUF_ERROR && zs.avail_in == 0)
        err_set(err, "light map data: truncated (the compressed stream ends early)");
    else if (zr == Z_BUF_ERROR)
        err_set(err, "light map data: inflates to more than the %zu bytes its header says",
                raw_len);
    else
        err_set(err, "light map data: corrupt compressed stream (zlib %d: %s)", zr, zmsg);
    inflateEnd(&zs);
    free(raw);
    return NULL;
}

typedef struct reader {
    const uint8_t *p;
    size_t left;
} reader_t;

static const uint8_t *take(reader_t *r, size_t n, const char *what, err_t *err)
{
    if (r->left < n) {
        err_set(err, "light map data: ends early, in %s", what);
        return NULL;
    }
    const uint8_t *p = r->p;
    r->p += n;
    r->left -= n;
    return p;
}

static int decode_body(lightmap_t *self, reader_t *r, size_t max_bytes, err_t *err)
{
    const int nb = self->grid.n, mask_bytes = (nb + 7) / 8;
    const uint8_t *h = take(r, WIRE_HEAD, "the header", err);
    if (!h)
        return -1;
    if (le_get_u32(h) != (uint32_t)nb)
        return err_set(err, "light map data: %u buckets, the job's film has %d", le_get_u32(h), nb);
    if (le_get_u32(h + 4) != 0)
        return err_set(err, "light map data: reserved field is %u, not 0", le_get_u32(h + 4));
    if (le_get_f64(h + 8) != self->grid.lambda_min || le_get_f64(h + 16) != self->grid.lambda_max)
        return err_set(err, "light map data: wavelength range [%g, %g] nm, the job's is [%g, %g]",
                       le_get_f64(h + 8), le_get_f64(h + 16), self->grid.lambda_min,
                       self->grid.lambda_max);
    if (le_get_f64(h + 24) != self->density)
        return err_set(err, "light map data: density %g texels per unit area, the job's is %g",
                       le_get_f64(h + 24), self->density);
    self->emitted = le_get_u64(h + 32);
    uint64_t nsurf = le_get_u64(h + 40);
    if (nsurf > r->left / WIRE_SURFACE)
        return err_set(err, "light map data: %llu surfaces cannot fit in the %zu bytes left",
                       (unsigned long long)nsurf, r->left);
    const size_t min_tile = 8 + (size_t)mask_bytes;
    tile_key_t prev = {0};
    for (uint64_t si = 0; si < nsurf; si++) {
        const uint8_t *s = take(r, WIRE_SURFACE, "a surface", err);
        if (!s)
            return -1;
        tile_key_t key = {.instance = le_get_u32(s),
                          .shape = le_get_u32(s + 4),
                          .prim = le_get_u32(s + 8),
                          .side = le_get_u32(s + 12),
                          .tile = 0};
        uint64_t ntiles = le_get_u64(s + 16);
        grid_info_t g;
        if (grid_of(self, key.instance, key.shape, key.prim, &g, err))
            return err_prefix(err, "light map data: surface %llu: ", (unsigned long long)si);
        if (key.side > 1)
            return err_set(err, "light map data: surface %llu: side %u is neither 0 nor 1",
                           (unsigned long long)si, key.side);
        if (si > 0 && key_cmp(&key, &prev) <= 0)
            return err_set(err, "light map data: surface %llu is out of order or repeated",
                           (unsigned long long)si);
        prev = key;
        if (ntiles == 0 || ntiles > r->left / min_tile)
            return err_set(err,
                           "light map data: surface %llu: %llu tiles (the bytes left hold "
                           "at most %zu)",
                           (unsigned long long)si, (unsigned long long)ntiles, r->left / min_tile);
        const uint64_t across = tiles_across(&g), down = (g.ny + TILE - 1) / TILE;
        uint64_t last = 0;
        for (uint64_t ti = 0; ti < ntiles; ti++) {
            const uint8_t *th = take(r, min_tile, "a tile", err);
            if (!th)
                return -1;
            key.tile = le_get_u64(th);
            if (key.tile / across >= down)
                return err_set(err,
                               "light map data: surface %llu: tile %llu is outside its "
                               "%llux%llu-texel grid",
                               (unsigned long long)si, (unsigned long long)key.tile,
                               (unsigned long long)g.nx, (unsigned long long)g.ny);
            if (ti > 0 && key.tile <= last)
                return err_set(err, "light map data: surface %llu: tile %llu is out of order",
                               (unsigned long long)si, (unsigned long long)key.tile);
            last = key.tile;
            const uint8_t *bmask = th + 8;
            if (nb % 8 && bmask[mask_bytes - 1] >> (nb % 8))
                return err_set(err,
                               "light map data: surface %llu tile %llu: bucket mask names "
                               "buckets beyond the film's %d",
                               (unsigned long long)si, (unsigned long long)key.tile, nb);
            tile_t *t = tile_get(self, &key, err);
            if (!t)
                return -1;
            const uint64_t x0 = (key.tile % across) * TILE, y0 = (key.tile / across) * TILE;
            int any = 0;
            for (int b = 0; b < nb; b++) {
                if (!(bmask[b / 8] & (1u << (b % 8))))
                    continue;
                any = 1;
                const uint8_t *mp = take(r, 2, "a texel mask", err);
                if (!mp)
                    return -1;
                uint16_t m = le_get_u16(mp);
                if (!m)
                    return err_set(err,
                                   "light map data: surface %llu tile %llu bucket %d: empty "
                                   "texel mask",
                                   (unsigned long long)si, (unsigned long long)key.tile, b);
                for (int k = 0; k < TILE_TEXELS; k++) {
                    if (!(m & (1u << k)))
                        continue;
                    if (x0 + (uint64_t)(k % TILE) >= g.nx || y0 + (uint64_t)(k / TILE) >= g.ny)
                        return err_set(err,
                                       "light map data: surface %llu tile %llu: texel %d is "
                                       "outside the %llux%llu grid",
                                       (unsigned long long)si, (unsigned long long)key.tile, k,
                                       (unsigned long long)g.nx, (unsigned long long)g.ny);
                    const uint8_t *v = take(r, WIRE_TEXEL, "a texel", err);
                    if (!v)
                        return -1;
                    int top = (int8_t)v[0];
                    uint64_t acc[ACC_BINS];
                    for (int q = 0; q < ACC_BINS; q++)
                        acc[q] = le_get_u64(v + 1 + 8 * q);
                    /* The store is trusted by the renderer afterwards: only canonical, finite
                     * sums come in. */
                    if (top < ACC_TOP_MIN || top > ACC_TOP_MAX || acc[0] == 0 ||
                        !isfinite(acc_value(acc, top)))
                        return err_set(err,
                                       "light map data: surface %llu tile %llu texel %d "
                                       "bucket %d: the sum is not a finite canonical value "
                                       "(top bin %d, leading digits %llu)",
                                       (unsigned long long)si, (unsigned long long)key.tile, k, b,
                                       top, (unsigned long long)acc[0]);
                    if (texel_add(self, t, b, k, acc, top, err))
                        return -1;
                }
                if (lightmap_memory_bytes(self) > max_bytes)
                    return err_set(err,
                                   "light map data: the decoded map would hold more than "
                                   "%zu bytes",
                                   max_bytes);
            }
            if (!any)
                return err_set(err, "light map data: surface %llu tile %llu holds no bucket",
                               (unsigned long long)si, (unsigned long long)key.tile);
        }
    }
    if (r->left)
        return err_set(err, "light map data: %zu bytes after the last surface", r->left);
    return 0;
}

lightmap_t *lightmap_decode(const scene_t *scene, double density, spectral_grid_t grid,
                            const uint8_t *data, size_t len, size_t max_bytes, err_t *err)
{
    if (!data || len < WIRE_OUTER) {
        err_set(err, "light map data: %zu bytes, shorter than its %d-byte header", len, WIRE_OUTER);
        return NULL;
    }
    if (le_get_u32(data) != WIRE_MAGIC) {
        err_set(err, "light map data: bad magic (not a prismfarm light map)");
        return NULL;
    }
    if (le_get_u32(data + 4) != LIGHTMAP_WIRE_VERSION) {
        err_set(err, "light map data: format version %u, expected %u", le_get_u32(data + 4),
                LIGHTMAP_WIRE_VERSION);
        return NULL;
    }
    uint64_t raw_len = le_get_u64(data + 8);
    if (raw_len > max_bytes) {
        err_set(err, "light map data: inflates to %llu bytes, more than the %zu allowed",
                (unsigned long long)raw_len, max_bytes);
        return NULL;
    }
    if (raw_len < WIRE_HEAD) {
        err_set(err, "light map data: %llu bytes of payload, shorter than its %d-byte header",
                (unsigned long long)raw_len, WIRE_HEAD);
        return NULL;
    }
    lightmap_t *self = lightmap_new(scene, density, grid, err);
    if (!self)
        return NULL;
    uint8_t *raw = inflate_payload(data + WIRE_OUTER, len - WIRE_OUTER, (size_t)raw_len, err);
    reader_t r = {raw, (size_t)raw_len};
    if (!raw || decode_body(self, &r, max_bytes, err))
        lightmap_destroy(&self);
    free(raw);
    return self;
}
