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

#include "fresnel.h"
#include "glass.h"
#include "pbrt_parser.h"
#include "photon_pass.h"
#include "scene.h"
#include "scene_builders.h"
#include "scene_load.h"

#define NB 16 /* the default grid: 16 buckets over 380-720 nm */

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
    scene_t *s = sb_new_scene();
    transform_t id = transform_identity();
    assert_true(scene_add_sphere(s, &id, 1.0, sb_diffuse(s, rho), -1, 0, NULL) >= 0);
    light_t l = {.kind = LIGHT_POINT,
                 .spectrum = sb_constant(s, 1.0),
                 .scale = I,
                 .position = vec3_make(0.1, -0.2, 0.05)};
    assert_true(scene_add_light(s, &l, NULL) >= 0);
    sb_finish(s);
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

/* A collimated beam through a non-absorbing N-SF11 slab at normal incidence onto a screen:
 * photons reflected back leave through the (pass-through) light, the rest land on the screen,
 * so the power deposited in bucket b is T(n) averaged over the bucket times the power emitted
 * in it. The photons of a bucket (N/16, the wavelength sequence spreads them evenly) each
 * land or not, so the fraction has standard error sqrt(T (1 - T) / (N/16)) = 0.0023 at
 * N = 400000; N-SF11's T goes from 0.858 (red) to 0.840 (violet), eight standard errors. */
static void test_slab_transmittance(void **state)
{
    (void)state;
    scene_t *s = sb_new_scene();
    sb_beam(s, vec3_make(0, 0, -1), vec3_make(0, 0, 1), 0.05);
    int glass = sb_material(s, MATERIAL_DIELECTRIC, "N-SF11");
    transform_t front = transform_identity(), back = transform_translate(vec3_make(0, 0, 0.1));
    assert_true(scene_add_disk(s, &front, 1.0, 0.0, glass, -1, 1, NULL) >= 0); /* normal -z */
    assert_true(scene_add_disk(s, &back, 1.0, 0.0, glass, -1, 0, NULL) >= 0);  /* normal +z */
    transform_t screen = transform_translate(vec3_make(0, 0, 1));
    assert_true(scene_add_disk(s, &screen, 2.0, 0.0, sb_diffuse(s, 0.8), -1, 1, NULL) >= 0);
    sb_finish(s);
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
            t += wgt * sb_slab_t(sb_sellmeier(SB_SF11_B, SB_SF11_C, lo + (hi - lo) * k / 8.0));
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
                  first, last, sb_slab_t(sb_sellmeier(SB_SF11_B, SB_SF11_C, 390.625)),
                  sb_slab_t(sb_sellmeier(SB_SF11_B, SB_SF11_C, 709.375)));
    /* Nothing is absorbed: the rest was reflected back and escaped. */
    assert_true(photon_map_power_sum(m) <= st.power_emitted);
    photon_store_destroy(&ps);
    scene_destroy(&s);
}

/* A collimated beam through the prism (geometry in scene_builders.h): per bucket, where Snell's
 * law at both faces puts the beam on the screen, averaged over the bucket's wavelengths
 * (Simpson; the photons' wavelengths are uniform within it), against the centroid of the
 * bucket's photons; and the power that arrives, the two faces' Fresnel transmittances.
 * At PRISM_LAMBDA0 the deviation is the minimum-deviation formula D = 2 asin(n sin(A/2)) - A. */
static void test_prism_beam(void **state)
{
    (void)state;
    sb_prism_t p;
    scene_t *s = sb_prism_build(&p, sb_new_scene());
    double dev0;
    assert_true(fabs(sb_prism_land(&p, PRISM_LAMBDA0, &dev0)) < 1e-9);
    double n0 = sb_sellmeier(SB_BK7_B, SB_BK7_C, PRISM_LAMBDA0);
    double dmin = 2.0 * asin(n0 * sin(PRISM_APEX / 2.0)) - PRISM_APEX;
    assert_true(fabs(dev0 - dmin) < 1e-9);
    print_message("N-BK7 prism: n(%.3f nm) = %.5f, minimum deviation %.4f deg\n", PRISM_LAMBDA0, n0,
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
            pred[b] += wgt * sb_prism_land(&p, lam, NULL) / 24.0;
            /* Transmittances of the central ray at both faces. */
            double n = sb_sellmeier(SB_BK7_B, SB_BK7_C, lam);
            vec3_t d = vec3_make(1, 0, 0), t = d, o = d;
            vec3_t f1 = sb_prism_outward(&p, 0, 1), f2 = sb_prism_outward(&p, 0, 2);
            assert_true(sb_snell(d, f1, 1.0, n, &t));
            assert_true(sb_snell(t, vec3_neg(f2), n, 1.0, &o));
            tt[b] += wgt / 24.0 * sb_fresnel_t(-vec3_dot(d, f1), 1.0, n) *
                     sb_fresnel_t(vec3_dot(t, f2), n, 1.0);
        }
        lo_pos[b] = sb_prism_land(&p, lo, NULL);
        hi_pos[b] = sb_prism_land(&p, hi, NULL);
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
typedef struct report {
    uint64_t last_done, total;
    int calls;
    bool monotone;
} report_t;

static void count_report(void *user, uint64_t done, uint64_t total)
{
    report_t *r = user;
    r->monotone = r->calls == 0 ? true : r->monotone && done > r->last_done;
    r->calls++;
    r->last_done = done;
    r->total = total;
}

static void test_determinism(void **state)
{
    (void)state;
    err_t err;
    sb_prism_t p;
    scene_t *s = sb_prism_build(&p, sb_new_scene());
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
    /* With progress reports each thread traces its range in pieces: the same store, and the
     * reports count up to every photon. */
    const uint64_t R = 3 * PHOTON_PASS_REPORT + 5; /* several pieces per thread */
    s->settings.photon.photons = R;
    photon_store_t *plain = photon_pass_run(s, 1, NULL, NULL, &err);
    report_t rep = {0};
    photon_store_t *reported = photon_pass_run_reporting(s, 2, NULL, NULL, count_report, &rep, &err);
    assert_non_null(plain);
    assert_non_null(reported);
    assert_same_maps(photon_store_map(plain), photon_store_map(reported));
    assert_int_equal(rep.last_done, R);
    assert_int_equal(rep.total, R);
    assert_true(rep.calls >= 4);
    assert_true(rep.monotone);
    photon_store_destroy(&plain);
    photon_store_destroy(&reported);
    assert_int_equal(photon_store_finish(merged, &err), 0);
    assert_same_maps(photon_store_map(one), photon_store_map(merged));
    photon_store_destroy(&one);
    photon_store_destroy(&three);
    photon_store_destroy(&whole);
    photon_store_destroy(&merged);
    scene_destroy(&s);
}

/* The power threshold is an unbiased cull: behind a mirror of reflectance 0.3 (pbrt-v4's
 * reading: eta 1, k = 2 sqrt(0.3) / sqrt(0.7), so R = 0.3 at normal incidence and R45 at the
 * 45 degrees here) a photon falls to R45 of its power; with threshold 0.5 it survives with
 * probability R45 / 0.5 at 0.5, so the deposited power keeps its expectation (R45 per photon)
 * with fewer photons. */
static void test_threshold_roulette(void **state)
{
    (void)state;
    err_t err;
    scene_t *s = sb_new_scene();
    sb_beam(s, vec3_make(0, 0, -1), vec3_make(0, 0, 1), 0.05);
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
    assert_true(scene_add_disk(s, &screen, 1.0, 0.0, sb_diffuse(s, 0.5), -1, 0, &err) >= 0);
    sb_finish(s);
    const uint64_t N = 40000;
    photon_store_t *ps = photon_store_new(s, &err);
    const photon_map_t *m = photon_store_map(ps);
    photon_job_t job = {.seed = 3, .maxdepth = 5, .mindepth = 1, .threshold = 0.5,
                        .monochromerays = 1, .policy = PHOTON_STORE_CAUSTIC};
    photon_stats_t st = {0};
    assert_int_equal(photon_trace(s, &job, 0, N, ps, &st, &err), 0);
    double frac = photon_map_power_sum(m) / st.power_emitted;
    double kept = (double)photon_map_count(m) / (double)N;
    const double r45 = fresnel_conductor(sqrt(0.5), 1.0, 2.0 * sqrt(0.3) / sqrt(0.7));
    const double q = r45 / 0.5; /* survival probability */
    assert_true(r45 > 0.3 && r45 < 0.5);
    /* Survival is Bernoulli(q) at power 0.5: se of the power fraction 0.5 sqrt(q (1-q) / N). */
    double se = 0.5 * sqrt(q * (1 - q) / (double)N);
    print_message("threshold: %.4f of the power deposited by %.3f of the photons (expected %.4f "
                  "by %.3f)\n",
                  frac, kept, r45, q);
    assert_true(fabs(frac - r45) < 4.0 * se);
    assert_true(fabs(kept - q) < 4.0 * sqrt(q * (1 - q) / (double)N));
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
    scene_t *s = sb_new_scene();
    sb_beam(s, vec3_make(0, 0, -1), vec3_make(0, 0, 1), 0.05);
    light_t pl = {.kind = LIGHT_POINT,
                  .spectrum = sb_constant(s, 1.0),
                  .scale = 50.0,
                  .position = vec3_make(0, 1, 0)};
    assert_true(scene_add_light(s, &pl, NULL) >= 0);
    transform_t screen = transform_translate(vec3_make(0, 0, 1));
    assert_true(scene_add_disk(s, &screen, 2.0, 0.0, sb_diffuse(s, 0.8), -1, 1, NULL) >= 0);
    sb_finish(s);
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

static void expect_error(const char *integrator, const char *fragment)
{
    char text[1024];
    snprintf(text, sizeof text, "%s\nWorldBegin\nLightSource \"point\"\n", integrator);
    err_t err = {{0}};
    scene_t *s = sb_load_text(text, &err);
    if (s || !strstr(err.msg, fragment))
        fail_msg("%s: expected an error with '%s', got '%s'", integrator, fragment,
                 s ? "(loaded)" : err.msg);
}

static void test_scene_parameters(void **state)
{
    (void)state;
    err_t err = {{0}};
    scene_t *s = sb_load_text(
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
    s = sb_load_text("Integrator \"photon\"\nWorldBegin\nLightSource \"point\"\nShape \"sphere\"\n",
                     &err);
    assert_non_null(s);
    assert_int_equal(s->settings.integrator, INTEGRATOR_PATH);
    assert_int_equal(s->settings.photon.photons, 1000000);
    assert_int_equal(s->settings.photon.k, 0);
    assert_true(fabs(photon_gather_radius(s) - 0.01 * s->scene_radius) < 1e-15);
    scene_destroy(&s);
    /* Other integrators have no photon pass. */
    s = sb_load_text("Integrator \"path\"\nWorldBegin\nLightSource \"point\"\n", &err);
    assert_false(s->settings.photon.enabled);
    scene_destroy(&s);
    /* An override to another integrator leaves the photon parameters unused but accepted. */
    const char *text =
        "Integrator \"photon\" \"integer photons\" 10\nWorldBegin\nLightSource \"point\"\n";
    scene_overrides_t ov = {.seed = -1, .integrator = "whitted"};
    s = sb_load_text_with(text, &ov, NULL);
    assert_false(s->settings.photon.enabled);
    assert_int_equal(s->settings.integrator, INTEGRATOR_WHITTED);
    scene_destroy(&s);

    expect_error("Integrator \"photon\" \"string store\" \"box\"",
                 "\"box\" (\"photonmap\" or \"lightmap\")");
    expect_error("Integrator \"photon\" \"integer monochromerays\" 65", "1..64");
    expect_error("Integrator \"photon\" \"string gather\" \"simplepath\"",
                 "unsupported \"string gather\" \"simplepath\" (\"path\" or \"whitted\")");
    expect_error("Integrator \"photon\" \"integer photons\" 0", "at least 1");
    expect_error("Integrator \"photon\" \"float radius\" 0", "must be positive");
    expect_error("Integrator \"photon\" \"integer k\" 5000", "0..1024");
    expect_error("Integrator \"photon\" \"float threshold\" 1", "[0, 1)");
    expect_error("Integrator \"photon\" \"integer mindepth\" 0", "1..10000");
    expect_error("Integrator \"photon\" \"float lightmapdensity\" -4", "texels per unit area");
    expect_error("Integrator \"path\" \"integer photons\" 5", "photons");
}

/* The pass on this machine: a finished store, its figures reported, and a scene whose only
 * light is an environment (which emits no photons) fails with a clear message. */
static void test_pass_run_reports(void **state)
{
    (void)state;
    err_t err;
    sb_prism_t p;
    scene_t *s = sb_prism_build(&p, sb_new_scene());
    s->settings.photon.enabled = 1;
    s->settings.photon.photons = 5000;
    photon_stats_t st;
    double sec = -1;
    photon_stats_t st_zero = {0};
    st = st_zero;
    photon_store_t *a = photon_pass_run(s, 2, &st, &sec, &err);
    assert_non_null(a);
    assert_true(photon_store_finished(a));
    assert_int_equal(st.emitted, 5000);
    assert_true(sec >= 0.0);
    photon_store_destroy(&a);
    scene_destroy(&s);

    s = sb_new_scene();
    light_t env = {.kind = LIGHT_INFINITE, .spectrum = sb_constant(s, 1.0), .scale = 1.0};
    assert_true(scene_add_light(s, &env, NULL) >= 0);
    transform_t id = transform_identity();
    assert_true(scene_add_sphere(s, &id, 1.0, sb_material(s, MATERIAL_DIELECTRIC, "N-BK7"), -1, 0,
                                 NULL) >= 0);
    sb_finish(s);
    s->settings.photon.enabled = 1;
    s->settings.photon.photons = 10;
    assert_null(photon_pass_run(s, 1, NULL, NULL, &err));
    assert_non_null(strstr(err.msg, "environment"));
    err.msg[0] = 0;
    assert_null(photon_pass_run(s, 2, NULL, NULL, &err));
    assert_non_null(strstr(err.msg, "environment"));
    /* The camera pass of a photon scene refuses to run without the store. */
    tilebuf_t *t = tilebuf_new(0, 0, 4, 4, s->settings.grid.n, &err);
    assert_non_null(t);
    s->settings.xres = s->settings.yres = 4;
    assert_int_equal(render_tile(s, NULL, 0, 0, 4, 4, 0, 1, t, NULL, &err), -1);
    assert_non_null(strstr(err.msg, "photon pass"));
    tilebuf_destroy(&t);
    scene_destroy(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_energy_closed_sphere), cmocka_unit_test(test_slab_transmittance),
        cmocka_unit_test(test_prism_beam),           cmocka_unit_test(test_determinism),
        cmocka_unit_test(test_threshold_roulette),   cmocka_unit_test(test_collimated_direct),
        cmocka_unit_test(test_scene_parameters),     cmocka_unit_test(test_pass_run_reports),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
