/* lightmap: texel grids against analytic areas (triangle, disk, sphere, ellipsoid, instances),
 * uniform deposits against the binomial noise they must show, exact and order-independent sums
 * (merge, 1e9 deposits), the wire form (bit-exact round trip, deterministic bytes, size of a
 * sparse caustic) and the strict decoder. Scenes are built here; hits come from
 * geometry_intersect, except the 1e6-photon caustic, whose barycentrics are written directly. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#include "lightmap.h"
#include "rng.h"
#include "scene.h"
#include "scene_builders.h"

#define NB 4 /* buckets of grid4(): 80 nm each over 400-720 nm */

static spectral_grid_t grid4(void)
{
    spectral_grid_t g;
    assert_int_equal(spectral_grid_init(&g, NB, 400.0, 720.0, NULL), 0);
    return g;
}

/* A w x h rectangle in the plane z = z0 from (x0, y0): triangles (0,1,2) and (0,2,3). */
static void rect(double x0, double y0, double w, double h, double z0, double P[12])
{
    double v[12] = {x0, y0, z0, x0 + w, y0, z0, x0 + w, y0 + h, z0, x0, y0 + h, z0};
    memcpy(P, v, sizeof v);
}
static const uint32_t RECT_IDX[6] = {0, 1, 2, 0, 2, 3};

static hit_t shoot(const scene_t *s, vec3_t org, vec3_t dir)
{
    hit_t h;
    if (!geometry_intersect(s->geometry, org, dir, 0.0, INFINITY, &h))
        fail_msg("ray from (%g %g %g) along (%g %g %g) missed", org.x, org.y, org.z, dir.x, dir.y,
                 dir.z);
    return h;
}

/* A hit straight down onto the plane z = 0 at (x, y). */
static hit_t down_at(const scene_t *s, double x, double y)
{
    return shoot(s, vec3_make(x, y, 1.0), vec3_make(0, 0, -1));
}

static const vec3_t UP = {0, 0, 1};

static lightmap_t *new_map(const scene_t *s, double density)
{
    err_t err;
    lightmap_t *m = lightmap_new(s, density, grid4(), &err);
    if (!m)
        fail_msg("lightmap_new: %s", err.msg);
    return m;
}

static void deposit(lightmap_t *m, const hit_t *h, vec3_t n, double lambda, double power)
{
    err_t err;
    if (lightmap_deposit(m, h, n, lambda, power, &err))
        fail_msg("lightmap_deposit: %s", err.msg);
}

static uint64_t texels_of(const lightmap_t *m, uint32_t instance, uint32_t shape, uint32_t prim)
{
    err_t err;
    uint64_t n = 0;
    if (lightmap_surface_texels(m, instance, shape, prim, &n, &err))
        fail_msg("lightmap_surface_texels: %s", err.msg);
    return n;
}

/* Sum of the world areas of every texel of a surface. */
static double area_sum(const lightmap_t *m, uint32_t instance, uint32_t shape, uint32_t prim)
{
    uint64_t n = texels_of(m, instance, shape, prim);
    /* Neumaier's compensated sum: a plain one over 45000 texels could itself be off by more
     * than the 1e-12 under test. */
    double sum = 0.0, c = 0.0;
    for (uint64_t i = 0; i < n; i++) {
        double a = lightmap_texel_area(
            m, (lightmap_texel_t){.instance = instance, .shape = shape, .prim = prim, .index = i});
        assert_true(a > 0.0);
        double t = sum + a;
        c += fabs(sum) >= fabs(a) ? (sum - t) + a : (a - t) + sum;
        sum = t;
    }
    return sum + c;
}

static uint8_t *encode(const lightmap_t *m, size_t *len)
{
    err_t err;
    uint8_t *out = NULL;
    if (lightmap_encode(m, &out, len, &err))
        fail_msg("lightmap_encode: %s", err.msg);
    return out;
}

static void assert_same_bytes(const uint8_t *a, size_t na, const uint8_t *b, size_t nb)
{
    assert_int_equal(na, nb);
    assert_memory_equal(a, b, na);
}

static void assert_maps_equal(const lightmap_t *a, const lightmap_t *b)
{
    size_t na, nb;
    uint8_t *ea = encode(a, &na), *eb = encode(b, &nb);
    assert_same_bytes(ea, na, eb, nb);
    free(ea);
    free(eb);
    assert_int_equal(lightmap_texels_used(a), lightmap_texels_used(b));
    assert_true(lightmap_power_sum(a) == lightmap_power_sum(b));
}

/* ------------------------------------------------------------------------------------------ */
/* (1) Uniform deposits give uniform irradiance, within binomial noise. */

/* A texel-bucket that each of N photons reaches with probability q holds c ~ Binomial(N, q)
 * photons, so E / E_expected = c / (N q) has standard deviation sqrt((1 - q) / (N q)).
 * Over K texel-buckets, sum z^2 is about chi-square with K - 1 degrees of freedom (the counts
 * are multinomial): mean K - 1, standard deviation sqrt(2 (K - 1)); the test allows 6 of them,
 * and any single |z| up to 5.5 (for K = 800, P(max |z| > 5.5) ~ 800 * 3.8e-8). */
static void check_chi2(const double *z, size_t K, const char *what)
{
    double chi2 = 0.0, zmax = 0.0;
    for (size_t k = 0; k < K; k++) {
        chi2 += z[k] * z[k];
        zmax = fmax(zmax, fabs(z[k]));
    }
    double dof = (double)K - 1.0;
    printf("  %s: %zu cells, chi2 %.1f (expected %.0f +- %.1f), max |z| %.2f\n", what, K, chi2, dof,
           sqrt(2.0 * dof), zmax);
    assert_true(fabs(chi2 - dof) < 6.0 * sqrt(2.0 * dof));
    assert_true(zmax < 5.5);
}

static void test_uniform_quad(void **state)
{
    (void)state;
    err_t err;
    scene_t *s = scene_new(&err);
    double P[12];
    rect(0, 0, 2, 1, 0, P); /* two triangles of area 1 */
    assert_int_equal(
        scene_add_mesh(s, P, 4, RECT_IDX, 2, NULL, NULL, sb_diffuse(s, 0.5), -1, 0, &err), 0);
    sb_finish(s);
    const double A = 2.0, density = 100.0; /* m = 10: 100 texels of 0.01 per triangle */
    lightmap_t *m = new_map(s, density);
    assert_int_equal(texels_of(m, GEOMETRY_NO_INSTANCE, 0, 0), 100);
    assert_int_equal(texels_of(m, GEOMETRY_NO_INSTANCE, 0, 1), 100);
    /* Photons uniform over the quad and over 400-720 nm, each of power A * 320 nm: the
     * expected irradiance is then P / (A * 320) = 1 in every bucket of every texel. */
    const uint64_t N = 80000;
    const double power = A * 320.0;
    enum { T = 200 };
    hit_t first[T];
    int seen[T] = {0};
    double lo[T][2], hi[T][2];
    for (uint64_t i = 0; i < N; i++) {
        double u[4];
        rng_uniform4(11, i, 0, 0, u);
        hit_t h = down_at(s, 2.0 * u[0], u[1]);
        deposit(m, &h, UP, 400.0 + 320.0 * u[2], power);
        lightmap_texel_t t;
        assert_int_equal(lightmap_locate(m, &h, UP, &t, &err), 0);
        assert_int_equal(t.side, 0);
        size_t k = t.prim * 100 + t.index;
        if (!seen[k]) {
            seen[k] = 1;
            first[k] = h;
            lo[k][0] = hi[k][0] = h.p.x;
            lo[k][1] = hi[k][1] = h.p.y;
        }
        lo[k][0] = fmin(lo[k][0], h.p.x);
        hi[k][0] = fmax(hi[k][0], h.p.x);
        lo[k][1] = fmin(lo[k][1], h.p.y);
        hi[k][1] = fmax(hi[k][1], h.p.y);
    }
    lightmap_add_emitted(m, N);
    /* Every photon's power is kept, exactly: 640 N is an integer sum. */
    assert_true(lightmap_power_sum(m) == power * (double)N);
    assert_int_equal(lightmap_texels_used(m), T);
    /* A texel is one sub-triangle of the 1/m-scaled triangle: its extent along x and y is at
     * most the longest edge / m (sqrt(5) / 10). Sub-triangles mixed up would be far wider. */
    for (int k = 0; k < T; k++) {
        assert_true(seen[k]);
        assert_true(hi[k][0] - lo[k][0] <= sqrt(5.0) / 10.0 + 1e-6);
        assert_true(hi[k][1] - lo[k][1] <= sqrt(5.0) / 10.0 + 1e-6);
    }
    const double q = 0.01 / A / NB; /* chance that a photon lands in a given texel and bucket */
    const double sd = sqrt((1.0 - q) / ((double)N * q));
    double z[T * NB];
    for (int k = 0; k < T; k++) {
        double E[NB];
        assert_int_equal(lightmap_irradiance(m, &first[k], UP, E), 1);
        for (int b = 0; b < NB; b++)
            z[k * NB + b] = (E[b] - 1.0) / sd;
        /* The other side of the quad received nothing. */
        assert_int_equal(lightmap_irradiance(m, &first[k], vec3_neg(UP), E), 0);
        for (int b = 0; b < NB; b++)
            assert_true(E[b] == 0.0);
    }
    check_chi2(z, T * NB, "quad, 200 texels x 4 buckets");
    lightmap_destroy(&m);
    scene_destroy(&s);
}

/* Equal-area parameterisations: photons uniform over a sphere (directions from its centre)
 * and a disk (rays from above) put Binomial(N, 1/T) photons in each of its T texels. */
static void test_uniform_sphere_and_disk(void **state)
{
    (void)state;
    err_t err;
    scene_t *s = scene_new(&err);
    int mat = sb_diffuse(s, 0.5);
    transform_t ts =
        transform_compose(transform_translate(vec3_make(3, 0, 0)), transform_scale(1.5, 1.5, 1.5));
    assert_int_equal(scene_add_sphere(s, &ts, 1.0, mat, -1, 0, &err), 0);
    transform_t td = transform_translate(vec3_make(-3, 0, 0));
    assert_int_equal(scene_add_disk(s, &td, 1.0, 0.0, mat, -1, 0, &err), 1);
    sb_finish(s);
    lightmap_t *m = new_map(s, 10.0);
    const uint64_t Ts = texels_of(m, GEOMETRY_NO_INSTANCE, 0, 0);
    const uint64_t Td = texels_of(m, GEOMETRY_NO_INSTANCE, 1, 0);
    /* sphere: T = ceil(4 pi 2.25 * 10) = 283, nz = round(sqrt(283 / pi)) = 9, nphi = 32;
     * disk: n = ceil(sqrt(10 pi)) = 6 */
    assert_int_equal(Ts, 9 * 32);
    assert_int_equal(Td, 36);
    const uint64_t per = 300; /* expected photons per texel */
    for (uint64_t i = 0; i < per * Ts; i++) {
        double u[4];
        rng_uniform4(12, i, 0, 0, u);
        double z = 1.0 - 2.0 * u[0], r = sqrt(fmax(0.0, 1.0 - z * z)), phi = 2.0 * PF_PI * u[1];
        vec3_t d = vec3_make(r * cos(phi), r * sin(phi), z);
        hit_t h = shoot(s, vec3_make(3, 0, 0), d);
        assert_int_equal(h.shape, 0);
        deposit(m, &h, vec3_neg(d), 500.0, 1.0); /* arriving from inside: side 1 */
    }
    uint64_t nd = 0;
    for (uint64_t i = 0; nd < per * Td; i++) {
        double u[4];
        rng_uniform4(13, i, 0, 0, u);
        double x = 2.0 * u[0] - 1.0, y = 2.0 * u[1] - 1.0;
        if (x * x + y * y >= 1.0)
            continue;
        hit_t h = down_at(s, x - 3.0, y);
        assert_int_equal(h.shape, 1);
        deposit(m, &h, UP, 500.0, 1.0);
        nd++;
    }
    const uint64_t Ns = per * Ts;
    double *z = malloc((Ts + Td) * sizeof *z);
    for (uint64_t k = 0; k < Ts + Td; k++) {
        int sphere = k < Ts;
        lightmap_texel_t t = {.instance = GEOMETRY_NO_INSTANCE,
                              .shape = sphere ? 0 : 1,
                              .side = sphere ? 1 : 0,
                              .index = sphere ? k : k - Ts};
        double pw[NB];
        lightmap_texel_power(m, t, pw);
        double n = sphere ? (double)Ns : (double)nd, q = 1.0 / (double)(sphere ? Ts : Td);
        z[k] = (pw[1] - n * q) / sqrt(n * q * (1.0 - q)); /* 500 nm is bucket 1 */
    }
    check_chi2(z, Ts, "sphere texels");
    check_chi2(z + Ts, Td, "disk texels");
    free(z);
    lightmap_destroy(&m);
    scene_destroy(&s);
}

/* ------------------------------------------------------------------------------------------ */
/* (2) Texel areas add up to the surface's area; texel counts follow area * density. */

static void test_texel_areas(void **state)
{
    (void)state;
    err_t err;
    scene_t *s = scene_new(&err);
    int mat = sb_diffuse(s, 0.5);
    transform_t rot;
    assert_int_equal(transform_rotate(37.0, vec3_make(1, 2, 3), &rot, &err), 0);
    /* 0: sphere of world radius 3 (radius 1.5 scaled by 2, rotated, moved) */
    transform_t ts = transform_compose(transform_translate(vec3_make(10, 1, -2)),
                                       transform_compose(rot, transform_scale(2, 2, 2)));
    assert_int_equal(scene_add_sphere(s, &ts, 1.5, mat, -1, 0, &err), 0);
    /* 1: disk of radius 0.7, uniformly scaled by 1.5 and rotated */
    transform_t td = transform_compose(rot, transform_scale(1.5, 1.5, 1.5));
    assert_int_equal(scene_add_disk(s, &td, 0.7, 0.3, mat, -1, 0, &err), 1);
    /* 2: a disk squashed along x (its area scales by 0.25 exactly) */
    transform_t tq =
        transform_compose(transform_translate(vec3_make(0, 0, 5)), transform_scale(0.25, 1, 3));
    assert_int_equal(scene_add_disk(s, &tq, 2.0, 0.0, mat, -1, 0, &err), 2);
    /* 3: a scalene triangle, area |(3,0,0) x (1,2,2)| / 2 = |(0,-6,6)| / 2 = 3 sqrt(2) */
    double P[9] = {0, 0, -4, 3, 0, -4, 1, 2, -2};
    uint32_t I[3] = {0, 1, 2};
    assert_int_equal(scene_add_mesh(s, P, 3, I, 1, NULL, NULL, mat, -1, 0, &err), 3);
    /* 4: a prolate spheroid, semi-axes 1, 1, 2 */
    transform_t te =
        transform_compose(transform_translate(vec3_make(-10, 0, 0)), transform_scale(1, 1, 2));
    assert_int_equal(scene_add_sphere(s, &te, 1.0, mat, -1, 0, &err), 4);
    sb_finish(s);
    const double d = 400.0;
    lightmap_t *m = new_map(s, d);
    const uint32_t W = GEOMETRY_NO_INSTANCE;

    struct {
        uint32_t shape;
        double area;
        const char *what;
    } exact[] = {
        {0, 4.0 * PF_PI * 9.0, "sphere r=3"},
        {1, PF_PI * 0.49 * 2.25, "disk r=0.7*1.5"},
        {2, PF_PI * 4.0 * 0.25, "disk squashed"},
        {3, 3.0 * sqrt(2.0), "triangle"},
    };
    for (size_t i = 0; i < sizeof exact / sizeof exact[0]; i++) {
        double sum = area_sum(m, W, exact[i].shape, 0), A = exact[i].area;
        uint64_t n = texels_of(m, W, exact[i].shape, 0);
        printf("  %s: area %.12g, texels %llu (area x density %.1f), texel-area sum rel. error "
               "%.2e\n",
               exact[i].what, A, (unsigned long long)n, A * d, fabs(sum - A) / A);
        assert_true(fabs(sum - A) <= 1e-12 * A);
        /* Counts: the smallest grid with at least A d texels (triangle and disk: a square of
         * side ceil(sqrt(A d)); sphere: nz rows of ceil(T / nz), at most nz extra). */
        assert_true((double)n >= A * d);
        if (exact[i].shape == 0) {
            double nz = floor(sqrt(ceil(A * d) / PF_PI) + 0.5);
            assert_true((double)n < ceil(A * d) + nz);
        } else {
            double side = sqrt((double)n);
            assert_true(side == floor(side) && (side - 1.0) * (side - 1.0) < A * d);
        }
    }
    /* The spheroid: S = 2 pi a^2 (1 + c / (a e) asin e), e^2 = 1 - a^2 / c^2 (a = 1, c = 2).
     * Texel areas take the area factor at texel centres: the midpoint rule in z for
     * g(z) = 2 sqrt(1 - 3 z^2 / 4) (the factor on the unit sphere, exact in phi), whose error is
     * at most 2 pi (2 / 24) h^2 max|g''| = 2 pi h^2 with h = 2 / nz and max|g''| = 12. */
    double e = sqrt(0.75), S = 2.0 * PF_PI * (1.0 + 2.0 / e * asin(e));
    uint64_t ne = texels_of(m, W, 4, 0);
    double A_est = 4.0 * PF_PI * pow(2.0, 2.0 / 3.0);
    double nz = floor(sqrt(ceil(A_est * d) / PF_PI) + 0.5), h = 2.0 / nz;
    double se = area_sum(m, W, 4, 0);
    printf("  spheroid: area %.9g, texel-area sum %.9g (bound %.2e), texels %llu\n", S, se,
           2.0 * PF_PI * h * h, (unsigned long long)ne);
    assert_true(fabs(se - S) <= 2.0 * PF_PI * h * h);
    assert_true(fabs(se - S) > 1e-9 * S); /* it is an approximation: the bound is not idle */
    /* Unknown surfaces are refused. */
    uint64_t n;
    assert_int_equal(lightmap_surface_texels(m, W, 5, 0, &n, &err), -1);
    assert_non_null(strstr(err.msg, "shape 5 does not exist"));
    assert_int_equal(lightmap_surface_texels(m, W, 3, 1, &n, &err), -1);
    assert_non_null(strstr(err.msg, "triangle 1 of shape 3"));
    assert_int_equal(lightmap_surface_texels(m, W, 0, 1, &n, &err), -1);
    assert_non_null(strstr(err.msg, "prim must be 0"));
    assert_true(lightmap_texel_area(m, (lightmap_texel_t){W, 3, 0, 0, ne * 1000}) == 0.0);
    lightmap_destroy(&m);
    scene_destroy(&s);
}

/* ------------------------------------------------------------------------------------------ */
/* (3) Instances: one object placed twice at different scales has texels of its own in each. */

static void test_instances(void **state)
{
    (void)state;
    err_t err;
    scene_t *s = scene_new(&err);
    int mat = sb_diffuse(s, 0.5);
    int obj = scene_add_object(s, &err);
    assert_true(obj >= 0);
    double P[12];
    rect(0, 0, 1, 1, 0, P); /* two triangles of area 0.5 */
    assert_int_equal(scene_add_object_mesh(s, obj, P, 4, RECT_IDX, 2, NULL, NULL, mat, 0, &err), 0);
    transform_t tdisk = transform_translate(vec3_make(2.5, 0.5, 0));
    assert_int_equal(scene_add_object_disk(s, obj, &tdisk, 0.5, 0.0, mat, 0, &err), 1);
    transform_t ta = transform_identity();
    transform_t tb =
        transform_compose(transform_translate(vec3_make(0, 5, 0)), transform_scale(2, 2, 2));
    assert_int_equal(scene_add_instance(s, obj, &ta, &err), 0);
    assert_int_equal(scene_add_instance(s, obj, &tb, &err), 1);
    sb_finish(s);
    const double d = 200.0;
    lightmap_t *m = new_map(s, d);
    /* Triangles: m = ceil(sqrt(0.5 * 200)) = 10 in A, ceil(sqrt(2 * 200)) = 20 in B; disks:
     * ceil(sqrt(pi / 4 * 200)) = 13, ceil(sqrt(pi * 200)) = 26. */
    assert_int_equal(texels_of(m, 0, 0, 0), 100);
    assert_int_equal(texels_of(m, 1, 0, 0), 400);
    assert_int_equal(texels_of(m, 0, 1, 0), 169);
    assert_int_equal(texels_of(m, 1, 1, 0), 676);
    for (uint32_t tri = 0; tri < 2; tri++) {
        assert_true(fabs(area_sum(m, 0, 0, tri) - 0.5) <= 1e-12);
        assert_true(fabs(area_sum(m, 1, 0, tri) - 2.0) <= 1e-12 * 2.0);
    }
    assert_true(fabs(area_sum(m, 0, 1, 0) - PF_PI / 4.0) <= 1e-12);
    assert_true(fabs(area_sum(m, 1, 1, 0) - PF_PI) <= 1e-12 * PF_PI);
    /* The object's shapes need an instance; an instance names its object's shapes only. */
    uint64_t n;
    assert_int_equal(lightmap_surface_texels(m, GEOMETRY_NO_INSTANCE, 0, 0, &n, &err), -1);
    assert_non_null(strstr(err.msg, "no instance is named"));
    assert_int_equal(lightmap_surface_texels(m, 2, 0, 0, &n, &err), -1);
    assert_non_null(strstr(err.msg, "instance 2 does not exist"));

    /* Points in both placements: separate texels, each read with its own placement's texel
     * area (here 0.5 / 10^2 = 2 / 20^2, and pi / 4 / 13^2 = pi / 26^2). */
    hit_t ha = down_at(s, 0.3, 0.2), hb = down_at(s, 0.6, 5.4);
    assert_int_equal(ha.instance, 0);
    assert_int_equal(hb.instance, 1);
    assert_int_equal(ha.shape, hb.shape);
    hit_t da = down_at(s, 2.6, 0.5), db = down_at(s, 5.2, 6.0);
    assert_int_equal(da.instance, 0);
    assert_int_equal(db.instance, 1);
    assert_int_equal(da.shape, 1);
    const hit_t *hits[4] = {&ha, &hb, &da, &db};
    for (int k = 0; k < 4; k++)
        deposit(m, hits[k], UP, 500.0, 8.0);
    lightmap_add_emitted(m, 2);
    assert_int_equal(lightmap_texels_used(m), 4);
    lightmap_texel_t a, b;
    assert_int_equal(lightmap_locate(m, &ha, UP, &a, &err), 0);
    assert_int_equal(lightmap_locate(m, &hb, UP, &b, &err), 0);
    assert_int_not_equal(a.instance, b.instance);
    double Ea[NB], Eb[NB];
    assert_int_equal(lightmap_irradiance(m, &ha, UP, Ea), 1);
    assert_int_equal(lightmap_irradiance(m, &hb, UP, Eb), 1);
    /* E = 8 / (2 photons * texel area * 80 nm); texels 0.5 / 100 and 2 / 400 */
    assert_true(fabs(Ea[1] - 8.0 / (2.0 * 0.005 * 80.0)) <= 1e-12 * Ea[1]);
    assert_true(fabs(Eb[1] - 8.0 / (2.0 * 0.005 * 80.0)) <= 1e-12 * Eb[1]);
    assert_int_equal(lightmap_irradiance(m, &da, UP, Ea), 1);
    assert_int_equal(lightmap_irradiance(m, &db, UP, Eb), 1);
    assert_true(fabs(Ea[1] - 8.0 / (2.0 * (PF_PI / 4.0 / 169.0) * 80.0)) <= 1e-12 * Ea[1]);
    assert_true(fabs(Eb[1] - 8.0 / (2.0 * (PF_PI / 676.0) * 80.0)) <= 1e-12 * Eb[1]);
    lightmap_destroy(&m);
    scene_destroy(&s);
}

/* ------------------------------------------------------------------------------------------ */
/* Test scene for (4)-(6): a 2x1 quad (shape 0, two triangles), a sphere (1), an object with a
 * disk (shape 2) placed by instance 0. */

static scene_t *mixed_scene(void)
{
    err_t err;
    scene_t *s = scene_new(&err);
    int mat = sb_diffuse(s, 0.5);
    double P[12];
    rect(0, 0, 2, 1, 0, P);
    assert_int_equal(scene_add_mesh(s, P, 4, RECT_IDX, 2, NULL, NULL, mat, -1, 0, &err), 0);
    transform_t ts = transform_translate(vec3_make(5, 0, 0));
    assert_int_equal(scene_add_sphere(s, &ts, 1.0, mat, -1, 0, &err), 1);
    int obj = scene_add_object(s, &err);
    transform_t id = transform_identity();
    assert_int_equal(scene_add_object_disk(s, obj, &id, 1.0, 0.0, mat, 0, &err), 2);
    transform_t ti = transform_translate(vec3_make(-5, 0, 0));
    assert_int_equal(scene_add_instance(s, obj, &ti, &err), 0);
    sb_finish(s);
    return s;
}

typedef struct dep {
    hit_t h;
    vec3_t n;
    double lambda, power;
} dep_t;

/* n deposits spread over the mixed scene's surfaces and both sides, with powers over twelve
 * decades and wavelengths partly outside the grid. */
static dep_t *random_deposits(const scene_t *s, size_t n, uint64_t seed)
{
    dep_t *v = malloc(n * sizeof *v);
    for (size_t i = 0; i < n; i++) {
        double u[4];
        rng_uniform4(seed, i, 0, 0, u);
        int which = (int)(u[3] * 4.0);
        vec3_t org, dir;
        if (which == 0) { /* quad, from above */
            org = vec3_make(2.0 * u[0], u[1], 1.0);
            dir = vec3_make(0, 0, -1);
        } else if (which == 1) { /* quad, from below */
            org = vec3_make(2.0 * u[0], u[1], -1.0);
            dir = vec3_make(0, 0, 1);
        } else if (which == 2) { /* sphere, from outside */
            org = vec3_make(5.0 + 1.4 * u[0] - 0.7, 1.4 * u[1] - 0.7, 3.0);
            dir = vec3_make(0, 0, -1);
        } else { /* instanced disk */
            org = vec3_make(-5.0 + 1.2 * u[0] - 0.6, 1.2 * u[1] - 0.6, 1.0);
            dir = vec3_make(0, 0, -1);
        }
        v[i].h = shoot(s, org, dir);
        v[i].n = vec3_neg(dir);
        v[i].lambda = 390.0 + 340.0 * rng_uniform(seed, i, 1, 0);
        v[i].power = 0.1 * pow(10.0, 12.0 * rng_uniform(seed, i, 1, 1) - 6.0);
    }
    return v;
}

static void deposit_all(lightmap_t *m, const dep_t *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        deposit(m, &v[i].h, v[i].n, v[i].lambda, v[i].power);
}

/* ------------------------------------------------------------------------------------------ */
/* (4) The wire form. */

static void test_encode_round_trip(void **state)
{
    (void)state;
    err_t err;
    scene_t *s = mixed_scene();
    const size_t n = 3000;
    dep_t *v = random_deposits(s, n, 21);
    lightmap_t *m = new_map(s, 50.0);
    deposit_all(m, v, n);
    lightmap_add_emitted(m, 123456789);
    size_t len;
    uint8_t *bytes = encode(m, &len);
    lightmap_t *d = lightmap_decode(s, 50.0, grid4(), bytes, len, (size_t)1 << 26, &err);
    if (!d)
        fail_msg("lightmap_decode: %s", err.msg);
    assert_int_equal(lightmap_emitted(d), 123456789);
    assert_maps_equal(m, d);
    /* Bit-exact: every texel's power and every irradiance read back the same. */
    for (size_t i = 0; i < n; i++) {
        double E1[NB], E2[NB];
        assert_int_equal(lightmap_irradiance(m, &v[i].h, v[i].n, E1),
                         lightmap_irradiance(d, &v[i].h, v[i].n, E2));
        assert_memory_equal(E1, E2, sizeof E1);
        lightmap_texel_t t;
        assert_int_equal(lightmap_locate(m, &v[i].h, v[i].n, &t, &err), 0);
        double p1[NB], p2[NB];
        assert_int_equal(lightmap_texel_power(m, t, p1), lightmap_texel_power(d, t, p2));
        assert_memory_equal(p1, p2, sizeof p1);
    }
    /* The same deposits in reverse and in a shuffled order: the same bytes (texel sums do not
     * depend on order, and the wire form is in key order). */
    lightmap_t *r = new_map(s, 50.0);
    for (size_t i = n; i-- > 0;)
        deposit(r, &v[i].h, v[i].n, v[i].lambda, v[i].power);
    lightmap_add_emitted(r, 123456789);
    assert_maps_equal(m, r);
    lightmap_t *sh = new_map(s, 50.0);
    for (size_t i = 0; i < n; i++) {
        size_t j = (i * 1237 + 17) % n; /* 1237 is prime to 3000: a permutation */
        deposit(sh, &v[j].h, v[j].n, v[j].lambda, v[j].power);
    }
    lightmap_add_emitted(sh, 123456789);
    assert_maps_equal(m, sh);
    printf("  %zu deposits: %zu texels, %zu bytes encoded, %zu bytes held\n", n,
           lightmap_texels_used(m), len, lightmap_memory_bytes(m));
    free(bytes);
    free(v);
    lightmap_destroy(&m);
    lightmap_destroy(&d);
    lightmap_destroy(&r);
    lightmap_destroy(&sh);
    scene_destroy(&s);
}

static double gauss(uint64_t seed, uint64_t i, uint32_t dim)
{
    double u1 = rng_uniform(seed, i, 2, dim), u2 = rng_uniform(seed, i, 2, dim + 1);
    return sqrt(-2.0 * log(1.0 - u1)) * cos(2.0 * PF_PI * u2);
}

/* A 10x10 screen at 1600 texels per unit area (two triangles of 283^2 texels each) and a
 * million photons of a dispersed caustic: a rainbow streak whose position along x follows the
 * wavelength (6 units over 380-720 nm), blurred by 0.05 in x and 0.1 in y. Prints the memory
 * per million photons and the encoded size against a dense map of doubles. */
static void test_caustic_size(void **state)
{
    (void)state;
    err_t err;
    scene_t *s = scene_new(&err);
    double P[12];
    rect(0, 0, 10, 10, 0, P);
    assert_int_equal(
        scene_add_mesh(s, P, 4, RECT_IDX, 2, NULL, NULL, sb_diffuse(s, 0.5), -1, 0, &err), 0);
    sb_finish(s);
    spectral_grid_t g16 = spectral_grid_default(); /* the film's usual 16 buckets */
    lightmap_t *m = lightmap_new(s, 1600.0, g16, &err);
    assert_non_null(m);
    const uint64_t m_side = 283; /* ceil(sqrt(50 * 1600)) */
    assert_int_equal(texels_of(m, GEOMETRY_NO_INSTANCE, 0, 0), m_side * m_side);
    const uint64_t N = 1000000;
    for (uint64_t i = 0; i < N; i++) {
        double lambda = 380.0 + 340.0 * rng_uniform(31, i, 0, 0);
        double x = 2.0 + 6.0 * (lambda - 380.0) / 340.0 + 0.05 * gauss(31, i, 0);
        double y = 5.0 + 0.1 * gauss(31, i, 2);
        x = fmin(9.999, fmax(0.001, x));
        y = fmin(9.999, fmax(0.001, y));
        /* Barycentrics of (x, y) on triangles (0,1,2) (y <= x) and (0,2,3), as Embree's. */
        hit_t h = {.p = vec3_make(x, y, 0), .ng = UP, .shape = 0, .instance = GEOMETRY_NO_INSTANCE};
        if (y <= x) {
            h.prim = 0;
            h.u = (x - y) / 10.0;
            h.v = y / 10.0;
        } else {
            h.prim = 1;
            h.u = x / 10.0;
            h.v = (y - x) / 10.0;
        }
        deposit(m, &h, UP, lambda, 1.0 + rng_uniform(31, i, 0, 1));
    }
    lightmap_add_emitted(m, N);
    size_t len;
    uint8_t *bytes = encode(m, &len);
    const uint64_t texels = 2 * m_side * m_side;
    const double dense = (double)texels * g16.n * 8.0;
    uint64_t raw = 0;
    for (int i = 7; i >= 0; i--)
        raw = raw << 8 | bytes[8 + i];
    printf("  caustic, 1e6 photons on a 10x10 screen at 1600 texels/unit^2 (%llu texels, 16 "
           "buckets):\n"
           "    texels with power %zu; memory held %.2f MB (%.1f bytes per photon)\n"
           "    encoded %.2f MB (raw %.2f MB before zlib) vs dense doubles %.1f MB\n",
           (unsigned long long)texels, lightmap_texels_used(m), lightmap_memory_bytes(m) / 1e6,
           (double)lightmap_memory_bytes(m) / (double)N, len / 1e6, raw / 1e6, dense / 1e6);
    /* The streak covers ~ 6 x 0.4 units: about a tenth of the screen. */
    assert_true(lightmap_texels_used(m) < texels / 10);
    assert_true((double)lightmap_memory_bytes(m) < dense / 5.0);
    assert_true((double)len < dense / 10.0);
    lightmap_t *d = lightmap_decode(s, 1600.0, g16, bytes, len, (size_t)1 << 28, &err);
    if (!d)
        fail_msg("lightmap_decode: %s", err.msg);
    assert_maps_equal(m, d);
    free(bytes);
    lightmap_destroy(&m);
    lightmap_destroy(&d);
    scene_destroy(&s);
}

/* ------------------------------------------------------------------------------------------ */
/* (5) merge(a, b) is the map that took all the deposits, bit for bit, in any grouping. */

static void test_merge(void **state)
{
    (void)state;
    err_t err;
    scene_t *s = mixed_scene();
    const size_t n = 6000;
    dep_t *v = random_deposits(s, n, 41);
    lightmap_t *all = new_map(s, 50.0), *part[3];
    for (int k = 0; k < 3; k++)
        part[k] = new_map(s, 50.0);
    deposit_all(all, v, n);
    lightmap_add_emitted(all, 3 * 1000);
    /* Deposits dealt to the three parts pseudo-randomly: most texels get deposits from each. */
    for (size_t i = 0; i < n; i++) {
        int k = (int)(rng_uniform(42, i, 0, 0) * 3.0);
        deposit(part[k], &v[i].h, v[i].n, v[i].lambda, v[i].power);
    }
    for (int k = 0; k < 3; k++)
        lightmap_add_emitted(part[k], 1000);
    /* ((a + b) + c) in batch order, and c + (b + a) */
    lightmap_t *m1 = new_map(s, 50.0), *m2 = new_map(s, 50.0), *ba = new_map(s, 50.0);
    for (int k = 0; k < 3; k++)
        assert_int_equal(lightmap_merge(m1, part[k], &err), 0);
    assert_int_equal(lightmap_merge(ba, part[1], &err), 0);
    assert_int_equal(lightmap_merge(ba, part[0], &err), 0);
    assert_int_equal(lightmap_merge(m2, part[2], &err), 0);
    assert_int_equal(lightmap_merge(m2, ba, &err), 0);
    assert_int_equal(lightmap_emitted(m1), 3000);
    assert_maps_equal(all, m1);
    assert_maps_equal(all, m2);
    /* A plain double sum would not have matched: check that the parts overlap. */
    size_t used = 0;
    for (int k = 0; k < 3; k++)
        used += lightmap_texels_used(part[k]);
    assert_true(used > lightmap_texels_used(all) + lightmap_texels_used(all) / 2);
    /* Misuse */
    assert_int_equal(lightmap_merge(m1, m1, &err), -1);
    assert_non_null(strstr(err.msg, "into itself"));
    lightmap_t *other = new_map(s, 60.0);
    assert_int_equal(lightmap_merge(m1, other, &err), -1);
    assert_non_null(strstr(err.msg, "different"));
    lightmap_destroy(&other);
    free(v);
    for (int k = 0; k < 3; k++)
        lightmap_destroy(&part[k]);
    lightmap_destroy(&all);
    lightmap_destroy(&m1);
    lightmap_destroy(&m2);
    lightmap_destroy(&ba);
    scene_destroy(&s);
}

/* ------------------------------------------------------------------------------------------ */
/* (6) The decoder refuses every kind of bad input with a message that says what is wrong. */

typedef struct buf {
    uint8_t b[4096];
    size_t n;
} buf_t;

static void b_u8(buf_t *b, uint8_t v)
{
    b->b[b->n++] = v;
}
static void b_u16(buf_t *b, uint16_t v)
{
    for (int i = 0; i < 2; i++)
        b_u8(b, (uint8_t)(v >> (8 * i)));
}
static void b_u32(buf_t *b, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        b_u8(b, (uint8_t)(v >> (8 * i)));
}
static void b_u64(buf_t *b, uint64_t v)
{
    for (int i = 0; i < 8; i++)
        b_u8(b, (uint8_t)(v >> (8 * i)));
}
static void b_f64(buf_t *b, double v)
{
    uint64_t u;
    memcpy(&u, &v, sizeof u);
    b_u64(b, u);
}

/* The raw payload's header, as the format in lightmap.h says. */
static void b_head(buf_t *b, uint32_t buckets, double lmin, double lmax, double density,
                   uint64_t nsurf)
{
    b_u32(b, buckets);
    b_u32(b, 0);
    b_f64(b, lmin);
    b_f64(b, lmax);
    b_f64(b, density);
    b_u64(b, 7); /* emitted */
    b_u64(b, nsurf);
}
static void b_surface(buf_t *b, uint32_t instance, uint32_t shape, uint32_t prim, uint32_t side,
                      uint64_t ntiles)
{
    b_u32(b, instance);
    b_u32(b, shape);
    b_u32(b, prim);
    b_u32(b, side);
    b_u64(b, ntiles);
}
/* A tile with one bucket (bucket_mask) holding one texel (slot) of sum acc[0] * 2^(24 top). */
static void b_tile(buf_t *b, uint64_t index, uint8_t bucket_mask, uint16_t texel_mask, int8_t top,
                   uint64_t acc0)
{
    b_u64(b, index);
    b_u8(b, bucket_mask);
    b_u16(b, texel_mask);
    b_u8(b, (uint8_t)top);
    b_u64(b, acc0);
    b_u64(b, 0);
    b_u64(b, 0);
    b_u64(b, 0);
}

/* "PFLM", version, raw length (claimed), then raw deflated. */
static uint8_t *wrap(const buf_t *raw, uint32_t version, uint64_t claimed, size_t *len)
{
    uLongf clen = compressBound(raw->n);
    uint8_t *out = malloc(16 + clen);
    assert_int_equal(compress2(out + 16, &clen, raw->b, raw->n, 6), Z_OK);
    memcpy(out, "PFLM", 4);
    for (int i = 0; i < 4; i++)
        out[4 + i] = (uint8_t)(version >> (8 * i));
    for (int i = 0; i < 8; i++)
        out[8 + i] = (uint8_t)(claimed >> (8 * i));
    *len = 16 + clen;
    return out;
}

/* Decoding must fail with a message containing `want`. */
static void expect_reject(const scene_t *s, const uint8_t *data, size_t len, size_t max_bytes,
                          const char *want)
{
    err_t err = {{0}};
    lightmap_t *m = lightmap_decode(s, 100.0, grid4(), data, len, max_bytes, &err);
    if (m) {
        lightmap_destroy(&m);
        fail_msg("decoded data that should fail with \"%s\"", want);
    }
    if (!strstr(err.msg, want))
        fail_msg("expected \"%s\" in \"%s\"", want, err.msg);
    printf("  rejected: %s\n", err.msg);
}

static void expect_reject_raw(const scene_t *s, const buf_t *raw, const char *want)
{
    size_t len;
    uint8_t *data = wrap(raw, 1, raw->n, &len);
    expect_reject(s, data, len, 1 << 20, want);
    free(data);
}

/* One surface with one texel: the quad's triangle 0 (m = 10 at density 100, so 3x3 tiles of
 * 4x4, the last row and column half outside the grid). */
static buf_t one_texel(uint32_t instance, uint32_t shape, uint32_t prim, uint32_t side,
                       uint64_t tile, uint16_t texel_mask, int8_t top, uint64_t acc0)
{
    buf_t b = {.n = 0};
    b_head(&b, NB, 400.0, 720.0, 100.0, 1);
    b_surface(&b, instance, shape, prim, side, 1);
    b_tile(&b, tile, 0x02, texel_mask, top, acc0);
    return b;
}

static void test_decode_rejects(void **state)
{
    (void)state;
    err_t err;
    scene_t *s = mixed_scene();
    const uint32_t W = GEOMETRY_NO_INSTANCE;
    /* The hand-built payload is valid: texel 0 of triangle 0, bucket 1, sum 3 * 2^0 = 3. */
    buf_t ok = one_texel(W, 0, 0, 0, 0, 0x0001, 0, 3);
    size_t len;
    uint8_t *data = wrap(&ok, 1, ok.n, &len);
    lightmap_t *m = lightmap_decode(s, 100.0, grid4(), data, len, 1 << 20, &err);
    if (!m)
        fail_msg("valid payload refused: %s", err.msg);
    double pw[NB];
    assert_int_equal(lightmap_texel_power(m, (lightmap_texel_t){W, 0, 0, 0, 0}, pw), 1);
    assert_true(pw[0] == 0.0 && pw[1] == 3.0 && pw[2] == 0.0);
    assert_int_equal(lightmap_emitted(m), 7);
    lightmap_destroy(&m);
    free(data);

    /* Framing */
    uint8_t junk[64] = "PFLM";
    expect_reject(s, junk, 10, 1 << 20, "shorter than its 16-byte header");
    data = wrap(&ok, 1, ok.n, &len);
    expect_reject(s, data, len - 5, 1 << 20, "truncated");
    expect_reject(s, data, len, ok.n - 1, "more than the");
    data[0] = 'X';
    expect_reject(s, data, len, 1 << 20, "bad magic");
    free(data);
    data = wrap(&ok, 2, ok.n, &len);
    expect_reject(s, data, len, 1 << 20, "format version 2");
    free(data);
    data = wrap(&ok, 1, ok.n + 8, &len);
    expect_reject(s, data, len, 1 << 20, "inflates to");
    free(data);
    data = wrap(&ok, 1, ok.n - 8, &len);
    expect_reject(s, data, len, 1 << 20, "inflates to more than the");
    free(data);
    data = wrap(&ok, 1, ok.n, &len);
    data[20] ^= 0xff; /* inside the deflate stream */
    expect_reject(s, data, len, 1 << 20, "light map data:");
    free(data);
    memcpy(junk + 4, "\x01\0\0\0\x40\0\0\0\0\0\0\0", 12);
    memset(junk + 16, 0x55, 48);
    expect_reject(s, junk, 64, 1 << 20, "corrupt compressed stream");
    {
        buf_t b = ok;
        b_u8(&b, 0);
        expect_reject_raw(s, &b, "1 bytes after the last surface");
    }

    /* Header */
    {
        buf_t b = {.n = 0};
        b_head(&b, 16, 400.0, 720.0, 100.0, 0);
        expect_reject_raw(s, &b, "16 buckets, the job's film has 4");
        b.n = 0;
        b_head(&b, NB, NAN, 720.0, 100.0, 0);
        expect_reject_raw(s, &b, "wavelength range");
        b.n = 0;
        b_head(&b, NB, 400.0, 720.0, NAN, 0);
        expect_reject_raw(s, &b, "density nan");
        b.n = 0;
        b_head(&b, NB, 400.0, 720.0, 100.0, UINT64_MAX);
        expect_reject_raw(s, &b, "surfaces cannot fit");
        b.n = 0;
        b_head(&b, NB, 400.0, 720.0, 100.0, 0);
        b.b[4] = 1;
        expect_reject_raw(s, &b, "reserved field");
    }

    /* Keys */
    buf_t b;
    b = one_texel(W, 3, 0, 0, 0, 1, 0, 3);
    expect_reject_raw(s, &b, "shape 3 does not exist");
    b = one_texel(W, 0, 2, 0, 0, 1, 0, 3);
    expect_reject_raw(s, &b, "triangle 2 of shape 0 does not exist");
    b = one_texel(W, 1, 5, 0, 0, 1, 0, 3);
    expect_reject_raw(s, &b, "prim must be 0");
    b = one_texel(5, 2, 0, 0, 0, 1, 0, 3);
    expect_reject_raw(s, &b, "instance 5 does not exist");
    b = one_texel(W, 2, 0, 0, 0, 1, 0, 3);
    expect_reject_raw(s, &b, "no instance is named");
    b = one_texel(0, 0, 0, 0, 0, 1, 0, 3);
    expect_reject_raw(s, &b, "not part of instance 0");
    b = one_texel(W, 0, 0, 2, 0, 1, 0, 3);
    expect_reject_raw(s, &b, "side 2");
    b = one_texel(W, 0, 0, 0, 9, 1, 0, 3);
    expect_reject_raw(s, &b, "tile 9 is outside");
    /* tile 2 covers x = 8..11: slot 3 is x = 11 >= 10 */
    b = one_texel(W, 0, 0, 0, 2, 1u << 3, 0, 3);
    expect_reject_raw(s, &b, "texel 3 is outside");
    b = one_texel(W, 0, 0, 0, 6, 1u << 12, 0, 3); /* y = 8 + 3 */
    expect_reject_raw(s, &b, "texel 12 is outside");
    b = one_texel(W, 0, 0, 0, 0, 0, 0, 3);
    expect_reject_raw(s, &b, "empty texel mask");

    /* Values: Inf (2^64 * 2^(24 * 42) overflows), non-canonical zero lead, bins out of range */
    b = one_texel(W, 0, 0, 0, 0, 1, 42, UINT64_MAX);
    expect_reject_raw(s, &b, "not a finite canonical value");
    b = one_texel(W, 0, 0, 0, 0, 1, 0, 0);
    expect_reject_raw(s, &b, "not a finite canonical value");
    b = one_texel(W, 0, 0, 0, 0, 1, 100, 1);
    expect_reject_raw(s, &b, "not a finite canonical value");
    b = one_texel(W, 0, 0, 0, 0, 1, -100, 1);
    expect_reject_raw(s, &b, "not a finite canonical value");

    /* Structure */
    b.n = 0;
    b_head(&b, NB, 400.0, 720.0, 100.0, 2);
    b_surface(&b, W, 0, 1, 0, 1);
    b_tile(&b, 0, 0x02, 1, 0, 3);
    b_surface(&b, W, 0, 0, 0, 1); /* triangle 0 after triangle 1 */
    b_tile(&b, 0, 0x02, 1, 0, 3);
    expect_reject_raw(s, &b, "surface 1 is out of order or repeated");
    b.n = 0;
    b_head(&b, NB, 400.0, 720.0, 100.0, 1);
    b_surface(&b, W, 0, 0, 0, 2);
    b_tile(&b, 4, 0x02, 1, 0, 3);
    b_tile(&b, 4, 0x02, 1, 0, 3);
    expect_reject_raw(s, &b, "tile 4 is out of order");
    b.n = 0;
    b_head(&b, NB, 400.0, 720.0, 100.0, 1);
    b_surface(&b, W, 0, 0, 0, 1);
    b_u64(&b, 0);
    b_u8(&b, 0x00);
    expect_reject_raw(s, &b, "holds no bucket");
    b.n = 0;
    b_head(&b, NB, 400.0, 720.0, 100.0, 1);
    b_surface(&b, W, 0, 0, 0, 1);
    b_tile(&b, 0, 0x12, 1, 0, 3);
    expect_reject_raw(s, &b, "beyond the film's 4");
    b.n = 0;
    b_head(&b, NB, 400.0, 720.0, 100.0, 1);
    b_surface(&b, W, 0, 0, 0, 1000);
    b_tile(&b, 0, 0x02, 1, 0, 3);
    expect_reject_raw(s, &b, "1000 tiles");
    b.n = 0;
    b_head(&b, NB, 400.0, 720.0, 100.0, 1);
    b_surface(&b, W, 0, 0, 0, 1);
    b_tile(&b, 0, 0x02, 3, 0, 3); /* two texels announced, one present */
    expect_reject_raw(s, &b, "ends early");

    /* Memory: nine small tiles inflate to 468 bytes but need a 16 KB slab and a table. */
    b.n = 0;
    b_head(&b, NB, 400.0, 720.0, 100.0, 1);
    b_surface(&b, W, 0, 0, 0, 9);
    for (uint64_t t = 0; t < 9; t++)
        b_tile(&b, t, 0x01, 1, 0, 1);
    data = wrap(&b, 1, b.n, &len);
    expect_reject(s, data, len, 4096, "would hold more than 4096 bytes");
    m = lightmap_decode(s, 100.0, grid4(), data, len, 1 << 20, &err);
    assert_non_null(m);
    assert_int_equal(lightmap_texels_used(m), 9);
    lightmap_destroy(&m);
    free(data);

    /* The caller's settings must match. */
    data = wrap(&ok, 1, ok.n, &len);
    assert_null(lightmap_decode(s, 99.0, grid4(), data, len, 1 << 20, &err));
    assert_non_null(strstr(err.msg, "density 100"));
    free(data);
    scene_destroy(&s);
}

/* ------------------------------------------------------------------------------------------ */
/* (7) A billion deposits into one texel stay exact. */

static void test_many_deposits_exact(void **state)
{
    (void)state;
    err_t err;
    scene_t *s = mixed_scene();
    hit_t h = down_at(s, 0.55, 0.35);
    lightmap_t *one = new_map(s, 100.0), *acc = new_map(s, 100.0);
    /* 0.1 is not a binary fraction: x = fl(0.1) = 0.1000000000000000055511151231257827...
     * The closed form of n deposits is n x, and (double)n * x is it correctly rounded. */
    const double x = 0.1;
    const uint64_t n1 = 1000000;
    for (uint64_t i = 0; i < n1; i++)
        deposit(one, &h, UP, 500.0, x);
    lightmap_add_emitted(one, n1);
    lightmap_texel_t t;
    assert_int_equal(lightmap_locate(one, &h, UP, &t, &err), 0);
    double pw[NB];
    assert_int_equal(lightmap_texel_power(one, t, pw), 1);
    assert_true(fabs(pw[1] - (double)n1 * x) <= 1e-15 * (double)n1 * x);
    /* Merging the same million 1000 times is the texel of 1e9 deposits (merge is exact). */
    for (int k = 1; k <= 1000; k++) {
        assert_int_equal(lightmap_merge(acc, one, &err), 0);
        if (k == 100 || k == 1000) {
            double n = (double)k * (double)n1;
            assert_int_equal(lightmap_texel_power(acc, t, pw), 1);
            double rel = fabs(pw[1] - n * x) / (n * x);
            printf("  %.0e deposits of 0.1: relative error %.1e\n", n, rel);
            assert_true(rel <= 1e-12);
            /* Irradiance: n x / (N * texel area * 80 nm), triangle of area 1 at m = 10 */
            double E[NB];
            assert_int_equal(lightmap_irradiance(acc, &h, UP, E), 1);
            double want = n * x / (n * 0.01 * 80.0);
            assert_true(fabs(E[1] - want) <= 1e-12 * want);
        }
    }
    /* The test can fail: a plain double sum of 1e7 deposits of 0.1 is off by ~1e-10. */
    double naive = 0.0;
    for (int i = 0; i < 10000000; i++)
        naive += x;
    double naive_rel = fabs(naive - 1e7 * x) / (1e7 * x);
    printf("  a plain double sum of 1e7 deposits of 0.1: relative error %.1e\n", naive_rel);
    assert_true(naive_rel > 1e-12);
    lightmap_destroy(&one);
    lightmap_destroy(&acc);
    scene_destroy(&s);
}

/* ------------------------------------------------------------------------------------------ */
/* Deposit arguments, and the sparse store's size. */

static void test_deposit_checks(void **state)
{
    (void)state;
    err_t err;
    scene_t *s = mixed_scene();
    lightmap_t *m = new_map(s, 100.0);
    hit_t h = down_at(s, 0.5, 0.5);
    assert_int_equal(lightmap_deposit(m, &h, UP, 500.0, -1.0, &err), -1);
    assert_non_null(strstr(err.msg, "power -1"));
    assert_int_equal(lightmap_deposit(m, &h, UP, 500.0, NAN, &err), -1);
    assert_int_equal(lightmap_deposit(m, &h, UP, 500.0, INFINITY, &err), -1);
    assert_int_equal(lightmap_deposit(m, &h, UP, NAN, 1.0, &err), -1);
    assert_non_null(strstr(err.msg, "wavelength"));
    /* Outside the film, or no power: nothing stored. */
    assert_int_equal(lightmap_deposit(m, &h, UP, 399.0, 1.0, &err), 0);
    assert_int_equal(lightmap_deposit(m, &h, UP, 721.0, 1.0, &err), 0);
    assert_int_equal(lightmap_deposit(m, &h, UP, 500.0, 0.0, &err), 0);
    assert_int_equal(lightmap_texels_used(m), 0);
    size_t empty = lightmap_memory_bytes(m);
    hit_t bad = h;
    bad.shape = 17;
    assert_int_equal(lightmap_deposit(m, &bad, UP, 500.0, 1.0, &err), -1);
    assert_non_null(strstr(err.msg, "shape 17 does not exist"));
    bad = h;
    bad.prim = 2;
    assert_int_equal(lightmap_deposit(m, &bad, UP, 500.0, 1.0, &err), -1);
    /* Irradiance without photons emitted: nothing, not a division by zero. */
    deposit(m, &h, UP, 500.0, 1.0);
    double E[NB];
    assert_int_equal(lightmap_irradiance(m, &h, UP, E), 0);
    assert_true(E[0] == 0.0 && E[1] == 0.0);
    assert_int_equal(lightmap_irradiance(m, &bad, UP, E), 0);
    lightmap_add_emitted(m, 1);
    assert_int_equal(lightmap_irradiance(m, &h, UP, E), 1);
    assert_true(lightmap_memory_bytes(m) > empty);
    /* Settings */
    assert_null(lightmap_new(s, 0.0, grid4(), &err));
    assert_non_null(strstr(err.msg, "density"));
    assert_null(lightmap_new(s, NAN, grid4(), &err));
    spectral_grid_t g = {.n = 0, .lambda_min = 400, .lambda_max = 700};
    assert_null(lightmap_new(s, 100.0, g, &err));
    lightmap_destroy(&m);
    lightmap_destroy(&m); /* a NULL pointer is fine */
    scene_destroy(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_uniform_quad),
        cmocka_unit_test(test_uniform_sphere_and_disk),
        cmocka_unit_test(test_texel_areas),
        cmocka_unit_test(test_instances),
        cmocka_unit_test(test_encode_round_trip),
        cmocka_unit_test(test_caustic_size),
        cmocka_unit_test(test_merge),
        cmocka_unit_test(test_decode_rejects),
        cmocka_unit_test(test_many_deposits_exact),
        cmocka_unit_test(test_deposit_checks),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
