/* Tests for path regularisation (bsdf/regularize.h, pbrt-v4's "bool regularize"):
 * - the roughening rule against pbrt-v4's TrowbridgeReitzDistribution::Regularize written out
 *   (alpha < 0.3 -> clamp(2 alpha, 0.1, 0.3)), per model (layered: both interfaces; diffuse and
 *   thin dielectric unchanged);
 * - a caustic seen through a diffuse bounce (a small light in a smooth mirror, lighting a floor
 *   the camera sees) is found by next-event estimation once the mirror is roughened after the
 *   floor's bounce: the per-sample variance drops many times, the mean stays near (the
 *   roughened caustic is the same light, blurred);
 * - before any non-specular bounce nothing changes: a glass ball and a mirror under a sky,
 *   with no diffuse surface, renders the same bytes with and without the option. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "regularize.h"
#include "scene_builders.h"
#include "tilebuf.h"

static void test_rule(void **state)
{
    (void)state;
    const double in[] = {0.0, 0.02, 0.05, 0.1, 0.12, 0.2, 0.29, 0.3, 0.5, 1.0};
    const double out[] = {0.1, 0.1, 0.1, 0.2, 0.24, 0.3, 0.3, 0.3, 0.5, 1.0};
    for (size_t i = 0; i < sizeof in / sizeof in[0]; i++) {
        microfacet_t m = regularize_microfacet((microfacet_t){in[i], 0.7});
        assert_true(fabs(m.alpha_x - out[i]) < 1e-12);
        assert_true(m.alpha_y == 0.7);
    }
    microfacet_t bad = regularize_microfacet((microfacet_t){NAN, -1.0});
    assert_true(bad.alpha_x == 0.1 && bad.alpha_y == 0.1);
}

static void test_models(void **state)
{
    (void)state;
    const microfacet_t smooth = {0.0, 0.0}, rough = {0.5, 0.5};
    bsdf_t b = {.kind = BSDF_DIELECTRIC, .mf = smooth, .mf_base = smooth};
    regularize_bsdf(&b);
    assert_true(b.mf.alpha_x == 0.1 && b.mf.alpha_y == 0.1 && !microfacet_smooth(&b.mf));
    b = (bsdf_t){.kind = BSDF_CONDUCTOR, .mf = rough};
    regularize_bsdf(&b);
    assert_true(b.mf.alpha_x == 0.5);
    b = (bsdf_t){.kind = BSDF_COATED_CONDUCTOR, .mf = smooth, .mf_base = {0.05, 0.2}};
    regularize_bsdf(&b);
    assert_true(b.mf.alpha_x == 0.1 && b.mf_base.alpha_x == 0.1 &&
                fabs(b.mf_base.alpha_y - 0.3) < 1e-12);
    b = (bsdf_t){.kind = BSDF_COATED_DIFFUSE, .mf = {0.12, 0.12}};
    regularize_bsdf(&b);
    assert_true(fabs(b.mf.alpha_x - 0.24) < 1e-12);
    const bsdf_kind_t same[] = {BSDF_DIFFUSE, BSDF_DIFFUSE_TRANSMISSION, BSDF_THIN_DIELECTRIC};
    for (size_t i = 0; i < 3; i++) {
        b = (bsdf_t){.kind = same[i], .mf = smooth, .mf_base = smooth};
        regularize_bsdf(&b);
        assert_true(b.mf.alpha_x == 0.0 && b.mf_base.alpha_x == 0.0);
    }
}

/* A floor seen from above, lit by a small sphere light directly and through a smooth mirror
 * wall that the camera does not see (L S D E: the mirror's caustic on the floor). */
static scene_t *caustic_scene(bool regularize)
{
    char text[2048];
    snprintf(text, sizeof text,
             "Film \"rgb\" \"integer xresolution\" 12 \"integer yresolution\" 12\n"
             "LookAt 0 5 1  0 0 1  0 0 -1\n"
             "Camera \"perspective\" \"float fov\" 40\n"
             "Sampler \"independent\"\n"
             "Integrator \"path\" \"integer maxdepth\" 5 \"bool regularize\" %s\n"
             "WorldBegin\n"
             "Material \"diffuse\" \"rgb reflectance\" [0.5 0.5 0.5]\n"
             "Shape \"bilinearmesh\" \"point3 P\" [-4 0 -3  4 0 -3  -4 0 4  4 0 4]\n"
             "AttributeBegin\n"
             "  Material \"conductor\" \"float roughness\" 0 \"spectrum eta\" \"metal-Ag-eta\" "
             "\"spectrum k\" \"metal-Ag-k\"\n"
             "  Shape \"bilinearmesh\" \"point3 P\" [-4 0 -2  4 0 -2  -4 3 -2  4 3 -2]\n"
             "AttributeEnd\n"
             "AttributeBegin\n"
             "  Translate 0 0.8 -1\n"
             "  AreaLightSource \"diffuse\" \"rgb L\" [400 400 400]\n"
             "  Shape \"sphere\" \"float radius\" 0.05\n"
             "AttributeEnd\n",
             regularize ? "true" : "false");
    return sb_load_text(text, NULL);
}

static void test_caustic_found(void **state)
{
    (void)state;
    const int res = 12, spp = 512;
    scene_t *plain = caustic_scene(false), *reg = caustic_scene(true);
    assert_int_equal(plain->settings.regularize, 0);
    assert_int_equal(reg->settings.regularize, 1);
    sb_image_stats_t a = sb_render_stats(plain, res, spp);
    sb_image_stats_t b = sb_render_stats(reg, res, spp);
    printf(
        "plain: mean %.4f +- %.4f var %.4g; regularized: mean %.4f +- %.4f var %.4g (ratio %.1f)\n",
        a.mean, a.se, a.var, b.mean, b.se, b.var, a.var / b.var);
    /* The caustic is found by light sampling instead of by chance. */
    assert_true(b.var * 8.0 < a.var);
    /* The same light, blurred by the roughened mirror: the mean moves little against the
     * plain render's own noise. */
    assert_true(fabs(a.mean - b.mean) < 4.0 * a.se + 0.1 * a.mean);
    scene_destroy(&plain);
    scene_destroy(&reg);
}

/* No non-specular surface: every bounce is on smooth glass or a smooth mirror, the option
 * never applies, and the tile's bytes are those without it. */
static tilebuf_t *render_specular_only(bool regularize)
{
    char text[2048];
    snprintf(text, sizeof text,
             "Film \"rgb\" \"integer xresolution\" 10 \"integer yresolution\" 10\n"
             "LookAt 0 0 5  0 0 0  0 1 0\n"
             "Camera \"perspective\" \"float fov\" 30\n"
             "Integrator \"path\" \"bool regularize\" %s\n"
             "WorldBegin\n"
             "LightSource \"infinite\" \"rgb L\" [0.3 0.5 0.8]\n"
             "Material \"dielectric\" \"float eta\" 1.5\n"
             "Shape \"sphere\" \"float radius\" 1\n"
             "Material \"conductor\" \"float roughness\" 0\n"
             "Shape \"bilinearmesh\" \"point3 P\" [-5 -1.5 -5  5 -1.5 -5  -5 -1.5 5  5 -1.5 5]\n",
             regularize ? "true" : "false");
    scene_t *s = sb_load_text(text, NULL);
    err_t err;
    tilebuf_t *t = tilebuf_new(0, 0, 10, 10, s->settings.grid.n, &err);
    assert_non_null(t);
    render_stats_t rst = {0};
    if (render_tile(s, NULL, 0, 0, 10, 10, 0, 16, t, &rst, &err))
        fail_msg("render_tile: %s", err.msg);
    scene_destroy(&s);
    return t;
}

static void test_specular_only_unchanged(void **state)
{
    (void)state;
    tilebuf_t *a = render_specular_only(false), *b = render_specular_only(true);
    double sum = 0.0;
    for (int y = 0; y < 10; y++)
        for (int x = 0; x < 10; x++) {
            assert_true(tilebuf_luminance_sum(a, x, y) == tilebuf_luminance_sum(b, x, y));
            for (int k = 0; k < tilebuf_nbuckets(a); k++)
                assert_true(tilebuf_sum(a, x, y, k) == tilebuf_sum(b, x, y, k));
            sum += tilebuf_luminance_sum(a, x, y);
        }
    assert_true(sum > 0.0);
    tilebuf_destroy(&a);
    tilebuf_destroy(&b);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rule),
        cmocka_unit_test(test_models),
        cmocka_unit_test(test_caustic_found),
        cmocka_unit_test(test_specular_only_unchanged),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
