/* photon: the photon tracer against optics -- energy in a closed diffuse sphere (the photon
 * furnace), a glass slab's transmittance per bucket, a collimated beam through an N-BK7
 * prism landing where Snell's law at both faces puts each bucket -- and determinism of
 * batches and threads; plus the "photon" integrator's scene parameters. Scenes are built
 * through the scene API; every oracle is computed here from its formula, with the SCHOTT
 * Sellmeier coefficients written out, not taken from the renderer. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "glass.h"
#include "pbrt_parser.h"
#include "photon.h"
#include "scene.h"
#include "scene_load.h"

#define NB 16 /* the default grid: 16 buckets over 380-720 nm */

static scene_t *new_scene(void)
{
    err_t err;
    scene_t *s = scene_new(&err);
    assert_non_null(s);
    s->settings.seed = 7;
    return s;
}

static const spectrum_t *constant(scene_t *s, double v)
{
    err_t err;
    spectrum_t *sp = spectrum_new_constant(v, &err);
    assert_non_null(sp);
    assert_int_equal(scene_own_spectrum(s, sp, &err), 0);
    return sp;
}

static int diffuse(scene_t *s, double albedo)
{
    err_t err;
    spectrum_t *sp = spectrum_new_constant(albedo, &err);
    texture_t *t = texture_new_constant(sp, &err);
    assert_non_null(t);
    assert_int_equal(scene_own_texture(s, t, &err), 0);
    material_t m = {.kind = MATERIAL_DIFFUSE, .reflectance = t};
    strcpy(m.name, "diffuse");
    int i = scene_add_material(s, &m, &err);
    assert_true(i >= 0);
    return i;
}

static int material(scene_t *s, material_kind_t kind, const char *glass)
{
    err_t err;
    material_t m = {.kind = kind};
    if (glass)
        m.ior = glass_find(glass)->ior;
    snprintf(m.name, sizeof m.name, "%s", glass ? glass : "m");
    int i = scene_add_material(s, &m, &err);
    assert_true(i >= 0);
    return i;
}

static void finish(scene_t *s)
{
    err_t err;
    if (scene_finish(s, &err))
        fail_msg("scene_finish: %s", err.msg);
}

/* Photons [0, n) into a new store (the scene's kind, a photon map unless a test says
 * otherwise); the test reads the map through photon_store_map. */
static photon_store_t *trace_store(const scene_t *s, photon_store_policy_t policy, int maxdepth,
                                   uint64_t n, photon_stats_t *st)
{
    err_t err;
    photon_store_t *m = photon_store_new(s, &err);
    assert_non_null(m);
    photon_job_t job = {.seed = s->settings.seed, .maxdepth = maxdepth, .mindepth = 1,
                        .threshold = 0.0, .monochromerays = 1, .policy = policy};
    memset(st, 0, sizeof *st);
    if (photon_trace(s, &job, 0, n, m, st, &err))
        fail_msg("photon_trace: %s", err.msg);
    assert_int_equal(st->emitted, n);
    assert_int_equal(photon_store_emitted(m), n);
    assert_int_equal(st->nonfinite, 0);
    return m;
}

/* Photon furnace: a point light at the centre of a closed diffuse sphere of albedo rho. The
 * thesis's store deposits every hit but the first (direct) one, and a photon reaches hit
 * k + 1 with probability rho^k carrying its full power (Russian roulette on the albedo), so
 * over maxdepth M the deposits sum to
 *   Phi (rho + rho^2 + ... + rho^M) = Phi rho (1 - rho^M) / (1 - rho),
 * which is also the bound "emitted power times the albedo bound" that no store may exceed.
 * The number of deposits per photon is geometric, variance rho / (1 - rho)^2, so the mean
 * of N photons has standard error sqrt(rho / N) / (1 - rho). */
static void test_energy_closed_sphere(void **state)
{
    (void)state;
    const double rho = 0.5, I = 2.0;
    const int M = 40;
    scene_t *s = new_scene();
    transform_t id = transform_identity();
    assert_true(scene_add_sphere(s, &id, 1.0, diffuse(s, rho), -1, 0, NULL) >= 0);
    light_t l = {.kind = LIGHT_POINT,
                 .spectrum = constant(s, 1.0),
                 .scale = I,
                 .position = vec3_make(0.1, -0.2, 0.05)};
    assert_true(scene_add_light(s, &l, NULL) >= 0);
    finish(s);
    const uint64_t N = 100000;
    photon_stats_t st;
    photon_store_t *ps = trace_store(s, PHOTON_STORE_ALL, M, N, &st);
    const photon_map_t *m = photon_store_map(ps);
    /* Every photon starts with Phi(lambda) / p_lambda = 4 pi I (range) W/nm. */
    const double range = 720.0 - 380.0, w = 4.0 * PF_PI * I * range;
    assert_true(fabs(st.power_emitted / (double)N / w - 1.0) < 1e-12);
    assert_int_equal(st.escaped, 0);
    double expect = rho * (1.0 - pow(rho, M)) / (1.0 - rho);
    double se = sqrt(rho / (double)N) / (1.0 - rho);
    double ratio = photon_map_power_sum(m) / st.power_emitted;
    print_message("photon furnace: deposited / emitted = %.5f, expected %.5f (se %.5f)\n", ratio,
                  expect, se);
    assert_true(fabs(ratio - expect) < 4.0 * se);
    assert_true(ratio <= rho / (1.0 - rho) + 4.0 * se);
    assert_true(fabs(st.power_deposited / st.power_emitted - ratio) < 1e-6); /* float storage */
    /* Per bucket: the wavelengths are spread evenly, so each bucket holds 1/16 of it. */
    double bucket[NB] = {0};
    for (size_t i = 0; i < photon_map_count(m); i++) {
        photon_info_t ph = photon_map_photon(m, i);
        assert_true(fabs(vec3_length(ph.p) - 1.0) < 1e-6);
        bucket[ph.bucket] += ph.power;
    }
    for (int b = 0; b < NB; b++) {
        double r = bucket[b] / (st.power_emitted / NB);
        if (!(fabs(r - expect) < 4.0 * se * sqrt((double)NB) + 2e-3))
            fail_msg("bucket %d: deposited / emitted %.4f, expected %.4f", b, r, expect);
    }
    photon_store_destroy(&ps);
    /* The caustic store has nothing to hold here: no specular surface. */
    ps = trace_store(s, PHOTON_STORE_CAUSTIC, M, 1000, &st);
    assert_int_equal(photon_map_count(photon_store_map(ps)), 0);
    photon_store_destroy(&ps);
    scene_destroy(&s);
}

/* SCHOTT Sellmeier coefficients (SCHOTT optical glass data sheets 2017), lambda in um. */
static double sellmeier(const double B[3], const double C[3], double lambda_nm)
{
    double l2 = lambda_nm * lambda_nm * 1e-6;
    return sqrt(1.0 + B[0] * l2 / (l2 - C[0]) + B[1] * l2 / (l2 - C[1]) + B[2] * l2 / (l2 - C[2]));
}
static const double SF11_B[3] = {1.73759695, 0.313747346, 1.89878101};
static const double SF11_C[3] = {0.013188707, 0.0623068142, 155.23629};
static const double BK7_B[3] = {1.03961212, 0.231792344, 1.01046945};
static const double BK7_C[3] = {0.00600069867, 0.0200179144, 103.560653};

/* A collimated disk light of radius r at `at`, emitting along `dir`, with irradiance 1. */
static void beam(scene_t *s, vec3_t at, vec3_t dir, double r)
{
    err_t err;
    light_t l = {.kind = LIGHT_COLLIMATED, .spectrum = constant(s, 1.0), .scale = 1.0};
    int li = scene_add_light(s, &l, &err);
    assert_true(li >= 0);
    /* The disk's normal +z turned onto dir. */
    vec3_t z = vec3_normalize(dir), x, y;
    vec3_basis(z, &x, &y);
    double m[4][4] = {
        {x.x, y.x, z.x, at.x}, {x.y, y.y, z.y, at.y}, {x.z, y.z, z.z, at.z}, {0, 0, 0, 1}};
    transform_t t = transform_from_matrix(m);
    assert_true(scene_add_disk(s, &t, r, 0.0, material(s, MATERIAL_INTERFACE, NULL), li, 0, &err) >=
                0);
}

/* Transmittance of a slab at normal incidence with every internal reflection summed
 * (incoherently): T = (1 - R)^2 / (1 - R^2) = (1 - R) / (1 + R) with R = ((n-1)/(n+1))^2,
 * which is 2n / (n^2 + 1). */
static double slab_t(double n)
{
    return 2.0 * n / (n * n + 1.0);
}

/* A collimated beam through a non-absorbing N-SF11 slab at normal incidence onto a screen:
 * photons reflected back leave through the (pass-through) light, the rest land on the screen,
 * so the power deposited in bucket b is T(n) averaged over the bucket times the power emitted
 * in it. The photons of a bucket (N/16, the wavelength sequence spreads them evenly) each
 * land or not, so the fraction has standard error sqrt(T (1 - T) / (N/16)) = 0.0023 at
 * N = 400000; N-SF11's T goes from 0.858 (red) to 0.840 (violet), eight standard errors. */
static void test_slab_transmittance(void **state)
{
    (void)state;
    scene_t *s = new_scene();
    beam(s, vec3_make(0, 0, -1), vec3_make(0, 0, 1), 0.05);
    int glass = material(s, MATERIAL_DIELECTRIC, "N-SF11");
    transform_t front = transform_identity(), back = transform_translate(vec3_make(0, 0, 0.1));
    assert_true(scene_add_disk(s, &front, 1.0, 0.0, glass, -1, 1, NULL) >= 0); /* normal -z */
    assert_true(scene_add_disk(s, &back, 1.0, 0.0, glass, -1, 0, NULL) >= 0);  /* normal +z */
    transform_t screen = transform_translate(vec3_make(0, 0, 1));
    assert_true(scene_add_disk(s, &screen, 2.0, 0.0, diffuse(s, 0.8), -1, 1, NULL) >= 0);
    finish(s);
    const uint64_t N = 400000;
    photon_stats_t st;
    photon_store_t *ps = trace_store(s, PHOTON_STORE_CAUSTIC, 200, N, &st);
    const photon_map_t *m = photon_store_map(ps);
    const double per_bucket = st.power_emitted / NB;
    double dep[NB] = {0};
    for (size_t i = 0; i < photon_map_count(m); i++) {
        photon_info_t ph = photon_map_photon(m, i);
        assert_true(fabs(ph.p.z - 1.0) < 1e-6);
        assert_true(hypot(ph.p.x, ph.p.y) <= 0.05 + 1e-6);
        dep[ph.bucket] += ph.power;
    }
    spectral_grid_t g = s->settings.grid;
    double first = 0, last = 0;
    for (int b = 0; b < NB; b++) {
        /* T averaged over the bucket (Simpson, 8 panels). */
        double lo = spectral_grid_bucket_min(g, b), hi = spectral_grid_bucket_max(g, b), t = 0;
        for (int k = 0; k <= 8; k++) {
            double wgt = k == 0 || k == 8 ? 1 : k % 2 ? 4 : 2;
            t += wgt * slab_t(sellmeier(SF11_B, SF11_C, lo + (hi - lo) * k / 8.0));
        }
        t /= 24.0;
        double got = dep[b] / per_bucket;
        double se = sqrt(t * (1.0 - t) / (N / (double)NB));
        /* The bucket's photon count may differ from N/16 by a couple of photons. */
        double tol = 4.0 * se + 3.0 / (N / (double)NB);
        if (!(fabs(got - t) < tol))
            fail_msg("bucket %d: transmitted %.4f, slab formula %.4f (tolerance %.4f)", b, got, t,
                     tol);
        if (b == 0)
            first = got;
        last = got;
    }
    print_message("N-SF11 slab: T = %.4f (violet bucket) .. %.4f (red), formula %.4f .. %.4f\n",
                  first, last, slab_t(sellmeier(SF11_B, SF11_C, 390.625)),
                  slab_t(sellmeier(SF11_B, SF11_C, 709.375)));
    /* Nothing is absorbed: the rest was reflected back and escaped. */
    assert_true(photon_map_power_sum(m) <= st.power_emitted);
    photon_store_destroy(&ps);
    scene_destroy(&s);
}

/* The prism test's geometry: an equilateral N-BK7 prism (side 0.1, height 0.2, axis y) set at
 * minimum deviation for LAMBDA0 (the centre of bucket 8) under a collimated beam along +x of
 * radius 0.5 mm through the middle of its first face, and a screen 5 m away perpendicular to
 * the beam leaving at LAMBDA0. */
#define LAMBDA0 560.625
#define APEX (PF_PI / 3.0)
#define THROW 5.0

typedef struct prism {
    vec3_t v[3];               /* the triangle in the y = 0 plane */
    vec3_t entry;              /* where the beam's axis meets the first face */
    vec3_t exit_dir0;          /* leaving direction at LAMBDA0 */
    vec3_t exit0;              /* where it leaves at LAMBDA0 */
    vec3_t screen_c, screen_e; /* screen centre and its horizontal axis */
} prism_t;

/* Snell's law in vector form (Born & Wolf 1.5): d unit, n unit facing the incident side. */
static int snell(vec3_t d, vec3_t n, double n1, double n2, vec3_t *t)
{
    double c = -vec3_dot(d, n), eta = n1 / n2, k = 1.0 - eta * eta * (1.0 - c * c);
    if (k < 0.0)
        return 0;
    *t = vec3_normalize(vec3_add(vec3_scale(d, eta), vec3_scale(n, eta * c - sqrt(k))));
    return 1;
}

static vec3_t outward(const prism_t *p, int a, int b)
{
    vec3_t e = vec3_sub(p->v[b], p->v[a]);
    vec3_t n = vec3_normalize(vec3_make(e.z, 0, -e.x));
    vec3_t c = vec3_scale(vec3_add(vec3_add(p->v[0], p->v[1]), p->v[2]), 1.0 / 3.0);
    return vec3_dot(n, vec3_sub(p->v[a], c)) < 0 ? vec3_neg(n) : n;
}

/* The central ray at wavelength lambda: into face (v0 v1), out of face (v0 v2), onto the
 * screen plane; returns its coordinate along screen_e and the deviation angle. */
static double land(const prism_t *p, double lambda, double *deviation)
{
    double n = sellmeier(BK7_B, BK7_C, lambda);
    vec3_t d = vec3_make(1, 0, 0), t, o;
    assert_true(snell(d, outward(p, 0, 1), 1.0, n, &t));
    vec3_t n2 = outward(p, 0, 2);
    double s = vec3_dot(vec3_sub(p->v[0], p->entry), n2) / vec3_dot(t, n2);
    vec3_t q = vec3_fma(p->entry, t, s);
    assert_true(snell(t, vec3_neg(n2), n, 1.0, &o));
    if (deviation)
        *deviation = acos(fmin(1.0, vec3_dot(o, d)));
    vec3_t sn = p->exit_dir0;
    double u = vec3_dot(vec3_sub(p->screen_c, q), sn) / vec3_dot(o, sn);
    return vec3_dot(vec3_sub(vec3_fma(q, o, u), p->screen_c), p->screen_e);
}

static scene_t *prism_scene(prism_t *p)
{
    /* In the prism's own frame the apex is up (+w), the base along u; at minimum deviation
     * the ray inside runs parallel to the base, so the beam meets the first face at
     * i0 = asin(n0 sin(A/2)) and travels at i0 - A/2 above the base. The frame is turned so
     * that the beam runs along +x. */
    double n0 = sellmeier(BK7_B, BK7_C, LAMBDA0);
    double i0 = asin(n0 * sin(APEX / 2.0));
    double a = -(i0 - APEX / 2.0), side = 0.1, h = side * sqrt(3.0) / 2.0;
    double uv[3][2] = {{0.0, h}, {-side / 2.0, 0.0}, {side / 2.0, 0.0}};
    for (int k = 0; k < 3; k++)
        p->v[k] = vec3_make(uv[k][0] * cos(a) - uv[k][1] * sin(a), 0.0,
                            uv[k][0] * sin(a) + uv[k][1] * cos(a));
    p->entry = vec3_scale(vec3_add(p->v[0], p->v[1]), 0.5);
    vec3_t t;
    assert_true(snell(vec3_make(1, 0, 0), outward(p, 0, 1), 1.0, n0, &t));
    vec3_t n2 = outward(p, 0, 2);
    p->exit0 = vec3_fma(p->entry, t, vec3_dot(vec3_sub(p->v[0], p->entry), n2) / vec3_dot(t, n2));
    assert_true(snell(t, vec3_neg(n2), n0, 1.0, &p->exit_dir0));
    p->screen_c = vec3_fma(p->exit0, p->exit_dir0, THROW);
    p->screen_e = vec3_normalize(vec3_cross(vec3_make(0, 1, 0), p->exit_dir0));

    scene_t *s = new_scene();
    beam(s, vec3_fma(p->entry, vec3_make(1, 0, 0), -0.2), vec3_make(1, 0, 0), 0.0005);
    double P[18];
    for (int k = 0; k < 6; k++) {
        vec3_t q = p->v[k % 3];
        P[3 * k] = q.x;
        P[3 * k + 1] = k < 3 ? -0.1 : 0.1;
        P[3 * k + 2] = q.z;
    }
    uint32_t tri[8][3] = {{0, 1, 2}, {3, 5, 4}, {0, 3, 4}, {0, 4, 1},
                          {1, 4, 5}, {1, 5, 2}, {2, 5, 3}, {2, 3, 0}};
    /* Orient every triangle outward (normal = (p0 - p2) x (p1 - p2), pbrt-v4's rule). */
    vec3_t c = vec3_make((p->v[0].x + p->v[1].x + p->v[2].x) / 3, 0,
                         (p->v[0].z + p->v[1].z + p->v[2].z) / 3);
    for (int k = 0; k < 8; k++) {
        vec3_t q[3];
        for (int j = 0; j < 3; j++)
            q[j] = vec3_make(P[3 * tri[k][j]], P[3 * tri[k][j] + 1], P[3 * tri[k][j] + 2]);
        vec3_t nrm = vec3_cross(vec3_sub(q[0], q[2]), vec3_sub(q[1], q[2]));
        vec3_t mid = vec3_scale(vec3_add(vec3_add(q[0], q[1]), q[2]), 1.0 / 3.0);
        if (vec3_dot(nrm, vec3_sub(mid, c)) < 0) {
            uint32_t x = tri[k][0];
            tri[k][0] = tri[k][1];
            tri[k][1] = x;
        }
    }
    assert_true(scene_add_mesh(s, P, 6, &tri[0][0], 8, NULL, NULL,
                               material(s, MATERIAL_DIELECTRIC, "N-BK7"), -1, 0, NULL) >= 0);
    /* The screen: a 0.6 x 0.6 square. */
    vec3_t e = p->screen_e, y = vec3_make(0, 1, 0), sc = p->screen_c;
    double S[12];
    vec3_t corners[4] = {vec3_add(sc, vec3_add(vec3_scale(e, -0.3), vec3_scale(y, -0.3))),
                         vec3_add(sc, vec3_add(vec3_scale(e, 0.3), vec3_scale(y, -0.3))),
                         vec3_add(sc, vec3_add(vec3_scale(e, 0.3), vec3_scale(y, 0.3))),
                         vec3_add(sc, vec3_add(vec3_scale(e, -0.3), vec3_scale(y, 0.3)))};
    for (int k = 0; k < 4; k++) {
        S[3 * k] = corners[k].x;
        S[3 * k + 1] = corners[k].y;
        S[3 * k + 2] = corners[k].z;
    }
    uint32_t sq[6] = {0, 1, 2, 0, 2, 3};
    assert_true(scene_add_mesh(s, S, 4, sq, 2, NULL, NULL, diffuse(s, 0.8), -1, 0, NULL) >= 0);
    finish(s);
    return s;
}

/* Unpolarised Fresnel transmittance, cosine form (Born & Wolf 1.5.2). */
static double fresnel_t(double cos_i, double n1, double n2)
{
    double sin_t = n1 / n2 * sqrt(fmax(0.0, 1.0 - cos_i * cos_i));
    if (sin_t >= 1.0)
        return 0.0;
    double cos_t = sqrt(1.0 - sin_t * sin_t);
    double rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
    double rp = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t);
    return 1.0 - 0.5 * (rs * rs + rp * rp);
}

/* A collimated beam through the prism (geometry in prism_scene): per bucket, where Snell's
 * law at both faces puts the beam on the screen, averaged over the bucket's wavelengths
 * (Simpson; the photons' wavelengths are uniform within it), against the centroid of the
 * bucket's photons; and the power that arrives, the two faces' Fresnel transmittances.
 * At LAMBDA0 the deviation is the minimum-deviation formula D = 2 asin(n sin(A/2)) - A. */
static void test_prism_beam(void **state)
{
    (void)state;
    prism_t p;
    scene_t *s = prism_scene(&p);
    double dev0;
    assert_true(fabs(land(&p, LAMBDA0, &dev0)) < 1e-9);
    double n0 = sellmeier(BK7_B, BK7_C, LAMBDA0);
    double dmin = 2.0 * asin(n0 * sin(APEX / 2.0)) - APEX;
    assert_true(fabs(dev0 - dmin) < 1e-9);
    print_message("N-BK7 prism: n(%.3f nm) = %.5f, minimum deviation %.4f deg\n", LAMBDA0, n0,
                  dmin * 180 / PF_PI);

    const uint64_t N = 100000;
    photon_stats_t st;
    photon_store_t *ps = trace_store(s, PHOTON_STORE_CAUSTIC, 10, N, &st);
    const photon_map_t *m = photon_store_map(ps);
    spectral_grid_t g = s->settings.grid;
    double pred[NB], lo_pos[NB], hi_pos[NB], tt[NB];
    for (int b = 0; b < NB; b++) {
        double lo = spectral_grid_bucket_min(g, b), hi = spectral_grid_bucket_max(g, b);
        pred[b] = 0.0;
        tt[b] = 0.0;
        for (int k = 0; k <= 8; k++) {
            double lam = lo + (hi - lo) * k / 8.0, wgt = k == 0 || k == 8 ? 1 : k % 2 ? 4 : 2;
            pred[b] += wgt * land(&p, lam, NULL) / 24.0;
            /* Transmittances of the central ray at both faces. */
            double n = sellmeier(BK7_B, BK7_C, lam);
            vec3_t d = vec3_make(1, 0, 0), t, o;
            vec3_t f1 = outward(&p, 0, 1), f2 = outward(&p, 0, 2);
            assert_true(snell(d, f1, 1.0, n, &t));
            assert_true(snell(t, vec3_neg(f2), n, 1.0, &o));
            tt[b] += wgt / 24.0 * fresnel_t(-vec3_dot(d, f1), 1.0, n) *
                     fresnel_t(vec3_dot(t, f2), n, 1.0);
        }
        lo_pos[b] = land(&p, lo, NULL);
        hi_pos[b] = land(&p, hi, NULL);
    }
    /* Photons of bucket b on the screen within three buckets' spacing of the prediction. */
    double sum[NB] = {0}, sq[NB] = {0}, cnt[NB] = {0}, pow_in[NB] = {0};
    for (size_t i = 0; i < photon_map_count(m); i++) {
        photon_info_t ph = photon_map_photon(m, i);
        double x = vec3_dot(vec3_sub(ph.p, p.screen_c), p.screen_e);
        int b = ph.bucket;
        if (fabs(x - pred[b]) > 3.0 * fabs(hi_pos[b] - lo_pos[b]))
            continue;
        sum[b] += x;
        sq[b] += x * x;
        cnt[b] += 1;
        pow_in[b] += ph.power;
    }
    double worst = 0;
    for (int b = 0; b < NB; b++) {
        assert_true(cnt[b] > 100);
        double mean = sum[b] / cnt[b], var = fmax(0.0, sq[b] / cnt[b] - mean * mean);
        double se = sqrt(var / cnt[b]);
        double spacing = fabs(hi_pos[b] - lo_pos[b]);
        /* 4 standard errors, and float storage of positions 5 m from the origin. */
        double tol = 4.0 * se + 2e-6;
        worst = fmax(worst, fabs(mean - pred[b]) / spacing);
        if (!(fabs(mean - pred[b]) < tol))
            fail_msg(
                "bucket %d: centroid %.6f m, Snell %.6f m (tolerance %.6f, bucket spans %.6f m)", b,
                mean, pred[b], tol, spacing);
        /* The power that took the path: both faces' Fresnel transmittances. */
        double frac = pow_in[b] / (st.power_emitted / NB);
        double fse = sqrt(tt[b] * (1.0 - tt[b]) / (N / (double)NB));
        if (!(fabs(frac - tt[b]) < 4.0 * fse + 3.0 / (N / (double)NB)))
            fail_msg("bucket %d: fraction %.4f through both faces, Fresnel %.4f", b, frac, tt[b]);
    }
    print_message(
        "prism: buckets land %.1f mm (violet) to %.1f mm (red) from the minimum-deviation point; "
        "worst centroid error %.4f of a bucket's width\n",
        1e3 * pred[0], 1e3 * pred[NB - 1], worst);
    /* The store resolves the buckets: a gather of a third of a bucket's width at bucket b's
     * landing point sees bucket b, and of buckets two away only the odd photon that took
     * another path through the prism (internal reflections): under 1/1000 of it. */
    err_t err;
    assert_int_equal(photon_store_finish(ps, &err), 0);
    for (int b = 2; b < NB - 2; b++) {
        double E[NB];
        vec3_t q = vec3_fma(p.screen_c, p.screen_e, pred[b]);
        double r = fabs(hi_pos[b] - lo_pos[b]) / 3.0;
        assert_true(photon_map_irradiance(m, q, vec3_neg(p.exit_dir0), r, 0, E) > 0);
        if (!(E[b] > 0.0 && E[b - 2] < 1e-3 * E[b] && E[b + 2] < 1e-3 * E[b]))
            fail_msg("bucket %d: gather of radius %.2g mm sees %g, buckets %d and %d %g and %g", b,
                     1e3 * r, E[b], b - 2, b + 2, E[b - 2], E[b + 2]);
    }
    assert_true(photon_map_power_sum(m) <= st.power_emitted);
    photon_store_destroy(&ps);
    scene_destroy(&s);
}

static void assert_same_maps(const photon_map_t *a, const photon_map_t *b)
{
    assert_int_equal(photon_map_count(a), photon_map_count(b));
    assert_int_equal(photon_map_emitted(a), photon_map_emitted(b));
    for (size_t i = 0; i < photon_map_count(a); i++) {
        photon_info_t x = photon_map_photon(a, i), y = photon_map_photon(b, i);
        assert_memory_equal(&x, &y, sizeof x);
    }
}

/* The same photons whatever the batches: [0, N) in one call, in three uneven batches merged
 * in order, and the whole pass with 1 and 3 threads, give identical maps. */
static void test_determinism(void **state)
{
    (void)state;
    err_t err;
    prism_t p;
    scene_t *s = prism_scene(&p);
    const uint64_t N = 20000;
    photon_stats_t st;
    photon_store_t *whole = trace_store(s, PHOTON_STORE_CAUSTIC, 10, N, &st);
    photon_store_t *merged = photon_store_new(s, &err);
    uint64_t cuts[4] = {0, 1, 7777, N};
    photon_job_t job = {.seed = s->settings.seed, .maxdepth = 10, .mindepth = 1,
                        .monochromerays = 1, .policy = PHOTON_STORE_CAUSTIC};
    for (int k = 0; k < 3; k++) {
        photon_store_t *part = photon_store_new(s, &err);
        assert_int_equal(photon_trace(s, &job, cuts[k], cuts[k + 1], part, NULL, &err), 0);
        /* Through the wire form, as the farm's batches travel. */
        uint8_t *bytes;
        size_t len;
        assert_int_equal(photon_store_encode(part, &bytes, &len, &err), 0);
        photon_store_t *back = photon_store_decode(s, bytes, len, &err);
        assert_non_null(back);
        assert_int_equal(photon_store_merge(merged, back, &err), 0);
        free(bytes);
        photon_store_destroy(&back);
        photon_store_destroy(&part);
    }
    assert_same_maps(photon_store_map(whole), photon_store_map(merged));
    assert_int_equal(photon_store_emitted(merged), N);
    assert_true(photon_store_count(whole) > N / 2);
    /* Another seed gives other photons. */
    job.seed = 8;
    photon_store_t *other = photon_store_new(s, &err);
    assert_int_equal(photon_trace(s, &job, 0, 100, other, NULL, &err), 0);
    photon_info_t x = photon_map_photon(photon_store_map(whole), 0),
                  y = photon_map_photon(photon_store_map(other), 0);
    assert_true(memcmp(&x, &y, sizeof x) != 0);
    photon_store_destroy(&other);

    s->settings.photon.photons = N;
    s->settings.photon.maxdepth = 10;
    s->settings.photon.threshold = 0.0;
    s->settings.visible_sampling = 0; /* as the jobs above: uniform wavelengths */
    photon_store_t *one = photon_pass_run(s, 1, NULL, NULL, &err);
    photon_store_t *three = photon_pass_run(s, 3, NULL, NULL, &err);
    assert_non_null(one);
    assert_non_null(three);
    assert_same_maps(photon_store_map(one), photon_store_map(three));
    assert_int_equal(photon_store_finish(merged, &err), 0);
    assert_same_maps(photon_store_map(one), photon_store_map(merged));
    photon_store_destroy(&one);
    photon_store_destroy(&three);
    photon_store_destroy(&whole);
    photon_store_destroy(&merged);
    scene_destroy(&s);
}

/* The power threshold is an unbiased cull: behind a mirror of reflectance 0.3 a photon falls
 * to 0.3 of its power; with threshold 0.5 it survives with probability 0.6 at 0.5, so the
 * deposited power keeps its expectation (0.3 per photon) with fewer photons. */
static void test_threshold_roulette(void **state)
{
    (void)state;
    err_t err;
    scene_t *s = new_scene();
    beam(s, vec3_make(0, 0, -1), vec3_make(0, 0, 1), 0.05);
    spectrum_t *r = spectrum_new_constant(0.3, &err);
    texture_t *t = texture_new_constant(r, &err);
    assert_int_equal(scene_own_texture(s, t, &err), 0);
    material_t mirror = {.kind = MATERIAL_CONDUCTOR, .reflectance = t};
    int mi = scene_add_material(s, &mirror, &err);
    /* A mirror tilted 45 degrees sends the beam along +x onto a screen. */
    transform_t rot;
    assert_int_equal(transform_rotate(45.0, vec3_make(0, 1, 0), &rot, &err), 0);
    assert_true(scene_add_disk(s, &rot, 0.5, 0.0, mi, -1, 0, &err) >= 0);
    transform_t rs;
    assert_int_equal(transform_rotate(90.0, vec3_make(0, 1, 0), &rs, &err), 0);
    transform_t screen = transform_compose(transform_translate(vec3_make(-1, 0, 0)), rs);
    assert_true(scene_add_disk(s, &screen, 1.0, 0.0, diffuse(s, 0.5), -1, 0, &err) >= 0);
    finish(s);
    const uint64_t N = 40000;
    photon_store_t *ps = photon_store_new(s, &err);
    const photon_map_t *m = photon_store_map(ps);
    photon_job_t job = {.seed = 3, .maxdepth = 5, .mindepth = 1, .threshold = 0.5,
                        .monochromerays = 1, .policy = PHOTON_STORE_CAUSTIC};
    photon_stats_t st = {0};
    assert_int_equal(photon_trace(s, &job, 0, N, ps, &st, &err), 0);
    double frac = photon_map_power_sum(m) / st.power_emitted;
    double kept = (double)photon_map_count(m) / (double)N;
    /* Survival is Bernoulli(0.6) at power 0.5: se of the power fraction 0.5 sqrt(0.24 / N). */
    double se = 0.5 * sqrt(0.24 / (double)N);
    print_message(
        "threshold: %.4f of the power deposited by %.3f of the photons (expected 0.3 by 0.6)\n",
        frac, kept);
    assert_true(fabs(frac - 0.3) < 4.0 * se);
    assert_true(fabs(kept - 0.6) < 4.0 * sqrt(0.24 / (double)N));
    for (size_t i = 0; i < photon_map_count(m); i += 97)
        assert_true(fabs(photon_map_photon(m, i).power / (st.power_emitted / N) - 0.5) < 1e-6);
    photon_store_destroy(&ps);
    scene_destroy(&s);
}

/* A collimated beam straight onto a screen: no camera path can find that light, so the
 * caustic store keeps its direct light too, every photon at full power on the beam's disk
 * (no glass in the scene, so a point light beside it emits no photons at all). */
static void test_collimated_direct(void **state)
{
    (void)state;
    scene_t *s = new_scene();
    beam(s, vec3_make(0, 0, -1), vec3_make(0, 0, 1), 0.05);
    light_t pl = {.kind = LIGHT_POINT,
                  .spectrum = constant(s, 1.0),
                  .scale = 50.0,
                  .position = vec3_make(0, 1, 0)};
    assert_true(scene_add_light(s, &pl, NULL) >= 0);
    transform_t screen = transform_translate(vec3_make(0, 0, 1));
    assert_true(scene_add_disk(s, &screen, 2.0, 0.0, diffuse(s, 0.8), -1, 1, NULL) >= 0);
    finish(s);
    photon_stats_t st;
    photon_store_t *ps = trace_store(s, PHOTON_STORE_CAUSTIC, 5, 2000, &st);
    const photon_map_t *m = photon_store_map(ps);
    assert_int_equal(photon_map_count(m), 2000);
    assert_true(fabs(photon_map_power_sum(m) / st.power_emitted - 1.0) < 1e-6);
    /* The beam's power: irradiance 1 over pi r^2, over the 340 nm range. */
    assert_true(fabs(st.power_emitted / 2000.0 - PF_PI * 0.05 * 0.05 * 340.0) < 1e-9);
    for (size_t i = 0; i < photon_map_count(m); i++) {
        photon_info_t ph = photon_map_photon(m, i);
        assert_true(hypot(ph.p.x, ph.p.y) <= 0.05 + 1e-6);
    }
    photon_store_destroy(&ps);
    scene_destroy(&s);
}

static scene_t *load_text(const char *text, err_t *err)
{
    scene_desc_t *d = pbrt_parse_string(text, strlen(text), "t.pbrt", err);
    if (!d)
        return NULL;
    scene_t *s = scene_load(d, NULL, err);
    scene_desc_destroy(&d);
    return s;
}

static void expect_error(const char *integrator, const char *fragment)
{
    char text[1024];
    snprintf(text, sizeof text, "%s\nWorldBegin\nLightSource \"point\"\n", integrator);
    err_t err = {{0}};
    scene_t *s = load_text(text, &err);
    if (s || !strstr(err.msg, fragment))
        fail_msg("%s: expected an error with '%s', got '%s'", integrator, fragment,
                 s ? "(loaded)" : err.msg);
}

static void test_scene_parameters(void **state)
{
    (void)state;
    err_t err = {{0}};
    scene_t *s = load_text(
        "Integrator \"photon\" \"integer photons\" 12345 \"float radius\" 0.25 \"integer k\" 30\n"
        "  \"string gather\" \"whitted\" \"integer maxdepth\" 7 \"float threshold\" 0.05\n"
        "  \"string store\" \"photonmap\" \"integer monochromerays\" 1 \"string dispersion\" "
        "\"fanout\"\n"
        "WorldBegin\nLightSource \"point\"\n",
        &err);
    if (!s)
        fail_msg("%s", err.msg);
    const render_settings_t *rs = &s->settings;
    assert_true(rs->photon.enabled);
    assert_int_equal(rs->integrator, INTEGRATOR_WHITTED);
    assert_int_equal(rs->photon.photons, 12345);
    assert_true(rs->photon.radius == 0.25);
    assert_int_equal(rs->photon.k, 30);
    assert_int_equal(rs->photon.maxdepth, 7);
    assert_int_equal(rs->maxdepth, 7);
    assert_true(rs->photon.threshold == 0.05);
    assert_int_equal(rs->dispersion, DISPERSION_FANOUT);
    assert_true(photon_gather_radius(s) == 0.25);
    scene_destroy(&s);
    /* Defaults: path gather, a million photons, automatic radius. */
    s = load_text("Integrator \"photon\"\nWorldBegin\nLightSource \"point\"\nShape \"sphere\"\n",
                  &err);
    assert_non_null(s);
    assert_int_equal(s->settings.integrator, INTEGRATOR_PATH);
    assert_int_equal(s->settings.photon.photons, 1000000);
    assert_int_equal(s->settings.photon.k, 0);
    assert_true(fabs(photon_gather_radius(s) - 0.01 * s->scene_radius) < 1e-15);
    scene_destroy(&s);
    /* Other integrators have no photon pass. */
    s = load_text("Integrator \"path\"\nWorldBegin\nLightSource \"point\"\n", &err);
    assert_false(s->settings.photon.enabled);
    scene_destroy(&s);
    /* An override to another integrator leaves the photon parameters unused but accepted. */
    const char *text =
        "Integrator \"photon\" \"integer photons\" 10\nWorldBegin\nLightSource \"point\"\n";
    scene_desc_t *d = pbrt_parse_string(text, strlen(text), "t.pbrt", &err);
    scene_overrides_t ov = {.seed = -1, .integrator = "whitted"};
    s = scene_load(d, &ov, &err);
    scene_desc_destroy(&d);
    if (!s)
        fail_msg("%s", err.msg);
    assert_false(s->settings.photon.enabled);
    assert_int_equal(s->settings.integrator, INTEGRATOR_WHITTED);
    scene_destroy(&s);

    expect_error("Integrator \"photon\" \"string store\" \"box\"", "must be \"photonmap\" or \"lightmap\"");
    expect_error("Integrator \"photon\" \"integer monochromerays\" 65", "1..64");
    expect_error("Integrator \"photon\" \"string gather\" \"simplepath\"",
                 "\"string gather\" must be");
    expect_error("Integrator \"photon\" \"integer photons\" 0", "at least 1");
    expect_error("Integrator \"photon\" \"float radius\" 0", "must be positive");
    expect_error("Integrator \"photon\" \"integer k\" 5000", "0..1024");
    expect_error("Integrator \"photon\" \"float threshold\" 1", "[0, 1)");
    expect_error("Integrator \"photon\" \"integer mindepth\" 0", "1..10000");
    expect_error("Integrator \"photon\" \"float lightmapdensity\" -4", "texels per unit area");
    expect_error("Integrator \"path\" \"integer photons\" 5", "photons");
}

/* The lazily built pass: the same map for every caller, figures reported, and a scene whose
 * only light is an environment (which emits no photons) fails with a clear message. */
static void test_pass_kept_with_scene(void **state)
{
    (void)state;
    err_t err;
    prism_t p;
    scene_t *s = prism_scene(&p);
    s->settings.photon.enabled = 1;
    s->settings.photon.photons = 5000;
    photon_stats_t st;
    double sec = -1;
    const photon_store_t *a = photon_pass_get(s, &st, &sec, &err);
    assert_non_null(a);
    assert_true(photon_store_finished(a));
    assert_int_equal(st.emitted, 5000);
    assert_true(sec >= 0.0);
    assert_ptr_equal(photon_pass_get(s, NULL, NULL, &err), a);
    scene_destroy(&s);

    s = new_scene();
    light_t env = {.kind = LIGHT_INFINITE, .spectrum = constant(s, 1.0), .scale = 1.0};
    assert_true(scene_add_light(s, &env, NULL) >= 0);
    transform_t id = transform_identity();
    assert_true(
        scene_add_sphere(s, &id, 1.0, material(s, MATERIAL_DIELECTRIC, "N-BK7"), -1, 0, NULL) >= 0);
    finish(s);
    s->settings.photon.enabled = 1;
    s->settings.photon.photons = 10;
    assert_null(photon_pass_get(s, NULL, NULL, &err));
    assert_non_null(strstr(err.msg, "environment"));
    err.msg[0] = 0;
    assert_null(photon_pass_get(s, NULL, NULL, &err));
    assert_non_null(strstr(err.msg, "environment"));
    scene_destroy(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_energy_closed_sphere), cmocka_unit_test(test_slab_transmittance),
        cmocka_unit_test(test_prism_beam),           cmocka_unit_test(test_determinism),
        cmocka_unit_test(test_threshold_roulette),   cmocka_unit_test(test_collimated_direct),
        cmocka_unit_test(test_scene_parameters),     cmocka_unit_test(test_pass_kept_with_scene),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
