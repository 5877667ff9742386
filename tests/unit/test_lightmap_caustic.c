/* lightmap_caustic: the light-map store of the photon integrator (Integrator "photon" "string
 * store" "lightmap") against optics, through photon_trace and photon_store as a job uses them,
 * as test_photon.c and test_photon_caustic.c check the photon map:
 *   1. a collimated beam through an equilateral N-BK7 prism lands where Snell's law at both
 *      faces puts each bucket: the power-weighted centroid of the lit texels within one texel;
 *   2. with a small area light, the photon integrator over a light map and plain path tracing
 *      converge to the same caustic (image mean within 3 %);
 *   3. energy: the full store in a closed diffuse sphere holds the geometric series of the
 *      albedo (uniformly spread, as a sphere's form factor says), the caustic store behind a
 *      slab the slab's transmittance, neither more than emitted power times the albedo bound;
 *   4. the rescale by photons emitted: 16 monochrome rays per photon hold the caustic energy
 *      of 1; batches traced apart and merged in any grouping encode to the bytes of one pass.
 * Every oracle is computed here from its formula (SCHOTT Sellmeier coefficients written out). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "colour.h"
#include "files_testutil.h"
#include "glass.h"
#include "lightmap.h"
#include "photon_pass.h"
#include "photon_testutil.h"
#include "render.h"
#include "scene.h"
#include "scene_builders.h"
#include "scene_load.h"

#define NB 16 /* the default grid: 16 buckets over 380-720 nm */

/* ------------------------------------------------------------------------------------------ */
/* The scenes of these tests: those of scene_builders.h (as test_photon.c's) with a light-map
 * store of `density` texels per square metre, photons deposited from the first bounce. */
static scene_t *lightmap_scene(double density)
{
    scene_t *s = sb_new_scene();
    s->settings.photon.store = PHOTON_STORE_LIGHTMAP;
    s->settings.photon.lightmap_density = density;
    s->settings.photon.mindepth = 1;
    return s;
}

static photon_job_t job_of(const scene_t *s, photon_store_policy_t policy, int maxdepth, int lanes)
{
    return (photon_job_t){.seed = s->settings.seed,
                          .maxdepth = maxdepth,
                          .mindepth = 1,
                          .threshold = 0.0,
                          .monochromerays = lanes,
                          .policy = policy};
}

/* Photons [0, n) into a new light-map store. */
static photon_store_t *trace_store(const scene_t *s, photon_store_policy_t policy, int maxdepth,
                                   uint64_t n, photon_stats_t *st)
{
    err_t err;
    photon_store_t *m = photon_store_new(s, &err);
    if (!m)
        fail_msg("photon_store_new: %s", err.msg);
    assert_int_equal(photon_store_kind(m), PHOTON_STORE_LIGHTMAP);
    photon_job_t job = job_of(s, policy, maxdepth, 1);
    memset(st, 0, sizeof *st);
    if (photon_trace(s, &job, 0, n, m, st, &err))
        fail_msg("photon_trace: %s", err.msg);
    assert_int_equal(st->emitted, n);
    assert_int_equal(photon_store_emitted(m), n);
    assert_int_equal(st->nonfinite, 0);
    /* Every deposit landed in a texel: the map's exact sums against the tracer's running sum
     * (a double, off by at most ~1e-16 per addition). */
    double held = photon_store_power_sum(m);
    assert_true(fabs(held - st->power_deposited) <= 1e-9 * st->power_deposited);
    return m;
}

/* ------------------------------------------------------------------------------------------ */
/* 1. The prism of scene_builders.h (N-BK7 at minimum deviation for PRISM_LAMBDA0 under a
 * collimated beam, a screen 5 m away), with a light-map store. */

/* A screen point (x along screen_e, y along world y) sampled by a ray, and its texel. */
typedef struct texel_sample {
    lightmap_texel_t t;
    double x, y;
} texel_sample_t;

static int cmp_texel(const lightmap_texel_t *a, const lightmap_texel_t *b)
{
    if (a->instance != b->instance)
        return a->instance < b->instance ? -1 : 1;
    if (a->shape != b->shape)
        return a->shape < b->shape ? -1 : 1;
    if (a->prim != b->prim)
        return a->prim < b->prim ? -1 : 1;
    if (a->side != b->side)
        return a->side < b->side ? -1 : 1;
    if (a->index != b->index)
        return a->index < b->index ? -1 : 1;
    return 0;
}

static int cmp_sample(const void *a, const void *b)
{
    return cmp_texel(&((const texel_sample_t *)a)->t, &((const texel_sample_t *)b)->t);
}

/* A lit texel: its centre (the mean of the sample points that fell in it) and power. */
typedef struct lit_texel {
    double x, y;
    double power[NB];
} lit_texel_t;

/* The texels of the screen over [x0, x1] x [y0, y1], found as the camera pass finds them: rays
 * onto the screen from the prism's side, every texel sampled at spacing h (a sixth of the
 * texel side, so that each texel's samples average to its centre). Returns the texels holding
 * power, in *out (malloc'ed). */
static size_t lit_texels(const scene_t *s, const sb_prism_t *p, const lightmap_t *lm, double x0,
                         double x1, double y0, double y1, double h, lit_texel_t **out)
{
    err_t err;
    size_t nx = (size_t)ceil((x1 - x0) / h), ny = (size_t)ceil((y1 - y0) / h), n = 0;
    texel_sample_t *smp = malloc(nx * ny * sizeof *smp);
    assert_non_null(smp);
    vec3_t back = vec3_neg(p->exit_dir0);
    for (size_t j = 0; j < ny; j++)
        for (size_t i = 0; i < nx; i++) {
            double x = x0 + ((double)i + 0.5) * h, y = y0 + ((double)j + 0.5) * h;
            vec3_t q = vec3_add(vec3_fma(p->screen_c, p->screen_e, x), vec3_make(0, y, 0));
            hit_t hit;
            assert_int_equal(geometry_intersect(s->geometry, vec3_fma(q, back, 0.05), p->exit_dir0,
                                                0.0, 0.1, &hit),
                             1);
            assert_int_equal(hit.shape, (uint32_t)p->screen);
            texel_sample_t *t = &smp[n++];
            if (lightmap_locate(lm, &hit, back, &t->t, &err))
                fail_msg("lightmap_locate: %s", err.msg);
            t->x = x;
            t->y = y;
        }
    qsort(smp, n, sizeof *smp, cmp_sample);
    lit_texel_t *lit = malloc(n * sizeof *lit);
    assert_non_null(lit);
    size_t nlit = 0;
    for (size_t a = 0, b; a < n; a = b) {
        double sx = 0, sy = 0;
        for (b = a; b < n && cmp_texel(&smp[a].t, &smp[b].t) == 0; b++) {
            sx += smp[b].x;
            sy += smp[b].y;
        }
        lit_texel_t *l = &lit[nlit];
        if (!lightmap_texel_power(lm, smp[a].t, l->power))
            continue;
        l->x = sx / (double)(b - a);
        l->y = sy / (double)(b - a);
        nlit++;
    }
    free(smp);
    *out = lit;
    return nlit;
}

/* Per bucket b, where Snell's law at both faces puts the beam on the screen: at the bucket's
 * centre wavelength (centre[b]) and averaged over its wavelengths (avg[b], Simpson over 8
 * panels: the photons' wavelengths are uniform within the bucket), the bucket's span on the
 * screen, and the two faces' Fresnel transmittance averaged over it (tt[b]). At PRISM_LAMBDA0 the
 * deviation is the minimum-deviation formula D = 2 asin(n sin(A/2)) - A. */
typedef struct prediction {
    double centre[NB], avg[NB], span[NB], tt[NB];
} prediction_t;

static prediction_t predict(const sb_prism_t *p, spectral_grid_t g)
{
    prediction_t pr;
    for (int b = 0; b < NB; b++) {
        double lo = spectral_grid_bucket_min(g, b), hi = spectral_grid_bucket_max(g, b);
        pr.avg[b] = pr.tt[b] = 0.0;
        for (int k = 0; k <= 8; k++) {
            double lam = lo + (hi - lo) * k / 8.0, wgt = k == 0 || k == 8 ? 1 : k % 2 ? 4 : 2;
            pr.avg[b] += wgt * sb_prism_land(p, lam, NULL) / 24.0;
            double n = sb_sellmeier(SB_BK7_B, SB_BK7_C, lam);
            vec3_t d = vec3_make(1, 0, 0), t = d, o = d;
            vec3_t f1 = sb_prism_outward(p, 0, 1), f2 = sb_prism_outward(p, 0, 2);
            assert_true(sb_snell(d, f1, 1.0, n, &t));
            assert_true(sb_snell(t, vec3_neg(f2), n, 1.0, &o));
            pr.tt[b] += wgt / 24.0 * sb_fresnel_t(-vec3_dot(d, f1), 1.0, n) *
                        sb_fresnel_t(vec3_dot(t, f2), n, 1.0);
        }
        pr.centre[b] = sb_prism_land(p, spectral_grid_centre(g, b), NULL);
        pr.span[b] = fabs(sb_prism_land(p, hi, NULL) - sb_prism_land(p, lo, NULL));
    }
    return pr;
}

/* The light map's centroids per bucket against Snell's law, at a texel side of 1 cm (a bucket
 * spans 4 mm (red) to 24 mm (violet) on the screen: neighbouring buckets share texels) and of
 * 1 mm (a bucket spans several texels).
 * Tolerance: one texel side, 1 / sqrt(density), the light map's resolution. The centroid of
 * texel centres differs from the photons' own centroid by the quantisation to texels (under
 * half a texel where the beam, 1 mm tall, sits inside one row of texels; averaging out along a
 * bucket that spans many), plus the photons' noise: 4 standard errors of the mean of N/16 positions
 * spread over a bucket's span, 4 x 24 mm / sqrt(12 x 6250) = 0.35 mm at worst (red buckets:
 * 0.06 mm). The oracle is the bucket-averaged landing point; the centre wavelength's lies
 * within 0.18 mm of it (printed), and the centroid is asserted within a texel of both.
 * The power that arrives per bucket is the two faces' Fresnel transmittance, as for photons:
 * within 4 binomial standard errors of N/16 photons (the texels near the bucket's prediction
 * count, and whole texels: a few rays that took another path through the prism can add
 * < 1e-3 of it). */
static void test_prism_beam_lands(void **state)
{
    (void)state;
    const double densities[2] = {1e4, 1e6};
    const uint64_t N = 100000;
    for (int di = 0; di < 2; di++) {
        const double d = densities[di], side = 1.0 / sqrt(d);
        sb_prism_t p;
        scene_t *s = sb_prism_build(&p, lightmap_scene(d));
        spectral_grid_t g = s->settings.grid;
        if (di == 0) {
            double dev0, n0 = sb_sellmeier(SB_BK7_B, SB_BK7_C, PRISM_LAMBDA0);
            assert_true(fabs(sb_prism_land(&p, PRISM_LAMBDA0, &dev0)) < 1e-9);
            assert_true(fabs(dev0 - (2.0 * asin(n0 * sin(PRISM_APEX / 2.0)) - PRISM_APEX)) < 1e-9);
        }
        prediction_t pr = predict(&p, g);
        photon_stats_t st;
        photon_store_t *ps = trace_store(s, PHOTON_STORE_CAUSTIC, 10, N, &st);
        const lightmap_t *lm = photon_store_lightmap(ps);
        assert_non_null(lm);
        /* The region to sample: every bucket's window (3 spans either side of its landing
         * point), widened by 3 texel sides so that every texel reaching into a window is
         * sampled whole; vertically the beam (|y| <= 0.5 mm) plus 2 texel sides, more than a
         * texel's height (the sub-triangles of the screen's triangles are at most sqrt(2)
         * texel sides tall). */
        double x0 = INFINITY, x1 = -INFINITY;
        for (int b = 0; b < NB; b++) {
            x0 = fmin(x0, pr.avg[b] - 3.0 * pr.span[b]);
            x1 = fmax(x1, pr.avg[b] + 3.0 * pr.span[b]);
        }
        x0 -= 3.0 * side;
        x1 += 3.0 * side;
        double ymax = 0.0005 + 2.0 * side;
        lit_texel_t *lit;
        size_t nlit = lit_texels(s, &p, lm, x0, x1, -ymax, ymax, side / 6.0, &lit);
        double worst = 0.0, worst_c = 0.0, shift = 0.0, sampled = 0.0;
        for (int b = 0; b < NB; b++) {
            double w = 0, wx = 0, wy = 0;
            for (size_t k = 0; k < nlit; k++) {
                sampled += lit[k].power[b];
                if (fabs(lit[k].x - pr.avg[b]) > 3.0 * pr.span[b] + side)
                    continue;
                w += lit[k].power[b];
                wx += lit[k].power[b] * lit[k].x;
                wy += lit[k].power[b] * lit[k].y;
            }
            assert_true(w > 0.0);
            double cx = wx / w, cy = wy / w;
            double err_avg = hypot(cx - pr.avg[b], cy) / side;
            double err_c = hypot(cx - pr.centre[b], cy) / side;
            worst = fmax(worst, err_avg);
            worst_c = fmax(worst_c, err_c);
            shift = fmax(shift, fabs(pr.avg[b] - pr.centre[b]));
            if (!(err_avg < 1.0 && err_c < 1.0))
                fail_msg("density %g: bucket %d: centroid (%.3f, %.3f) mm, Snell %.3f mm (bucket "
                         "average) %.3f mm (centre wavelength): %.2f and %.2f texels off",
                         d, b, 1e3 * cx, 1e3 * cy, 1e3 * pr.avg[b], 1e3 * pr.centre[b], err_avg,
                         err_c);
            double frac = w / (st.power_emitted / NB);
            double fse = sqrt(pr.tt[b] * (1.0 - pr.tt[b]) / (N / (double)NB));
            if (!(fabs(frac - pr.tt[b]) < 4.0 * fse + 3.0 / (N / (double)NB) + 1e-3))
                fail_msg("density %g: bucket %d: %.4f of its power near the prediction, two faces' "
                         "Fresnel %.4f",
                         d, b, frac, pr.tt[b]);
        }
        /* The samples found every lit texel of the beam: nearly all the map's power (the rest
         * took an internal reflection). */
        double total = photon_store_power_sum(ps);
        assert_true(sampled <= total * (1.0 + 1e-12));
        assert_true(sampled > 0.99 * total);
        print_message("N-BK7 prism, light map at %g texels/m^2 (texel %.1f mm, %zu lit, %.0f kB): "
                      "worst centroid error %.3f texel (bucket-averaged Snell), %.3f texel "
                      "(centre wavelength; the two predictions differ by <= %.3f mm); %.4f of the "
                      "map's power sampled\n",
                      d, 1e3 * side, photon_store_count(ps), photon_store_memory_bytes(ps) / 1e3,
                      worst, worst_c, 1e3 * shift, sampled / total);
        free(lit);
        photon_store_destroy(&ps);
        scene_destroy(&s);
    }
}

/* ------------------------------------------------------------------------------------------ */
/* 2. Photon integrator over a light map against plain path tracing (the scene of
 * test_photon_caustic.c): a disk light of radius 0.8 at height 8 above a glass ball (n = 1.5,
 * radius 1, centre 1.6 above the floor) that focuses it onto the floor; the camera looks at
 * the floor under the ball, so every pixel is caustic (L S+ D E). */
#define RES 16
#define BALL_DENSITY 1e4 /* texels of 1 cm: a pixel covers 3 x 6 cm of floor, the caustic 40 cm */

static scene_t *ball_scene(int photons, photon_store_kind_t kind)
{
    scene_t *s = lightmap_scene(BALL_DENSITY);
    s->settings.photon.store = kind;
    return sb_ball_build(s, photons, RES);
}

/* The store's own noise in the image mean, relative. The light map adds photon i, of
 * luminance-weighted power a_i, to the mean over pixels in proportion to the pixel density
 * over its texel, and a texel is small against the caustic, so as a photon map would: at its
 * landing point, w_i = cos theta / (d^2 cos^3 alpha) (pixels per steradian times steradians
 * per unit area). The relative standard error is sqrt(sum (a_i w_i)^2) / sum a_i w_i over the
 * photons in view (test_photon_caustic.c). The light map keeps no photons, so the sum runs
 * over the same job's first n_twin photons traced into a photon map (the tracer does not
 * depend on the store), scaled by sqrt(n_twin / n): independent photons. */
static double store_relative_se(uint64_t n, uint64_t n_twin)
{
    err_t err;
    scene_t *s = ball_scene((int)n_twin, PHOTON_STORE_PHOTONMAP);
    photon_store_t *ps = photon_store_new(s, &err);
    assert_non_null(ps);
    photon_job_t job = photon_job_from_settings(&s->settings);
    assert_int_equal(photon_trace(s, &job, 0, n_twin, ps, NULL, &err), 0);
    double se = testutil_photon_relative_se(s, ps);
    photon_store_destroy(&ps);
    scene_destroy(&s);
    return se * sqrt((double)n_twin / (double)n);
}

/* Tolerance: the means differ by the path tracer's noise, the photon render's camera noise
 * (both from per-sample variances) and the light map's (store_relative_se), independent, so
 * |photon - path| < 4 sigma of their sum. The texels' box filter moves light by a centimetre
 * within an image 43 cm across that holds the whole caustic but for a faint rim, and leaves
 * the mean alone. The sizes make 4 sigma 2.6 %, under a fixed 3 % bound, which is asserted as
 * well (the whole test costs about 3 CPU seconds, 6.5 in the sanitizer build). */
static void test_caustic_agrees_with_path(void **state)
{
    (void)state;
    const int path_spp = 4096, photon_spp = 32, photons = 2000000;
    scene_t *path = ball_scene(0, PHOTON_STORE_LIGHTMAP);
    scene_t *ph = ball_scene(photons, PHOTON_STORE_LIGHTMAP);
    err_t err;
    photon_store_t *store = photon_pass_run(ph, 0, NULL, NULL, &err);
    assert_non_null(store);
    sb_image_stats_t a = sb_render_stats(path, RES, path_spp),
                     b = sb_render_stats_with(ph, store, RES, photon_spp);
    assert_int_equal(photon_store_kind(store), PHOTON_STORE_LIGHTMAP);
    double map_se = b.mean * store_relative_se((uint64_t)photons, 200000);
    double se = sqrt(a.se * a.se + b.se * b.se + map_se * map_se);
    print_message("caustic mean luminance: path %.4f +- %.4f (%d spp), light map %.4f +- %.4f "
                  "(%d spp) +- %.4f (%dk photons, %zu texels lit): %+.2f%%, sigma %.2f%%\n",
                  a.mean, a.se, path_spp, b.mean, b.se, photon_spp, map_se, photons / 1000,
                  photon_store_count(store), 100.0 * (b.mean / a.mean - 1.0), 100.0 * se / a.mean);
    assert_true(fabs(b.mean - a.mean) < 4.0 * se);
    assert_true(4.0 * se / a.mean < 0.03);
    assert_true(fabs(b.mean / a.mean - 1.0) < 0.03);
    /* Per bucket (white light, constant glass: every bucket alike), within 4 sigma scaled by
     * sqrt(16) for a bucket's share of the samples. */
    for (int k = 0; k < NB; k++)
        if (!(fabs(b.buckets[k] / a.buckets[k] - 1.0) < 4.0 * 4.0 * se / a.mean))
            fail_msg("bucket %d: light map %.4f, path %.4f", k, b.buckets[k], a.buckets[k]);
    /* Fireflies: at equal samples, the light-map image's per-sample variance and brightest
     * pixel against the path tracer's. */
    sb_image_stats_t c = sb_render_stats(path, RES, photon_spp);
    print_message("at %d spp: per-sample luminance variance path %.3g, light map %.3g (%.0fx "
                  "lower); brightest pixel path %.2f, light map %.2f\n",
                  photon_spp, c.var, b.var, c.var / b.var, c.max, b.max);
    assert_true(b.var * 20.0 < c.var);
    assert_true(b.max < c.max);
    /* The thesis's own combination: Whitted gather with fan-out dispersion over the light map.
     * Same store, so its noise cancels: 4 sigma of both renders' camera noise, plus 1 % for
     * the floor's light that the ball returns to it (path gather only). */
    ph->settings.integrator = INTEGRATOR_WHITTED;
    ph->settings.dispersion = DISPERSION_FANOUT;
    sb_image_stats_t d = sb_render_stats_with(ph, store, RES, 4);
    print_message("Whitted gather, fan-out, light map: %.4f (%+.2f%% against the path gather)\n",
                  d.mean, 100.0 * (d.mean / b.mean - 1.0));
    assert_true(fabs(d.mean - b.mean) < 4.0 * sqrt(b.se * b.se + d.se * d.se) + 0.01 * b.mean);
    photon_store_destroy(&store);
    scene_destroy(&path);
    scene_destroy(&ph);
}

/* ------------------------------------------------------------------------------------------ */
/* 3. Energy. */

/* The full store in a photon furnace: a point light inside a closed diffuse sphere of albedo
 * rho (radius 1, light off centre). The store keeps every hit but the first, and a photon
 * reaches hit k + 1 with probability rho^k at its full power (Russian roulette on the albedo),
 * so over maxdepth M the map holds Phi (rho + ... + rho^M) = Phi rho (1 - rho^M) / (1 - rho):
 * never more than the albedo bound Phi rho / (1 - rho). Deposits per photon are geometric
 * (variance rho / (1 - rho)^2), so the fraction has standard error sqrt(rho / N) / (1 - rho).
 * Where they land: a Lambertian point on the inside of a sphere lights the sphere uniformly
 * (the form factor from it to dA is dA / (4 pi R^2)), so every deposit is uniform over the
 * sphere whatever the light's position, and the texels (equal-area by Archimedes) hold
 * multinomial counts: variance over mean 1 - 1/T, the sample ratio within
 * 4 sqrt(2 / (T - 1) + 1 / (mu T)) of it (mu deposits per texel). An unequal texel area, or
 * a lookup that read the wrong texel, shows as excess variance or a wrong mean irradiance. */
static void test_energy_full_store(void **state)
{
    (void)state;
    err_t err;
    const double rho = 0.5, I = 2.0, density = 400.0;
    const int M = 40;
    scene_t *s = lightmap_scene(density);
    transform_t id = transform_identity();
    int sphere = scene_add_sphere(s, &id, 1.0, sb_diffuse(s, rho), -1, 0, NULL);
    assert_true(sphere >= 0);
    light_t l = {.kind = LIGHT_POINT,
                 .spectrum = sb_constant(s, 1.0),
                 .scale = I,
                 .position = vec3_make(0.1, -0.2, 0.05)};
    assert_true(scene_add_light(s, &l, NULL) >= 0);
    sb_finish(s);
    const uint64_t N = 100000;
    photon_stats_t st;
    photon_store_t *ps = trace_store(s, PHOTON_STORE_ALL, M, N, &st);
    const lightmap_t *lm = photon_store_lightmap(ps);
    const double range = 720.0 - 380.0, w0 = 4.0 * PF_PI * I * range;
    assert_true(fabs(st.power_emitted / (double)N / w0 - 1.0) < 1e-12);
    assert_int_equal(st.escaped, 0);
    double expect = rho * (1.0 - pow(rho, M)) / (1.0 - rho);
    double se = sqrt(rho / (double)N) / (1.0 - rho);
    double ratio = photon_store_power_sum(ps) / st.power_emitted;
    assert_true(fabs(ratio - expect) < 4.0 * se);
    assert_true(ratio <= rho / (1.0 - rho) + 4.0 * se);

    /* Every deposit carries the photon's emitted power, so each texel holds a whole number of
     * them; light arrives from inside only (side 1, against the outward normal). */
    uint64_t T;
    assert_int_equal(
        lightmap_surface_texels(lm, GEOMETRY_NO_INSTANCE, (uint32_t)sphere, 0, &T, &err), 0);
    double wdep = st.power_emitted / (double)N, P[NB], cs = 0, cq = 0, area = 0;
    for (uint64_t i = 0; i < T; i++) {
        lightmap_texel_t t = {GEOMETRY_NO_INSTANCE, (uint32_t)sphere, 0, 0, i};
        assert_int_equal(lightmap_texel_power(lm, t, P), 0);
        t.side = 1;
        lightmap_texel_power(lm, t, P);
        double c = 0;
        for (int b = 0; b < NB; b++)
            c += P[b] / wdep;
        if (!(fabs(c - round(c)) < 1e-6))
            fail_msg("texel %llu holds %.9f deposits", (unsigned long long)i, c);
        cs += c;
        cq += c * c;
        area += lightmap_texel_area(lm, t);
    }
    assert_true(fabs(area / (4.0 * PF_PI) - 1.0) < 1e-9);
    assert_true(fabs(cs - (double)st.deposited) < 0.5);
    double mu = cs / (double)T, var = (cq - cs * cs / (double)T) / (double)(T - 1);
    double disp = var / mu, dtol = 4.0 * sqrt(2.0 / (double)(T - 1) + 1.0 / (mu * (double)T));
    if (!(fabs(disp - (1.0 - 1.0 / (double)T)) < dtol))
        fail_msg("texel counts: variance / mean %.4f, multinomial %.4f (tolerance %.4f)", disp,
                 1.0 - 1.0 / (double)T, dtol);

    /* Irradiance as the camera pass reads it, at hits along a Fibonacci lattice of directions
     * from the centre (equal areas of the sphere): its mean is the deposited flux over the
     * sphere's area, Phi_dep / (N 4 pi) (the texels' sum times the bucket width). */
    const int K = 8192;
    double es = 0, eq = 0;
    spectral_grid_t g = s->settings.grid;
    assert_int_equal(photon_store_finish(ps, &err), 0);
    for (int k = 0; k < K; k++) {
        double z = 1.0 - (2.0 * k + 1.0) / K, r = sqrt(fmax(0.0, 1.0 - z * z));
        double phi = k * PF_PI * (3.0 - sqrt(5.0));
        vec3_t dir = vec3_make(r * cos(phi), r * sin(phi), z);
        hit_t h;
        assert_int_equal(geometry_intersect(s->geometry, vec3_make(0, 0, 0), dir, 0.0, 10.0, &h),
                         1);
        double E[NB], e = 0;
        assert_int_equal(photon_store_irradiance(ps, &h, h.p, vec3_neg(dir), E), 1);
        for (int b = 0; b < NB; b++)
            e += E[b] * spectral_grid_width(g);
        es += e;
        eq += e * e;
    }
    double emean = es / K, ese = sqrt(fmax(0.0, eq / K - emean * emean) / K);
    double eexp = photon_store_power_sum(ps) / ((double)N * 4.0 * PF_PI);
    print_message("light-map furnace: deposited / emitted %.5f, expected %.5f (se %.5f), bound "
                  "%.1f; %llu texels, counts variance / mean %.3f (multinomial %.3f +- %.3f); "
                  "mean irradiance %.4f, expected %.4f (se %.4f)\n",
                  ratio, expect, se, rho / (1.0 - rho), (unsigned long long)T, disp,
                  1.0 - 1.0 / (double)T, dtol / 4.0, emean, eexp, ese);
    assert_true(fabs(emean - eexp) < 4.0 * ese);
    photon_store_destroy(&ps);
    /* The caustic store has nothing to hold here: no specular surface. */
    ps = trace_store(s, PHOTON_STORE_CAUSTIC, M, 1000, &st);
    assert_int_equal(photon_store_count(ps), 0);
    assert_true(photon_store_power_sum(ps) == 0.0);
    photon_store_destroy(&ps);
    scene_destroy(&s);
}

/* The caustic store behind a non-absorbing N-SF11 slab under a collimated beam at normal
 * incidence: the light map holds, per bucket, T(n) averaged over the bucket times the power
 * emitted in it (photons reflected back escape through the pass-through light), all on the
 * screen's lit side and none behind it; never more than the power emitted (the caustic
 * store's albedo bound is 1: specular surfaces only lose power). Each photon of a bucket
 * (N/16 of them) lands or not: standard error sqrt(T (1 - T) / (N/16)). */
static void test_energy_caustic_store(void **state)
{
    (void)state;
    scene_t *s = lightmap_scene(400.0);
    sb_beam(s, vec3_make(0, 0, -1), vec3_make(0, 0, 1), 0.05);
    int glass = sb_material(s, MATERIAL_DIELECTRIC, "N-SF11");
    transform_t front = transform_identity(), back = transform_translate(vec3_make(0, 0, 0.1));
    assert_true(scene_add_disk(s, &front, 1.0, 0.0, glass, -1, 1, NULL) >= 0); /* normal -z */
    assert_true(scene_add_disk(s, &back, 1.0, 0.0, glass, -1, 0, NULL) >= 0);  /* normal +z */
    transform_t screen = transform_translate(vec3_make(0, 0, 1));
    int scr = scene_add_disk(s, &screen, 2.0, 0.0, sb_diffuse(s, 0.8), -1, 1, NULL); /* faces -z */
    assert_true(scr >= 0);
    sb_finish(s);
    const uint64_t N = 400000;
    photon_stats_t st;
    photon_store_t *ps = trace_store(s, PHOTON_STORE_CAUSTIC, 200, N, &st);
    const lightmap_t *lm = photon_store_lightmap(ps);
    err_t err;
    uint64_t T;
    assert_int_equal(lightmap_surface_texels(lm, GEOMETRY_NO_INSTANCE, (uint32_t)scr, 0, &T, &err),
                     0);
    double dep[NB] = {0}, P[NB];
    for (uint64_t i = 0; i < T; i++) {
        lightmap_texel_t t = {GEOMETRY_NO_INSTANCE, (uint32_t)scr, 0, 1, i};
        assert_int_equal(lightmap_texel_power(lm, t, P), 0);
        t.side = 0;
        if (lightmap_texel_power(lm, t, P))
            for (int b = 0; b < NB; b++)
                dep[b] += P[b];
    }
    spectral_grid_t g = s->settings.grid;
    const double per_bucket = st.power_emitted / NB;
    double total = 0, first = 0, last = 0;
    for (int b = 0; b < NB; b++) {
        double lo = spectral_grid_bucket_min(g, b), hi = spectral_grid_bucket_max(g, b), t = 0;
        for (int k = 0; k <= 8; k++) {
            double wgt = k == 0 || k == 8 ? 1 : k % 2 ? 4 : 2;
            t += wgt * sb_slab_t(sb_sellmeier(SB_SF11_B, SB_SF11_C, lo + (hi - lo) * k / 8.0));
        }
        t /= 24.0;
        double got = dep[b] / per_bucket;
        double tol = 4.0 * sqrt(t * (1.0 - t) / (N / (double)NB)) + 3.0 / (N / (double)NB);
        if (!(fabs(got - t) < tol))
            fail_msg("bucket %d: light map holds %.4f of the power, slab formula %.4f (tolerance "
                     "%.4f)",
                     b, got, t, tol);
        total += dep[b];
        if (b == 0)
            first = got;
        last = got;
    }
    assert_true(fabs(total - photon_store_power_sum(ps)) <= 1e-12 * total);
    assert_true(total <= st.power_emitted);
    print_message("N-SF11 slab, light map: T = %.4f (violet bucket) .. %.4f (red), formula %.4f "
                  ".. %.4f; held / emitted %.4f <= 1\n",
                  first, last, sb_slab_t(sb_sellmeier(SB_SF11_B, SB_SF11_C, 390.625)),
                  sb_slab_t(sb_sellmeier(SB_SF11_B, SB_SF11_C, 709.375)), total / st.power_emitted);
    photon_store_destroy(&ps);
    scene_destroy(&s);
}

/* ------------------------------------------------------------------------------------------ */
/* 4. Rescaling and merging, on the shipped scenes/prism_beam.pbrt (SF10 prism, a collimated
 * slit beam and a ceiling light, a room of diffuse walls) with a light-map store. */

static scene_t *beam_scene(int lanes)
{
    scene_t *s = sb_load_file(testutil_source_path("scenes/prism_beam.pbrt"));
    s->settings.photon.store = PHOTON_STORE_LIGHTMAP;
    s->settings.photon.lightmap_density = 400.0;
    s->settings.photon.monochromerays = lanes;
    return s;
}

/* Photons [i0, i1) of the scene's job into a new store. */
static photon_store_t *trace_range(const scene_t *s, uint64_t i0, uint64_t i1)
{
    err_t err;
    photon_store_t *st = photon_store_new(s, &err);
    if (!st)
        fail_msg("%s", err.msg);
    photon_job_t job = photon_job_from_settings(&s->settings);
    if (photon_trace(s, &job, i0, i1, st, NULL, &err))
        fail_msg("photon_trace: %s", err.msg);
    return st;
}

/* The N-BK7 prism of test 1 (beam only) with the scene's photon job set for lanes. */
static scene_t *bk7_scene(int lanes)
{
    sb_prism_t p;
    scene_t *s = sb_prism_build(&p, lightmap_scene(1e4));
    s->settings.photon.maxdepth = 10;
    s->settings.photon.threshold = 0.0;
    s->settings.photon.monochromerays = lanes;
    return s;
}

/* The caustic's energy per emitted monochrome photon (held power over the emitted count) of
 * photons [0, K n) traced in K batches of n and merged; its relative standard error from the
 * spread of the K batches' own figures (batch means: this counts the correlation of a
 * photon's lanes, which share its light, position and direction until the glass splits
 * them). */
static double energy_per_photon(scene_t *(*make)(int), int lanes, uint64_t n, int K, double *rel_se)
{
    err_t err;
    scene_t *s = make(lanes);
    photon_store_t *all = photon_store_new(s, &err);
    assert_non_null(all);
    double sum = 0, sq = 0;
    for (int k = 0; k < K; k++) {
        photon_store_t *b = trace_range(s, (uint64_t)k * n, (uint64_t)(k + 1) * n);
        assert_int_equal(photon_store_emitted(b), n * (uint64_t)lanes);
        double e = photon_store_power_sum(b) / (double)photon_store_emitted(b);
        sum += e;
        sq += e * e;
        assert_int_equal(photon_store_merge(all, b, &err), 0);
        photon_store_destroy(&b);
    }
    assert_int_equal(photon_store_emitted(all), (uint64_t)K * n * (uint64_t)lanes);
    double e = photon_store_power_sum(all) / (double)photon_store_emitted(all);
    double mean = sum / K;
    /* Batches are equal in size, so the merged figure is the batches' mean. */
    assert_true(fabs(e / mean - 1.0) < 1e-12);
    *rel_se = sqrt(fmax(0.0, sq / K - mean * mean) / (K - 1)) / mean;
    photon_store_destroy(&all);
    scene_destroy(&s);
    return e;
}

/* Following 16 monochrome rays per photon creates 16 photons from each; the light map divides
 * by the photons actually emitted (the thesis's missing post-pass, docs/physics.md §4.4), so
 * the caustic energy per emitted photon is that of 1 ray per photon, within 4 standard errors
 * of the difference. Two scenes: the N-BK7 prism under its beam alone (the energy varies only by
 * the Fresnel choices, a sharp test) and the shipped prism_beam, whose ceiling light's photons
 * mostly miss the prism (a photon's 16 rays then count as one: a wider test). */
static void test_monochrome_rays_keep_energy(void **state)
{
    (void)state;
    struct {
        const char *name;
        scene_t *(*make)(int);
        uint64_t n1, n16;
    } cases[2] = {{"N-BK7 prism", bk7_scene, 4000, 1000},
                  {"prism_beam.pbrt", beam_scene, 4000, 1000}};
    for (int c = 0; c < 2; c++) {
        double se1, se16;
        double e1 = energy_per_photon(cases[c].make, 1, cases[c].n1, 16, &se1);
        double e16 = energy_per_photon(cases[c].make, 16, cases[c].n16, 16, &se16);
        double tol = 4.0 * sqrt(se1 * se1 + se16 * se16);
        print_message("%s, light map: caustic energy per monochrome photon, 1 ray %.6g (se "
                      "%.2g%%), 16 rays %.6g (se %.2g%%): ratio %.4f (tolerance %.4f)\n",
                      cases[c].name, e1, 100 * se1, e16, 100 * se16, e16 / e1, tol);
        assert_true(fabs(e16 / e1 - 1.0) < tol);
        /* Without the rescale (dividing by photon indices, not rays) it would be 16 times off. */
        assert_true(tol < 0.1);
    }
}

static uint8_t *encode(const photon_store_t *st, size_t *len)
{
    err_t err;
    uint8_t *bytes = NULL;
    /* A finished light map is the same map (finishing builds nothing): read it directly. */
    if (photon_store_finished(st))
        assert_int_equal(lightmap_encode(photon_store_lightmap(st), &bytes, len, &err), 0);
    else
        assert_int_equal(photon_store_encode(st, &bytes, len, &err), 0);
    return bytes;
}

/* Through the wire form, as a farm's batches travel. */
static photon_store_t *wire(const scene_t *s, const photon_store_t *st)
{
    err_t err;
    size_t len;
    uint8_t *bytes = encode(st, &len);
    photon_store_t *back = photon_store_decode(s, bytes, len, &err);
    if (!back)
        fail_msg("photon_store_decode: %s", err.msg);
    free(bytes);
    return back;
}

static void assert_same_bytes(const uint8_t *a, size_t la, const photon_store_t *st,
                              const char *what)
{
    size_t lb;
    uint8_t *b = encode(st, &lb);
    if (la != lb || memcmp(a, b, la) != 0)
        fail_msg("%s: %zu bytes, one pass %zu bytes, not the same", what, lb, la);
    free(b);
}

/* The same light map whatever the batches: photons [0, N) with 4 rays per photon in one pass,
 * in four uneven batches traced apart and merged through their wire form in batch order,
 * in reverse order and as a tree ((0 + 1) + (2 + 3)), by photon_batch_run, and by the local
 * pass on 1 and 3 threads, all encode to the same bytes. (The texel sums are exact, so this
 * holds for any grouping, not only for merges in batch order as the photon map needs.) */
static void test_merge_groupings_bit_identical(void **state)
{
    (void)state;
    err_t err;
    scene_t *s = beam_scene(4);
    const uint64_t N = 6000, cuts[5] = {0, 1, 2500, 4100, N};
    photon_store_t *whole = trace_range(s, 0, N);
    size_t len;
    uint8_t *one = encode(whole, &len);
    assert_true(photon_store_count(whole) > 100);
    photon_store_t *b[4];
    for (int k = 0; k < 4; k++) {
        photon_store_t *part = trace_range(s, cuts[k], cuts[k + 1]);
        b[k] = wire(s, part);
        photon_store_destroy(&part);
    }
    photon_store_t *inorder = photon_store_new(s, &err), *reverse = photon_store_new(s, &err);
    for (int k = 0; k < 4; k++) {
        assert_int_equal(photon_store_merge(inorder, b[k], &err), 0);
        assert_int_equal(photon_store_merge(reverse, b[3 - k], &err), 0);
    }
    assert_same_bytes(one, len, inorder, "batches merged in order");
    assert_same_bytes(one, len, reverse, "batches merged in reverse order");
    photon_store_t *left = photon_store_new(s, &err), *right = photon_store_new(s, &err);
    assert_int_equal(photon_store_merge(left, b[0], &err), 0);
    assert_int_equal(photon_store_merge(left, b[1], &err), 0);
    assert_int_equal(photon_store_merge(right, b[2], &err), 0);
    assert_int_equal(photon_store_merge(right, b[3], &err), 0);
    photon_store_t *lw = wire(s, left), *rw = wire(s, right);
    assert_int_equal(photon_store_merge(rw, lw, &err), 0);
    assert_same_bytes(one, len, rw, "batches merged as a tree");
    assert_int_equal(photon_store_emitted(rw), N * 4);

    uint8_t *batch;
    size_t blen;
    s->settings.photon.photons = N;
    assert_int_equal(photon_batch_run(s, 0, N, &batch, &blen, NULL, &err), 0);
    assert_true(blen == len && memcmp(batch, one, len) == 0);
    free(batch);
    photon_store_t *t1 = photon_pass_run(s, 1, NULL, NULL, &err);
    photon_store_t *t3 = photon_pass_run(s, 3, NULL, NULL, &err);
    assert_non_null(t1);
    assert_non_null(t3);
    assert_same_bytes(one, len, t1, "the local pass on 1 thread");
    assert_same_bytes(one, len, t3, "the local pass on 3 threads");
    print_message("light map of %llu photons x 4 rays: %zu texels lit, %zu wire bytes, the same "
                  "from 1 pass, 4 batches in 3 groupings, a farm batch and 1 or 3 threads\n",
                  (unsigned long long)N, photon_store_count(whole), len);
    /* Another seed gives another map. */
    s->settings.seed += 1;
    photon_store_t *other = trace_range(s, 0, N);
    size_t lo;
    uint8_t *ob = encode(other, &lo);
    assert_true(lo != len || memcmp(ob, one, len) != 0);
    free(ob);
    photon_store_destroy(&other);
    for (int k = 0; k < 4; k++)
        photon_store_destroy(&b[k]);
    photon_store_t *all[] = {whole, inorder, reverse, left, right, lw, rw, t1, t3};
    for (size_t k = 0; k < sizeof all / sizeof *all; k++)
        photon_store_destroy(&all[k]);
    free(one);
    scene_destroy(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_prism_beam_lands),
        cmocka_unit_test(test_caustic_agrees_with_path),
        cmocka_unit_test(test_energy_full_store),
        cmocka_unit_test(test_energy_caustic_store),
        cmocka_unit_test(test_monochrome_rays_keep_energy),
        cmocka_unit_test(test_merge_groupings_bit_identical),
    };
    /* LMFILTER=test_name runs that test alone (cmocka's filter). */
    if (getenv("LMFILTER"))
        cmocka_set_test_filter(getenv("LMFILTER"));
    return cmocka_run_group_tests(tests, NULL, NULL);
}
