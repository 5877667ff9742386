/* Tests for shading-normal perturbation and cut-outs (render/shading.h):
 * - bump mapping (pbrt-v4 BumpMap): on a square of side L in z = 0 with uv running 0..1
 *   across it (|dp/du| = |dp/dv| = L), a displacement d = a u moves dp/du to (L, 0, a n) and
 *   the shading normal to (-a, 0, L) / sqrt(a^2 + L^2) up to the side, a tilt of atan(a / L);
 * - a normal map (pbrt-v4 NormalMap) of (0.5, 0.5, 1) leaves the normal as it is, one of
 *   (0.5 + sin(t) / 2, 0.5, 0.5 + cos(t) / 2) tilts it by t toward dp/du;
 * - alpha: a quad of alpha 0 lets shadow rays and camera rays through as if absent, one of
 *   alpha 0.25 lets 75 % of them through (binomial noise, 4 standard errors). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "scene_builders.h"
#include "shading.h"

#define L_SIDE 2.0

static int add_quad(scene_t *s, double z, double half, int material, int light)
{
    err_t err;
    double P[12] = {-half, -half, z, half, -half, z, half, half, z, -half, half, z};
    double uv[8] = {0, 0, 1, 0, 1, 1, 0, 1};
    uint32_t ix[6] = {0, 1, 2, 0, 2, 3};
    int r = scene_add_mesh(s, P, 4, ix, 2, NULL, uv, material, light, 0, &err);
    assert_true(r >= 0);
    return r;
}

static texture_t *own(scene_t *s, texture_t *t)
{
    err_t err;
    assert_non_null(t);
    assert_int_equal(scene_own_texture(s, t, &err), 0);
    return t;
}

/* The surface at (x, y) of the quad through scene_surface and shading_perturb. */
static surface_t hit_at(scene_t *s, double x, double y, vec3_t *ns_before)
{
    hit_t h;
    assert_true(geometry_intersect(s->geometry, vec3_make(x, y, 5), vec3_make(0, 0, -1), 0, INFINITY, &h));
    surface_t sf;
    scene_surface(s, &h, &sf);
    *ns_before = sf.ns;
    shading_perturb(sf.material, &sf);
    return sf;
}

static void test_bump_plane(void **state)
{
    (void)state;
    err_t err;
    scene_t *s = sb_new_scene();
    /* d(u) = a u on u in [0.25, 0.75]: a clamp-wrapped 2x1 image (0, 1) is 2 (u - 0.25)
     * between its texel centres, scaled by a / 2. */
    const double a = 0.3;
    float px[6] = {0, 0, 0, 1, 1, 1};
    texture_image_opts_t o = texture_image_opts_default();
    o.wrap = TEXTURE_WRAP_CLAMP;
    o.grey = 1;
    texture_t *img = own(s, texture_new_image(px, 2, 1, &o, &err));
    texture_t *k = own(s, texture_new_constant_value(a / 2, &err));
    texture_t *d = own(s, texture_new_scale(img, k, &err));
    material_t m = {.kind = MATERIAL_DIFFUSE, .displacement = d};
    int mi = scene_add_material(s, &m, &err);
    add_quad(s, 0.0, L_SIDE / 2, mi, -1);
    sb_finish(s);
    vec3_t n0;
    surface_t sf = hit_at(s, -0.2, 0.2, &n0); /* u = 0.4 */
    double norm = sqrt(a * a + L_SIDE * L_SIDE);
    printf("bumped normal (%.6f %.6f %.6f), expected (%.6f 0 +-%.6f)\n", sf.ns.x, sf.ns.y, sf.ns.z,
           -a / norm, L_SIDE / norm);
    assert_true(fabs(sf.ns.x - -a / norm) < 1e-6);
    assert_true(fabs(sf.ns.y) < 1e-9);
    assert_true(fabs(fabs(sf.ns.z) - L_SIDE / norm) < 1e-6);
    assert_true(vec3_dot(sf.ns, sf.ng) > 0);
    assert_true(sf.smooth);
    scene_destroy(&s);
}

static void test_normal_map(void **state)
{
    (void)state;
    err_t err;
    const double t = 30.0 * PF_PI / 180.0;
    for (int tilt = 0; tilt < 2; tilt++) {
        scene_t *s = sb_new_scene();
        float px[3] = {0.5f, 0.5f, 1.0f};
        if (tilt) {
            px[0] = (float)(0.5 + 0.5 * sin(t));
            px[2] = (float)(0.5 + 0.5 * cos(t));
        }
        texture_t *nm = own(s, texture_new_normalmap(px, 1, 1, &err));
        material_t m = {.kind = MATERIAL_DIFFUSE, .normalmap = nm};
        add_quad(s, 0.0, L_SIDE / 2, scene_add_material(s, &m, &err), -1);
        sb_finish(s);
        vec3_t n0;
        surface_t sf = hit_at(s, 0.3, -0.1, &n0);
        /* dp/du is +x here; the tilted normal is sin t x + cos t n. */
        vec3_t want = tilt ? vec3_add(vec3_scale(vec3_make(1, 0, 0), sin(t)), vec3_scale(n0, cos(t))) : n0;
        assert_true(vec3_length(vec3_sub(sf.ns, want)) < 1e-6);
        scene_destroy(&s);
    }
}

static scene_t *cutout_scene(double alpha, int with_blocker)
{
    err_t err;
    scene_t *s = sb_render_scene(INTEGRATOR_PATH, DISPERSION_HERO, 8, 16);
    sb_look_at(s, vec3_make(0, 0, -5), vec3_make(0, 0, 0), 20.0);
    light_t l = {.kind = LIGHT_AREA, .spectrum = sb_constant(s, 1.0), .scale = 1.0, .twosided = 1};
    int li = scene_add_light(s, &l, &err);
    assert_true(li >= 0);
    int black = sb_diffuse(s, 0.0);
    add_quad(s, 2.0, 10.0, black, li);
    if (with_blocker) {
        int q = add_quad(s, 0.0, 10.0, black, -1);
        s->shapes[q].alpha = own(s, texture_new_constant_value(alpha, &err));
        s->has_alpha = 1;
    }
    sb_finish(s);
    return s;
}

static void test_alpha_shadow_rays(void **state)
{
    (void)state;
    const double alphas[3] = {0.0, 1.0, 0.25};
    for (int k = 0; k < 3; k++) {
        scene_t *s = cutout_scene(alphas[k], 1);
        int n = 4000, through = 0;
        for (int i = 0; i < n; i++) {
            double x = -1.0 + 2.0 * ((i * 0.618034) - floor(i * 0.618034));
            double y = -1.0 + 2.0 * ((i * 0.754878) - floor(i * 0.754878));
            through += !shading_occluded(s, vec3_make(x, y, -1), vec3_make(0, 0, 1), 0.0, 2.0);
        }
        double f = (double)through / n, want = 1.0 - alphas[k];
        double tol = 4.0 * sqrt(want * (1 - want) / n) + 1e-12;
        printf("alpha %.2f: %.4f of shadow rays pass (expected %.2f)\n", alphas[k], f, want);
        assert_true(fabs(f - want) <= tol);
        scene_destroy(&s);
    }
}

static void test_alpha_camera_rays(void **state)
{
    (void)state;
    scene_t *s = cutout_scene(0.0, 0);
    sb_image_stats_t open = sb_render_stats(s, 8, 32);
    scene_destroy(&s);
    s = cutout_scene(0.0, 1);
    sb_image_stats_t cut = sb_render_stats(s, 8, 32);
    scene_destroy(&s);
    s = cutout_scene(0.25, 1);
    sb_image_stats_t part = sb_render_stats(s, 8, 32);
    scene_destroy(&s);
    printf("camera: open %.5f, alpha 0 %.5f, alpha 0.25 %.5f +- %.5f (ratio %.4f)\n", open.mean, cut.mean,
           part.mean, part.se, part.mean / open.mean);
    assert_true(open.mean > 0.0);
    assert_true(fabs(cut.mean - open.mean) < 1e-9 * open.mean);
    /* each sample passes (L) or not (0): se of the fraction sqrt(p (1 - p) / N), N = 8 8 32 */
    double se = sqrt(0.75 * 0.25 / (8 * 8 * 32));
    assert_true(fabs(part.mean / open.mean - 0.75) < 4 * se);
}

/* The scene format: "texture displacement", "float alpha" and "texture alpha" reach the
 * scene; "ptex" loads as the constant 0.5 with a warning naming its file:line:col. */
static void test_parsed(void **state)
{
    (void)state;
    scene_t *s = sb_load_text(
        "WorldBegin\n"
        "Texture \"b\" \"float\" \"checkerboard\" \"float tex1\" 0 \"float tex2\" 0.001\n"
        "Texture \"p\" \"spectrum\" \"ptex\" \"string filename\" \"x.ptx\"\n"
        "Material \"diffuse\" \"texture displacement\" \"b\" \"texture reflectance\" \"p\"\n"
        "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] \"float alpha\" 0\n"
        "Shape \"trianglemesh\" \"point3 P\" [0 0 1 1 0 1 0 1 1] \"texture alpha\" \"b\"\n"
        "Shape \"trianglemesh\" \"point3 P\" [0 0 2 1 0 2 0 1 2]\n",
        NULL);
    assert_non_null(s->materials[1].displacement);
    assert_null(s->materials[0].displacement);
    assert_true(fabs(texture_eval(s->materials[1].reflectance, 0.3, 0.3, 500) - 0.5) < 1e-12);
    assert_non_null(s->shapes[0].alpha);
    assert_non_null(s->shapes[1].alpha);
    assert_null(s->shapes[2].alpha);
    assert_true(s->has_alpha);
    int found = 0;
    for (size_t i = 0; i < warnings_count(s->warnings); i++)
        found += strstr(warnings_at(s->warnings, i), "t.pbrt:3:") && strstr(warnings_at(s->warnings, i), "ptex");
    assert_int_equal(found, 1);
    scene_destroy(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bump_plane),
        cmocka_unit_test(test_normal_map),
        cmocka_unit_test(test_alpha_shadow_rays),
        cmocka_unit_test(test_alpha_camera_rays),
        cmocka_unit_test(test_parsed),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
