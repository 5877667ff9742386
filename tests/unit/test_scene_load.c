/* scene_load: pbrt-v4's meaning of the scene values the loader turns into a renderable scene,
 * checked against pbrt-v4's formulas (lights.cpp, textures.cpp, shapes.h), not against the
 * loader's code: light normalisation (spectrum / photometric value, "scale" = luminance, rgb
 * normalised by its illuminant alone), "power" and "illuminance", imagemap encodings, default
 * texture coordinates, and vertex normals under ReverseOrientation; pbrt-v4's procedural
 * textures loaded and rendered, a 3D one read at each hit's point in the CTM's space. */
#define _XOPEN_SOURCE 700 /* mkdtemp */

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cie.h"
#include "image_png.h"
#include "pbrt_parser.h"
#include "scene_builders.h"
#include "scene_load.h"
#include "tilebuf.h"

static void expect_load_error(const char *text, const char *expected)
{
    err_t err = {{0}};
    scene_desc_t *d = pbrt_parse_string(text, strlen(text), "t.pbrt", &err);
    if (!d)
        fail_msg("parse: %s", err.msg);
    scene_t *s = scene_load(d, NULL, &err);
    scene_desc_destroy(&d);
    if (s) {
        scene_destroy(&s);
        fail_msg("loaded but should have failed with: %s", expected);
    }
    if (strcmp(err.msg, expected) != 0)
        fail_msg("wrong message\n  got:      %s\n  expected: %s", err.msg, expected);
}

static void assert_rel(double got, double expected, double tol, const char *what)
{
    if (!(fabs(got - expected) <= tol * fabs(expected)))
        fail_msg("%s: got %.9g, expected %.9g (relative tolerance %g)", what, got, expected, tol);
}

/* Luminance of what a light emits per unit "scale": Y = integral of s y-bar / integral of
 * y-bar (colour.h's normalisation: a constant 1 has Y = 1). */
static double light_luminance(const light_t *l)
{
    return l->scale * spectrum_photometric(l->spectrum) / CIE_Y_INTEGRAL;
}

/* The spectra sum against the 1 nm CIE table, as the normalisation does: agreement to 1e-9. */
#define TOL 1e-9

static void test_light_normalisation(void **state)
{
    (void)state;
    scene_t *s =
        sb_load_text("WorldBegin\n"
                     "LightSource \"point\" \"blackbody I\" 3000 \"float scale\" 3\n"
                     "LightSource \"point\" \"spectrum I\" \"stdillum-A\" \"float scale\" 2\n"
                     "LightSource \"point\" \"spectrum I\" [400 1 500 8 700 3]\n"
                     "LightSource \"point\" \"rgb I\" [1 1 1]\n"
                     "LightSource \"point\" \"rgb I\" [10 10 10] \"float scale\" 0.5\n"
                     "LightSource \"point\" \"rgb I\" [0.8 0.4 0.1]\n"
                     "LightSource \"point\" \"float I\" 5\n"
                     "LightSource \"point\"\n",
                     NULL);
    assert_int_equal(s->nlights, 8);
    /* Spectra are divided by their photometric value: "scale" is the luminance. */
    assert_rel(light_luminance(&s->lights[0]), 3.0, TOL, "blackbody");
    assert_rel(light_luminance(&s->lights[1]), 2.0, TOL, "stdillum-A");
    assert_rel(light_luminance(&s->lights[2]), 1.0, TOL, "sampled");
    /* ... and keep their shape: the sampled spectrum's 500 nm / 400 nm ratio is 8. */
    assert_rel(spectrum_eval(s->lights[2].spectrum, 500) / spectrum_eval(s->lights[2].spectrum, 400), 8.0,
               1e-12, "shape");
    /* rgb is normalised by its illuminant (D65) only, so it keeps the colour's luminance
     * (pbrt-v4 SpectrumToPhotometric): rgb [1 1 1] has Y = 1, [10 10 10] at scale 0.5 Y = 5, and
     * [0.8 0.4 0.1] the sRGB luminance 0.2126 0.8 + 0.7152 0.4 + 0.0722 0.1 (IEC 61966-2-1),
     * up to the uplift's residual (1e-3). */
    assert_rel(light_luminance(&s->lights[3]), 1.0, 1e-3, "rgb white");
    assert_rel(light_luminance(&s->lights[4]), 5.0, 1e-3, "rgb 10");
    assert_rel(light_luminance(&s->lights[5]), 0.2126 * 0.8 + 0.7152 * 0.4 + 0.0722 * 0.1, 1e-3, "rgb colour");
    /* prismfarm's "float I" v: equal energy, luminance v. */
    assert_rel(light_luminance(&s->lights[6]), 5.0, TOL, "float");
    assert_rel(spectrum_eval(s->lights[6].spectrum, 420) / spectrum_eval(s->lights[6].spectrum, 680), 1.0,
               1e-12, "flat");
    /* The default is the colour space's illuminant, D65, of luminance 1. */
    assert_rel(light_luminance(&s->lights[7]), 1.0, TOL, "default");
    scene_destroy(&s);
}

static void test_power_and_illuminance(void **state)
{
    (void)state;
    scene_t *s =
        sb_load_text("WorldBegin\n"
                     "LightSource \"point\" \"float power\" 100\n"
                     "LightSource \"spot\" \"float power\" 100 \"float coneangle\" 40 "
                     "\"float conedeltaangle\" 10 \"float scale\" 2\n"
                     "LightSource \"distant\" \"float illuminance\" 7\n"
                     "LightSource \"infinite\" \"float illuminance\" 7\n"
                     "AttributeBegin\n"
                     "  AreaLightSource \"diffuse\" \"float power\" 100\n"
                     "  Shape \"sphere\" \"float radius\" 2\n"
                     "AttributeEnd\n"
                     "AttributeBegin\n"
                     "  AreaLightSource \"diffuse\" \"float power\" 100 \"bool twosided\" true\n"
                     "  Shape \"trianglemesh\" \"point3 P\" [0 0 0 2 0 0 2 2 0 0 2 0] \"integer "
                     "indices\" [0 1 2 0 2 3]\n"
                     "AttributeEnd\n",
                     NULL);
    assert_int_equal(s->nlights, 6);
    /* pbrt-v4 lights.cpp, with the spectrum normalised to luminance 1:
     * point: I = power / (4 pi). */
    assert_rel(light_luminance(&s->lights[0]), 100 / (4 * PF_PI), TOL, "point");
    /* spot: I = scale * power / (2 pi ((1 - cos start) + (cos start - cos end) / 2)), with the
     * falloff starting at coneangle - conedeltaangle = 30 degrees and ending at 40. */
    double cs = cos(30 * PF_PI / 180), ce = cos(40 * PF_PI / 180);
    assert_rel(light_luminance(&s->lights[1]), 2 * 100 / (2 * PF_PI * ((1 - cs) + (cs - ce) / 2)), TOL, "spot");
    /* distant: the illuminance at normal incidence; infinite: a uniform sky of radiance L
     * gives illuminance pi L. */
    assert_rel(light_luminance(&s->lights[2]), 7, TOL, "distant");
    assert_rel(light_luminance(&s->lights[3]), 7 / PF_PI, TOL, "infinite");
    /* A diffuse emitter of radiance L and area A emits pi A L: sphere of radius 2. */
    assert_rel(light_luminance(&s->lights[4]), 100 / (PF_PI * 4 * PF_PI * 4), TOL, "sphere");
    /* A two-sided quad of two equal triangles: pbrt-v4 gives each triangle (area 2) the power:
     * L = 100 / (2 pi 2). */
    assert_rel(light_luminance(&s->lights[5]), 100 / (2 * PF_PI * 2), TOL, "quad");
    scene_destroy(&s);

    expect_load_error("WorldBegin\nAreaLightSource \"diffuse\" \"float power\" 10\n"
                      "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0 3 3 0] \"integer indices\" [0 1 2 1 3 2]\n",
                      "t.pbrt:2:1: \"power\" on a mesh whose triangles differ in area is not supported "
                      "(pbrt-v4 gives each triangle that power); use \"scale\"");
}

/* A 2 x 1 PNG written for the test: a grey of 128 and the colour (200, 100, 0). */
static void write_png(char *dir, char *path, size_t n)
{
    assert_non_null(mkdtemp(dir));
    snprintf(path, n, "%s/tex.png", dir);
    uint8_t rgb[6] = {128, 128, 128, 200, 100, 0};
    err_t err;
    assert_int_equal(image_png_write_rgb(path, 2, 1, rgb, &err), 0);
}

static double srgb_to_linear(double v)
{
    /* IEC 61966-2-1 */
    return v <= 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4);
}

static void test_imagemap_encodings(void **state)
{
    (void)state;
    char dir[] = "/tmp/prismfarm-tex-XXXXXX", path[128], text[2048];
    write_png(dir, path, sizeof path);
    /* Materials 1-3 read the grey texel with each encoding; material 4 is a mix whose amount
     * is a float imagemap of the colour texel (linear): pbrt-v4 averages the channels. */
    snprintf(text, sizeof text,
             "WorldBegin\n"
             "Texture \"s\" \"spectrum\" \"imagemap\" \"string filename\" \"%s\"\n"
             "Texture \"l\" \"spectrum\" \"imagemap\" \"string filename\" \"%s\" \"string encoding\" \"linear\"\n"
             "Texture \"g\" \"spectrum\" \"imagemap\" \"string filename\" \"%s\" \"string encoding\" \"gamma 2.2\"\n"
             "Texture \"f\" \"float\" \"imagemap\" \"string filename\" \"%s\" \"string encoding\" \"linear\"\n"
             "Texture \"m\" \"spectrum\" \"mix\" \"float tex1\" 0 \"float tex2\" 1 \"texture amount\" \"f\"\n"
             "Material \"diffuse\" \"texture reflectance\" \"s\"\n"
             "Material \"diffuse\" \"texture reflectance\" \"l\"\n"
             "Material \"diffuse\" \"texture reflectance\" \"g\"\n"
             "Material \"diffuse\" \"texture reflectance\" \"m\"\n",
             path, path, path, path);
    scene_t *s = sb_load_text(text, NULL);
    /* Texel centres: (0.25, 0.5) is the grey, (0.75, 0.5) the colour. A grey uplifts to a flat
     * spectrum of exactly its value. */
    double v = 128 / 255.0;
    assert_rel(texture_eval(s->materials[1].reflectance, 0.25, 0.5, 550), srgb_to_linear(v), 1e-6, "sRGB");
    assert_rel(texture_eval(s->materials[2].reflectance, 0.25, 0.5, 550), v, 1e-6, "linear");
    assert_rel(texture_eval(s->materials[3].reflectance, 0.25, 0.5, 550), pow(v, 2.2), 1e-6, "gamma");
    double avg = (200 + 100 + 0) / 255.0 / 3.0;
    assert_rel(texture_eval(s->materials[4].reflectance, 0.75, 0.5, 450), avg, 1e-6, "float 450");
    assert_rel(texture_eval(s->materials[4].reflectance, 0.75, 0.5, 650), avg, 1e-6, "float 650");
    scene_destroy(&s);
    unlink(path);
    rmdir(dir);
}

/* Texture coordinates and normals at hits, as pbrt-v4 defines them. */
static void test_surface_conventions(void **state)
{
    (void)state;
    scene_t *s = sb_load_text(
        "WorldBegin\n"
        /* 0: no uv: pbrt-v4 gives the vertices (0,0), (1,0), (1,1) */
        "Shape \"trianglemesh\" \"point3 P\" [0 0 0 4 0 0 4 4 0]\n"
        /* 1: a sphere at x = 10 */
        "AttributeBegin\nTranslate 10 0 0\nShape \"sphere\"\nAttributeEnd\n"
        /* 2: normals (0 0 1) under ReverseOrientation, wound to face -z */
        "AttributeBegin\nReverseOrientation\nTranslate 20 0 0\n"
        "Shape \"trianglemesh\" \"point3 P\" [0 0 0 0 4 0 4 0 0] \"normal N\" [0 0 1 0 0 1 0 0 1]\n"
        "AttributeEnd\n",
        NULL);
    hit_t h;
    surface_t sf;
    /* (3, 1) = 0.25 p0 + 0.5 p1 + 0.25 p2: uv = 0.5 (1, 0) + 0.25 (1, 1) = (0.75, 0.25). */
    assert_int_equal(geometry_intersect(s->geometry, vec3_make(3, 1, 5), vec3_make(0, 0, -1), 0, INFINITY, &h), 1);
    scene_surface(s, &h, &sf);
    assert_rel(sf.u, 0.75, 1e-6, "u");
    assert_rel(sf.v, 0.25, 1e-6, "v");
    assert_false(sf.smooth);
    /* pbrt-v4 Sphere: v = (theta - pi) / (0 - pi): 1 at the north pole z = +r, 0 at z = -r;
     * u = phi / 2 pi: at (0, 1, 0) of the sphere, 1/4. */
    assert_int_equal(geometry_intersect(s->geometry, vec3_make(10, 0, 5), vec3_make(0, 0, -1), 0, INFINITY, &h), 1);
    scene_surface(s, &h, &sf);
    assert_true(fabs(sf.v - 1.0) < 1e-6);
    assert_int_equal(geometry_intersect(s->geometry, vec3_make(10, 5, 0), vec3_make(0, -1, 0), 0, INFINITY, &h), 1);
    scene_surface(s, &h, &sf);
    assert_rel(sf.u, 0.25, 1e-9, "u");
    assert_rel(sf.v, 0.5, 1e-9, "v");
    /* Winding (0,0,0) (0,4,0) (4,0,0) gives (p0 - p2) x (p1 - p2) = -z, ReverseOrientation
     * flips it to +z; pbrt-v4's TriangleMesh flips the vertex normals too, to -z, and the
     * geometric normal turns toward them: both end at -z. */
    assert_int_equal(geometry_intersect(s->geometry, vec3_make(21, 1, 5), vec3_make(0, 0, -1), 0, INFINITY, &h), 1);
    assert_true(h.ng.z > 0.999);
    scene_surface(s, &h, &sf);
    assert_true(sf.smooth);
    assert_true(sf.ns.z < -0.999);
    assert_true(sf.ng.z < -0.999);
    scene_destroy(&s);
}

static void test_integrator_options(void **state)
{
    (void)state;
    scene_t *s = sb_load_text(
        "Integrator \"path\" \"string lightsampler\" \"power\" \"bool regularize\" false\n"
        "WorldBegin\n",
        NULL);
    assert_int_equal(s->settings.integrator, INTEGRATOR_PATH);
    assert_int_equal(s->settings.regularize, 0);
    scene_destroy(&s);
    s = sb_load_text("Integrator \"volpath\" \"bool regularize\" true\nWorldBegin\n", NULL);
    assert_int_equal(s->settings.regularize, 1);
    scene_destroy(&s);
    expect_load_error("Integrator \"whitted\" \"bool regularize\" true\nWorldBegin\n",
                      "t.pbrt:1:22: unsupported parameter \"bool regularize\" for Integrator "
                      "\"whitted\"");
    expect_load_error("Integrator \"whitted\" \"string lightsampler\" \"bvh\"\nWorldBegin\n",
                      "t.pbrt:1:22: unsupported parameter \"string lightsampler\" for Integrator "
                      "\"whitted\"");
    /* The loader's names are looked up in their tables, whose names its messages list. */
    expect_load_error("Integrator \"path\" \"string lightsampler\" \"powr\"\nWorldBegin\n",
                      "t.pbrt:1:19: unsupported \"string lightsampler\" \"powr\" (did you mean "
                      "\"power\"? \"bvh\", \"power\" or \"uniform\")");
    expect_load_error("Integrator \"photon\" \"string store\" \"grid\"\nWorldBegin\n",
                      "t.pbrt:1:21: unsupported \"string store\" \"grid\" (\"photonmap\" or "
                      "\"lightmap\")");
}

/* What a scene asks for that is accepted without being simulated comes back as warnings
 * naming file:line:col, once each; a scene without lights says why it renders black. */
/* The procedural textures' scene renders finite pixels; a floor under a 3D checkerboard of
 * 0 and 0.8 (cells of side 1 after Scale 1 1 1, seen from above) shows both colours, about half
 * each, so the texture was read at every hit's own point. */
static void test_procedural_textures(void **state)
{
    (void)state;
    scene_t *s = sb_load_file("data/scenes/procedural.pbrt");
    sb_image_stats_t st = sb_render_stats(s, 16, 4);
    printf("procedural.pbrt: mean %.4f max %.4f\n", st.mean, st.max);
    assert_true(st.mean > 0.05 && isfinite(st.max));
    scene_destroy(&s);
    s = sb_load_text("Film \"rgb\" \"integer xresolution\" 32 \"integer yresolution\" 32\n"
                     "LookAt 0.1 10 0.1  0.1 0 0.1  0 0 1\n"
                     "Camera \"orthographic\" \"float screenwindow\" [-4 4 -4 4]\n"
                     "WorldBegin\n"
                     "LightSource \"infinite\" \"rgb L\" [1 1 1]\n"
                     "Texture \"c\" \"spectrum\" \"checkerboard\" \"integer dimension\" 3\n"
                     "  \"rgb tex1\" [0 0 0] \"rgb tex2\" [0.8 0.8 0.8]\n"
                     "Material \"diffuse\" \"texture reflectance\" \"c\"\n"
                     "Shape \"bilinearmesh\" \"point3 P\" [-9 0.5 -9  9 0.5 -9  -9 0.5 9  9 0.5 9]\n",
                     NULL);
    s->settings.maxdepth = 1;
    err_t err;
    tilebuf_t *t = tilebuf_new(0, 0, 32, 32, s->settings.grid.n, &err);
    assert_non_null(t);
    render_stats_t rst = {0};
    assert_int_equal(render_tile(s, NULL, 0, 0, 32, 32, 0, 4, t, &rst, &err), 0);
    int dark = 0, bright = 0;
    for (int y = 0; y < 32; y++)
        for (int x = 0; x < 32; x++) {
            double l = tilebuf_luminance_sum(t, x, y) / (double)tilebuf_count(t, x, y);
            dark += l < 0.4; /* half of tex2's 0.8: pixels mostly in a dark cell */
            bright += l >= 0.4;
        }
    printf("3D checkerboard: %d dark and %d bright pixels of 1024\n", dark, bright);
    assert_true(dark > 400 && bright > 400);
    tilebuf_destroy(&t);
    scene_destroy(&s);
}

static void test_warnings(void **state)
{
    (void)state;
    err_t err = {{0}};
    scene_t *s = sb_load_text("WorldBegin\nShape \"sphere\"\n", NULL);
    assert_int_equal(warnings_count(s->warnings), 1);
    assert_string_equal(warnings_at(s->warnings, 0),
                        "t.pbrt:1:1: the scene has no light source: the image will be black");
    scene_destroy(&s);
    s = sb_load_text("WorldBegin\nLightSource \"point\"\nShape \"sphere\"\n", NULL);
    assert_int_equal(warnings_count(s->warnings), 0);
    scene_destroy(&s);

    warnings_t *w = warnings_new(&err);
    pbrt_loc_t at = {"a.pbrt", 3, 7};
    for (int i = 0; i < 3; i++)
        assert_int_equal(warnings_add(w, at, "%s is ignored", "x"), 0);
    assert_int_equal(warnings_count(w), 1);
    assert_string_equal(warnings_at(w, 0), "a.pbrt:3:7: x is ignored");
    for (int i = 0; i < WARNINGS_MAX + 5; i++)
        assert_int_equal(warnings_add(w, at, "line %d", i), 0);
    assert_int_equal(warnings_count(w), WARNINGS_MAX);
    assert_int_equal(warnings_dropped(w), 6);
    warnings_destroy(&w);
    assert_null(w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_light_normalisation),
        cmocka_unit_test(test_power_and_illuminance),
        cmocka_unit_test(test_imagemap_encodings),
        cmocka_unit_test(test_surface_conventions),
        cmocka_unit_test(test_integrator_options),
        cmocka_unit_test(test_warnings),
        cmocka_unit_test(test_procedural_textures),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
