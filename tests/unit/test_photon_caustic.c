/* The photon integrator against plain path tracing on a caustic both can see: a small disk
 * light above a glass ball (n = 1.5) that focuses it onto a diffuse floor inside the ball's
 * shadow. The camera looks at the floor under the ball, so every pixel is caustic (L S+ D E),
 * the light the photon integrator takes from its store and the path tracer finds by hitting
 * the light through the ball. The two must agree on the mean, and the photon image must be
 * far less noisy. */
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
#include "photon_pass.h"
#include "photon_testutil.h"
#include "render.h"
#include "scene.h"
#include "scene_builders.h"
#include "texture.h"

#define RES 16

/* The caustic ball of scene_builders.h, RES x RES, with a photon pass of `photons` photons (none
 * for 0). */
static scene_t *ball_scene(int photons)
{
    err_t err;
    scene_t *s = scene_new(&err);
    if (!s)
        fail_msg("scene_new: %s", err.msg);
    return sb_ball_build(s, photons, RES);
}

/* Tolerance: the two means differ by the path tracer's noise (per-sample variances), the
 * photon render's camera noise (likewise) and the photon map's noise (testutil_photon_relative_se),
 * all independent, so |photon - path| < 4 sigma of their sum; the kernel's blur (radius 0.02
 * against a caustic 0.4 across, all inside the image but for a faint rim) moves light
 * within the image and leaves the mean alone. At the test size sigma is about 0.9 %, so the
 * fixed 5 % bound, asserted as well, is met with 4 sigma to spare. (With 4096 path samples and
 * 2 million photons the two agree to 0.4 %, within sigma.) */
static void test_caustic_agrees_with_path(void **state)
{
    (void)state;
    scene_t *path = ball_scene(0), *ph = ball_scene(800000);
    err_t err;
    photon_store_t *store = photon_pass_run(ph, 0, NULL, NULL, &err);
    assert_non_null(store);
    sb_image_stats_t a = sb_render_stats(path, RES, 2048),
                     b = sb_render_stats_with(ph, store, RES, 16);
    double map_se = b.mean * testutil_photon_relative_se(ph, store);
    double se = sqrt(a.se * a.se + b.se * b.se + map_se * map_se);
    print_message("caustic mean luminance: path %.4f +- %.4f (2048 spp), photon %.4f +- %.4f (16 "
                  "spp) +- %.4f "
                  "(800k photons): %+.2f%%, sigma %.2f%%\n",
                  a.mean, a.se, b.mean, b.se, map_se, 100.0 * (b.mean / a.mean - 1.0),
                  100.0 * se / a.mean);
    assert_true(fabs(b.mean - a.mean) < 4.0 * se);
    assert_true(fabs(b.mean / a.mean - 1.0) < 0.05);
    assert_true(4.0 * se / a.mean < 0.06);
    /* Per bucket too (the light is white, the glass constant: every bucket alike), within
     * 4 sigma scaled by sqrt(16) for the bucket's share of the samples. */
    for (int k = 0; k < path->settings.grid.n; k++)
        if (!(fabs(b.buckets[k] / a.buckets[k] - 1.0) < 4.0 * 4.0 * se / a.mean))
            fail_msg("bucket %d: photon %.4f, path %.4f", k, b.buckets[k], a.buckets[k]);
    /* Fireflies: at equal samples, the photon image's per-sample variance and its brightest
     * pixel against the path tracer's. */
    sb_image_stats_t c = sb_render_stats(path, RES, 16);
    print_message("at 16 spp: per-sample luminance variance path %.3g, photon %.3g (%.0fx lower); "
                  "brightest pixel "
                  "path %.2f, photon %.2f (the caustic's peak is about 5)\n",
                  c.var, b.var, c.var / b.var, c.max, b.max);
    assert_true(b.var * 20.0 < c.var);
    assert_true(b.max < c.max);
    /* The thesis's combination: Whitted gather with fan-out dispersion over the same store
     * sees the caustic too; it lacks only the diffuse interreflection the path gather adds. */
    ph->settings.integrator = INTEGRATOR_WHITTED;
    ph->settings.dispersion = DISPERSION_FANOUT;
    sb_image_stats_t d = sb_render_stats_with(ph, store, RES, 4);
    print_message("Whitted gather, fan-out: %.4f (%+.2f%% against the path gather)\n", d.mean,
                  100.0 * (d.mean / b.mean - 1.0));
    /* Same store, so its noise cancels: 4 sigma of both renders' camera noise, plus 1 % for
     * the floor's light that the ball returns to it (path gather only; measured 0.03 %). */
    assert_true(fabs(d.mean - b.mean) < 4.0 * sqrt(b.se * b.se + d.se * d.se) + 0.01 * b.mean);
    photon_store_destroy(&store);
    scene_destroy(&path);
    scene_destroy(&ph);
}

/* A glossy floor for the ball's caustic (L S+ G E): material kind with reflectance r and
 * roughness alpha (pbrt-v4's alpha, not remapped); a coated diffuse gets a coat of n = 1.5. */
static int glossy_floor(scene_t *s, material_kind_t kind, double r, double alpha)
{
    err_t err;
    texture_t *refl = texture_new_constant_value(r, &err);
    texture_t *rough = texture_new_constant_value(alpha, &err);
    assert_non_null(refl);
    assert_non_null(rough);
    assert_int_equal(scene_own_texture(s, refl, &err), 0);
    assert_int_equal(scene_own_texture(s, rough, &err), 0);
    material_t m = {
        .kind = kind, .reflectance = refl, .uroughness = rough, .vroughness = rough, .rough = 1};
    m.ior = ior_constant(1.5);
    snprintf(m.name, sizeof m.name, "glossy floor");
    int i = scene_add_material(s, &m, &err);
    assert_true(i >= 0);
    return i;
}

static scene_t *glossy_ball_scene(int photons, material_kind_t kind, double r, double alpha)
{
    err_t err;
    scene_t *s = scene_new(&err);
    if (!s)
        fail_msg("scene_new: %s", err.msg);
    return sb_ball_build_on(s, photons, RES, glossy_floor(s, kind, r, alpha));
}

/* The glossy receiver's photon estimate (photon_store_gather with the floor's BSDF) against
 * the path tracer, which finds the same light by sampling the floor's lobe through the ball
 * to the light: means within 4 sigma as in test_caustic_agrees_with_path (the map's own
 * noise estimated with the diffuse weights of testutil_photon_relative_se, which for a lobe this
 * wide differ from the glossy ones by a factor of order one), and within 6 %. A rough conductor
 * (every photon is evaluated exactly once or picked by the gather's subsampling) and a coated
 * diffuse floor (the stochastic layered evaluation, and a coat whose smooth part the camera
 * path carries on) both; without the glossy estimate the photon render would lose the whole
 * caustic, since the camera pass no longer counts it (checked: under 50 % of the path mean). */
static void check_glossy(material_kind_t kind, double r, double alpha, const char *what)
{
    scene_t *path = glossy_ball_scene(0, kind, r, alpha),
            *ph = glossy_ball_scene(800000, kind, r, alpha);
    err_t err;
    photon_store_t *store = photon_pass_run(ph, 0, NULL, NULL, &err);
    assert_non_null(store);
    assert_true(photon_store_directional(store));
    assert_true(photon_store_count(store) > 1000);
    sb_image_stats_t a = sb_render_stats(path, RES, 2048),
                     b = sb_render_stats_with(ph, store, RES, 64);
    double map_se = b.mean * testutil_photon_relative_se(ph, store);
    double se = sqrt(a.se * a.se + b.se * b.se + map_se * map_se);
    print_message("%s caustic: path %.4f +- %.4f (2048 spp), photon %.4f +- %.4f (64 spp) +- "
                  "%.4f (map): %+.2f%%, sigma %.2f%%; photon render at 64 spp per-sample "
                  "variance %.3g\n",
                  what, a.mean, a.se, b.mean, b.se, map_se, 100.0 * (b.mean / a.mean - 1.0),
                  100.0 * se / a.mean, b.var);
    assert_true(a.mean > 0.0);
    assert_true(fabs(b.mean - a.mean) < 4.0 * se);
    assert_true(fabs(b.mean / a.mean - 1.0) < 0.06);
    /* The same camera pass with an empty store of the same scene: the caustic is the store's. */
    photon_store_t *empty = photon_store_new(ph, &err);
    assert_non_null(empty);
    photon_store_add_emitted(empty, 1);
    assert_int_equal(photon_store_finish(empty, &err), 0);
    sb_image_stats_t e = sb_render_stats_with(ph, empty, RES, 16);
    print_message("%s: without photons %.4f (%.0f%% of the path mean)\n", what, e.mean,
                  100.0 * e.mean / a.mean);
    assert_true(e.mean < 0.5 * a.mean);
    photon_store_destroy(&empty);
    photon_store_destroy(&store);
    scene_destroy(&path);
    scene_destroy(&ph);
}

static void test_glossy_conductor_agrees_with_path(void **state)
{
    (void)state;
    check_glossy(MATERIAL_CONDUCTOR, 0.8, 0.4, "rough conductor (alpha 0.4)");
}

static void test_glossy_coated_agrees_with_path(void **state)
{
    (void)state;
    check_glossy(MATERIAL_COATED_DIFFUSE, 0.5, 0.2, "coated diffuse (alpha 0.2)");
}

/* The farm's guarantee with photons: two workers that each load the scene and trace the
 * photon pass themselves render a tile to the same bytes, and a tile rendered in pieces
 * (sub-tiles and sample ranges, as the scheduler may cut it) sums to the same image. */
static void check_workers_agree(scene_t *w1, scene_t *w2)
{
    err_t err;
    w1->settings.spp = w2->settings.spp = 4;
    /* Each worker traces the photon pass itself, with its own thread count. */
    photon_store_t *p1 = photon_pass_run(w1, 1, NULL, NULL, &err),
                   *p2 = photon_pass_run(w2, 3, NULL, NULL, &err);
    assert_non_null(p1);
    assert_non_null(p2);
    int nb = w1->settings.grid.n;
    tilebuf_t *a = tilebuf_new(0, 0, RES, RES, nb, &err),
              *b = tilebuf_new(0, 0, RES, RES, nb, &err);
    assert_int_equal(render_tile(w1, p1, 0, 0, RES, RES, 0, 4, a, NULL, &err), 0);
    for (int y = 0; y < RES; y += 5)
        for (int x = 0; x < RES; x += 7) {
            int w = x + 7 > RES ? RES - x : 7, h = y + 5 > RES ? RES - y : 5;
            for (uint32_t s0 = 0; s0 < 4; s0 += 3) {
                tilebuf_t *t = tilebuf_new(x, y, w, h, nb, &err);
                assert_int_equal(
                    render_tile(w2, p2, x, y, w, h, s0, s0 + 3 > 4 ? 4 : s0 + 3, t, NULL, &err), 0);
                assert_int_equal(tilebuf_merge(b, t, &err), 0);
                tilebuf_destroy(&t);
            }
        }
    for (int y = 0; y < RES; y++)
        for (int x = 0; x < RES; x++) {
            assert_int_equal(tilebuf_count(a, x, y), tilebuf_count(b, x, y));
            for (int k = 0; k < nb; k++)
                assert_true(fabs(tilebuf_sum(a, x, y, k) - tilebuf_sum(b, x, y, k)) <=
                            1e-12 * fabs(tilebuf_sum(a, x, y, k)));
        }
    /* Whole tiles are bit-identical. */
    tilebuf_t *c = tilebuf_new(0, 0, RES, RES, nb, &err);
    assert_int_equal(render_tile(w2, p2, 0, 0, RES, RES, 0, 4, c, NULL, &err), 0);
    assert_memory_equal(tilebuf_sums(a), tilebuf_sums(c), sizeof(double) * RES * RES * (size_t)nb);
    tilebuf_destroy(&a);
    tilebuf_destroy(&b);
    tilebuf_destroy(&c);
    photon_store_destroy(&p1);
    photon_store_destroy(&p2);
    scene_destroy(&w1);
    scene_destroy(&w2);
}

static void test_workers_agree(void **state)
{
    (void)state;
    check_workers_agree(ball_scene(50000), ball_scene(50000));
}

/* The same on a coated floor: the glossy gather's picks and the layered evaluation draw from
 * the sample's own random stream, so tiles and sample ranges do not change them. */
static void test_workers_agree_glossy(void **state)
{
    (void)state;
    check_workers_agree(glossy_ball_scene(50000, MATERIAL_COATED_DIFFUSE, 0.5, 0.2),
                        glossy_ball_scene(50000, MATERIAL_COATED_DIFFUSE, 0.5, 0.2));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_caustic_agrees_with_path),
        cmocka_unit_test(test_glossy_conductor_agrees_with_path),
        cmocka_unit_test(test_glossy_coated_agrees_with_path),
        cmocka_unit_test(test_workers_agree),
        cmocka_unit_test(test_workers_agree_glossy),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
