/* photon_map: the kd-tree against brute force, the density estimate against a deposit of
 * known density, and the store's size. Photons are placed by a fixed-seed generator. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "photon_map.h"
#include "rng.h"

static spectral_grid_t grid8(void)
{
    spectral_grid_t g;
    assert_int_equal(spectral_grid_init(&g, 8, 400.0, 720.0, NULL), 0);
    return g;
}

/* A photon map of n photons scattered in the unit cube, on the faces z = 0 (normal +z) and
 * x = 0 (normal +x), with powers and wavelengths from the RNG. */
static photon_map_t *random_map(size_t n, uint64_t seed)
{
    err_t err;
    photon_map_t *m = photon_map_new(grid8(), &err);
    assert_non_null(m);
    for (size_t i = 0; i < n; i++) {
        double u[4];
        rng_uniform4(seed, i, 0, 0, u);
        int wall = rng_uniform(seed, i, 0, 4) < 0.3;
        vec3_t p = wall ? vec3_make(0.0, u[0], u[1]) : vec3_make(u[0], u[1], 0.0);
        vec3_t n_ = wall ? vec3_make(1, 0, 0) : vec3_make(0, 0, 1);
        double lambda = 400.0 + 320.0 * u[2];
        assert_int_equal(photon_map_deposit(m, p, vec3_neg(n_), n_, lambda, 1.0 + u[3], &err), 0);
    }
    photon_map_add_emitted(m, 1000);
    return m;
}

/* Every photon within r, by brute force, with the same normal rule as the map. */
static int brute_force(const photon_map_t *m, vec3_t q, vec3_t n, double r, double *E)
{
    spectral_grid_t g = photon_map_grid(m);
    for (int b = 0; b < g.n; b++)
        E[b] = 0.0;
    int used = 0;
    for (size_t i = 0; i < photon_map_count(m); i++) {
        photon_info_t ph = photon_map_photon(m, i);
        vec3_t d = vec3_sub(ph.p, q);
        if (vec3_dot(d, d) <= r * r && vec3_dot(ph.normal, n) > 0.5) {
            E[ph.bucket] += ph.power;
            used++;
        }
    }
    double scale = 1.0 / ((double)photon_map_emitted(m) * spectral_grid_width(g) * PF_PI * r * r);
    for (int b = 0; b < g.n; b++)
        E[b] *= scale;
    return used;
}

static void test_fixed_radius_matches_brute_force(void **state)
{
    (void)state;
    err_t err;
    photon_map_t *m = random_map(20000, 7);
    assert_int_equal(photon_map_build(m, &err), 0);
    for (int k = 0; k < 200; k++) {
        double u[4];
        rng_uniform4(99, (uint64_t)k, 0, 0, u);
        int wall = u[3] < 0.3;
        vec3_t q = wall ? vec3_make(0.0, u[0], u[1]) : vec3_make(u[0], u[1], 0.0);
        vec3_t n = wall ? vec3_make(1, 0, 0) : vec3_make(0, 0, 1);
        double r = 0.02 + 0.1 * u[2];
        double E[8], F[8];
        int a = photon_map_irradiance(m, q, n, r, 0, E);
        int b = brute_force(m, q, n, r, F);
        assert_int_equal(a, b);
        for (int i = 0; i < 8; i++)
            if (!(fabs(E[i] - F[i]) <= 1e-12 * fmax(1.0, F[i])))
                fail_msg("query %d bucket %d: tree %.17g, brute force %.17g", k, i, E[i], F[i]);
    }
    photon_map_destroy(&m);
}

/* What photon_map_gather hands over, summed: power per bucket, and the power-weighted sum of
 * the photons' directions (each decoded to within its 8-bit octahedral code). */
typedef struct visit_sum {
    double E[8];
    vec3_t dir;
    int n;
} visit_sum_t;

static void visit_add(void *user, vec3_t dir, int bucket, double power)
{
    visit_sum_t *v = user;
    assert_true(bucket >= 0 && bucket < 8);
    assert_true(fabs(vec3_length(dir) - 1.0) < 1e-9);
    v->E[bucket] += power;
    v->dir = vec3_fma(v->dir, dir, power);
    v->n++;
}

/* The glossy receiver's query: the photons photon_map_irradiance takes, and those on the other
 * side of n as well (a floor's photons seen from below, which the receiver's BSDF weighs),
 * each with its direction; times *scale it is the irradiance when f is 1. On the random map's
 * floor every photon travels along -z: the directions come back as that. */
static void test_gather_both_sides_with_directions(void **state)
{
    (void)state;
    err_t err;
    photon_map_t *m = random_map(20000, 11);
    assert_int_equal(photon_map_build(m, &err), 0);
    for (int k = 0; k < 100; k++) {
        double u[4];
        rng_uniform4(98, (uint64_t)k, 0, 0, u);
        vec3_t q = vec3_make(0.2 + 0.6 * u[0], 0.2 + 0.6 * u[1], 0.0);
        double r = 0.02 + 0.1 * u[2];
        double E[8], F[8], scale;
        visit_sum_t up = {.n = 0}, down = {.n = 0};
        int a = photon_map_irradiance(m, q, vec3_make(0, 0, 1), r, 0, E);
        int b = photon_map_gather(m, q, vec3_make(0, 0, 1), r, 0, visit_add, &up, &scale);
        int c = photon_map_gather(m, q, vec3_make(0, 0, -1), r, 0, visit_add, &down, &scale);
        /* Below the floor, irradiance sees nothing; the two-sided gather sees the same photons. */
        assert_int_equal(photon_map_irradiance(m, q, vec3_make(0, 0, -1), r, 0, F), 0);
        assert_int_equal(a, b);
        assert_int_equal(b, c);
        assert_int_equal(up.n, a);
        if (a == 0)
            continue;
        assert_true(scale > 0.0);
        for (int i = 0; i < 8; i++) {
            assert_true(fabs(up.E[i] * scale - E[i]) <= 1e-12 * fmax(1.0, E[i]));
            assert_true(up.E[i] == down.E[i]);
        }
        vec3_t d = vec3_normalize(up.dir);
        assert_true(d.z < -0.9999);
    }
    /* k nearest: the same selection as the irradiance's k-nearest search. */
    double E[8], scale;
    visit_sum_t v = {.n = 0};
    int a = photon_map_irradiance(m, vec3_make(0.5, 0.5, 0.0), vec3_make(0, 0, 1), 0.2, 50, E);
    int b = photon_map_gather(m, vec3_make(0.5, 0.5, 0.0), vec3_make(0, 0, 1), 0.2, 50,
                              visit_add, &v, &scale);
    assert_int_equal(a, 50);
    assert_int_equal(b, 50);
    for (int i = 0; i < 8; i++)
        assert_true(fabs(v.E[i] * scale - E[i]) <= 1e-12 * fmax(1.0, E[i]));
    photon_map_destroy(&m);
}

typedef struct dist {
    double d2;
    size_t i;
} dist_t;

static int by_d2(const void *a, const void *b)
{
    double x = ((const dist_t *)a)->d2, y = ((const dist_t *)b)->d2;
    return x < y ? -1 : x > y;
}

static void test_k_nearest_matches_brute_force(void **state)
{
    (void)state;
    err_t err;
    photon_map_t *m = random_map(5000, 11);
    assert_int_equal(photon_map_build(m, &err), 0);
    size_t n = photon_map_count(m);
    dist_t *d = malloc(n * sizeof *d);
    assert_non_null(d);
    const int K = 50;
    for (int k = 0; k < 100; k++) {
        double u[4];
        rng_uniform4(5, (uint64_t)k, 0, 0, u);
        vec3_t q = vec3_make(u[0], u[1], 0.0), nz = vec3_make(0, 0, 1);
        size_t cnt = 0;
        for (size_t i = 0; i < n; i++) {
            photon_info_t ph = photon_map_photon(m, i);
            if (vec3_dot(ph.normal, nz) <= 0.5)
                continue;
            vec3_t dd = vec3_sub(ph.p, q);
            d[cnt++] = (dist_t){vec3_dot(dd, dd), i};
        }
        qsort(d, cnt, sizeof *d, by_d2);
        double rmax = 1.0;
        double F[8] = {0}, E[8];
        for (int j = 0; j < K; j++) {
            photon_info_t ph = photon_map_photon(m, d[j].i);
            F[ph.bucket] += ph.power;
        }
        double r2 = d[K - 1].d2;
        for (int b = 0; b < 8; b++)
            F[b] /= (double)photon_map_emitted(m) * 40.0 * PF_PI * r2;
        assert_int_equal(photon_map_irradiance(m, q, nz, rmax, K, E), K);
        for (int b = 0; b < 8; b++)
            if (!(fabs(E[b] - F[b]) <= 1e-12 * fmax(1.0, F[b])))
                fail_msg("query %d bucket %d: k-nearest %.17g, brute force %.17g", k, b, E[b],
                         F[b]);
        /* Fewer than k within the radius: all of them, over the search radius. */
        double small = sqrt(d[9].d2 + 0.5 * (d[10].d2 - d[9].d2));
        assert_int_equal(photon_map_irradiance(m, q, nz, small, K, E), 10);
        double G[8];
        assert_int_equal(brute_force(m, q, nz, small, G), 10);
        for (int b = 0; b < 8; b++)
            assert_true(fabs(E[b] - G[b]) <= 1e-12 * fmax(1.0, G[b]));
    }
    free(d);
    photon_map_destroy(&m);
}

/* n photons of raw power p deposited uniformly over a 1 x 1 square, n / 8 in each bucket:
 * the irradiance per bucket is (n / 8) p / (N_emitted * width * area) in expectation. A box kernel
 * of radius r well inside the square sees about n pi r^2 photons, so the estimate's relative
 * standard error is 1 / sqrt(n pi r^2 / nbuckets) per bucket. */
static void test_uniform_density(void **state)
{
    (void)state;
    err_t err;
    spectral_grid_t g = grid8();
    photon_map_t *m = photon_map_new(g, &err);
    const size_t n = 400000;
    const double power = 3.0;
    for (size_t i = 0; i < n; i++) {
        double u[4];
        rng_uniform4(3, i, 0, 0, u);
        /* Wavelengths stratified over the buckets, so that each holds n / 8 photons. */
        double lambda = 400.0 + 40.0 * ((double)(i % 8) + u[2]);
        assert_int_equal(photon_map_deposit(m, vec3_make(u[0], 0.5, u[1]), vec3_make(0, -1, 0),
                                            vec3_make(0, 1, 0), lambda, power, &err),
                         0);
    }
    const uint64_t emitted = 2 * n; /* half of the photons "escaped" */
    photon_map_add_emitted(m, emitted);
    assert_int_equal(photon_map_build(m, &err), 0);
    const double expect = (double)n / 8.0 * power / ((double)emitted * 40.0 * 1.0);
    const double r = 0.1;
    double per_bucket = (double)n * PF_PI * r * r / 8.0;
    double tol = 4.0 / sqrt(per_bucket);
    double E[8];
    for (int k = 0; k < 5; k++) {
        vec3_t q = vec3_make(0.3 + 0.1 * k, 0.5, 0.3 + 0.1 * k);
        assert_true(photon_map_irradiance(m, q, vec3_make(0, 1, 0), r, 0, E) > 0);
        for (int b = 0; b < 8; b++)
            if (!(fabs(E[b] / expect - 1.0) < tol))
                fail_msg("bucket %d: %.5f, expected %.5f (tolerance %.3f)", b, E[b], expect, tol);
        /* Seen from the other side (normal -y), nothing. */
        assert_int_equal(photon_map_irradiance(m, q, vec3_make(0, -1, 0), r, 0, E), 0);
        /* k nearest: the same density within its own noise, 1/sqrt(k) overall. */
        assert_true(photon_map_irradiance(m, q, vec3_make(0, 1, 0), 1.0, 800, E) == 800);
        double sum = 0;
        for (int b = 0; b < 8; b++)
            sum += E[b];
        if (!(fabs(sum / 8.0 / expect - 1.0) < 4.0 / sqrt(800.0)))
            fail_msg("k nearest: mean %.5f, expected %.5f", sum / 8.0, expect);
    }
    photon_map_destroy(&m);
}

/* Merging partial stores is concatenation plus emitted counts, and the tree depends only on
 * the deposits and their order. */
static void test_append_and_build_are_deterministic(void **state)
{
    (void)state;
    err_t err;
    photon_map_t *whole = random_map(3000, 21);
    photon_map_t *a = photon_map_new(grid8(), &err), *b = photon_map_new(grid8(), &err);
    for (size_t i = 0; i < 3000; i++) {
        photon_info_t ph = photon_map_photon(whole, i);
        assert_int_equal(photon_map_deposit(i < 1234 ? a : b, ph.p, ph.dir, ph.normal, ph.lambda,
                                            ph.power, &err),
                         0);
    }
    photon_map_add_emitted(a, 400);
    photon_map_add_emitted(b, 600);
    photon_map_t *merged = photon_map_new(grid8(), &err);
    assert_int_equal(photon_map_append(merged, a, &err), 0);
    assert_int_equal(photon_map_append(merged, b, &err), 0);
    assert_int_equal(photon_map_emitted(merged), 1000);
    assert_int_equal(photon_map_count(merged), 3000);
    assert_int_equal(photon_map_build(whole, &err), 0);
    assert_int_equal(photon_map_build(merged, &err), 0);
    for (size_t i = 0; i < 3000; i++) {
        photon_info_t x = photon_map_photon(whole, i), y = photon_map_photon(merged, i);
        assert_memory_equal(&x, &y, sizeof x);
    }
    /* A built map takes no more deposits or merges. */
    assert_int_equal(photon_map_deposit(whole, vec3_make(0, 0, 0), vec3_make(0, 0, -1),
                                        vec3_make(0, 0, 1), 500, 1, &err),
                     -1);
    assert_int_equal(photon_map_append(whole, a, &err), -1);
    photon_map_destroy(&a);
    photon_map_destroy(&b);
    photon_map_destroy(&whole);
    photon_map_destroy(&merged);
    assert_null(merged);
}

/* What a deposit keeps: position to float precision, directions to about a degree (8-bit
 * octahedral: cells of 2/255 in the projected square, at most 1.2 degrees apart), the
 * wavelength to range/65535 and its bucket; nothing non-finite enters. */
static void test_encoding(void **state)
{
    (void)state;
    err_t err;
    photon_map_t *m = photon_map_new(grid8(), &err);
    for (int i = 0; i < 2000; i++) {
        double u[4];
        rng_uniform4(77, (uint64_t)i, 0, 0, u);
        vec3_t dir = vec3_make(2 * u[0] - 1, 2 * u[1] - 1, 2 * u[2] - 1);
        if (vec3_length(dir) < 1e-3)
            continue;
        dir = vec3_normalize(dir);
        double lambda = 400.0 + 320.0 * u[3];
        assert_int_equal(photon_map_deposit(m, vec3_make(u[0], u[1], u[2]), dir, vec3_neg(dir),
                                            lambda, 2.5, &err),
                         0);
        photon_info_t ph = photon_map_photon(m, photon_map_count(m) - 1);
        assert_true(vec3_dot(ph.dir, dir) > cos(1.5 * PF_PI / 180.0));
        assert_true(vec3_dot(ph.normal, vec3_neg(dir)) > cos(1.5 * PF_PI / 180.0));
        assert_true(fabs(ph.lambda - lambda) <= 0.5 * 320.0 / 65535.0 + 1e-9);
        assert_int_equal(ph.bucket, spectral_grid_index(grid8(), lambda));
        assert_true(fabs(ph.p.x - u[0]) < 1e-7 && fabs(ph.p.y - u[1]) < 1e-7 &&
                    fabs(ph.p.z - u[2]) < 1e-7);
        assert_true(ph.power == 2.5);
    }
    size_t n = photon_map_count(m);
    /* Outside the grid: ignored; non-finite: refused. */
    assert_int_equal(photon_map_deposit(m, vec3_make(0, 0, 0), vec3_make(0, 0, 1),
                                        vec3_make(0, 0, -1), 390.0, 1.0, &err),
                     0);
    assert_int_equal(photon_map_deposit(m, vec3_make(0, 0, 0), vec3_make(0, 0, 1),
                                        vec3_make(0, 0, -1), 500.0, NAN, &err),
                     -1);
    assert_int_equal(photon_map_deposit(m, vec3_make(INFINITY, 0, 0), vec3_make(0, 0, 1),
                                        vec3_make(0, 0, -1), 500.0, 1.0, &err),
                     -1);
    assert_int_equal(photon_map_deposit(m, vec3_make(0, 0, 0), vec3_make(0, 0, 1),
                                        vec3_make(0, 0, -1), 500.0, -1.0, &err),
                     -1);
    assert_int_equal(photon_map_count(m), n);
    /* 24 bytes a photon: 24 MB per million, plus the growth slack of the array. */
    assert_int_equal(photon_map_photon_bytes(), 24);
    assert_true(photon_map_memory_bytes(m) >= n * 24);
    /* Unbuilt, empty or bad radius: no estimate. */
    double E[8];
    assert_int_equal(
        photon_map_irradiance(m, vec3_make(0.5, 0.5, 0.5), vec3_make(0, 0, 1), 0.1, 0, E), 0);
    assert_int_equal(photon_map_build(m, &err), 0);
    assert_int_equal(
        photon_map_irradiance(m, vec3_make(0.5, 0.5, 0.5), vec3_make(0, 0, 1), NAN, 0, E), 0);
    assert_int_equal(
        photon_map_irradiance(m, vec3_make(0.5, 0.5, 0.5), vec3_make(0, 0, 1), -1.0, 0, E), 0);
    for (int b = 0; b < 8; b++)
        assert_true(E[b] == 0.0);
    photon_map_destroy(&m);
}

/* Many photons on one point (a collimated beam on a screen): the build must not degrade to
 * quadratic time, and a k-nearest query over them stays finite. */
static void test_coincident_photons(void **state)
{
    (void)state;
    err_t err;
    photon_map_t *m = photon_map_new(grid8(), &err);
    for (int i = 0; i < 200000; i++)
        assert_int_equal(photon_map_deposit(m, vec3_make(1, 2, 3), vec3_make(0, 0, -1),
                                            vec3_make(0, 0, 1), 401.0 + (i % 8) * 40.0, 1.0, &err),
                         0);
    photon_map_add_emitted(m, 200000);
    assert_int_equal(photon_map_build(m, &err), 0);
    double E[8];
    assert_int_equal(photon_map_irradiance(m, vec3_make(1, 2, 3), vec3_make(0, 0, 1), 0.1, 16, E),
                     16);
    for (int b = 0; b < 8; b++)
        assert_true(isfinite(E[b]) && E[b] > 0.0);
    assert_int_equal(photon_map_irradiance(m, vec3_make(1, 2, 3.05), vec3_make(0, 0, 1), 0.1, 0, E),
                     200000);
    photon_map_destroy(&m);
}

/* White photons (photon_map_deposit_white): a white photon of spectrum s and power P counts
 * as P x shape[s][b] in every bucket b, so a map of white photons estimates what a map of
 * coloured photons of those powers does, in the irradiance (to rounding) and in what the
 * gather hands over (bucket PHOTON_MAP_WHITE(s), the row from photon_map_spectrum); the wire
 * form keeps them, a map refuses a white photon of a spectrum it does not know (a deposit, or
 * a build after decoding without spectra), and the power sum weighs them by their row. */
static void visit_white(void *user, vec3_t dir, int bucket, double power)
{
    (void)dir;
    double *sum = user;
    assert_true(bucket == PHOTON_MAP_WHITE(0) || bucket == PHOTON_MAP_WHITE(1));
    sum[PHOTON_MAP_WHITE_SPECTRUM(bucket)] += power;
}

static void test_white_photons(void **state)
{
    (void)state;
    err_t err;
    const spectral_grid_t g = grid8();
    double shape[2 * 8];
    for (int b = 0; b < 8; b++) {
        shape[b] = 1.0 + b;
        shape[8 + b] = b % 2 ? 0.25 : 2.0;
    }
    photon_map_t *w = photon_map_new(g, &err), *c = photon_map_new(g, &err);
    assert_non_null(w);
    assert_non_null(c);
    assert_int_not_equal(photon_map_deposit_white(w, vec3_make(0, 0, 0), vec3_make(0, 0, -1),
                                                  vec3_make(0, 0, 1), 0, 1.0, &err),
                         0);
    assert_int_equal(photon_map_set_spectra(w, 2, shape, &err), 0);
    double total = 0.0;
    for (size_t i = 0; i < 400; i++) {
        double u[4];
        rng_uniform4(11, i, 0, 0, u);
        const vec3_t p = vec3_make(u[0], u[1], 0.0), n = vec3_make(0, 0, 1);
        const int sp = u[3] < 0.5;
        const double power = 0.5 + u[2];
        assert_int_equal(photon_map_deposit_white(w, p, vec3_neg(n), n, sp, power, &err), 0);
        for (int b = 0; b < 8; b++) {
            const double lambda = 400.0 + 40.0 * (b + 0.5);
            assert_int_equal(
                photon_map_deposit(c, p, vec3_neg(n), n, lambda, power * shape[8 * sp + b], &err),
                0);
            total += (float)power * shape[8 * sp + b];
        }
    }
    assert_int_not_equal(photon_map_deposit_white(w, vec3_make(0, 0, 0), vec3_make(0, 0, -1),
                                                  vec3_make(0, 0, 1), 2, 1.0, &err),
                         0);
    assert_true(fabs(photon_map_power_sum(w) / total - 1.0) < 1e-6);
    photon_map_add_emitted(w, 1000);
    photon_map_add_emitted(c, 1000);
    uint8_t *bytes;
    size_t len;
    assert_int_equal(photon_map_encode(w, &bytes, &len, &err), 0);
    photon_map_t *d = photon_map_decode(g, bytes, len, &err);
    free(bytes);
    assert_non_null(d);
    assert_int_not_equal(photon_map_build(d, &err), 0); /* no spectra: refused */
    photon_map_destroy(&d);
    assert_int_equal(photon_map_build(w, &err), 0);
    assert_int_equal(photon_map_build(c, &err), 0);
    assert_true(photon_map_spectrum(w, 1) != NULL && photon_map_spectrum(w, 1)[1] == 0.25);
    assert_null(photon_map_spectrum(w, 2));
    for (int q = 0; q < 20; q++) {
        const vec3_t p = vec3_make(0.1 + 0.04 * q, 0.9 - 0.04 * q, 0.0), n = vec3_make(0, 0, 1);
        double E[8], F[8];
        const int a = photon_map_irradiance(w, p, n, 0.15, 0, E);
        const int b = photon_map_irradiance(c, p, n, 0.15, 0, F);
        assert_int_equal(8 * a, b);
        for (int k = 0; k < 8; k++)
            assert_true(fabs(E[k] - F[k]) <= 1e-6 * F[k] + 1e-300);
        double sum[2] = {0, 0}, scale;
        assert_int_equal(photon_map_gather(w, p, n, 0.15, 0, visit_white, sum, &scale), a);
        double e0 = 0.0;
        for (int k = 0; k < 8; k++)
            e0 += E[k];
        const double from_gather =
            (sum[0] * (1 + 2 + 3 + 4 + 5 + 6 + 7 + 8) + sum[1] * 9.0) * scale;
        assert_true(fabs(from_gather - e0) <= 1e-9 * e0 + 1e-300);
    }
    photon_map_destroy(&w);
    photon_map_destroy(&c);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fixed_radius_matches_brute_force),
        cmocka_unit_test(test_gather_both_sides_with_directions),
        cmocka_unit_test(test_k_nearest_matches_brute_force),
        cmocka_unit_test(test_uniform_density),
        cmocka_unit_test(test_append_and_build_are_deterministic),
        cmocka_unit_test(test_encoding),
        cmocka_unit_test(test_coincident_photons),
        cmocka_unit_test(test_white_photons),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
