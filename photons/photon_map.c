#include "photon_map.h"

#include "le_bytes.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* 24 bytes. The kd-tree is implicit: the node of a range [lo, hi) is its middle element
 * lo + (hi - lo) / 2, its children the ranges on either side; the split axis of a node is kept
 * in the top two bits of `bucket`. */
typedef struct photon {
    float p[3];
    float power;
    uint16_t bucket; /* bits 0-13 the bucket, 14-15 the split axis */
    uint16_t lambda; /* (lambda - lambda_min) / (lambda_max - lambda_min) * 65535 */
    uint16_t dir;    /* octahedral, 8 bits per coordinate */
    uint16_t normal;
} photon_t;

#define BUCKET_MASK 0x3FFFu
#define AXIS_SHIFT 14
/* A white photon's bucket field (photon_map_deposit_white): no grid has this many buckets
 * (photon_map_new), and its lambda field holds the spectrum's index instead. */
#define WHITE_BUCKET BUCKET_MASK

/* Every octahedral code's unit vector: the gather's normal test decodes a normal per photon
 * in range, which took an eighth of a caustic render's time; a table lookup gives exactly
 * oct_decode's doubles. */
#define OCT_CODES 65536

struct photon_map {
    spectral_grid_t grid;
    photon_t *ph;
    size_t n, cap;
    uint64_t emitted;
    int built;
    vec3_t *normals; /* [OCT_CODES], made by photon_map_build */
    /* White photons' spectra (photon_map_set_spectra): nspectra rows of grid.n. */
    int nspectra;
    double *spectra;
};

/* Octahedral encoding of a unit vector (Meyer et al. 2010, "On floating-point normal
 * vectors"): project onto |x| + |y| + |z| = 1, fold the lower half over the diagonals. */
static uint16_t oct_encode(vec3_t v)
{
    double s = fabs(v.x) + fabs(v.y) + fabs(v.z);
    if (!(s > 0.0))
        return 0x8080;
    double x = v.x / s, y = v.y / s;
    if (v.z < 0.0) {
        double ox = (1.0 - fabs(y)) * (x >= 0.0 ? 1.0 : -1.0);
        double oy = (1.0 - fabs(x)) * (y >= 0.0 ? 1.0 : -1.0);
        x = ox;
        y = oy;
    }
    long qx = lround((x * 0.5 + 0.5) * 255.0), qy = lround((y * 0.5 + 0.5) * 255.0);
    qx = qx < 0 ? 0 : qx > 255 ? 255 : qx;
    qy = qy < 0 ? 0 : qy > 255 ? 255 : qy;
    return (uint16_t)((qx << 8) | qy);
}

static vec3_t oct_decode(uint16_t e)
{
    double x = (e >> 8) / 255.0 * 2.0 - 1.0, y = (e & 0xFF) / 255.0 * 2.0 - 1.0;
    double z = 1.0 - fabs(x) - fabs(y);
    if (z < 0.0) {
        double ox = (1.0 - fabs(y)) * (x >= 0.0 ? 1.0 : -1.0);
        double oy = (1.0 - fabs(x)) * (y >= 0.0 ? 1.0 : -1.0);
        x = ox;
        y = oy;
    }
    return vec3_normalize(vec3_make(x, y, z));
}

photon_map_t *photon_map_new(spectral_grid_t grid, err_t *err)
{
    if (spectral_grid_validate(grid, err))
        return NULL;
    if (grid.n > (int)WHITE_BUCKET) {
        err_set(err, "a photon map holds at most %u buckets, the grid has %d", WHITE_BUCKET,
                grid.n);
        return NULL;
    }
    photon_map_t *self = calloc(1, sizeof *self);
    if (!self) {
        err_set(err, "out of memory");
        return NULL;
    }
    self->grid = grid;
    return self;
}

void photon_map_destroy(photon_map_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    free((*self_p)->ph);
    free((*self_p)->normals);
    free((*self_p)->spectra);
    free(*self_p);
    *self_p = NULL;
}

static int reserve(photon_map_t *self, size_t more, err_t *err)
{
    if (self->n + more <= self->cap)
        return 0;
    size_t cap = self->cap ? self->cap : 1024;
    while (cap < self->n + more) {
        if (cap > SIZE_MAX / 2 / sizeof(photon_t))
            return err_set(err, "photon map too large (%zu photons)", self->n + more);
        cap *= 2;
    }
    photon_t *p = realloc(self->ph, cap * sizeof *p);
    if (!p)
        return err_set(err, "out of memory for %zu photons (%zu MB)", cap, cap * sizeof *p >> 20);
    self->ph = p;
    self->cap = cap;
    return 0;
}

/* The checks every deposit makes before it is stored: the map still open, a finite point and
 * a power a float holds. */
static int deposit_check(const photon_map_t *self, vec3_t p, double power, err_t *err)
{
    if (self->built)
        return err_set(err, "photon map: deposit after the kd-tree was built");
    if (!(power >= 0.0 && power <= FLT_MAX) || !isfinite(p.x) || !isfinite(p.y) || !isfinite(p.z))
        return err_set(err, "photon map: non-finite deposit (power %g)", power);
    return 0;
}

/* Stores one checked photon; bucket and lambda as photon_t keeps them (a white photon:
 * WHITE_BUCKET and its spectrum's index). */
static int append(photon_map_t *self, vec3_t p, vec3_t dir, vec3_t normal, double power,
                  uint16_t bucket, uint16_t lambda, err_t *err)
{
    if (reserve(self, 1, err))
        return -1;
    photon_t *ph = &self->ph[self->n++];
    ph->p[0] = (float)p.x;
    ph->p[1] = (float)p.y;
    ph->p[2] = (float)p.z;
    ph->power = (float)power;
    ph->bucket = bucket;
    ph->lambda = lambda;
    ph->dir = oct_encode(dir);
    ph->normal = oct_encode(normal);
    return 0;
}

int photon_map_deposit(photon_map_t *self, vec3_t p, vec3_t dir, vec3_t normal, double lambda,
                       double power, err_t *err)
{
    if (deposit_check(self, p, power, err))
        return -1;
    int b = spectral_grid_index(self->grid, lambda);
    if (b < 0)
        return 0;
    double t = (lambda - self->grid.lambda_min) / (self->grid.lambda_max - self->grid.lambda_min);
    return append(self, p, dir, normal, power, (uint16_t)b,
                  (uint16_t)lround(fmin(1.0, fmax(0.0, t)) * 65535.0), err);
}

int photon_map_deposit_white(photon_map_t *self, vec3_t p, vec3_t dir, vec3_t normal, int spectrum,
                             double power, err_t *err)
{
    if (deposit_check(self, p, power, err))
        return -1;
    if (spectrum < 0 || spectrum >= self->nspectra)
        return err_set(err, "photon map: white photon of spectrum %d, the map has %d", spectrum,
                       self->nspectra);
    return append(self, p, dir, normal, power, WHITE_BUCKET, (uint16_t)spectrum, err);
}

int photon_map_set_spectra(photon_map_t *self, int n, const double *shape, err_t *err)
{
    if (n < 0 || n > PHOTON_MAP_MAX_SPECTRA)
        return err_set(err, "photon map: %d white spectra, at most %d", n, PHOTON_MAP_MAX_SPECTRA);
    size_t len = (size_t)n * (size_t)self->grid.n;
    double *c = len ? malloc(len * sizeof *c) : NULL;
    if (len && !c)
        return err_set(err, "out of memory");
    for (size_t i = 0; i < len; i++)
        if (!(shape[i] >= 0.0 && shape[i] <= DBL_MAX)) {
            free(c);
            return err_set(err, "photon map: a white spectrum's bucket is %g", shape[i]);
        }
    if (len)
        memcpy(c, shape, len * sizeof *c);
    free(self->spectra);
    self->spectra = c;
    self->nspectra = n;
    return 0;
}

const double *photon_map_spectrum(const photon_map_t *self, int spectrum)
{
    return spectrum >= 0 && spectrum < self->nspectra
               ? self->spectra + (size_t)spectrum * (size_t)self->grid.n
               : NULL;
}

void photon_map_add_emitted(photon_map_t *self, uint64_t n)
{
    self->emitted += n;
}
uint64_t photon_map_emitted(const photon_map_t *self)
{
    return self->emitted;
}
size_t photon_map_count(const photon_map_t *self)
{
    return self->n;
}
int photon_map_built(const photon_map_t *self)
{
    return self->built;
}
spectral_grid_t photon_map_grid(const photon_map_t *self)
{
    return self->grid;
}
size_t photon_map_photon_bytes(void)
{
    return sizeof(photon_t);
}

size_t photon_map_memory_bytes(const photon_map_t *self)
{
    return sizeof *self + self->cap * sizeof(photon_t);
}

int photon_map_append(photon_map_t *dst, const photon_map_t *src, err_t *err)
{
    if (dst->built || src->built)
        return err_set(err, "photon map: only unbuilt maps merge");
    if (dst->grid.n != src->grid.n || dst->grid.lambda_min != src->grid.lambda_min ||
        dst->grid.lambda_max != src->grid.lambda_max)
        return err_set(err, "photon map: merging maps of different wavelength grids");
    if (reserve(dst, src->n, err))
        return -1;
    for (size_t i = 0; i < src->n; i++)
        if ((src->ph[i].bucket & BUCKET_MASK) == WHITE_BUCKET && src->ph[i].lambda >= dst->nspectra)
            return err_set(err,
                           "photon map: merging a white photon of spectrum %u into a map of %d",
                           src->ph[i].lambda, dst->nspectra);
    if (src->n)
        memcpy(dst->ph + dst->n, src->ph, src->n * sizeof *src->ph);
    dst->n += src->n;
    dst->emitted += src->emitted;
    return 0;
}

photon_info_t photon_map_photon(const photon_map_t *self, size_t i)
{
    photon_info_t r = {0};
    if (i >= self->n)
        return r;
    const photon_t *ph = &self->ph[i];
    r.p = vec3_make(ph->p[0], ph->p[1], ph->p[2]);
    r.dir = oct_decode(ph->dir);
    r.normal = oct_decode(ph->normal);
    r.power = ph->power;
    if ((ph->bucket & BUCKET_MASK) == WHITE_BUCKET) {
        r.bucket = PHOTON_MAP_WHITE(ph->lambda);
        r.lambda = 0.0;
        return r;
    }
    r.lambda = self->grid.lambda_min +
               ph->lambda / 65535.0 * (self->grid.lambda_max - self->grid.lambda_min);
    r.bucket = ph->bucket & BUCKET_MASK;
    return r;
}

double photon_map_power_sum(const photon_map_t *self)
{
    double s = 0.0;
    for (size_t i = 0; i < self->n; i++) {
        const photon_t *ph = &self->ph[i];
        double w = 1.0;
        if ((ph->bucket & BUCKET_MASK) == WHITE_BUCKET) {
            const double *c = photon_map_spectrum(self, ph->lambda);
            w = 0.0;
            for (int b = 0; c && b < self->grid.n; b++)
                w += c[b];
        }
        s += ph->power * w;
    }
    return s;
}

static void swap(photon_t *a, photon_t *b)
{
    photon_t t = *a;
    *a = *b;
    *b = t;
}

/* Reorders ph[lo, hi) so that ph[k] holds the element that sorting by coordinate `axis`
 * would put there, everything before it <= and everything after it >= (Hoare's selection
 * with a three-way partition, so runs of equal coordinates cost O(n), not O(n^2)). */
static void select_kth(photon_t *ph, size_t lo, size_t hi, size_t k, int axis)
{
    while (hi - lo > 1) {
        float a = ph[lo].p[axis], b = ph[lo + (hi - lo) / 2].p[axis], c = ph[hi - 1].p[axis];
        float pivot = a < b ? (b < c ? b : (a < c ? c : a)) : (a < c ? a : (b < c ? c : b));
        size_t lt = lo, i = lo, gt = hi;
        while (i < gt) {
            float v = ph[i].p[axis];
            if (v < pivot)
                swap(&ph[lt++], &ph[i++]);
            else if (v > pivot)
                swap(&ph[i], &ph[--gt]);
            else
                i++;
        }
        if (k < lt)
            hi = lt;
        else if (k >= gt)
            lo = gt;
        else
            return;
    }
}

static void build_range(photon_t *ph, size_t lo, size_t hi)
{
    while (hi - lo > 0) {
        float mn[3] = {INFINITY, INFINITY, INFINITY}, mx[3] = {-INFINITY, -INFINITY, -INFINITY};
        for (size_t i = lo; i < hi; i++)
            for (int a = 0; a < 3; a++) {
                mn[a] = fminf(mn[a], ph[i].p[a]);
                mx[a] = fmaxf(mx[a], ph[i].p[a]);
            }
        int axis = 0;
        for (int a = 1; a < 3; a++)
            if (mx[a] - mn[a] > mx[axis] - mn[axis])
                axis = a;
        size_t mid = lo + (hi - lo) / 2;
        select_kth(ph, lo, hi, mid, axis);
        ph[mid].bucket = (uint16_t)((ph[mid].bucket & BUCKET_MASK) | (unsigned)axis << AXIS_SHIFT);
        /* Recurse into the smaller side, loop on the larger: stack depth O(log n). */
        if (mid - lo < hi - (mid + 1)) {
            build_range(ph, lo, mid);
            lo = mid + 1;
        } else {
            build_range(ph, mid + 1, hi);
            hi = mid;
        }
    }
}

int photon_map_build(photon_map_t *self, err_t *err)
{
    if (self->built)
        return err_set(err, "photon map: built twice");
    for (size_t i = 0; i < self->n; i++)
        if ((self->ph[i].bucket & BUCKET_MASK) == WHITE_BUCKET &&
            self->ph[i].lambda >= self->nspectra)
            return err_set(err, "photon map: a white photon of spectrum %u, the map knows %d",
                           self->ph[i].lambda, self->nspectra);
    self->normals = malloc(OCT_CODES * sizeof *self->normals);
    if (!self->normals)
        return err_set(err, "photon map: out of memory for its normal table");
    for (uint32_t e = 0; e < OCT_CODES; e++)
        self->normals[e] = oct_decode((uint16_t)e);
    if (self->n)
        build_range(self->ph, 0, self->n);
    /* The map is read-only from here on: give back the growth slack. */
    if (self->n && self->n < self->cap) {
        photon_t *p = realloc(self->ph, self->n * sizeof *p);
        if (p) {
            self->ph = p;
            self->cap = self->n;
        }
    }
    self->built = 1;
    return 0;
}

/* What a query collects. Photons pass the normal test when their normal is within 60 degrees
 * of the query's. */
typedef struct query {
    const photon_t *ph;
    const vec3_t *normals; /* the map's decoded octahedral codes */
    const double *spectra; /* white photons' rows of nb */
    int nb;
    double q[3];
    vec3_t n;
    int two_sided; /* the normal test takes photons on either side of n */
    double r2; /* current search radius squared */
    /* fixed radius: E, or the visitor when there is one */
    double *E;
    photon_map_visit_fn fn;
    void *user;
    int used;
    /* k nearest: a max-heap on distance */
    int k, nheap;
    double heap_d2[PHOTON_MAP_MAX_K];
    uint32_t heap_i[PHOTON_MAP_MAX_K];
} query_t;

#define NORMAL_COS_MIN 0.5

static int normal_ok(const query_t *qr, const photon_t *ph)
{
    double c = vec3_dot(qr->normals[ph->normal], qr->n);
    return (qr->two_sided ? fabs(c) : c) > NORMAL_COS_MIN;
}

/* A photon found by a fixed-radius query: into E, or handed to the visitor. */
static inline void take(query_t *qr, const photon_t *ph)
{
    const unsigned b = ph->bucket & BUCKET_MASK;
    if (qr->fn) {
        qr->fn(qr->user, qr->normals[ph->dir],
               b == WHITE_BUCKET ? PHOTON_MAP_WHITE(ph->lambda) : (int)b, ph->power);
    } else if (b == WHITE_BUCKET) {
        const double *c = qr->spectra + (size_t)ph->lambda * (size_t)qr->nb;
        for (int k = 0; k < qr->nb; k++)
            qr->E[k] += ph->power * c[k];
    } else {
        qr->E[b] += ph->power;
    }
    qr->used++;
}

static void heap_push(query_t *qr, double d2, uint32_t idx)
{
    if (qr->nheap < qr->k) {
        int i = qr->nheap++;
        while (i > 0) {
            int parent = (i - 1) / 2;
            if (qr->heap_d2[parent] >= d2)
                break;
            qr->heap_d2[i] = qr->heap_d2[parent];
            qr->heap_i[i] = qr->heap_i[parent];
            i = parent;
        }
        qr->heap_d2[i] = d2;
        qr->heap_i[i] = idx;
        if (qr->nheap == qr->k)
            qr->r2 = qr->heap_d2[0];
        return;
    }
    /* Full: replace the farthest and sift down. */
    int i = 0, n = qr->nheap;
    for (;;) {
        int l = 2 * i + 1, r = l + 1, m = i;
        double dm = d2;
        if (l < n && qr->heap_d2[l] > dm) {
            m = l;
            dm = qr->heap_d2[l];
        }
        if (r < n && qr->heap_d2[r] > dm)
            m = r;
        if (m == i)
            break;
        qr->heap_d2[i] = qr->heap_d2[m];
        qr->heap_i[i] = qr->heap_i[m];
        i = m;
    }
    qr->heap_d2[i] = d2;
    qr->heap_i[i] = idx;
    qr->r2 = qr->heap_d2[0];
}

/* One photon of the tree against the query: in range and facing the query's side. */
static inline void consider(query_t *qr, size_t i)
{
    const photon_t *ph = &qr->ph[i];
    double dx = qr->q[0] - ph->p[0], dy = qr->q[1] - ph->p[1], dz = qr->q[2] - ph->p[2];
    double d2 = dx * dx + dy * dy + dz * dz;
    if (d2 <= qr->r2 && normal_ok(qr, ph)) {
        if (qr->k > 0) {
            if (qr->nheap < qr->k || d2 < qr->heap_d2[0])
                heap_push(qr, d2, (uint32_t)i);
        } else {
            take(qr, ph);
        }
    }
}

/* Ranges this small are scanned in order rather than descended: the recursion's calls cost
 * more than testing the few photons the split would have skipped. */
#define LEAF_SCAN 16

static void visit(query_t *qr, size_t lo, size_t hi)
{
    if (hi - lo <= LEAF_SCAN) {
        for (size_t i = lo; i < hi; i++)
            consider(qr, i);
        return;
    }
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        const photon_t *ph = &qr->ph[mid];
        int axis = ph->bucket >> AXIS_SHIFT;
        double d = qr->q[axis] - ph->p[axis];
        double dx = qr->q[0] - ph->p[0], dy = qr->q[1] - ph->p[1], dz = qr->q[2] - ph->p[2];
        double d2 = dx * dx + dy * dy + dz * dz;
        /* Visit the near side first, so that a k-nearest search shrinks its radius early. */
        size_t nlo = d < 0.0 ? lo : mid + 1, nhi = d < 0.0 ? mid : hi;
        size_t flo = d < 0.0 ? mid + 1 : lo, fhi = d < 0.0 ? hi : mid;
        visit(qr, nlo, nhi);
        if (d2 <= qr->r2 && normal_ok(qr, ph)) {
            if (qr->k > 0) {
                if (qr->nheap < qr->k || d2 < qr->heap_d2[0])
                    heap_push(qr, d2, (uint32_t)mid);
            } else {
                take(qr, ph);
            }
        }
        if (!(d * d <= qr->r2))
            return;
        lo = flo;
        hi = fhi;
    }
}

/* The search both estimates share: every photon within radius (or the k nearest) that passes
 * the normal test goes to E or to fn. Returns the photons used and *r2_out the squared radius
 * of the disk they were gathered from (0 photons: *r2_out undefined). */
static int search(const photon_map_t *self, vec3_t p, vec3_t n, int two_sided, double radius,
                  int k, double *E, photon_map_visit_fn fn, void *user, double *r2_out)
{
    if (!self->built || self->n == 0 || self->emitted == 0 || !(radius > 0.0) || !isfinite(radius))
        return 0;
    if (k > PHOTON_MAP_MAX_K)
        k = PHOTON_MAP_MAX_K;
    if (self->n > UINT32_MAX && k > 0)
        k = 0; /* heap indices are 32-bit; such maps fall back to the fixed radius */
    /* 12 kB on the stack: the k-nearest heap at its largest. */
    query_t query, *qr = &query;
    qr->ph = self->ph;
    qr->normals = self->normals;
    qr->spectra = self->spectra;
    qr->nb = self->grid.n;
    qr->q[0] = p.x;
    qr->q[1] = p.y;
    qr->q[2] = p.z;
    qr->n = n;
    qr->two_sided = two_sided;
    qr->r2 = radius * radius;
    qr->E = E;
    qr->fn = fn;
    qr->user = user;
    qr->used = 0;
    qr->k = k > 0 ? k : 0;
    qr->nheap = 0;
    visit(qr, 0, self->n);
    double r2 = radius * radius;
    int used = qr->used;
    if (k > 0) {
        /* Heap order: a function of the deposits and the query alone. */
        for (int i = 0; i < qr->nheap; i++)
            take(qr, &self->ph[qr->heap_i[i]]);
        used = qr->nheap;
        if (qr->nheap == k)
            r2 = qr->heap_d2[0];
    }
    /* A k-th neighbour at distance 0 (photons piled on one point) would divide by zero: the
     * radius is kept above a millionth of the search radius. */
    *r2_out = fmax(r2, 1e-12 * radius * radius);
    return used;
}

int photon_map_irradiance(const photon_map_t *self, vec3_t p, vec3_t n, double radius, int k,
                          double *E)
{
    const int nb = self->grid.n;
    for (int b = 0; b < nb; b++)
        E[b] = 0.0;
    double r2;
    int used = search(self, p, n, 0, radius, k, E, NULL, NULL, &r2);
    if (used == 0)
        return 0;
    double scale = 1.0 / ((double)self->emitted * spectral_grid_width(self->grid) * PF_PI * r2);
    for (int b = 0; b < nb; b++)
        E[b] *= scale;
    return used;
}

int photon_map_gather(const photon_map_t *self, vec3_t p, vec3_t n, double radius, int k,
                      photon_map_visit_fn fn, void *user, double *scale)
{
    *scale = 0.0;
    double r2;
    int used = search(self, p, n, 1, radius, k, NULL, fn, user, &r2);
    if (used > 0)
        *scale = 1.0 / ((double)self->emitted * spectral_grid_width(self->grid) * PF_PI * r2);
    return used;
}

/* The wire form (photon_map_encode): a 32-byte header -- magic "PFPM", format version,
 * bucket count, photon count, emitted count -- then 24 bytes per photon, every field little
 * endian: x, y, z and power as IEEE float32, then bucket, lambda, dir and normal as uint16.
 * It is the in-memory record without the kd-tree's axis bits, so encoding a map costs a copy
 * and a decoded map appends and builds like a locally traced one. */
#define WIRE_MAGIC 0x4D504650u /* "PFPM" read as a little-endian uint32 */
/* 2: the same record, but a store of this version also holds the photons of glossy
 * receivers (render/photon.c), which the camera pass no longer finds itself: a version-1
 * store (a journal's photons.store, an older worker's batch) would lose those caustics, so
 * it is refused rather than used. */
/* 3: the same record, but a bucket field of 0x3FFF is a white photon whose lambda field is its
 * spectrum (photon_map_deposit_white); a version-2 store has none and reads the same. */
#define WIRE_VERSION 3u
#define WIRE_HEADER 32
#define WIRE_RECORD 24

int photon_map_encode(const photon_map_t *self, uint8_t **out, size_t *out_len, err_t *err)
{
    *out = NULL;
    *out_len = 0;
    if (self->built)
        return err_set(err, "photon map: only an unbuilt map (deposit order) can be encoded");
    if (self->n > (SIZE_MAX - WIRE_HEADER) / WIRE_RECORD)
        return err_set(err, "photon map too large to encode (%zu photons)", self->n);
    size_t len = WIRE_HEADER + self->n * WIRE_RECORD;
    uint8_t *b = malloc(len);
    if (!b)
        return err_set(err, "out of memory encoding %zu photons (%zu MB)", self->n, len >> 20);
    le_put_u32(b, WIRE_MAGIC);
    le_put_u32(b + 4, WIRE_VERSION);
    le_put_u32(b + 8, (uint32_t)self->grid.n);
    le_put_u32(b + 12, 0);
    le_put_u64(b + 16, (uint64_t)self->n);
    le_put_u64(b + 24, self->emitted);
    for (size_t i = 0; i < self->n; i++) {
        const photon_t *ph = &self->ph[i];
        uint8_t *r = b + WIRE_HEADER + i * WIRE_RECORD;
        for (int k = 0; k < 3; k++)
            le_put_f32(r + 4 * k, ph->p[k]);
        le_put_f32(r + 12, ph->power);
        le_put_u16(r + 16, (uint16_t)(ph->bucket & BUCKET_MASK));
        le_put_u16(r + 18, ph->lambda);
        le_put_u16(r + 20, ph->dir);
        le_put_u16(r + 22, ph->normal);
    }
    *out = b;
    *out_len = len;
    return 0;
}

photon_map_t *photon_map_decode(spectral_grid_t grid, const uint8_t *data, size_t len,
                                err_t *err)
{
    if (len < WIRE_HEADER) {
        err_set(err, "photon map data: %zu bytes, shorter than its %d-byte header", len, WIRE_HEADER);
        return NULL;
    }
    if (le_get_u32(data) != WIRE_MAGIC) {
        err_set(err, "photon map data: bad magic (not a prismfarm photon map)");
        return NULL;
    }
    if (le_get_u32(data + 4) != WIRE_VERSION && le_get_u32(data + 4) != 2u) {
        err_set(err, "photon map data: format version %u, expected %u", le_get_u32(data + 4),
                WIRE_VERSION);
        return NULL;
    }
    if (le_get_u32(data + 8) != (uint32_t)grid.n || le_get_u32(data + 12) != 0) {
        err_set(err, "photon map data: %u buckets, the job's film has %d", le_get_u32(data + 8),
                grid.n);
        return NULL;
    }
    uint64_t n = le_get_u64(data + 16);
    if (n > (len - WIRE_HEADER) / WIRE_RECORD || (len - WIRE_HEADER) != n * WIRE_RECORD) {
        err_set(err, "photon map data: %zu bytes do not hold the %llu photons the header names",
                len, (unsigned long long)n);
        return NULL;
    }
    photon_map_t *self = photon_map_new(grid, err);
    if (!self)
        return NULL;
    if (reserve(self, (size_t)n, err)) {
        photon_map_destroy(&self);
        return NULL;
    }
    for (uint64_t i = 0; i < n; i++) {
        const uint8_t *r = data + WIRE_HEADER + i * WIRE_RECORD;
        photon_t *ph = &self->ph[i];
        for (int k = 0; k < 3; k++)
            ph->p[k] = le_get_f32(r + 4 * k);
        ph->power = le_get_f32(r + 12);
        ph->bucket = le_get_u16(r + 16);
        ph->lambda = le_get_u16(r + 18);
        ph->dir = le_get_u16(r + 20);
        ph->normal = le_get_u16(r + 22);
        /* The map is trusted by the renderer afterwards: no NaN, Inf, negative power or bucket
         * outside the film may come in from the network. */
        if (!isfinite(ph->p[0]) || !isfinite(ph->p[1]) || !isfinite(ph->p[2]) ||
            !(ph->power >= 0.0f && ph->power <= FLT_MAX) ||
            (ph->bucket >= (unsigned)grid.n && ph->bucket != WHITE_BUCKET)) {
            err_set(err, "photon map data: photon %llu is invalid (position, power or bucket)",
                    (unsigned long long)i);
            photon_map_destroy(&self);
            return NULL;
        }
    }
    self->n = (size_t)n;
    self->emitted = le_get_u64(data + 24);
    return self;
}
