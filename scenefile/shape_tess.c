#include "shape_tess.h"

#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

static const double PI = 3.14159265358979323846;

/* An (nu+1) x (nv+1) grid of vertices, vertex (i, j) at j * (nu + 1) + i, with normals and
 * uv, and its 2 nu nv triangles (i, j) (i+1, j) (i+1, j+1) and (i, j) (i+1, j+1) (i, j+1). */
static int grid_alloc(size_t nu, size_t nv, mesh_data_t *m, err_t *err)
{
    size_t verts = (nu + 1) * (nv + 1), tris = 2 * nu * nv;
    m->nvertices = verts;
    m->ntriangles = tris;
    m->P = malloc(3 * verts * sizeof *m->P);
    m->N = malloc(3 * verts * sizeof *m->N);
    m->uv = malloc(2 * verts * sizeof *m->uv);
    m->indices = malloc(3 * tris * sizeof *m->indices);
    if (!m->P || !m->N || !m->uv || !m->indices) {
        mesh_data_free(m);
        return err_set(err, "out of memory for a mesh of %zu triangles", tris);
    }
    return 0;
}

/* The triangles of a grid whose first vertex is base, into idx (6 nu nv entries); flip
 * reverses each triangle's winding. */
static void grid_triangles(uint32_t base, size_t nu, size_t nv, bool flip, uint32_t *idx)
{
    size_t t = 0;
    for (size_t j = 0; j < nv; j++)
        for (size_t i = 0; i < nu; i++) {
            uint32_t a = base + (uint32_t)(j * (nu + 1) + i), b = a + 1,
                     c = a + 1 + (uint32_t)(nu + 1), d = a + (uint32_t)(nu + 1);
            uint32_t tri[6] = {a, b, c, a, c, d};
            if (flip) {
                uint32_t s = tri[1];
                tri[1] = tri[2], tri[2] = s;
                s = tri[4];
                tri[4] = tri[5], tri[5] = s;
            }
            memcpy(&idx[6 * t++], tri, sizeof tri);
        }
}

static size_t segments(double angle_rad)
{
    double n = ceil(angle_rad / (2 * PI) * SHAPE_TESS_TURN_SEGMENTS);
    return n < 4 ? 4 : (size_t)n;
}

int shape_tess_cylinder(double r, double zmin, double zmax, double phimax_deg, mesh_data_t *out,
                        err_t *err)
{
    memset(out, 0, sizeof *out);
    double z0 = fmin(zmin, zmax), z1 = fmax(zmin, zmax);
    double phimax = fmin(fmax(phimax_deg, 0.0), 360.0) * PI / 180.0;
    size_t nu = segments(phimax);
    if (grid_alloc(nu, 1, out, err) != 0)
        return -1;
    for (size_t j = 0; j <= 1; j++)
        for (size_t i = 0; i <= nu; i++) {
            size_t v = j * (nu + 1) + i;
            double u = (double)i / (double)nu, phi = u * phimax;
            double c = i == nu && phimax_deg >= 360.0 ? 1.0 : cos(phi),
                   s = i == nu && phimax_deg >= 360.0 ? 0.0 : sin(phi);
            out->P[3 * v] = r * c, out->P[3 * v + 1] = r * s, out->P[3 * v + 2] = j ? z1 : z0;
            out->N[3 * v] = c, out->N[3 * v + 1] = s, out->N[3 * v + 2] = 0.0;
            out->uv[2 * v] = u, out->uv[2 * v + 1] = (double)j;
        }
    /* (i, j) -> (i+1, j) turns with phi and (i, j) -> (i, j+1) climbs z: dp/dphi x dp/dz
     * points out, as pbrt-v4's cross(dpdu, dpdv) does for zmax > zmin. */
    grid_triangles(0, nu, 1, false, out->indices);
    return 0;
}

int shape_tess_sphere(double r, double zmin, double zmax, double phimax_deg, mesh_data_t *out,
                      err_t *err)
{
    memset(out, 0, sizeof *out);
    double z0 = fmin(fmax(fmin(zmin, zmax), -r), r), z1 = fmin(fmax(fmax(zmin, zmax), -r), r);
    double th0 = acos(fmin(fmax(z0 / r, -1.0), 1.0)), th1 = acos(fmin(fmax(z1 / r, -1.0), 1.0));
    double phimax = fmin(fmax(phimax_deg, 0.0), 360.0) * PI / 180.0;
    size_t nu = segments(phimax), nv = segments(th0 - th1);
    if (grid_alloc(nu, nv, out, err) != 0)
        return -1;
    for (size_t j = 0; j <= nv; j++)
        for (size_t i = 0; i <= nu; i++) {
            size_t v = j * (nu + 1) + i;
            double u = (double)i / (double)nu, t = (double)j / (double)nv;
            double phi = u * phimax, th = th0 + t * (th1 - th0);
            bool closed = i == nu && phimax_deg >= 360.0;
            double c = closed ? 1.0 : cos(phi), s = closed ? 0.0 : sin(phi);
            double st = sin(th), ct = j == 0 ? z0 / r : j == nv ? z1 / r : cos(th);
            if (j == 0 || j == nv)
                st = sqrt(fmax(0.0, 1.0 - ct * ct));
            double n[3] = {st * c, st * s, ct};
            for (int k = 0; k < 3; k++) {
                out->P[3 * v + (size_t)k] = r * n[k];
                out->N[3 * v + (size_t)k] = n[k];
            }
            out->uv[2 * v] = u, out->uv[2 * v + 1] = t;
        }
    /* j climbs from zmin to zmax: dp/dphi x dp/dz points out, as for the cylinder. At a pole
     * the triangles of one row are degenerate (zero area), which Embree skips. */
    grid_triangles(0, nu, nv, false, out->indices);
    return 0;
}

static void bilerp(const double *a, const double *b, const double *c, const double *d, double u,
                   double v, int n, double *out)
{
    for (int k = 0; k < n; k++)
        out[k] = (1 - u) * (1 - v) * a[k] + u * (1 - v) * b[k] + (1 - u) * v * c[k] + u * v * d[k];
}

/* Grid cells along each side of a patch: 1 for a planar patch (exact), else enough that the
 * surface lies within about 1e-3 of the patch's size from the triangles. The bilinear patch
 * departs from the plane of its corners by the twist q = p00 - p10 - p01 + p11 (times u v),
 * and a grid of n x n cells follows it to within |q| / (4 n^2). */
static size_t patch_cells(const double *p00, const double *p10, const double *p01,
                          const double *p11)
{
    double q = 0, size = 0;
    for (int k = 0; k < 3; k++) {
        double t = p00[k] - p10[k] - p01[k] + p11[k], d = p11[k] - p00[k], e = p10[k] - p01[k];
        q += t * t;
        size += fmax(d * d, e * e);
    }
    q = sqrt(q), size = sqrt(size);
    if (!(q > 1e-9 * size))
        return 1;
    double n = ceil(sqrt(q / (4.0 * 1e-3 * size)));
    return n < 2 ? 2 : n > 32 ? 32 : (size_t)n;
}

int shape_tess_bilinear(const double *P, size_t nv, const uint32_t *idx, size_t npatches,
                        const double *uv, const double *N, mesh_data_t *out, err_t *err)
{
    (void)nv;
    memset(out, 0, sizeof *out);
    size_t verts = 0, tris = 0;
    bool curved = false;
    for (size_t i = 0; i < npatches; i++) {
        const uint32_t *c = &idx[4 * i];
        size_t n = patch_cells(&P[3 * c[0]], &P[3 * c[1]], &P[3 * c[2]], &P[3 * c[3]]);
        curved = curved || n > 1;
        verts += (n + 1) * (n + 1);
        tris += 2 * n * n;
    }
    if (verts >= UINT32_MAX)
        return err_set(err, "the patches make more than %u vertices", UINT32_MAX);
    bool normals = N || curved;
    out->nvertices = verts;
    out->ntriangles = tris;
    out->P = malloc(3 * verts * sizeof *out->P);
    out->N = normals ? malloc(3 * verts * sizeof *out->N) : NULL;
    out->uv = malloc(2 * verts * sizeof *out->uv);
    out->indices = malloc(3 * tris * sizeof *out->indices);
    if (!out->P || (normals && !out->N) || !out->uv || !out->indices) {
        mesh_data_free(out);
        return err_set(err, "out of memory for %zu patches", npatches);
    }
    static const double UV[8] = {0, 0, 1, 0, 0, 1, 1, 1};
    size_t v0 = 0, t0 = 0;
    for (size_t i = 0; i < npatches; i++) {
        const uint32_t *c = &idx[4 * i];
        const double *p[4] = {&P[3 * c[0]], &P[3 * c[1]], &P[3 * c[2]], &P[3 * c[3]]};
        size_t n = patch_cells(p[0], p[1], p[2], p[3]);
        for (size_t j = 0; j <= n; j++)
            for (size_t k = 0; k <= n; k++) {
                double u = (double)k / (double)n, v = (double)j / (double)n;
                size_t o = v0 + j * (n + 1) + k;
                bilerp(p[0], p[1], p[2], p[3], u, v, 3, &out->P[3 * o]);
                if (uv)
                    bilerp(&uv[2 * c[0]], &uv[2 * c[1]], &uv[2 * c[2]], &uv[2 * c[3]], u, v, 2,
                           &out->uv[2 * o]);
                else
                    bilerp(&UV[0], &UV[2], &UV[4], &UV[6], u, v, 2, &out->uv[2 * o]);
                if (!normals)
                    continue;
                double *no = &out->N[3 * o];
                if (N) {
                    bilerp(&N[3 * c[0]], &N[3 * c[1]], &N[3 * c[2]], &N[3 * c[3]], u, v, 3, no);
                    continue;
                }
                /* pbrt-v4's normal: cross(dp/du, dp/dv) */
                double du[3], dv[3];
                for (int m = 0; m < 3; m++) {
                    du[m] = (1 - v) * (p[1][m] - p[0][m]) + v * (p[3][m] - p[2][m]);
                    dv[m] = (1 - u) * (p[2][m] - p[0][m]) + u * (p[3][m] - p[1][m]);
                }
                no[0] = du[1] * dv[2] - du[2] * dv[1];
                no[1] = du[2] * dv[0] - du[0] * dv[2];
                no[2] = du[0] * dv[1] - du[1] * dv[0];
            }
        /* (k, j) -> (k+1, j) is dp/du and -> (k, j+1) dp/dv: the grid's triangles face
         * cross(dp/du, dp/dv), and a planar patch is (p00 p10 p11) (p00 p11 p01). */
        grid_triangles((uint32_t)v0, n, n, false, &out->indices[3 * t0]);
        v0 += (n + 1) * (n + 1);
        t0 += 2 * n * n;
    }
    return 0;
}
