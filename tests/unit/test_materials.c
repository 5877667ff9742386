/* materials in the renderer: pbrt-v4's rough and layered materials as the camera pass sees
 * them, from pbrt-v4 scene text. The numbers come from energy conservation, not from the
 * code: in a furnace (a uniform environment of radiance 1 and nothing else) a surface that
 * loses no energy vanishes, so every bucket of the image is 1 within noise; a rough surface
 * loses only what single-scattering microfacets are known to lose (docs/physics.md). The two
 * ways of carrying hero wavelengths through a rough dispersive dielectric (spectral MIS and
 * pbrt-v4's termination of the secondaries) and the thesis's fan-out must agree in
 * expectation. No sample may be non-finite (sb_render_stats_with asserts it). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "material_class.h"
#include "material_kind.h"
#include "scene_builders.h"
#include "shading.h"

#define RES 12

/* A furnace: the sphere (radius 1) with the given material lines fills the middle of the
 * view; the environment is the only light. */
static scene_t *furnace_scene(const char *material, const char *integrator_extra)
{
    char text[2048];
    snprintf(text, sizeof text,
             "LookAt 0 0 -4  0 0 0  0 1 0\n"
             "Camera \"perspective\" \"float fov\" [ 24 ]\n"
             "Film \"spectral\" \"integer xresolution\" [ %d ] \"integer yresolution\" [ %d ]\n"
             "    \"integer nbuckets\" [ 8 ]\n"
             "Sampler \"independent\" \"integer pixelsamples\" [ 64 ]\n"
             "Integrator \"path\" \"integer maxdepth\" [ 100 ] \"string wavelengths\" \"uniform\" %s\n"
             "WorldBegin\n"
             "LightSource \"infinite\" \"spectrum L\" [ 300 1 900 1 ]\n"
             "%s\n"
             "Shape \"sphere\" \"float radius\" [ 1 ]\n",
             RES, RES, integrator_extra ? integrator_extra : "", material);
    return sb_load_text(text, NULL);
}

/* The environment's radiance as the film sees it: pbrt-v4 normalises a light's spectrum to
 * luminance 1 (scene_load's light_spectrum), which for a constant spectrum keeps it 1. The
 * same scene without the sphere gives the reference, so the test does not depend on that
 * convention: every bucket of the furnace divided by the empty scene's. */
static void furnace_check(const char *material, double lo, double hi, int spp)
{
    scene_t *s = furnace_scene(material, NULL);
    sb_image_stats_t st = sb_render_stats(s, RES, spp);
    scene_t *e = sb_load_text("LookAt 0 0 -4  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 24 ]\n"
                              "Film \"spectral\" \"integer xresolution\" [ 12 ] \"integer yresolution\" [ 12 ]\n"
                              "    \"integer nbuckets\" [ 8 ]\n"
                              "Integrator \"path\" \"string wavelengths\" \"uniform\"\n"
                              "WorldBegin\nLightSource \"infinite\" \"spectrum L\" [ 300 1 900 1 ]\n",
                              NULL);
    sb_image_stats_t ref = sb_render_stats(e, RES, 16);
    /* The environment's spectrum is constant: every bucket of the empty view holds the same
     * value, whose best estimate is their mean. */
    double ref_bucket = 0.0;
    for (int b = 0; b < s->settings.grid.n; b++)
        ref_bucket += ref.buckets[b] / s->settings.grid.n;
    double ratio = st.mean / ref.mean, se = st.se / ref.mean;
    print_message("furnace %-90.90s %.4f +- %.4f (allowed %.3f..%.3f)\n", material, ratio, se, lo, hi);
    if (!(ratio >= lo - 4 * se && ratio <= hi + 4 * se))
        fail_msg("%s: furnace %.5f +- %.5f, outside [%.3f, %.3f]", material, ratio, se, lo, hi);
    for (int b = 0; b < s->settings.grid.n; b++) {
        double r = st.buckets[b] / ref_bucket;
        /* A bucket holds an eighth of the wavelength samples, weighted differently from the
         * luminance: a wider band than the mean's. */
        if (!(r >= lo - 0.03 - 12 * se && r <= hi + 0.03 + 12 * se))
            fail_msg("%s: bucket %d furnace %.5f, outside [%.3f, %.3f] (+- 0.03 + 12 x %.5f)", material,
                     b, r, lo, hi, se);
    }
    scene_destroy(&s);
    scene_destroy(&e);
}

/* A perfect conductor (eta 0, k 1: Fresnel reflectance 1 at every angle) loses nothing when
 * smooth and, rough, only what a single-scattering GGX surface loses (Heitz et al. 2016,
 * Kulla & Conty 2017): the light its microfacets send below the horizon and what masking and
 * shadowing remove. At normal incidence at most 1 / (1 + alpha^2) survives (the visible
 * normals within 45 degrees), so at alpha 1 half is lost at least; test_bsdf measures the
 * directional albedo at 0 and 60 degrees (0.9879 / 0.9685 at roughness 0.01, 0.307 / 0.451
 * at roughness 1), and the sphere, seen from 0 to about 60 degrees, lies between. */
static void test_furnace_conductor(void **state)
{
    (void)state;
    furnace_check("Material \"conductor\" \"float eta\" [ 0 ] \"float k\" [ 1 ]", 1.0, 1.0, 16);
    furnace_check("Material \"conductor\" \"float eta\" [ 0 ] \"float k\" [ 1 ] \"float roughness\" [ 0.001 ]",
                  0.99, 1.0, 32);
    furnace_check("Material \"conductor\" \"float eta\" [ 0 ] \"float k\" [ 1 ] \"float roughness\" [ 0.01 ]",
                  0.965, 0.99, 32);
    furnace_check("Material \"conductor\" \"float eta\" [ 0 ] \"float k\" [ 1 ] \"float roughness\" [ 1 ]",
                  0.30, 0.46, 32);
}

/* Rough glass: reflection plus transmission at both interfaces of the sphere, and inside it
 * every internal reflection at the angle the light entered: each event loses the microfacet
 * share test_bsdf measures (0.9983 outside / 0.9848 inside at roughness 0.01, 30 degrees),
 * a few events per path. */
static void test_furnace_dielectric(void **state)
{
    (void)state;
    furnace_check("Material \"dielectric\" \"float eta\" [ 1.5 ] \"float roughness\" [ 0.001 ]", 0.99, 1.0, 32);
    furnace_check("Material \"dielectric\" \"float eta\" [ 1.5 ] \"float roughness\" [ 0.01 ]", 0.93, 0.99, 32);
    furnace_check("Material \"dielectric\" \"float eta\" [ 1.5 ] \"float roughness\" [ 0.3 ]", 0.50, 0.95, 32);
    /* dispersive rough glass: every lane in its own lobe, spectral MIS */
    furnace_check("Material \"dielectric\" \"string glass\" \"N-SF11\" \"float roughness\" [ 0.01 ]", 0.90, 0.99, 32);
}

/* Lossless Lambertian transmission and a thin slab vanish; so does a mix of lossless
 * materials. */
static void test_furnace_transmission(void **state)
{
    (void)state;
    furnace_check("Material \"diffusetransmission\" \"float reflectance\" [ 0.5 ] \"float transmittance\" [ 0.5 ]",
                  1.0, 1.0, 16);
    furnace_check("Material \"thindielectric\" \"float eta\" [ 1.5 ]", 1.0, 1.0, 16);
    furnace_check("MakeNamedMaterial \"a\" \"string type\" \"thindielectric\"\n"
                  "MakeNamedMaterial \"b\" \"string type\" \"diffusetransmission\" \"float reflectance\" [ 0.3 ] "
                  "\"float transmittance\" [ 0.7 ]\n"
                  "Material \"mix\" \"string materials\" [ \"a\" \"b\" ] \"float amount\" [ 0.3 ]",
                  1.0, 1.0, 16);
}

/* A coat over a white Lambertian base reflects everything but what the medium between them
 * absorbs: pbrt-v4's medium has unit extinction, so a thickness of 1e-5 absorbs nothing
 * measurable, while the default 0.01 absorbs about 8 % (exp(-0.01 / |cos|) per crossing, and
 * the coat's total internal reflection keeps the light crossing: bsdf/'s own albedo is 0.917
 * at normal incidence); the walk is cut at maxdepth (100 here); a rough coat loses its
 * microfacet share too, at every crossing of the coat and every bounce on a rough base (about
 * 2 % each at alpha 0.1, and the coat's total internal reflection makes several). */
static void test_furnace_coated(void **state)
{
    (void)state;
    furnace_check("Material \"coateddiffuse\" \"float reflectance\" [ 1 ] \"float thickness\" [ 1e-5 ] "
                  "\"integer maxdepth\" [ 100 ]",
                  0.985, 1.0, 32);
    furnace_check("Material \"coateddiffuse\" \"float reflectance\" [ 1 ] \"integer maxdepth\" [ 100 ]", 0.90,
                  0.94, 32);
    furnace_check("Material \"coateddiffuse\" \"float reflectance\" [ 1 ] \"float roughness\" [ 0.01 ] "
                  "\"float thickness\" [ 1e-5 ] \"integer maxdepth\" [ 100 ]",
                  0.90, 1.0, 32);
    furnace_check("Material \"coatedconductor\" \"float conductor.eta\" [ 0 ] \"float conductor.k\" [ 1 ] "
                  "\"float interface.roughness\" [ 0.01 ] \"float conductor.roughness\" [ 0.01 ] "
                  "\"float thickness\" [ 1e-5 ] \"integer maxdepth\" [ 100 ]",
                  0.87, 1.0, 32);
}

/* Rough N-SF11 in front of a coloured checkerboard: the camera sees the board through the
 * glass, each wavelength through its own lobe. Spectral MIS, termination of the secondaries
 * and fan-out estimate the same image. */
static sb_image_stats_t rough_glass(const char *integrator_extra, int spp)
{
    char text[2048];
    snprintf(text, sizeof text,
             "LookAt 0 0 -4  0 0 0  0 1 0\n"
             "Camera \"perspective\" \"float fov\" [ 24 ]\n"
             "Film \"spectral\" \"integer xresolution\" [ 12 ] \"integer yresolution\" [ 12 ]\n"
             "    \"integer nbuckets\" [ 8 ]\n"
             "Integrator \"path\" \"integer maxdepth\" [ 20 ] \"string wavelengths\" \"uniform\" %s\n"
             "WorldBegin\n"
             "LightSource \"infinite\" \"spectrum L\" [ 300 1 900 1 ]\n"
             "Texture \"c\" \"spectrum\" \"checkerboard\" \"float uscale\" [ 8 ] \"float vscale\" [ 8 ]\n"
             "    \"rgb tex1\" [ 0.9 0.1 0.1 ] \"rgb tex2\" [ 0.1 0.2 0.9 ]\n"
             "AttributeBegin\n"
             "  Material \"diffuse\" \"texture reflectance\" \"c\"\n"
             "  Shape \"trianglemesh\" \"point3 P\" [ -3 -3 3  3 -3 3  3 3 3  -3 3 3 ]\n"
             "    \"integer indices\" [ 0 1 2  0 2 3 ] \"point2 uv\" [ 0 0 1 0 1 1 0 1 ]\n"
             "AttributeEnd\n"
             "Material \"dielectric\" \"string glass\" \"N-SF11\" \"float roughness\" [ 0.003 ]\n"
             "Shape \"sphere\" \"float radius\" [ 1 ]\n",
             integrator_extra);
    scene_t *s = sb_load_text(text, NULL);
    sb_image_stats_t st = sb_render_stats(s, 12, spp);
    scene_destroy(&s);
    return st;
}

static void test_rough_dispersion_agrees(void **state)
{
    (void)state;
    sb_image_stats_t mis = rough_glass("\"bool spectralmis\" true", 256);
    sb_image_stats_t term = rough_glass("\"bool spectralmis\" false", 256);
    sb_image_stats_t fan = rough_glass("\"string dispersion\" \"fanout\"", 64);
    print_message("rough dispersive glass: MIS %.5f +- %.5f (per-sample variance %.4f), termination "
                  "%.5f +- %.5f (%.4f), fan-out %.5f +- %.5f\n",
                  mis.mean, mis.se, mis.var, term.mean, term.se, term.var, fan.mean, fan.se);
    double d = fabs(mis.mean - term.mean), sd = sqrt(mis.se * mis.se + term.se * term.se);
    if (!(d <= 4 * sd))
        fail_msg("MIS %.5f and termination %.5f differ by %.2f standard errors", mis.mean, term.mean, d / sd);
    d = fabs(mis.mean - fan.mean);
    sd = sqrt(mis.se * mis.se + fan.se * fan.se);
    if (!(d <= 4 * sd))
        fail_msg("MIS %.5f and fan-out %.5f differ by %.2f standard errors", mis.mean, fan.mean, d / sd);
    for (int b = 0; b < 8; b++) {
        double rel = fabs(mis.buckets[b] - term.buckets[b]) / mis.buckets[b];
        if (!(rel < 0.05))
            fail_msg("bucket %d: MIS %.5f, termination %.5f", b, mis.buckets[b], term.buckets[b]);
    }
}

/* The shading frame's x axis follows dp/du, so "uroughness" is the roughness along u as in
 * pbrt-v4: on a quad whose u runs along world z, and on a sphere at (1, 0, 0) of its own space
 * (phi runs about z: dp/du along +y there), here turned by a Rotate. */
static void test_frame_follows_u(void **state)
{
    (void)state;
    scene_t *s = sb_load_text("WorldBegin\nLightSource \"point\"\n"
                              "Shape \"trianglemesh\" \"point3 P\" [ -1 0 -1  -1 0 1  1 0 1  1 0 -1 ]\n"
                              "  \"integer indices\" [ 0 1 2  0 2 3 ] \"point2 uv\" [ 0 0  1 0  1 1  0 1 ]\n"
                              "AttributeBegin\n  Translate 0 5 0\n  Rotate 90 1 0 0\n"
                              "  Shape \"sphere\" \"float radius\" [ 1 ]\nAttributeEnd\n",
                              NULL);
    hit_t h;
    surface_t sf;
    assert_true(geometry_intersect(s->geometry, vec3_make(0.2, 2, 0.3), vec3_make(0, -1, 0), 0, INFINITY, &h));
    scene_surface(s, &h, &sf);
    shading_frame_t f = shading_frame_make(&sf, vec3_make(0, 1, 0));
    if (!(fabs(fabs(f.x.z) - 1.0) < 1e-9))
        fail_msg("quad: frame x (%g %g %g), expected along z", f.x.x, f.x.y, f.x.z);
    assert_true(fabs(vec3_dot(f.x, f.z)) < 1e-12 && fabs(vec3_dot(f.y, f.z)) < 1e-12);
    /* Rotate 90 about x takes the sphere's own +y to world +z; its point (1, 0, 0) stays. */
    assert_true(geometry_intersect(s->geometry, vec3_make(3, 5, 0), vec3_make(-1, 0, 0), 0, INFINITY, &h));
    scene_surface(s, &h, &sf);
    f = shading_frame_make(&sf, vec3_make(1, 0, 0));
    if (!(fabs(f.x.z - 1.0) < 1e-6))
        fail_msg("sphere: frame x (%g %g %g), expected +z", f.x.x, f.x.y, f.x.z);
    scene_destroy(&s);
}

/* An "interface" shape is no surface: light reaches the floor through it as if it were not
 * there, for shadow rays too (pbrt-v4's shadow rays stop at it and its path tracer makes up for
 * that by counting the pass as a specular bounce, the same expectation with more noise). */
static void test_interface_lets_light_through(void **state)
{
    (void)state;
    const char *head = "LookAt 0 5 -0.01  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 30 ]\n"
                       "Film \"spectral\" \"integer xresolution\" [ 12 ] \"integer yresolution\" [ 12 ]\n"
                       "Integrator \"whitted\"\nWorldBegin\n"
                       "LightSource \"point\" \"point3 from\" [ 0 3 0 ] \"float scale\" [ 10 ]\n"
                       "Shape \"trianglemesh\" \"point3 P\" [ -4 0 -4  4 0 -4  4 0 4  -4 0 4 ]\n"
                       "  \"integer indices\" [ 0 2 1  0 3 2 ]\n";
    char with[2048];
    snprintf(with, sizeof with,
             "%sAttributeBegin\n  Material \"interface\"\n  Translate 0 1.5 0\n"
             "  Shape \"sphere\" \"float radius\" [ 1 ]\nAttributeEnd\n",
             head);
    scene_t *a = sb_load_text(head, NULL), *b = sb_load_text(with, NULL);
    assert_false(a->has_interface);
    assert_true(b->has_interface);
    sb_image_stats_t sa = sb_render_stats(a, 12, 4), sbb = sb_render_stats(b, 12, 4);
    if (!(fabs(sa.mean - sbb.mean) <= 1e-9 * sa.mean + 4 * (sa.se + sbb.se)))
        fail_msg("floor under an interface sphere: %.6f, without it %.6f", sbb.mean, sa.mean);
    scene_destroy(&a);
    scene_destroy(&b);
}

/* Every kind of the registry (material_kind.h) has a class, whose name the loader's lookup
 * finds and reports give; the aliases find their kind too, and an unknown type is refused at
 * its place with the list written from the classes. Every kind that keeps its own kind when
 * loaded and is a surface makes its own BSDF, and a kind without one (a mix, an interface, a
 * sheet) gets the diffuse class's 0.5, as shading_bsdf's switch gave it before the classes. */
static void test_every_material_has_a_class(void **state)
{
    (void)state;
    const pbrt_loc_t loc = {.file = "t.pbrt", .line = 7, .col = 3};
    err_t err = {{0}};
    for (int k = 0; k < MATERIAL_KIND_COUNT; k++) {
        const material_kind_t kind = (material_kind_t)k;
        const material_class_t *c = material_class_of(kind);
        if (!c || !c->name)
            fail_msg("kind %d has no class or no name", k);
        material_kind_t found;
        if (material_class_lookup(c->name, loc, &found, &err) != 0 || found != kind)
            fail_msg("\"%s\" does not find its own kind: %s", c->name, err.msg);
        assert_string_equal(material_kind_name(kind), c->name);
        const int own_bsdf = kind != MATERIAL_MIX && kind != MATERIAL_INTERFACE &&
                             kind != MATERIAL_POLARISER && kind != MATERIAL_RETARDER &&
                             kind != MATERIAL_UNIAXIAL && kind != MATERIAL_SUBSURFACE;
        if (own_bsdf != (c->bsdf != NULL))
            fail_msg("material \"%s\": a BSDF of its own is %s", c->name,
                     own_bsdf ? "missing" : "unexpected");
    }
    assert_null(material_class_of(MATERIAL_KIND_COUNT));
    assert_string_equal(material_kind_name(MATERIAL_KIND_COUNT), "?");
    static const struct {
        const char *alias;
        material_kind_t kind;
    } ALIASES[] = {
        {"polariser", MATERIAL_POLARISER}, {"", MATERIAL_INTERFACE}, {"none", MATERIAL_INTERFACE}};
    for (size_t i = 0; i < sizeof ALIASES / sizeof ALIASES[0]; i++) {
        material_kind_t found;
        assert_int_equal(material_class_lookup(ALIASES[i].alias, loc, &found, &err), 0);
        assert_int_equal(found, ALIASES[i].kind);
    }
    material_kind_t found;
    assert_int_equal(material_class_lookup("polarisr", loc, &found, &err), -1);
    assert_string_equal(err.msg, "t.pbrt:7:3: unsupported material \"polarisr\" (did you mean "
                                 "\"polarizer\"? \"diffuse\", \"conductor\", \"dielectric\", "
                                 "\"thindielectric\", \"diffusetransmission\", \"coateddiffuse\", "
                                 "\"coatedconductor\", \"mix\", \"uniaxial\", \"interface\", "
                                 "\"polarizer\", \"retarder\", \"measured\", \"hair\" or "
                                 "\"subsurface\")");
    const material_t mix = {.kind = MATERIAL_MIX};
    const surface_t sf = {.ns = {0, 0, 1}, .ng = {0, 0, 1}};
    const double lambda[2] = {450.0, 650.0};
    bsdf_t b;
    shading_bsdf(&mix, &sf, lambda, 2, BSDF_RADIANCE, &b);
    assert_int_equal(b.kind, BSDF_DIFFUSE);
    assert_true(b.reflectance[0] == 0.5 && b.reflectance[1] == 0.5);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_furnace_conductor),
        cmocka_unit_test(test_furnace_dielectric),
        cmocka_unit_test(test_furnace_transmission),
        cmocka_unit_test(test_furnace_coated),
        cmocka_unit_test(test_rough_dispersion_agrees),
        cmocka_unit_test(test_frame_follows_u),
        cmocka_unit_test(test_interface_lets_light_through),
        cmocka_unit_test(test_every_material_has_a_class),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
