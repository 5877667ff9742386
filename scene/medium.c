#include "medium.h"

#include "nanovdb.h"
#include "phase_hg.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

struct medium {
    medium_kind_t kind;
    medium_params_t p;
    double g;
    /* grid: dense samples (uniformgrid) or a NanoVDB grid */
    int n[3];
    double *density;
    nanovdb_grid_t *vdb, *temperature;
    double t_offset, t_scale;     /* temperature: (T - offset) scale kelvin */
    transform_t world_to_medium;  /* NanoVDB grids are looked up in medium space */
    vec3_t p0, extent;            /* the box in medium space: p0 + u extent, u in [0, 1]^3 */
    transform_t world_to_unit;    /* world to the box's unit coordinates u */
    int res;                      /* majorant cells per axis */
    float *majorant;              /* max density over each cell of the box's res^3 subdivision */
};

static double clamp_sigma(double s)
{
    if (!(s > 0.0))
        return 0.0;
    return s < MEDIUM_SIGMA_MAX ? s : MEDIUM_SIGMA_MAX;
}

static int check_params(const medium_params_t *p, err_t *err)
{
    if (!p->sigma_a || !p->sigma_s)
        return err_set(err, "a medium needs sigma_a and sigma_s");
    if (!(p->scale >= 0.0) || !isfinite(p->scale))
        return err_set(err, "a medium's \"scale\" must be finite and >= 0, got %g", p->scale);
    if (!isfinite(p->g) || p->g <= -1.0 || p->g >= 1.0)
        return err_set(err, "a medium's \"g\" must be in (-1, 1), got %g", p->g);
    if (!(p->Le_scale >= 0.0) || !isfinite(p->Le_scale))
        return err_set(err, "a medium's \"Lescale\" must be finite and >= 0, got %g", p->Le_scale);
    return 0;
}

static medium_t *alloc_medium(const medium_params_t *p, medium_kind_t kind, err_t *err)
{
    if (check_params(p, err))
        return NULL;
    medium_t *m = calloc(1, sizeof *m);
    if (!m) {
        err_set(err, "out of memory");
        return NULL;
    }
    m->kind = kind;
    m->p = *p;
    m->g = phase_hg_clamp(p->g);
    return m;
}

medium_t *medium_new_homogeneous(const medium_params_t *p, err_t *err)
{
    return alloc_medium(p, MEDIUM_HOMOGENEOUS, err);
}

static double sample_at(const medium_t *m, int x, int y, int z)
{
    if (x < 0 || y < 0 || z < 0 || x >= m->n[0] || y >= m->n[1] || z >= m->n[2])
        return 0.0;
    return m->density[((size_t)z * (size_t)m->n[1] + (size_t)y) * (size_t)m->n[0] + (size_t)x];
}

/* The samples whose trilinear weights can be non-zero somewhere in [a, b] (unit coordinates)
 * along an axis of n samples at (i + 1/2) / n. */
static void sample_range(double a, double b, int n, int *i0, int *i1)
{
    *i0 = (int)floor(a * n - 0.5);
    *i1 = (int)floor(b * n - 0.5) + 1;
    if (*i0 < 0)
        *i0 = 0;
    if (*i1 > n - 1)
        *i1 = n - 1;
}

/* A bound rounded up to float, so that it still holds. */
static float round_up(double mx)
{
    float f = (float)mx;
    if ((double)f < mx)
        f = nextafterf(f, INFINITY);
    return f;
}

static void build_majorants(medium_t *m)
{
    const int R = m->res;
    for (int z = 0; z < R; z++)
        for (int y = 0; y < R; y++)
            for (int x = 0; x < R; x++) {
                int lo[3], hi[3];
                const int c[3] = {x, y, z};
                for (int a = 0; a < 3; a++)
                    sample_range((double)c[a] / R, (double)(c[a] + 1) / R, m->n[a], &lo[a], &hi[a]);
                double mx = 0.0;
                for (int k = lo[2]; k <= hi[2]; k++)
                    for (int j = lo[1]; j <= hi[1]; j++)
                        for (int i = lo[0]; i <= hi[0]; i++)
                            mx = fmax(mx, sample_at(m, i, j, k));
                m->majorant[(z * R + y) * R + x] = round_up(mx);
            }
}

/* A NanoVDB grid's majorants (pbrt-v4 NanoVDBMedium: 64^3 cells over the bounds): the cell's
 * corners taken to index space (all eight, so a rotated map stays bounded), widened to the
 * voxels a trilinear lookup inside can reach, and the grid's maximum there. */
static void build_vdb_majorants(medium_t *m)
{
    const int R = m->res;
    const transform_t to_index = nanovdb_medium_to_index(m->vdb);
    for (int z = 0; z < R; z++)
        for (int y = 0; y < R; y++)
            for (int x = 0; x < R; x++) {
                double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
                for (int c = 0; c < 8; c++) {
                    vec3_t u = vec3_make((double)(x + (c & 1)) / R, (double)(y + (c >> 1 & 1)) / R,
                                         (double)(z + (c >> 2)) / R);
                    vec3_t pm = vec3_make(m->p0.x + u.x * m->extent.x, m->p0.y + u.y * m->extent.y,
                                          m->p0.z + u.z * m->extent.z);
                    vec3_t q = transform_point(&to_index, pm);
                    const double qa[3] = {q.x, q.y, q.z};
                    for (int a = 0; a < 3; a++) {
                        lo[a] = fmin(lo[a], qa[a]);
                        hi[a] = fmax(hi[a], qa[a]);
                    }
                }
                int64_t ilo[3], ihi[3];
                for (int a = 0; a < 3; a++) {
                    /* index coordinates are 32-bit: beyond, every voxel is the background */
                    ilo[a] = (int64_t)floor(fmax(lo[a], -3e9));
                    ihi[a] = (int64_t)floor(fmin(hi[a], 3e9)) + 1;
                }
                double mx = nanovdb_max_in(m->vdb, ilo, ihi);
                m->majorant[(z * R + y) * R + x] = round_up(mx > 0.0 ? mx : 0.0);
            }
}

static int alloc_majorants(medium_t *m, int res, err_t *err)
{
    m->res = res;
    if (!(m->majorant = malloc((size_t)res * res * res * sizeof *m->majorant)))
        return err_set(err, "out of memory");
    return 0;
}

medium_t *medium_new_grid(const medium_params_t *p, int nx, int ny, int nz, const double *density,
                          vec3_t p0, vec3_t p1, const transform_t *medium_to_world, err_t *err)
{
    if (nx < 1 || ny < 1 || nz < 1 || (int64_t)nx * ny * nz > (int64_t)1 << 31) {
        err_set(err, "a grid medium's nx, ny, nz must be >= 1 (at most 2^31 values), got %d x %d x %d", nx,
                ny, nz);
        return NULL;
    }
    size_t count = (size_t)nx * (size_t)ny * (size_t)nz;
    for (size_t i = 0; i < count; i++)
        if (!(density[i] >= 0.0) || !isfinite(density[i])) {
            err_set(err, "a grid medium's \"density\" values must be finite and >= 0; value %zu is %g", i,
                    density[i]);
            return NULL;
        }
    const double e[3] = {p1.x - p0.x, p1.y - p0.y, p1.z - p0.z};
    for (int a = 0; a < 3; a++)
        if (!(e[a] > 0.0) || !isfinite(e[a])) {
            err_set(err, "a grid medium's box p0 (%g %g %g) to p1 (%g %g %g) must have p1 > p0 on every axis",
                    p0.x, p0.y, p0.z, p1.x, p1.y, p1.z);
            return NULL;
        }
    if (medium_to_world->singular || !transform_is_finite(medium_to_world)) {
        err_set(err, "a grid medium's transform (the CTM at MakeNamedMedium) is not invertible");
        return NULL;
    }
    medium_t *m = alloc_medium(p, MEDIUM_GRID, err);
    if (!m)
        return NULL;
    m->density = malloc(count * sizeof *m->density);
    if (!m->density) {
        free(m);
        err_set(err, "out of memory");
        return NULL;
    }
    memcpy(m->density, density, count * sizeof *density);
    if (alloc_majorants(m, MEDIUM_MAJORANT_RES, err)) {
        medium_destroy(&m);
        return NULL;
    }
    m->n[0] = nx;
    m->n[1] = ny;
    m->n[2] = nz;
    m->p0 = p0;
    m->extent = vec3_make(e[0], e[1], e[2]);
    /* world -> medium -> unit box: u = (inverse(M) x - p0) / extent */
    transform_t to_unit = transform_compose(transform_scale(1.0 / e[0], 1.0 / e[1], 1.0 / e[2]),
                                            transform_translate(vec3_neg(p0)));
    m->world_to_unit = transform_compose(to_unit, transform_inverse(*medium_to_world));
    build_majorants(m);
    return m;
}

medium_t *medium_new_nanovdb(const medium_params_t *p, nanovdb_grid_t **density, nanovdb_grid_t **temperature,
                             double temperature_offset, double temperature_scale,
                             const transform_t *medium_to_world, err_t *err)
{
    nanovdb_grid_t *d = *density, *t = temperature ? *temperature : NULL;
    *density = NULL;
    if (temperature)
        *temperature = NULL;
    medium_t *m = NULL;
    if (!(nanovdb_min(d) >= 0.0))
        err_set(err, "the density grid holds a negative value (%g)", nanovdb_min(d));
    else if (!isfinite(temperature_offset) || !isfinite(temperature_scale))
        err_set(err, "\"temperatureoffset\" and \"temperaturescale\" must be finite");
    else if (medium_to_world->singular || !transform_is_finite(medium_to_world))
        err_set(err, "the medium's transform (the CTM at MakeNamedMedium) is not invertible");
    else
        m = alloc_medium(p, MEDIUM_GRID, err);
    if (!m) {
        nanovdb_destroy(&d);
        nanovdb_destroy(&t);
        return NULL;
    }
    m->vdb = d;
    m->temperature = t;
    m->t_offset = temperature_offset;
    m->t_scale = temperature_scale;
    /* pbrt-v4: the bounds are the density grid's, joined with the temperature grid's */
    vec3_t lo, hi;
    nanovdb_bounds(d, &lo, &hi);
    if (t) {
        vec3_t tlo, thi;
        nanovdb_bounds(t, &tlo, &thi);
        lo = vec3_make(fmin(lo.x, tlo.x), fmin(lo.y, tlo.y), fmin(lo.z, tlo.z));
        hi = vec3_make(fmax(hi.x, thi.x), fmax(hi.y, thi.y), fmax(hi.z, thi.z));
    }
    m->p0 = lo;
    m->extent = vec3_sub(hi, lo);
    m->world_to_medium = transform_inverse(*medium_to_world);
    transform_t to_unit = transform_compose(
        transform_scale(1.0 / m->extent.x, 1.0 / m->extent.y, 1.0 / m->extent.z), transform_translate(vec3_neg(lo)));
    m->world_to_unit = transform_compose(to_unit, m->world_to_medium);
    if (!transform_is_finite(&m->world_to_unit)) {
        err_set(err, "the grid's bounds are too small or too large to map");
        medium_destroy(&m);
        return NULL;
    }
    if (alloc_majorants(m, MEDIUM_VDB_MAJORANT_RES, err)) {
        medium_destroy(&m);
        return NULL;
    }
    build_vdb_majorants(m);
    return m;
}

void medium_destroy(medium_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    free((*self_p)->density);
    free((*self_p)->majorant);
    nanovdb_destroy(&(*self_p)->vdb);
    nanovdb_destroy(&(*self_p)->temperature);
    free(*self_p);
    *self_p = NULL;
}

medium_kind_t medium_kind(const medium_t *self) { return self->kind; }
double medium_g(const medium_t *self) { return self->g; }
int medium_is_emissive(const medium_t *self)
{
    return (self->p.Le || self->temperature) && self->p.Le_scale > 0.0;
}

int medium_Le_varies(const medium_t *self) { return self->temperature != NULL; }

/* pbrt-v4 NanoVDBMedium::Le: the temperature grid's value T at p, (T - offset) scale kelvin,
 * no emission at or below 100 K, else Lescale times the blackbody normalised to its peak. */
double medium_Le_at(const medium_t *self, vec3_t p, double lambda)
{
    if (!self->temperature || !(self->p.Le_scale > 0.0))
        return 0.0;
    double T = (nanovdb_sample(self->temperature, transform_point(&self->world_to_medium, p)) - self->t_offset) *
               self->t_scale;
    if (!(T > 100.0) || !isfinite(T))
        return 0.0;
    double le = self->p.Le_scale * spectrum_blackbody_eval(lambda, T);
    return le > 0.0 && isfinite(le) ? le : 0.0;
}

medium_coeffs_t medium_coeffs(const medium_t *self, double lambda)
{
    const medium_params_t *p = &self->p;
    medium_coeffs_t c;
    c.sigma_a = clamp_sigma(p->scale * spectrum_eval(p->sigma_a, lambda));
    c.sigma_s = clamp_sigma(p->scale * spectrum_eval(p->sigma_s, lambda));
    double le = medium_is_emissive(self) && p->Le ? p->Le_scale * spectrum_eval(p->Le, lambda) : 0.0;
    c.Le = le > 0.0 && isfinite(le) ? le : 0.0;
    return c;
}

double medium_density(const medium_t *self, vec3_t p)
{
    if (self->kind == MEDIUM_HOMOGENEOUS)
        return 1.0;
    vec3_t u = transform_point(&self->world_to_unit, p);
    if (!(u.x >= 0.0 && u.x <= 1.0 && u.y >= 0.0 && u.y <= 1.0 && u.z >= 0.0 && u.z <= 1.0))
        return 0.0;
    if (self->vdb) {
        double v = nanovdb_sample(self->vdb, transform_point(&self->world_to_medium, p));
        return v > 0.0 ? v : 0.0;
    }
    double ps[3] = {u.x * self->n[0] - 0.5, u.y * self->n[1] - 0.5, u.z * self->n[2] - 0.5};
    int i[3];
    double f[3];
    for (int a = 0; a < 3; a++) {
        double fl = floor(ps[a]);
        i[a] = (int)fl;
        f[a] = ps[a] - fl;
    }
    double d = 0.0;
    for (int k = 0; k < 2; k++)
        for (int j = 0; j < 2; j++)
            for (int h = 0; h < 2; h++) {
                double w = (h ? f[0] : 1.0 - f[0]) * (j ? f[1] : 1.0 - f[1]) * (k ? f[2] : 1.0 - f[2]);
                if (w > 0.0)
                    d += w * sample_at(self, i[0] + h, i[1] + j, i[2] + k);
            }
    return d > 0.0 ? d : 0.0;
}

void medium_segments_begin(const medium_t *self, vec3_t org, vec3_t dir, double tmax,
                           medium_segments_t *it)
{
    memset(it, 0, sizeof *it);
    it->m = self;
    it->t = 0.0;
    it->t_end = tmax;
    if (!(tmax > 0.0)) {
        it->done = 1;
        return;
    }
    if (self->kind == MEDIUM_HOMOGENEOUS)
        return;
    const int R = self->res;
    /* The ray in the box's unit coordinates (an affine map keeps the parameter t). */
    vec3_t o = transform_point(&self->world_to_unit, org);
    vec3_t d = transform_vector(&self->world_to_unit, dir);
    const double oa[3] = {o.x, o.y, o.z}, da[3] = {d.x, d.y, d.z};
    double t0 = 0.0, t1 = tmax;
    for (int a = 0; a < 3; a++) {
        if (da[a] == 0.0) {
            if (!(oa[a] >= 0.0 && oa[a] <= 1.0))
                t1 = -1.0;
            continue;
        }
        double ta = (0.0 - oa[a]) / da[a], tb = (1.0 - oa[a]) / da[a];
        if (ta > tb) {
            double s = ta;
            ta = tb;
            tb = s;
        }
        t0 = ta > t0 ? ta : t0;
        t1 = tb < t1 ? tb : t1;
    }
    if (!(t0 < t1)) {
        it->done = 1;
        return;
    }
    it->t = t0;
    it->t_end = t1;
    for (int a = 0; a < 3; a++) {
        double ua = oa[a] + t0 * da[a];
        int v = (int)floor(ua * R);
        it->voxel[a] = v < 0 ? 0 : v > R - 1 ? R - 1 : v;
        if (da[a] > 0.0) {
            it->step[a] = 1;
            it->t_next[a] = ((double)(it->voxel[a] + 1) / R - oa[a]) / da[a];
            it->t_delta[a] = 1.0 / (R * da[a]);
        } else if (da[a] < 0.0) {
            it->step[a] = -1;
            it->t_next[a] = ((double)it->voxel[a] / R - oa[a]) / da[a];
            it->t_delta[a] = -1.0 / (R * da[a]);
        } else {
            it->step[a] = 0;
            it->t_next[a] = INFINITY;
            it->t_delta[a] = INFINITY;
        }
    }
}

int medium_segments_next(medium_segments_t *it, double *t0, double *t1, double *dmax)
{
    if (it->done)
        return 0;
    if (it->m->kind == MEDIUM_HOMOGENEOUS) {
        *t0 = 0.0;
        *t1 = it->t_end;
        *dmax = 1.0;
        it->done = 1;
        return 1;
    }
    int a = 0;
    if (it->t_next[1] < it->t_next[a])
        a = 1;
    if (it->t_next[2] < it->t_next[a])
        a = 2;
    *t0 = it->t;
    *t1 = it->t_next[a] < it->t_end ? it->t_next[a] : it->t_end;
    if (*t1 < *t0)
        *t1 = *t0;
    const int R = it->m->res;
    *dmax = it->m->majorant[(it->voxel[2] * R + it->voxel[1]) * R + it->voxel[0]];
    it->t = *t1;
    if (!(it->t < it->t_end)) {
        it->done = 1;
        return 1;
    }
    it->voxel[a] += it->step[a];
    if (it->voxel[a] < 0 || it->voxel[a] >= R)
        it->done = 1;
    it->t_next[a] += it->t_delta[a];
    return 1;
}
