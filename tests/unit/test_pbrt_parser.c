/* pbrt_parser: every supported directive parses into the data pbrt-v4 gives it, each error
 * case produces its exact located message, includes resolve relative to the including file,
 * PLY files (ascii and binary) load with their vertex and face counts, and mutated scenes
 * never crash the parser. Runs with the working directory tests/ (tests/CMakeLists.txt). */
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

#include "files_testutil.h"
#include "material_coatedconductor.h"
#include "material_coateddiffuse.h"
#include "material_diffusetransmission.h"
#include "material_mix.h"
#include "mesh_import.h"
#include "numeric_testutil.h"
#include "pbrt_parser.h"
#include "scene_load.h"

/* Values in the scene files are short decimals parsed by strtod (correctly rounded) and
 * pushed through at most two 4x4 products of small integers: a few ulps, far below 1e-12. */
#define TOL 1e-12

static scene_desc_t *parse_ok(const char *path)
{
    err_t err = {{0}};
    scene_desc_t *s = pbrt_parse_file(path, &err);
    if (!s)
        fail_msg("%s did not parse: %s", path, err.msg);
    return s;
}

static scene_desc_t *parse_text_ok(const char *text)
{
    err_t err = {{0}};
    scene_desc_t *s = pbrt_parse_string(text, strlen(text), "t.pbrt", &err);
    if (!s)
        fail_msg("did not parse: %s\n--\n%s", err.msg, text);
    return s;
}

static void expect_error_named(const char *name, const char *text, const char *expected)
{
    err_t err = {{0}};
    scene_desc_t *s = pbrt_parse_string(text, strlen(text), name, &err);
    if (s) {
        /* A material's parameters are read by its class when the scene loads (pbrt-v4's
         * Material::Create): their errors come from the loader, in the same words. */
        scene_t *sc = scene_load(s, NULL, &err);
        scene_desc_destroy(&s);
        if (sc) {
            scene_destroy(&sc);
            fail_msg("parsed and loaded but should have failed with: %s\n--\n%s", expected, text);
        }
    }
    if (strcmp(err.msg, expected) != 0)
        fail_msg("wrong message for\n%s\n  got:      %s\n  expected: %s", text, err.msg, expected);
}

static void expect_error(const char *text, const char *expected)
{
    expect_error_named("t.pbrt", text, expected);
}

static void assert_point(const transform_t *t, vec3_t p, double x, double y, double z)
{
    vec3_t q = transform_point(t, p);
    if (fabs(q.x - x) > TOL || fabs(q.y - y) > TOL || fabs(q.z - z) > TOL)
        fail_msg("mapped to (%.17g, %.17g, %.17g), expected (%g, %g, %g)", q.x, q.y, q.z, x, y, z);
}

/* ---- options ---- */

static void test_options(void **state)
{
    (void)state;
    scene_desc_t *s = parse_ok("data/scenes/options.pbrt");
    assert_string_equal(s->camera.type, "perspective");
    testutil_assert_near(s->camera.fov, 45, TOL);
    testutil_assert_near(s->camera.lensradius, 0.1, TOL);
    testutil_assert_near(s->camera.focaldistance, 5, TOL);
    assert_int_equal(s->camera.loc.line, 3);
    /* LookAt 0 0 -5  0 0 0  0 1 0: the world origin is 5 units ahead of the camera. */
    assert_point(&s->camera.camera_from_world, vec3_make(0, 0, 0), 0, 0, 5);
    assert_point(&s->camera.camera_from_world, vec3_make(1, 0, 0), 1, 0, 5);

    assert_int_equal(s->film.type, SCENE_FILM_SPECTRAL);
    assert_int_equal(s->film.xres, 320);
    assert_int_equal(s->film.yres, 240);
    assert_string_equal(s->film.filename, "out.exr");
    assert_int_equal(s->film.nbuckets, 32);
    testutil_assert_near(s->film.lambda_min, 300, TOL);
    testutil_assert_near(s->film.lambda_max, 1000, TOL);

    assert_string_equal(s->sampler.type, "halton");
    assert_int_equal(s->sampler.pixelsamples, 64);

    /* The renderer's side of the integrator contract: look up what it knows, then reject
     * the rest with the parameter's location. */
    assert_string_equal(s->integrator.type, "path");
    params_t *ip = s->integrator.params;
    assert_int_equal(params_count(ip), 4);
    int maxdepth = 0, photons = 0;
    const char *dispersion = NULL;
    err_t err = {{0}};
    assert_int_equal(params_get_int(ip, "maxdepth", 5, &maxdepth, &err), 0);
    assert_int_equal(params_get_string(ip, "dispersion", "hero", &dispersion, &err), 0);
    assert_int_equal(params_get_int(ip, "photons", 0, &photons, &err), 0);
    assert_int_equal(maxdepth, 7);
    assert_string_equal(dispersion, "fanout");
    assert_int_equal(photons, 100000);
    assert_int_equal(params_check_unused(ip, &err), -1);
    assert_string_equal(err.msg, "data/scenes/options.pbrt:10:30: unsupported parameter \"bool "
                                 "extra\" for Integrator \"path\"");
    double wrong;
    assert_int_equal(params_get_float(ip, "maxdepth", 0, &wrong, &err), -1);
    assert_string_equal(err.msg, "data/scenes/options.pbrt:9:19: \"integer maxdepth\" has the "
                                 "wrong type for Integrator \"path\": expected \"float maxdepth\"");
    assert_int_equal(s->nshapes, 0);
    scene_desc_destroy(&s);
    assert_null(s);
}

static void test_defaults(void **state)
{
    (void)state;
    scene_desc_t *s = parse_text_ok("WorldBegin\n");
    /* pbrt-v4 defaults; the rgb film's bucket grid is prismfarm's (docs/physics.md §1.2). */
    testutil_assert_near(s->camera.fov, 90, TOL);
    assert_true(transform_is_identity(&s->camera.camera_from_world));
    assert_int_equal(s->film.type, SCENE_FILM_RGB);
    assert_int_equal(s->film.xres, 1280);
    assert_int_equal(s->film.yres, 720);
    assert_string_equal(s->film.filename, "pbrt.exr");
    assert_int_equal(s->film.nbuckets, 16);
    testutil_assert_near(s->film.lambda_min, 380, TOL);
    testutil_assert_near(s->film.lambda_max, 720, TOL);
    assert_string_equal(s->sampler.type, "zsobol");
    assert_int_equal(s->sampler.pixelsamples, 16);
    assert_string_equal(s->integrator.type, "auto");
    assert_int_equal(params_count(s->integrator.params), 0);
    /* defaults point at line 0 of the main file, so messages about them still name it */
    assert_string_equal(s->film.loc.file, "t.pbrt");
    assert_int_equal(s->film.loc.line, 0);
    assert_string_equal(s->camera.loc.file, "t.pbrt");
    assert_int_equal(s->nmaterials, 1);
    assert_string_equal(s->materials[0].type, "diffuse");
    assert_null(s->materials[0].params); /* its class's defaults: reflectance 0.5 */
    scene_desc_destroy(&s);

    s = parse_text_ok("Film \"spectral\"\nSampler \"stratified\" \"integer xsamples\" 2 "
                      "\"integer ysamples\" 3 \"bool jitter\" false\nWorldBegin\n");
    assert_int_equal(s->film.nbuckets, 16);
    testutil_assert_near(s->film.lambda_min, 360, TOL);
    testutil_assert_near(s->film.lambda_max, 830, TOL);
    assert_int_equal(s->sampler.pixelsamples, 6);
    scene_desc_destroy(&s);
}

/* ---- materials and textures ---- */

/* A material's parameters are read by its class when the scene loads (scene/material_*.c):
 * what they give is the loaded scene's material_t. */
static scene_t *load_scene_ok(scene_desc_t *d)
{
    err_t err = {{0}};
    scene_t *sc = scene_load(d, NULL, &err);
    if (!sc)
        fail_msg("did not load: %s", err.msg);
    return sc;
}

/* Texture t at the middle of the uv square. */
static double tex_at(const texture_t *t, double lambda)
{
    assert_non_null(t);
    const texture_point_t at = {0.5, 0.5, {0, 0, 0}, {0, 0, 1}};
    return texture_eval_at(t, &at, lambda);
}

/* The materials of data/scenes/materials.pbrt as pbrt-v4 reads their parameters: textures by
 * name, RGB and sampled reflectances, every form of an index, conductors' defaults. */
static void test_materials_loaded(void **state)
{
    (void)state;
    scene_desc_t *d = parse_ok("data/scenes/materials.pbrt");
    scene_t *sc = load_scene_ok(d);
    assert_true(sc->nmaterials >= 14);
    const material_t *m = sc->materials;
    testutil_assert_near(tex_at(m[0].reflectance, 550), 0.5, 1e-12); /* pbrt-v4's default */
    assert_int_equal(m[1].kind, MATERIAL_DIFFUSE);
    /* "texture reflectance" "checks": the checkerboard, 1 and 0 */
    const texture_point_t a = {0.01, 0.01, {0, 0, 0}, {0, 0, 1}};
    const texture_point_t b = {0.13, 0.01, {0, 0, 0}, {0, 0, 1}};
    assert_true(fabs(texture_eval_at(m[1].reflectance, &a, 550) -
                     texture_eval_at(m[1].reflectance, &b, 550)) > 0.5);
    assert_true(tex_at(m[2].reflectance, 460) > tex_at(m[2].reflectance, 640)); /* rgb, bluish */
    testutil_assert_near(tex_at(m[3].reflectance, 500), 0.5, 1e-12); /* (lambda, value) pairs */
    testutil_assert_near(tex_at(m[3].reflectance, 600), 0.7, 1e-12);
    assert_true(m[4].named);
    assert_string_equal(m[4].name, "bk7");
    assert_int_equal(m[4].kind, MATERIAL_DIELECTRIC);
    /* BK7 four ways: pbrt-v4's named spectrum, the catalogue, Sellmeier terms (n_d 1.5168) */
    testutil_assert_near(ior_eval(&m[4].ior, 587.56), 1.5168, 2e-4);
    testutil_assert_near(ior_eval(&m[5].ior, 587.56), 1.5168, 2e-4);
    testutil_assert_near(ior_eval(&m[6].ior, 587.56), 1.5168, 2e-4);
    testutil_assert_near(ior_eval(&m[7].ior, 500.0), 1.5046 + 0.0042 / 0.25, 1e-12); /* Cauchy */
    testutil_assert_near(ior_eval(&m[8].ior, 500.0), 1.33, 1e-12);
    testutil_assert_near(ior_eval(&m[9].ior, 500.0), 1.5, 1e-12); /* pbrt-v4's default eta */
    assert_null(m[9].uroughness);
    assert_true(m[9].smooth);
    assert_int_equal(m[10].kind, MATERIAL_CONDUCTOR);
    assert_non_null(m[10].eta); /* pbrt-v4's default, copper */
    assert_non_null(m[10].k);
    assert_null(m[10].reflectance);
    assert_null(m[10].uroughness);
    assert_true(m[10].remaproughness);
    assert_true(spectrum_eval(m[11].eta, 650) != spectrum_eval(m[10].eta, 650)); /* gold */
    testutil_assert_near(tex_at(m[11].uroughness, 550), 0.25, 1e-12); /* "texture roughness" */
    testutil_assert_near(tex_at(m[11].vroughness, 550), 0.25, 1e-12);
    assert_null(m[12].eta); /* "reflectance" instead */
    assert_true(tex_at(m[12].reflectance, 650) > tex_at(m[12].reflectance, 450));
    testutil_assert_near(tex_at(m[12].uroughness, 550), 0.1, 1e-12);
    testutil_assert_near(tex_at(m[12].vroughness, 550), 0.2, 1e-12);
    assert_false(m[12].remaproughness);
    assert_int_equal(m[13].kind, MATERIAL_INTERFACE);
    scene_destroy(&sc);
    scene_desc_destroy(&d);
}

static void test_materials_and_textures(void **state)
{
    (void)state;
    scene_desc_t *s = parse_ok("data/scenes/materials.pbrt");
    assert_int_equal(s->ntextures, 5);
    const scene_texture_t *t = s->textures;
    assert_string_equal(t[0].name, "checks");
    assert_int_equal(t[0].type, SCENE_TEXTURE_SPECTRUM);
    assert_int_equal(t[0].cls, SCENE_TEX_CHECKERBOARD);
    testutil_assert_near(t[0].uscale, 8, TOL);
    testutil_assert_near(t[0].vscale, 4, TOL);
    testutil_assert_near(t[0].udelta, 0, TOL);
    assert_int_equal(t[0].spec_in1.spectrum.kind, SCENE_SPECTRUM_RGB);
    testutil_assert_near(t[0].spec_in1.spectrum.rgb[1], 1, TOL);
    testutil_assert_near(t[0].spec_in2.spectrum.rgb[2], 0, TOL);
    assert_int_equal(t[1].type, SCENE_TEXTURE_FLOAT);
    assert_int_equal(t[1].cls, SCENE_TEX_CONSTANT);
    testutil_assert_near(t[1].float_in1.value, 0.25, TOL);
    assert_int_equal(t[2].cls, SCENE_TEX_IMAGEMAP);
    assert_string_equal(t[2].image.filename, "data/scenes/../scene_checker2x2.png");
    assert_string_equal(t[2].image.wrap, "clamp");
    assert_string_equal(t[2].image.filter, "bilinear");
    assert_string_equal(t[2].image.encoding, "sRGB");
    testutil_assert_near(t[2].image.scale, 1, TOL);
    assert_false(t[2].image.invert);
    assert_int_equal(t[3].cls, SCENE_TEX_SCALE);
    assert_int_equal(t[3].spec_in1.texture, 0);
    testutil_assert_near(t[3].amount.value, 0.5, TOL);
    assert_int_equal(t[4].cls, SCENE_TEX_MIX);
    assert_int_equal(t[4].spec_in1.texture, 0);
    assert_int_equal(t[4].spec_in2.texture, -1);
    testutil_assert_near(t[4].spec_in2.spectrum.rgb[0], 0.5, TOL);
    assert_int_equal(t[4].amount.texture, 1);

    assert_int_equal(s->nmaterials, 14);
    assert_string_equal(s->materials[1].type, "diffuse");
    assert_null(s->materials[1].name);
    assert_string_equal(s->materials[4].name, "bk7");
    assert_string_equal(s->materials[4].type, "dielectric");
    assert_string_equal(s->materials[10].type, "conductor");
    assert_string_equal(s->materials[13].type, "interface");
    /* A "spectrum" given by a string is read while parsing (a file would be listed). */
    assert_int_equal(s->materials[4].nresolved, 1);
    assert_string_equal(s->materials[4].resolved[0].param, "eta");
    assert_int_equal(s->materials[4].resolved[0].spectrum.kind, SCENE_SPECTRUM_NAMED);
    assert_string_equal(s->materials[4].resolved[0].spectrum.name, "glass-BK7");

    assert_int_equal(s->nshapes, 2);
    assert_int_equal(s->shapes[0].material, 1);
    assert_int_equal(s->shapes[1].material, 5); /* NamedMaterial "nbk7" */
    scene_desc_destroy(&s);
}

/* pbrt-v4's layered, transmissive and mix materials: parameter names and defaults as
 * materials.cpp reads them. */
static void test_more_materials(void **state)
{
    (void)state;
    scene_desc_t *d = parse_ok("data/scenes/layered.pbrt");
    assert_int_equal(d->nmaterials, 10);
    scene_t *sc = load_scene_ok(d);
    const material_t *m = sc->materials;
    /* coateddiffuse defaults */
    assert_int_equal(m[1].kind, MATERIAL_COATED_DIFFUSE);
    testutil_assert_near(tex_at(m[1].reflectance, 550), 0.5, 1e-12);
    testutil_assert_near(ior_eval(&m[1].ior, 550), 1.5, 1e-12);
    assert_null(m[1].uroughness);
    testutil_assert_near(tex_at(material_coateddiffuse_of(&m[1])->layer.thickness, 550), 0.01, 1e-12);
    testutil_assert_near(tex_at(material_coateddiffuse_of(&m[1])->layer.albedo, 550), 0, 1e-12);
    testutil_assert_near(tex_at(material_coateddiffuse_of(&m[1])->layer.g, 550), 0, 1e-12);
    assert_int_equal(material_coateddiffuse_of(&m[1])->layer.maxdepth, 10);
    assert_int_equal(material_coateddiffuse_of(&m[1])->layer.nsamples, 1);
    assert_true(m[1].remaproughness);
    /* coateddiffuse, everything given */
    assert_true(tex_at(m[2].reflectance, 450) > tex_at(m[2].reflectance, 650));
    testutil_assert_near(tex_at(m[2].uroughness, 550), 0.05, 1e-12);
    testutil_assert_near(tex_at(m[2].vroughness, 550), 0.05, 1e-12);
    testutil_assert_near(ior_eval(&m[2].ior, 550), 1.6, 1e-12);
    testutil_assert_near(tex_at(material_coateddiffuse_of(&m[2])->layer.thickness, 550), 0.02, 1e-12);
    testutil_assert_near(tex_at(material_coateddiffuse_of(&m[2])->layer.g, 550), 0.3, 1e-12);
    const texture_t *albedo2 = material_coateddiffuse_of(&m[2])->layer.albedo;
    assert_true(tex_at(albedo2, 550) > 0.4 && tex_at(albedo2, 550) < 0.6);
    assert_int_equal(material_coateddiffuse_of(&m[2])->layer.maxdepth, 20);
    assert_int_equal(material_coateddiffuse_of(&m[2])->layer.nsamples, 4);
    assert_false(m[2].remaproughness);
    /* coatedconductor: interface.* and conductor.* */
    assert_int_equal(m[3].kind, MATERIAL_COATED_CONDUCTOR);
    testutil_assert_near(tex_at(m[3].uroughness, 550), 0.02, 1e-12);
    testutil_assert_near(tex_at(material_coatedconductor_of(&m[3])->base_uroughness, 550), 0.002, 1e-12);
    testutil_assert_near(tex_at(material_coatedconductor_of(&m[3])->base_vroughness, 550), 0.002, 1e-12);
    testutil_assert_near(ior_eval(&m[3].ior, 550), 1.4, 1e-12);
    assert_non_null(m[3].eta);
    assert_null(m[3].reflectance);
    assert_true(spectrum_eval(m[3].eta, 650) != spectrum_eval(m[4].eta, 650)); /* Au, Cu */
    testutil_assert_near(ior_eval(&m[4].ior, 550), 1.5, 1e-12);
    /* diffusetransmission: reflectance 0.25 by default */
    assert_int_equal(m[5].kind, MATERIAL_DIFFUSE_TRANSMISSION);
    testutil_assert_near(tex_at(m[5].reflectance, 550), 0.25, 1e-12);
    const material_diffusetransmission_t *dt = material_diffusetransmission_of(&m[5]);
    assert_true(tex_at(dt->transmittance, 550) > tex_at(dt->transmittance, 450));
    testutil_assert_near(dt->scale, 0.9, TOL);
    assert_int_equal(m[6].kind, MATERIAL_THIN_DIELECTRIC);
    testutil_assert_near(ior_eval(&m[6].ior, 550), 1.52, 1e-12);
    /* mix: the names resolve to the named materials' indices */
    assert_int_equal(m[7].kind, MATERIAL_MIX);
    assert_int_equal(material_mix_of(&m[7])->materials[0], 1);
    assert_int_equal(material_mix_of(&m[7])->materials[1], 6);
    testutil_assert_near(tex_at(material_mix_of(&m[7])->amount, 550), 0.3, 1e-12); /* "amt" */
    assert_int_equal(material_mix_of(&m[8])->materials[0], 5);
    assert_int_equal(material_mix_of(&m[8])->materials[1], 7);
    testutil_assert_near(tex_at(material_mix_of(&m[8])->amount, 550), 0.5, 1e-12);
    /* an anisotropic rough dielectric */
    assert_int_equal(m[9].kind, MATERIAL_DIELECTRIC);
    testutil_assert_near(tex_at(m[9].uroughness, 550), 0.1, 1e-12);
    testutil_assert_near(tex_at(m[9].vroughness, 550), 0.3, 1e-12);
    assert_true(m[9].rough);
    scene_destroy(&sc);
    scene_desc_destroy(&d);
}

/* What pbrt-v4 has and prismfarm does not simulate is accepted with a warning naming the
 * place: the media prismfarm does not simulate ("cloud", "rgbgrid": vacuum; a nanovdb medium's
 * file must exist, as every data file must), motion blur (the
 * scene renders as at the shutter's opening: EndTime-only transforms leave the CTM alone, and
 * AttributeEnd restores the active transform as pbrt-v4's graphics state does), TransformTimes;
 * ColorSpace "srgb" and Accelerator are accepted silently. */
static void test_accepted_not_simulated(void **state)
{
    (void)state;
    const char *text =
        "ColorSpace \"srgb\"\n"
        "Accelerator \"bvh\" \"integer maxnodeprims\" 4\n"
        "TransformTimes 0 1\n"
        "WorldBegin\n"
        "MakeNamedMedium \"fog\" \"string type\" \"cloud\" \"rgb sigma_a\" [1 1 1]\n"
        "MediumInterface \"fog\" \"\"\n"
        "MediumInterface \"\"\n"
        "AttributeBegin\n"
        "  ActiveTransform EndTime\n"
        "  Translate 5 0 0\n"
        "AttributeEnd\n"
        "Translate 0 1 0\n"
        "Shape \"sphere\"\n";
    err_t err = {{0}};
    scene_desc_t *d = pbrt_parse_string(text, strlen(text), "t.pbrt", &err);
    if (!d)
        fail_msg("%s", err.msg);
    assert_int_equal(d->nmedia, 1);
    assert_int_equal(d->media_loc.line, 5);
    assert_int_equal(warnings_count(d->warnings), 3);
    assert_string_equal(warnings_at(d->warnings, 0), "t.pbrt:3:1: TransformTimes 0 1 is ignored (no motion blur)");
    assert_string_equal(warnings_at(d->warnings, 1),
                        "t.pbrt:5:1: \"cloud\" media are not simulated: medium \"fog\" renders "
                        "as vacuum (empty space), so the image lacks it");
    assert_string_equal(warnings_at(d->warnings, 2),
                        "t.pbrt:9:3: motion blur is not simulated: the scene renders as at the "
                        "shutter's opening (the transforms for its end are ignored)");
    /* The EndTime translate was ignored and AttributeEnd restored "All": only (0, 1, 0). */
    vec3_t c = transform_point(&d->shapes[0].to_world, vec3_make(0, 0, 0));
    testutil_assert_near(c.x, 0, TOL);
    testutil_assert_near(c.y, 1, TOL);
    scene_desc_destroy(&d);
    expect_error("WorldBegin\nMediumInterface \"smoke\"\n",
                 "t.pbrt:2:17: medium \"smoke\" is not defined (MakeNamedMedium must come before its use)");
    /* A nanovdb medium's file must be there (check lists missing assets). */
    expect_error("WorldBegin\nMakeNamedMedium \"c\" \"string type\" \"nanovdb\" \"string filename\" "
                 "\"data/scenes/missing.nvdb\"\n",
                 "t.pbrt:2:45: cannot open the nanovdb medium's file \"data/scenes/missing.nvdb\": No "
                 "such file or directory");
    expect_error("WorldBegin\nMakeNamedMedium \"c\" \"string type\" \"nanovdb\"\n",
                 "t.pbrt:2:1: MakeNamedMedium \"nanovdb\" needs \"string filename\"");
    expect_error("WorldBegin\nMakeNamedMedium \"a\" \"rgb sigma_a\" [1 1 1]\n",
                 "t.pbrt:2:1: MakeNamedMedium \"a\" needs \"string type\"");
    expect_error("ActiveTransform Sometimes\n",
                 "t.pbrt:1:17: ActiveTransform expects StartTime, EndTime or All, got Sometimes");
    expect_error("ColorSpace \"aces2065-1\"\n",
                 "t.pbrt:1:12: unsupported colour space \"aces2065-1\" (only \"srgb\", pbrt-v4's default)");
}

/* ---- lights ---- */

static void test_lights(void **state)
{
    (void)state;
    scene_desc_t *s = parse_ok("data/scenes/lights.pbrt");
    assert_int_equal(s->nlights, 5);
    const scene_light_t *l = s->lights;
    assert_int_equal(l[0].type, SCENE_LIGHT_INFINITE);
    assert_int_equal(l[0].spectrum.kind, SCENE_SPECTRUM_RGB);
    testutil_assert_near(l[0].spectrum.rgb[2], 0.3, TOL);
    testutil_assert_near(l[0].scale, 2, TOL);
    assert_int_equal(l[1].type, SCENE_LIGHT_POINT);
    assert_int_equal(l[1].spectrum.kind, SCENE_SPECTRUM_BLACKBODY);
    testutil_assert_near(l[1].spectrum.temperature, 3000, TOL);
    testutil_assert_near(l[1].from.y, 2, TOL);
    assert_int_equal(l[2].type, SCENE_LIGHT_SPOT);
    assert_string_equal(l[2].spectrum.name, "stdillum-A");
    testutil_assert_near(l[2].from.y, 5, TOL);
    testutil_assert_near(l[2].to.y, 0, TOL);
    testutil_assert_near(l[2].coneangle, 20, TOL);
    testutil_assert_near(l[2].conedeltaangle, 4, TOL);
    assert_point(&l[2].to_world, vec3_make(0, 0, 0), 0, 10, 0); /* CTM at the directive */
    assert_int_equal(l[3].type, SCENE_LIGHT_DISTANT);
    assert_int_equal(l[3].spectrum.kind, SCENE_SPECTRUM_SAMPLED);
    assert_int_equal(l[3].spectrum.count, 3);
    testutil_assert_near(l[3].spectrum.value[2], 3, TOL);
    testutil_assert_near(l[3].scale, 0.5, TOL);
    assert_true(transform_is_identity(&l[3].to_world));
    /* pbrt-v4 defaults: the colour space illuminant, scale 1, at the origin */
    assert_int_equal(l[4].spectrum.kind, SCENE_SPECTRUM_NAMED);
    assert_string_equal(l[4].spectrum.name, "stdillum-D65");
    testutil_assert_near(l[4].scale, 1, TOL);
    testutil_assert_near(l[4].from.x, 0, TOL);

    assert_int_equal(s->narea_lights, 2);
    const scene_area_light_t *a = s->area_lights;
    assert_int_equal(a[0].type, SCENE_AREA_DIFFUSE);
    testutil_assert_near(a[0].L.temperature, 6500, TOL);
    testutil_assert_near(a[0].scale, 3, TOL);
    assert_true(a[0].twosided);
    assert_int_equal(a[1].type, SCENE_AREA_COLLIMATED);
    assert_string_equal(a[1].L.name, "stdillum-D65");
    testutil_assert_near(a[1].scale, 10, TOL);
    assert_false(a[1].twosided);

    assert_int_equal(s->nshapes, 3);
    assert_int_equal(s->shapes[0].area_light, 0);
    testutil_assert_near(s->shapes[0].radius, 0.5, TOL);
    testutil_assert_near(s->shapes[0].height, 1, TOL);
    assert_int_equal(s->shapes[1].area_light, 1);
    assert_int_equal(s->shapes[2].area_light, -1); /* AttributeEnd ended the area light */
    scene_desc_destroy(&s);
}

/* ---- shapes ---- */

/* pbrt-v4's triangle geometric normal, normalize(cross(p0 - p2, p1 - p2)) (shapes.h). */
static vec3_t tri_normal(const scene_mesh_t *m, size_t t)
{
    vec3_t p[3];
    for (int k = 0; k < 3; k++) {
        const double *v = &m->P[3 * m->indices[3 * t + (size_t)k]];
        p[k] = vec3_make(v[0], v[1], v[2]);
    }
    return vec3_normalize(vec3_cross(vec3_sub(p[0], p[2]), vec3_sub(p[1], p[2])));
}

static double mesh_area(const scene_mesh_t *m)
{
    double area = 0;
    for (size_t t = 0; t < m->ntriangles; t++) {
        vec3_t p[3];
        for (int k = 0; k < 3; k++) {
            const double *v = &m->P[3 * m->indices[3 * t + (size_t)k]];
            p[k] = vec3_make(v[0], v[1], v[2]);
        }
        area += 0.5 * vec3_length(vec3_cross(vec3_sub(p[1], p[0]), vec3_sub(p[2], p[0])));
    }
    return area;
}

static void test_shapes(void **state)
{
    (void)state;
    scene_desc_t *s = parse_ok("data/scenes/shapes.pbrt");
    assert_int_equal(s->nshapes, 9);
    const scene_shape_t *sh = s->shapes;

    assert_int_equal(sh[0].type, SCENE_SHAPE_SPHERE);
    testutil_assert_near(sh[0].radius, 0.5, TOL);
    /* Translate 1 2 3, Scale 2 2 2: the scale applies first. */
    assert_point(&sh[0].to_world, vec3_make(1, 0, 0), 3, 2, 3);
    assert_false(sh[0].flip_normals);
    assert_int_equal(sh[0].material, 0);
    assert_string_equal(sh[0].loc.file, "data/scenes/shapes.pbrt");
    assert_int_equal(sh[0].loc.line, 6);
    assert_int_equal(sh[0].loc.col, 3);

    assert_string_equal(sh[1].kind, "trianglemesh");
    assert_int_equal(sh[1].mesh.nvertices, 3);
    assert_int_equal(sh[1].mesh.ntriangles, 1);
    assert_int_equal(sh[1].mesh.indices[2], 2);
    assert_true(sh[1].reverse_orientation);
    assert_false(sh[1].swaps_handedness);
    assert_true(sh[1].flip_normals);

    assert_int_equal(sh[2].mesh.nvertices, 4);
    assert_int_equal(sh[2].mesh.ntriangles, 2);
    assert_non_null(sh[2].mesh.N);
    assert_non_null(sh[2].mesh.uv);
    testutil_assert_near(sh[2].mesh.uv[5], 1, TOL);
    testutil_assert_near(sh[2].mesh.N[11], 1, TOL);
    assert_false(sh[2].reverse_orientation);
    assert_true(sh[2].swaps_handedness); /* Scale -1 1 1 */
    assert_true(sh[2].flip_normals);

    assert_int_equal(sh[3].type, SCENE_SHAPE_DISK);
    assert_true(sh[3].reverse_orientation && sh[3].swaps_handedness);
    assert_false(sh[3].flip_normals); /* the two flips cancel, as in pbrt-v4 */
    testutil_assert_near(sh[3].radius, 1, TOL);
    testutil_assert_near(sh[3].height, 0, TOL);

    /* A bilinear patch p00 p10 p01 p11 becomes two triangles with the patch's normal
     * cross(p10 - p00, p01 - p00) = +z here. */
    assert_string_equal(sh[4].kind, "bilinearmesh");
    assert_int_equal(sh[4].mesh.ntriangles, 2);
    const uint32_t want[6] = {0, 1, 3, 0, 3, 2};
    for (int i = 0; i < 6; i++)
        assert_int_equal(sh[4].mesh.indices[i], want[i]);
    for (size_t t = 0; t < 2; t++)
        testutil_assert_near(tri_normal(&sh[4].mesh, t).z, 1, TOL);
    testutil_assert_near(mesh_area(&sh[4].mesh), 1, TOL);
    assert_int_equal(sh[5].mesh.nvertices, 8);
    assert_int_equal(sh[5].mesh.ntriangles, 4);

    /* ascii PLY: 5 vertices, a unit quad split in two plus the triangle (0,0,0) (1,0,0)
     * (.5,.5,1) of area |(1,0,0) x (.5,.5,1)| / 2 = sqrt(1.25) / 2. */
    assert_string_equal(sh[6].kind, "plymesh");
    assert_int_equal(sh[6].mesh.nvertices, 5);
    assert_int_equal(sh[6].mesh.ntriangles, 3);
    assert_non_null(sh[6].mesh.uv);
    assert_null(sh[6].mesh.N);
    testutil_assert_near(sh[6].mesh.P[14], 1, TOL);
    testutil_assert_near(mesh_area(&sh[6].mesh), 1.0 + sqrt(1.25) / 2.0, TOL);
    size_t up = 0;
    for (size_t t = 0; t < 3; t++)
        up += fabs(tri_normal(&sh[6].mesh, t).z - 1) < TOL;
    assert_int_equal(up, 2); /* the quad keeps its winding (+z) */
    /* binary PLY: the unit tetrahedron, area 3/2 + sqrt(3)/2, normals read from the file */
    assert_int_equal(sh[7].mesh.nvertices, 4);
    assert_int_equal(sh[7].mesh.ntriangles, 4);
    assert_non_null(sh[7].mesh.N);
    assert_null(sh[7].mesh.uv);
    testutil_assert_near(sh[7].mesh.N[2], 1, TOL);
    testutil_assert_near(mesh_area(&sh[7].mesh), 1.5 + sqrt(3.0) / 2.0, TOL);

    testutil_assert_near(sh[8].radius, 2, TOL);
    testutil_assert_near(sh[8].height, 0.5, TOL);
    assert_int_equal(scene_desc_triangle_count(s), 1 + 2 + 2 + 4 + 3 + 4);
    scene_desc_destroy(&s);
}

static void test_ply_import_direct(void **state)
{
    (void)state;
    mesh_data_t m;
    err_t err = {{0}};
    assert_int_equal(mesh_import_ply("data/scenes/meshes/tetra_binary.ply", &m, &err), 0);
    assert_int_equal(m.nvertices, 4);
    assert_int_equal(m.ntriangles, 4);
    mesh_data_free(&m);
    assert_null(m.P);
    assert_int_equal(mesh_import_ply("data/scenes/options.pbrt", &m, &err), -1);
    assert_string_equal(err.msg, "\"data/scenes/options.pbrt\" is not a PLY file (it does not "
                                 "start with \"ply\")");
    assert_int_equal(mesh_import_ply("data/scenes/meshes/none.ply", &m, &err), -1);
    assert_string_equal(err.msg, "cannot open PLY file \"data/scenes/meshes/none.ply\": No such "
                                 "file or directory");

    /* assimp does not check face indices; mesh_import does. */
    char dir[] = "/tmp/prismfarm-ply-XXXXXX";
    assert_non_null(mkdtemp(dir));
    char path[128];
    snprintf(path, sizeof path, "%s/bad.ply", dir);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
          "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
          "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n",
          f);
    fclose(f);
    assert_int_equal(mesh_import_ply(path, &m, &err), -1);
    char expected[256];
    snprintf(expected, sizeof expected, "\"%s\": face 0 uses vertex 7 but there are only 3", path);
    assert_string_equal(err.msg, expected);
    unlink(path);
    rmdir(dir);
}

static uint64_t next_rand(uint64_t *x);

/* mesh_import checks a PLY file's structure before assimp reads it: the forms that real files
 * use must still load. Big-endian floats are written byte by byte (IEEE 754: 1.0f is
 * 3f 80 00 00, 2.0f 40 00 00 00, 3.0f 40 40 00 00), so the positions are exact. */
static void test_ply_variants_still_load(void **state)
{
    (void)state;
    mesh_data_t m;
    err_t err = {{0}};
    /* ascii with CRLF line ends, tabs and runs of spaces, exponents, a signed list length
     * type, trailing blank lines: the quad_tri file's 5 vertices, 3 triangles. */
    const char *crlf = "ply\r\nformat ascii 1.0\r\ncomment written on Windows\r\n"
                       "obj_info made by hand\r\nelement vertex 5\r\nproperty float x\r\n"
                       "property float y\r\nproperty double z\r\nelement face 2\r\n"
                       "property list char int vertex_indices\r\nend_header\r\n"
                       "0 0 0\r\n1e0 0 0\r\n1\t1  0\r\n0 1 0\r\n0.5 .5 +1.0E-0\r\n"
                       "4 0 1 2 3\r\n3 0 1 4 \r\n\r\n";
    if (mesh_import_ply_memory(crlf, strlen(crlf), "crlf.ply", &m, &err) != 0)
        fail_msg("CRLF ascii PLY refused: %s", err.msg);
    assert_int_equal(m.nvertices, 5);
    assert_int_equal(m.ntriangles, 3);
    testutil_assert_near(m.P[3 * 4 + 2], 1.0, TOL);
    mesh_data_free(&m);

    /* binary big-endian: one triangle (1,2,3) (3,2,1) (1,1,1) with a uchar colour each and an
     * extra element that assimp skips. */
    const char *hdr = "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\n"
                      "property float y\nproperty float z\nproperty uchar red\nelement face 1\n"
                      "property list uchar uint vertex_indices\nelement extra 2\n"
                      "property list ushort short values\nend_header\n";
    static const unsigned char one[4] = {0x3f, 0x80, 0, 0}, two[4] = {0x40, 0, 0, 0},
                               three[4] = {0x40, 0x40, 0, 0};
    const unsigned char *verts[3][3] = {{one, two, three}, {three, two, one}, {one, one, one}};
    unsigned char buf[512];
    size_t n = strlen(hdr);
    memcpy(buf, hdr, n);
    for (int v = 0; v < 3; v++) {
        for (int c = 0; c < 3; c++, n += 4)
            memcpy(buf + n, verts[v][c], 4);
        buf[n++] = 200;
    }
    static const unsigned char face[13] = {3, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 2};
    memcpy(buf + n, face, sizeof face);
    n += sizeof face;
    static const unsigned char extra[8] = {0, 1, 0xff, 0xff, 0, 1, 0, 7}; /* [-1], [7] */
    memcpy(buf + n, extra, sizeof extra);
    n += sizeof extra;
    if (mesh_import_ply_memory(buf, n, "be.ply", &m, &err) != 0)
        fail_msg("big-endian PLY refused: %s", err.msg);
    assert_int_equal(m.nvertices, 3);
    assert_int_equal(m.ntriangles, 1);
    const double want[9] = {1, 2, 3, 3, 2, 1, 1, 1, 1};
    for (int i = 0; i < 9; i++)
        testutil_assert_near(m.P[i], want[i], TOL);
    mesh_data_free(&m);

    /* One byte short of the extra element: the file ends inside it. */
    assert_int_equal(mesh_import_ply_memory(buf, n - 1, "be.ply", &m, &err), -1);
    assert_string_equal(err.msg, "\"be.ply\": extra 1 has a list of 1 values, more than the 1 "
                                 "bytes left (truncated)");
    /* Values assimp would read differently from a whole token are refused. */
    const char *comma = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                        "property float y\nproperty float z\nelement face 1\n"
                        "property list uchar int vertex_indices\nend_header\n"
                        "0 0 0\n1,5 0 0\n0 1 0\n3 0 1 2\n";
    assert_int_equal(mesh_import_ply_memory(comma, strlen(comma), "c.ply", &m, &err), -1);
    assert_string_equal(err.msg, "\"c.ply\": line 11: \"1,5\" is not a decimal number");
}

/* Malformed PLY files are refused with a message that names the fault. These were the files
 * that crashed or misled assimp 5.2.5 (Debian 12), which read PLY before mesh_import did: an
 * empty face, a face list without indices, an index past the vertices. */
static void expect_ply_refused(const char *text, size_t len, const char *expected)
{
    mesh_data_t m;
    err_t err = {{0}};
    if (mesh_import_ply_memory(text, len, "x.ply", &m, &err) == 0) {
        mesh_data_free(&m);
        fail_msg("accepted but should have failed with: %s", expected);
    }
    if (strcmp(err.msg, expected) != 0)
        fail_msg("wrong message\n  got:      %s\n  expected: %s", err.msg, expected);
}

static void test_ply_unsafe_refused(void **state)
{
    (void)state;
#define VERTS3                                                                                     \
    "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"                \
    "property float z\n"
#define BODY4 "0 0 0\n1 0 0\n1 1 0\n0 1 0\n"
    static const struct {
        const char *text, *expected;
    } CASES[] = {
        {VERTS3 "element face 1\nproperty list uchar int vertex_indices\nend_header\n" BODY4 "0\n",
         "\"x.ply\": face 0 has 0 vertices (points and lines are not surfaces)"},
        {VERTS3 "element face 1\nproperty list uchar float texcoord\nend_header\n" BODY4
                "6 0 0 1 0 1 1\n",
         "\"x.ply\": element face needs one vertex_indices list"},
        {VERTS3 "element face 1\nproperty list uchar int vertex_indices\nend_header\n" BODY4
                "4 0 1 2 900000000\n",
         "\"x.ply\": face 0 uses vertex 900000000 but there are only 4"},
        {VERTS3 "element face 1\nproperty list uchar int vertex_indices\nend_header\n" BODY4
                "4 0 1 2 9\n",
         "\"x.ply\": face 0 uses vertex 9 but there are only 4"},
        {VERTS3 "element face 1\nproperty list uchar int vertex_indices\nend_header\n" BODY4
                "3 0 -1 2\n",
         "\"x.ply\": face 0 uses a negative vertex index"},
        {"ply\nformat ascii 1.0\nelement vertex 3\nproperty list uchar float x\n"
         "property float y\nproperty float z\nelement face 1\n"
         "property list uchar int vertex_indices\nend_header\n0 0 0\n1 1 0 0\n1 0 1 0\n3 0 1 2\n",
         "\"x.ply\": line 4: vertex property \"x\" must be a single value, not a list"},
        {"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
         "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0\n1 0\n0 1\n"
         "3 0 1 2\n",
         "\"x.ply\": element vertex needs properties x, y and z"},
        {"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
         "propery float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n",
         "\"x.ply\": unknown PLY header line 6 \"propery float z\""},
        {VERTS3 "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                "0 0 0\n1 0 0\n1 1 0\n",
         "\"x.ply\": PLY element \"vertex\" declares 4 instances but only 18 bytes of the file "
         "are left for them (the file is truncated)"},
        {VERTS3 "element tristrips 1\nproperty list int int vertex_indices\nend_header\n" BODY4
                "4 0 1 2 3\n",
         "\"x.ply\": triangle strips (element tristrips) are not supported"},
        {"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
         "property float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n",
         "\"x.ply\" has no faces"},
        {"ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\n"
         "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
         "3 0 1 2\n0 0 0\n1 0 0\n0 1 0\n",
         "\"x.ply\": element face comes before element vertex"},
    };
#undef VERTS3
#undef BODY4
    for (size_t i = 0; i < sizeof CASES / sizeof CASES[0]; i++)
        expect_ply_refused(CASES[i].text, strlen(CASES[i].text), CASES[i].expected);
    /* A NUL in a property name (found by the mutations when assimp read PLY). */
    static const char nul[] = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                              "property float \0\nproperty float z\nelement face 1\n"
                              "property list uchar int vertex_indices\nend_header\n"
                              "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    expect_ply_refused(nul, sizeof nul - 1,
                       "\"x.ply\": line 5 of the PLY header holds a control character");
}

/* Random mutations of the test PLY files, with the tokens that make forged counts: every
 * outcome is a mesh or a message, never a crash, a huge allocation (ASan reports those) or a
 * long loop. */
static void test_ply_mutations_never_crash(void **state)
{
    (void)state;
    static const char *FILES[] = {"data/scenes/meshes/quad_tri_ascii.ply",
                                  "data/scenes/meshes/tetra_binary.ply"};
    static const char *TOKENS[] = {
        "4294967295", "2147483648",       "-1",   "255", "\n",      " ", "\r\n", "list",
        "uint",       "element face 9\n", "1e38", "nan", "\xff\xff"};
    uint64_t rng = 0x243f6a8885a308d3ull;
    size_t loaded = 0, refused = 0;
    for (size_t fi = 0; fi < sizeof FILES / sizeof FILES[0]; fi++) {
        FILE *f = fopen(FILES[fi], "rb");
        assert_non_null(f);
        char orig[4096];
        size_t len = fread(orig, 1, sizeof orig, f);
        fclose(f);
        assert_true(len > 0 && len < sizeof orig);
        char buf[4096 + 64];
        for (int iter = 0; iter < 400; iter++) {
            memcpy(buf, orig, len);
            size_t n = len;
            int edits = 1 + (int)(next_rand(&rng) % 3);
            for (int e = 0; e < edits && n > 0; e++) {
                size_t at = next_rand(&rng) % n;
                switch (next_rand(&rng) % 4) {
                case 0:
                    buf[at] = (char)(next_rand(&rng) % 256);
                    break;
                case 1: {
                    size_t k = 1 + next_rand(&rng) % 8;
                    if (k > n - at)
                        k = n - at;
                    memmove(buf + at, buf + at + k, n - at - k);
                    n -= k;
                    break;
                }
                case 2: {
                    const char *tok = TOKENS[next_rand(&rng) % (sizeof TOKENS / sizeof TOKENS[0])];
                    size_t k = strlen(tok);
                    if (n + k > sizeof buf)
                        break;
                    memmove(buf + at + k, buf + at, n - at);
                    memcpy(buf + at, tok, k);
                    n += k;
                    break;
                }
                default:
                    n = at;
                    break;
                }
            }
            mesh_data_t m;
            err_t err = {{0}};
            if (mesh_import_ply_memory(buf, n, "m.ply", &m, &err) == 0) {
                loaded++;
                mesh_data_free(&m);
            } else {
                refused++;
                assert_true(strlen(err.msg) > 0);
            }
        }
    }
    assert_true(loaded > 0);
    assert_true(refused > 0);
}

/* ---- transforms, instances, includes ---- */

static void test_transforms(void **state)
{
    (void)state;
    scene_desc_t *s = parse_ok("data/scenes/transforms.pbrt");
    assert_int_equal(s->nshapes, 7);
    const scene_shape_t *sh = s->shapes;
    assert_point(&sh[0].to_world, vec3_make(1, 0, 0), 0, 1, 0); /* Rotate 90 0 0 1 */
    assert_point(&sh[1].to_world, vec3_make(0, 0, 0), 3, 4, 5); /* Transform, by columns */
    assert_point(&sh[2].to_world, vec3_make(1, 1, 1), 5, 6, 7); /* ConcatTransform scale 2 */
    assert_true(transform_is_identity(&sh[3].to_world));        /* Identity */
    assert_point(&sh[4].to_world, vec3_make(1, 1, 1), 5, 6, 7); /* CoordSysTransform "here" */
    /* CoordSysTransform "camera" is world-from-camera: the camera sits at (0,0,-5) and looks
     * down world +z. */
    assert_point(&sh[5].to_world, vec3_make(0, 0, 0), 0, 0, -5);
    assert_point(&sh[5].to_world, vec3_make(0, 0, 1), 0, 0, -4);
    assert_point(&sh[5].to_world, vec3_make(1, 0, 0), 1, 0, -5);
    assert_true(transform_is_identity(&sh[6].to_world)); /* TransformBegin/End restored it */
    scene_desc_destroy(&s);
}

static void test_instances(void **state)
{
    (void)state;
    scene_desc_t *s = parse_ok("data/scenes/instances.pbrt");
    assert_int_equal(s->nobjects, 2);
    assert_string_equal(s->objects[0].name, "tri");
    assert_int_equal(s->objects[0].first_shape, 0);
    assert_int_equal(s->objects[0].nshapes, 2);
    assert_string_equal(s->objects[1].name, "later");
    assert_int_equal(s->objects[1].first_shape, 2);
    assert_int_equal(s->objects[1].nshapes, 1);
    assert_int_equal(s->nobject_shapes, 3);
    /* object shapes keep the CTM of their definition */
    assert_point(&s->object_shapes[0].to_world, vec3_make(0, 0, 0), 0, 0, 1);
    assert_int_equal(s->object_shapes[0].mesh.ntriangles, 1);
    assert_int_equal(s->ninstances, 2);
    assert_int_equal(s->instances[0].object, 0);
    assert_point(&s->instances[0].to_world, vec3_make(0, 0, 0), 10, 0, 0);
    assert_false(s->instances[0].swaps_handedness);
    assert_int_equal(s->instances[1].object, 1); /* defined after its use */
    assert_true(s->instances[1].swaps_handedness);
    assert_int_equal(s->nshapes, 1);
    assert_true(transform_is_identity(&s->shapes[0].to_world));
    assert_int_equal(scene_desc_triangle_count(s), 1);
    scene_desc_destroy(&s);
}

static void test_includes(void **state)
{
    (void)state;
    scene_desc_t *s = parse_ok("data/scenes/include_main.pbrt");
    assert_int_equal(s->film.xres, 64);
    assert_int_equal(s->film.yres, 48);
    assert_int_equal(s->nshapes, 3);
    const scene_shape_t *sh = s->shapes;
    testutil_assert_near(sh[0].radius, 3, TOL);
    assert_string_equal(sh[0].loc.file, "data/scenes/inc/deeper/sphere.pbrt");
    assert_int_equal(sh[0].loc.line, 1);
    assert_point(&sh[0].to_world, vec3_make(0, 0, 0), 0, 1, 0); /* Include is textual */
    testutil_assert_near(sh[1].radius, 4, TOL);
    assert_point(&sh[1].to_world, vec3_make(0, 0, 0), 100, 1, 0);
    assert_string_equal(s->materials[sh[1].material].type, "conductor");
    /* Import does not leak its CTM or material */
    testutil_assert_near(sh[2].radius, 5, TOL);
    assert_point(&sh[2].to_world, vec3_make(0, 0, 0), 0, 1, 0);
    assert_int_equal(sh[2].material, 0);
    scene_desc_destroy(&s);

    expect_error_named("data/scenes/main.pbrt", "WorldBegin\nInclude \"inc/cycle_a.pbrt\"\n",
                       "data/scenes/inc/cycle_b.pbrt:1:9: include cycle: "
                       "\"data/scenes/inc/cycle_a.pbrt\" is already being read");
    expect_error_named("data/scenes/main.pbrt", "WorldBegin\nInclude \"inc/missing.pbrt\"\n",
                       "data/scenes/main.pbrt:2:9: cannot open included file "
                       "\"data/scenes/inc/missing.pbrt\": No such file or directory");
    /* A name missing from an included file's folder and from the main file's: both named. */
    expect_error_named("data/scenes/main.pbrt", "WorldBegin\nInclude \"inc/deeper/includes_missing.pbrt\"\n",
                       "data/scenes/inc/deeper/includes_missing.pbrt:2:9: cannot open included file "
                       "\"data/scenes/inc/deeper/nowhere.pbrt\": No such file or directory (also "
                       "looked for \"data/scenes/nowhere.pbrt\")");
    expect_error("Import \"x.pbrt\"\n", "t.pbrt:1:1: Import is only allowed after WorldBegin");

    err_t err = {{0}};
    assert_null(pbrt_parse_file("data/scenes/none.pbrt", &err));
    assert_string_equal(err.msg, "cannot open scene file \"data/scenes/none.pbrt\": No such file "
                                 "or directory");

    /* A chain f0 -> f1 -> ... deeper than the limit, and an Import that leaves an attribute
     * block open; written to a temporary folder. */
    char dir[] = "/tmp/prismfarm-inc-XXXXXX";
    assert_non_null(mkdtemp(dir));
    char path[128], expected[512];
    for (int i = 0; i < PBRT_INCLUDE_DEPTH_MAX + 2; i++) {
        snprintf(path, sizeof path, "%s/f%d.pbrt", dir, i);
        FILE *f = fopen(path, "w");
        assert_non_null(f);
        fprintf(f, "Include \"f%d.pbrt\"\n", i + 1);
        fclose(f);
    }
    snprintf(path, sizeof path, "%s/f0.pbrt", dir);
    assert_null(pbrt_parse_file(path, &err));
    snprintf(expected, sizeof expected,
             "%s/f%d.pbrt:1:9: Include/Import nested deeper than %d "
             "files",
             dir, PBRT_INCLUDE_DEPTH_MAX - 1, PBRT_INCLUDE_DEPTH_MAX);
    assert_string_equal(err.msg, expected);
    snprintf(path, sizeof path, "%s/open.pbrt", dir);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs("AttributeBegin\n", f);
    fclose(f);
    char main_name[128];
    snprintf(main_name, sizeof main_name, "%s/main.pbrt", dir);
    snprintf(expected, sizeof expected,
             "%s:1:1: AttributeBegin has no matching end before the "
             "end of imported file \"%s\"",
             path, path);
    expect_error_named(main_name, "WorldBegin\nImport \"open.pbrt\"\n", expected);
    for (int i = 0; i < PBRT_INCLUDE_DEPTH_MAX + 2; i++) {
        snprintf(path, sizeof path, "%s/f%d.pbrt", dir, i);
        unlink(path);
    }
    snprintf(path, sizeof path, "%s/open.pbrt", dir);
    unlink(path);
    rmdir(dir);
}

/* ---- the files a scene reads, for bundling ---- */

static const scene_file_t *file_entry(const scene_desc_t *s, const char *relative)
{
    int i = scene_desc_find_file(s, relative);
    if (i < 0)
        fail_msg("no file \"%s\" among the %zu read", relative, s->nfiles);
    return &s->files[i];
}

static void test_files_read(void **state)
{
    (void)state;
    /* Includes and imports, nested, all inside the main file's folder, in reading order. */
    scene_desc_t *s = parse_ok("data/scenes/include_main.pbrt");
    static const struct {
        const char *relative, *path;
        scene_file_kind_t kind;
        int line;
    } INC[] = {
        {"include_main.pbrt", "data/scenes/include_main.pbrt", SCENE_FILE_MAIN, 0},
        {"inc/options.pbrt", "data/scenes/inc/options.pbrt", SCENE_FILE_INCLUDE, 2},
        {"inc/shapes.pbrt", "data/scenes/inc/shapes.pbrt", SCENE_FILE_INCLUDE, 4},
        {"inc/deeper/sphere.pbrt", "data/scenes/inc/deeper/sphere.pbrt", SCENE_FILE_INCLUDE, 3},
        {"inc/imported.pbrt", "data/scenes/inc/imported.pbrt", SCENE_FILE_INCLUDE, 5},
    };
    assert_int_equal(s->nfiles, 5);
    for (size_t i = 0; i < 5; i++) {
        const scene_file_t *f = &s->files[i];
        assert_string_equal(f->relative, INC[i].relative);
        assert_string_equal(f->path, INC[i].path);
        assert_int_equal(f->kind, INC[i].kind);
        assert_int_equal(f->loc.line, INC[i].line);
        assert_false(f->outside);
    }
    /* The nested include is located in the file that names it. */
    assert_string_equal(s->files[3].loc.file, "data/scenes/inc/shapes.pbrt");
    scene_desc_destroy(&s);

    /* The same through a main path with "." and ".." in it: relative paths are normalised. */
    s = parse_ok("data/./scenes/../scenes/include_main.pbrt");
    assert_int_equal(s->nfiles, 5);
    assert_string_equal(s->files[0].relative, "include_main.pbrt");
    assert_string_equal(s->files[3].relative, "inc/deeper/sphere.pbrt");
    assert_string_equal(s->files[3].path, "data/./scenes/../scenes/inc/deeper/sphere.pbrt");
    scene_desc_destroy(&s);

    /* PLY meshes inside the folder. */
    s = parse_ok("data/scenes/shapes.pbrt");
    assert_int_equal(s->nfiles, 3);
    const scene_file_t *f = file_entry(s, "meshes/quad_tri_ascii.ply");
    assert_int_equal(f->kind, SCENE_FILE_PLY);
    assert_string_equal(f->path, "data/scenes/meshes/quad_tri_ascii.ply");
    assert_int_equal(f->loc.line, 24);
    assert_false(f->outside);
    assert_int_equal(file_entry(s, "meshes/tetra_binary.ply")->kind, SCENE_FILE_PLY);
    scene_desc_destroy(&s);

    /* An image one folder up: recorded, and marked outside so that a bundler refuses it. */
    s = parse_ok("data/scenes/materials.pbrt");
    assert_int_equal(s->nfiles, 2);
    f = file_entry(s, "../scene_checker2x2.png");
    assert_int_equal(f->kind, SCENE_FILE_IMAGE);
    assert_string_equal(f->path, "data/scenes/../scene_checker2x2.png");
    assert_true(f->outside);
    assert_int_equal(f->loc.line, 6);
    assert_int_equal(f->loc.col, 37);
    scene_desc_destroy(&s);

    /* pbrt-v4's rule: inc/main_folder_rule.pbrt names "meshes/tetra_binary.ply" relative to
     * the main file's folder; included twice, every file is listed once. */
    s = parse_ok("data/scenes/main_folder_rule.pbrt");
    assert_int_equal(s->nfiles, 3);
    assert_int_equal(s->nshapes, 2);
    f = file_entry(s, "meshes/tetra_binary.ply");
    assert_string_equal(f->path, "data/scenes/meshes/tetra_binary.ply");
    assert_string_equal(f->loc.file, "data/scenes/inc/main_folder_rule.pbrt");
    assert_false(f->outside);
    scene_desc_destroy(&s);

    /* A file named by an absolute path is outside, whatever folder it is in; a scene parsed
     * from memory lists only the files it read. */
    char cwd[1024], text[1400];
    assert_non_null(getcwd(cwd, sizeof cwd));
    snprintf(text, sizeof text,
             "WorldBegin\nShape \"plymesh\" \"string filename\" "
             "\"%s/data/scenes/meshes/tetra_binary.ply\"\n",
             cwd);
    s = parse_text_ok(text);
    assert_int_equal(s->nfiles, 1);
    assert_true(s->files[0].outside);
    assert_int_equal(s->files[0].relative[0], '/');
    assert_non_null(strstr(s->files[0].relative, "/data/scenes/meshes/tetra_binary.ply"));
    scene_desc_destroy(&s);

    /* The images of goniometric, projection and image area lights are files read, so that
     * the farm's bundle carries them. */
    s = parse_text_ok("WorldBegin\n"
                      "LightSource \"goniometric\" \"string filename\" \"data/scene_checker2x2.png\"\n"
                      "LightSource \"projection\" \"string filename\" \"data/scene_checker2x2.png\"\n"
                      "AttributeBegin\nAreaLightSource \"diffuse\" \"string filename\" "
                      "\"data/scene_checker2x2.png\"\nShape \"sphere\"\nAttributeEnd\n");
    assert_int_equal(s->nfiles, 1); /* listed once */
    assert_int_equal(s->files[0].kind, SCENE_FILE_IMAGE);
    assert_int_equal(s->files[0].loc.line, 2);
    assert_string_equal(s->lights[0].filename, "data/scene_checker2x2.png");
    assert_string_equal(s->lights[1].filename, "data/scene_checker2x2.png");
    assert_true(s->lights[1].fov == 90.0);
    assert_string_equal(s->area_lights[0].filename, "data/scene_checker2x2.png");
    assert_int_equal(s->area_lights[0].filename_loc.line, 5);
    scene_desc_destroy(&s);
}

/* ---- errors: each with its exact message ---- */

static void test_error_messages(void **state)
{
    (void)state;
    static const struct {
        const char *text, *msg;
    } CASES[] = {
        /* the example of docs/scene-format.md */
        {"WorldBegin\nLightSource \"point\" \"point3 from\" [1 2]\n",
         "t.pbrt:2:21: expected 3 numbers after \"point3 from\", got 2"},
        {"Frobnicate\n", "t.pbrt:1:1: unknown directive Frobnicate"},
        {"PixelFilter \"lanczos\"\nWorldBegin\n",
         "t.pbrt:1:13: unsupported filter \"lanczos\" (\"box\", \"gaussian\", \"mitchell\", "
         "\"sinc\" or \"triangle\")"},
        {"PixelFilter \"box\" \"float radius\" 1\nWorldBegin\n",
         "t.pbrt:1:19: unsupported parameter \"float radius\" for PixelFilter \"box\" (did you "
         "mean \"xradius\"?)"},
        {"PixelFilter \"gaussian\" \"float sigma\" 0\nWorldBegin\n",
         "t.pbrt:1:24: \"float sigma\" must be greater than 0, got 0"},
        {"WorldBegin\nShape \"disk\"   \"float zmin\" -1\n",
         "t.pbrt:2:16: unsupported parameter \"float zmin\" for Shape \"disk\""},
        {"WorldBegin\nShape \"sphere\" \"integer radius\" 2\n",
         "t.pbrt:2:16: \"integer radius\" has the wrong type for Shape \"sphere\": expected "
         "\"float radius\""},
        {"WorldBegin\nShape \"trianglemesh\" \"integer indices\" [0 1 2]\n",
         "t.pbrt:2:1: Shape \"trianglemesh\" needs \"point3 P\""},
        {"WorldBegin\nShape \"trianglemesh\"\n  \"point3 P\" [0 0 0 1 0 0 0 1 0]\n"
         "  \"integer indices\" [0 1 3]\n",
         "t.pbrt:4:3: index 3 (entry 3 of \"integer indices\") is out of range: \"point3 P\" has 3 "
         "points"},
        {"WorldBegin\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0 1 1 0]\n",
         "t.pbrt:2:1: Shape \"trianglemesh\" without \"integer indices\" needs exactly 3 points in "
         "\"point3 P\", got 4"},
        {"WorldBegin\nShape \"trianglemesh\"\n  \"point3 P\" [0 0 0 1 0 0 0 1 0]\n"
         "  \"integer indices\" [0 1]\n",
         "t.pbrt:4:3: expected a multiple of 3 numbers after \"integer indices\", got 2"},
        {"WorldBegin\nShape \"trianglemesh\"\n  \"point3 P\" [0 0 0 1 0 0 0 1]\n",
         "t.pbrt:3:3: expected a multiple of 3 numbers after \"point3 P\", got 8"},
        {"WorldBegin\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0]\n  \"normal N\" [0 0 "
         "1]\n",
         "t.pbrt:3:3: \"normal N\" has 1 normals but \"point3 P\" has 3 points"},
        {"WorldBegin\nShape \"sphere\" \"float radius\" 1e999\n",
         "t.pbrt:2:31: non-finite number 1e999 in \"float radius\""},
        {"WorldBegin\nShape \"sphere\" \"float radius\" nan\n",
         "t.pbrt:2:31: \"float radius\" needs numbers, got nan"},
        {"WorldBegin\nShape \"sphere\" \"float radius\" -2\n",
         "t.pbrt:2:16: \"float radius\" must be greater than 0, got -2"},
        {"WorldBegin\nAttributeEnd\n",
         "t.pbrt:2:1: AttributeEnd without a matching AttributeBegin"},
        {"WorldBegin\nAttributeBegin\n", "t.pbrt:2:1: AttributeBegin has no matching end"},
        {"WorldBegin\nObjectBegin \"a\"\nAttributeBegin\nObjectEnd\n",
         "t.pbrt:4:1: ObjectEnd closes AttributeBegin at line 3 (mismatched nesting)"},
        {"WorldBegin\nObjectEnd\n", "t.pbrt:2:1: ObjectEnd without a matching ObjectBegin"},
        {"WorldBegin\nShape \"sphere", "t.pbrt:2:7: unterminated string (end of file before "
                                       "the closing quote)"},
        {"WorldBegin\nShape \"sphere\nShape \"sphere\"\n",
         "t.pbrt:2:7: unterminated string (end of line before the closing quote)"},
        {"WorldBegin\nShape \"sph\\qere\"\n", "t.pbrt:2:11: unknown escape sequence \"\\q\" in "
                                              "string"},
        {"WorldBegin\nShape \"sphere\" \"float radius\" [1\n",
         "t.pbrt:2:31: unterminated [ after \"float radius\""},
        {"WorldBegin\nShape \"sphere\" \"float radius\"\n",
         "t.pbrt:2:16: missing value after \"float radius\""},
        {"WorldBegin\nShape \"sphere\" \"float radius\" \"big\"\n",
         "t.pbrt:2:31: \"float radius\" needs numbers, got \"big\""},
        {"WorldBegin\nShape \"sphere\" \"float radius\" 1 \"float radius\" 2\n",
         "t.pbrt:2:33: parameter \"radius\" is given twice for Shape \"sphere\" (first at 2:16)"},
        {"WorldBegin\nShape \"sphere\" \"floot radius\" 1\n",
         "t.pbrt:2:16: unknown parameter type \"floot\" in \"floot radius\""},
        {"WorldBegin\nShape \"plymesh\" \"string filename\" nope.ply\n",
         "t.pbrt:2:35: \"string filename\" needs quoted strings, got nope.ply"},
        {"WorldBegin\nShape \"plymesh\" \"string filename\" \"nope.ply\"\n",
         "t.pbrt:2:17: cannot open PLY file \"nope.ply\": No such file or directory"},
        {"Film \"rgb\" \"integer xresolution\" 2.5\nWorldBegin\n",
         "t.pbrt:1:34: \"integer xresolution\" needs integers, got 2.5"},
        {"Film \"rgb\" \"integer xresolution\" 0\nWorldBegin\n",
         "t.pbrt:1:12: \"integer xresolution\" must be within [1, 65536], got 0"},
        {"Film \"spectral\" \"float lambdamin\" 700 \"float lambdamax\" 400\nWorldBegin\n",
         "t.pbrt:1:1: Film: \"lambdamin\" (700) must be below \"lambdamax\" (400)"},
        {"Film \"image\"\nWorldBegin\n",
         "t.pbrt:1:6: unsupported film \"image\" (\"rgb\", \"gbuffer\" or \"spectral\")"},
        {"Film \"rgb\" \"float cropwindow\" [0 1 0]\nWorldBegin\n",
         "t.pbrt:1:12: \"float cropwindow\" needs 4 values (x0 x1 y0 y1), got 3"},
        {"Integrator \"nosuch\"\nWorldBegin\n",
         "t.pbrt:1:12: unsupported integrator \"nosuch\" (\"simplepath\", \"path\", \"whitted\", "
         "\"photon\", \"auto\", \"volpath\", \"bdpt\", \"mlt\", \"sppm\", \"lightpath\", "
         "\"randomwalk\" or \"simplevolpath\")"},
        {"Integrator \"ambientocclusion\"\nWorldBegin\n",
         "t.pbrt:1:12: unsupported integrator \"ambientocclusion\": ambient occlusion renders the "
         "unoccluded fraction of the hemisphere, not radiance, and prismfarm has no integrator "
         "with that expectation"},
        {"Shape \"sphere\"\n", "t.pbrt:1:1: Shape is only allowed after WorldBegin"},
        {"WorldBegin\nCamera \"perspective\"\n",
         "t.pbrt:2:1: Camera must come before WorldBegin (line 1)"},
        {"Camera \"realistic\"\nWorldBegin\n",
         "t.pbrt:1:1: Camera \"realistic\" needs \"string lensfile\""},
        {"Camera \"realistic\" \"string lensfile\" \"no-such.dat\"\nWorldBegin\n",
         "t.pbrt:1:20: cannot open lens file \"no-such.dat\": No such file or directory"},
        {"Camera \"thinlens\"\nWorldBegin\n",
         "t.pbrt:1:8: unsupported camera \"thinlens\" (\"perspective\", \"orthographic\", "
         "\"spherical\" or "
         "\"realistic\")"},
        {"Camera \"perspective\"\n", "t.pbrt: the scene has no WorldBegin"},
        {"WorldBegin\nWorldBegin\n", "t.pbrt:2:1: WorldBegin appears twice (first at line 1)"},
        {"LookAt 0 0 0 1 1 1 0 1\nWorldBegin\n",
         "t.pbrt:2:1: LookAt expects 9 numbers, got WorldBegin as number 9"},
        {"LookAt 0 0 0 0 0 1 0 0 1\nWorldBegin\n",
         "t.pbrt:1:1: LookAt up vector is parallel to the viewing direction"},
        {"Rotate 30 0 0 0\nWorldBegin\n", "t.pbrt:1:1: Rotate: rotation axis is the zero vector"},
        {"Transform [1 0 0 0 1]\nWorldBegin\n", "t.pbrt:1:21: Transform expects 16 numbers, got 5"},
        {"ConcatTransform 1 0\n", "t.pbrt:1:17: ConcatTransform expects [ and 16 numbers, got 1"},
        {"WorldBegin\nScale 0 1 1\nShape \"sphere\"\n",
         "t.pbrt:3:1: the current transform is singular, so Shape cannot use it"},
        {"WorldBegin\nConcatTransform [1 0 0 0 0 1 0 0 0 0 1 1 0 0 0 1]\nShape \"sphere\"\n",
         "t.pbrt:3:1: the current transform is projective (its last row is not 0 0 0 1), so Shape "
         "cannot use it"},
        {"WorldBegin\nCoordSysTransform \"nowhere\"\n",
         "t.pbrt:2:19: unknown coordinate system \"nowhere\""},
        {"WorldBegin\nObjectInstance \"x\"\n", "t.pbrt:2:1: ObjectInstance: object \"x\" is not "
                                               "defined"},
        {"WorldBegin\nObjectBegin \"a\"\nObjectEnd\nObjectBegin \"a\"\n",
         "t.pbrt:4:13: object \"a\" is already defined (line 2)"},
        {"WorldBegin\nObjectBegin \"a\"\nAreaLightSource \"diffuse\"\nShape \"sphere\"\n",
         "t.pbrt:4:1: area lights are not supported inside ObjectBegin (AreaLightSource at line "
         "3)"},
        {"WorldBegin\nNamedMaterial \"glass\"\n",
         "t.pbrt:2:15: named material \"glass\" is not defined (MakeNamedMaterial must come before "
         "its use)"},
        {"WorldBegin\nMakeNamedMaterial \"g\" \"string type\" \"dielectric\"\n"
         "MakeNamedMaterial \"g\" \"string type\" \"dielectric\"\n",
         "t.pbrt:3:19: named material \"g\" is already defined (line 2)"},
        {"WorldBegin\nMakeNamedMaterial \"g\" \"float eta\" 1.5\n",
         "t.pbrt:2:1: MakeNamedMaterial \"g\" needs \"string type\""},
        {"WorldBegin\nMaterial \"diffuse\" \"texture reflectance\" \"nope\"\n",
         "t.pbrt:2:20: spectrum texture \"nope\" is not defined (a Texture must come before its "
         "use)"},
        {"WorldBegin\nTexture \"r\" \"float\" \"constant\"\n"
         "Material \"diffuse\" \"texture reflectance\" \"r\"\n",
         "t.pbrt:3:20: texture \"r\" is a float texture, but \"reflectance\" needs a spectrum "
         "texture"},
        {"WorldBegin\nMaterial \"diffuse\" \"rgb reflectance\" [0.5 1.5 0.5]\n",
         "t.pbrt:2:20: \"rgb reflectance\" has a component above 1 (a reflectance is at most 1)"},
        /* One name table writes every such list, with base/suggest's "did you mean". */
        {"WorldBegin\nMaterial \"difuse\"\n",
         "t.pbrt:2:10: unsupported material \"difuse\" (did you mean \"diffuse\"? \"diffuse\", "
         "\"conductor\", \"dielectric\", \"thindielectric\", \"diffusetransmission\", "
         "\"coateddiffuse\", \"coatedconductor\", \"mix\", \"uniaxial\", \"interface\", "
         "\"polarizer\", \"retarder\", \"measured\", \"hair\" or \"subsurface\")"},
        {"Sampler \"sobel\"\nWorldBegin\n",
         "t.pbrt:1:9: unsupported sampler \"sobel\" (did you mean \"sobol\"? \"halton\", "
         "\"independent\", \"paddedsobol\", \"pmj02bn\", \"sobol\", \"stratified\" or \"zsobol\")"},
        {"WorldBegin\nMaterial \"skin\"\n",
         "t.pbrt:2:10: unsupported material \"skin\" (\"diffuse\", \"conductor\", "
         "\"dielectric\", \"thindielectric\", \"diffusetransmission\", \"coateddiffuse\", "
         "\"coatedconductor\", \"mix\", \"uniaxial\", \"interface\", \"polarizer\", "
         "\"retarder\", \"measured\", \"hair\" or \"subsurface\")"},
        {"WorldBegin\nMaterial \"subsurface\" \"rgb sigma_a\" [1 1 1]\n",
         "t.pbrt:2:23: Material \"subsurface\": \"sigma_a\" is given without \"sigma_s\""},
        {"WorldBegin\nMaterial \"subsurface\" \"string name\" \"Cheese\"\n",
         "t.pbrt:2:23: Material \"subsurface\": named medium \"Cheese\" is not in pbrt-v4's "
         "table of measured media (e.g. \"Skin1\", \"Ketchup\", \"Apple\", \"Wholemilk\"; "
         "docs/scene-format.md lists them)"},
        {"WorldBegin\nMaterial \"mix\" \"string materials\" [\"a\" \"b\"]\n",
         "t.pbrt:2:16: mix: named material \"a\" is not defined (a MakeNamedMaterial must come "
         "before the mix that uses it)"},
        {"WorldBegin\nMakeNamedMaterial \"a\" \"string type\" \"diffuse\"\n"
         "Material \"mix\" \"string materials\" [\"a\"]\n",
         "t.pbrt:3:16: expected 2 material names after \"string materials\", got 1"},
        {"WorldBegin\nMaterial \"mix\"\n",
         "t.pbrt:2:1: mix: \"string materials\" (two named materials) is missing"},
        {"WorldBegin\nMaterial \"coateddiffuse\" \"float thickness\" [0]\n",
         "t.pbrt:2:26: \"float thickness\" must be greater than 0, got 0"},
        {"WorldBegin\nMaterial \"coateddiffuse\" \"float g\" [1]\n",
         "t.pbrt:2:26: \"float g\" must be within [-0.999, 0.999], got 1"},
        {"WorldBegin\nMaterial \"coatedconductor\" \"float conductor.roughness\" [-1]\n",
         "t.pbrt:2:1: conductor.roughness must not be negative"},
        {"WorldBegin\nMaterial \"coatedconductor\" \"rgb reflectance\" [1 1 1] "
         "\"spectrum conductor.k\" \"metal-Au-k\"\n",
         "t.pbrt:2:28: Material \"coatedconductor\": give either \"reflectance\" or "
         "\"conductor.eta\" and \"conductor.k\", not both"},
        {"WorldBegin\nMaterial \"dielectric\" \"float sellmeier\" [1 2 3]\n",
         "t.pbrt:2:23: \"float sellmeier\" needs (B, C) pairs, got 3 numbers"},
        {"WorldBegin\nMaterial \"dielectric\" \"float cauchy\" [1.5]\n",
         "t.pbrt:2:23: expected 2 numbers after \"float cauchy\" (A B), got 1"},
        {"WorldBegin\nMaterial \"dielectric\" \"float eta\" 1.5 \"string glass\" \"N-BK7\"\n",
         "t.pbrt:2:39: give only one of \"eta\", \"glass\", \"sellmeier\" and \"cauchy\" for "
         "Material \"dielectric\" (\"eta\" is already given)"},
        {"WorldBegin\nMaterial \"conductor\" \"rgb reflectance\" [1 1 1] \"spectrum k\" "
         "\"metal-Au-k\"\n",
         "t.pbrt:2:22: Material \"conductor\": give either \"reflectance\" or \"eta\" and "
         "\"k\", not both"},
        {"WorldBegin\nLightSource \"point\" \"spectrum I\" [400 1 500]\n",
         "t.pbrt:2:21: \"spectrum I\" needs (wavelength, value) pairs, got 3 numbers"},
        {"WorldBegin\nLightSource \"point\" \"spectrum I\" [500 1 400 2]\n",
         "t.pbrt:2:21: \"spectrum I\": wavelengths must increase, but pair 2 has 400 nm after 500 "
         "nm"},
        {"WorldBegin\nLightSource \"point\" \"spectrum I\" [500 1 \"x\"]\n",
         "t.pbrt:2:21: \"spectrum I\" mixes numbers, strings and booleans"},
        {"WorldBegin\nLightSource \"point\" \"spectrum I\" \"spds/lamp.spd\"\n",
         "t.pbrt:2:21: \"spds/lamp.spd\" is not a named spectrum, and no spectrum file is there "
         "(looked for \"spds/lamp.spd\")"},
        {"WorldBegin\nLightSource \"point\" \"rgb I\" [1 -1 1]\n",
         "t.pbrt:2:21: \"rgb I\" has a negative component"},
        {"WorldBegin\nLightSource \"point\" \"blackbody I\" [3000 1]\n",
         "t.pbrt:2:21: expected 1 number after \"blackbody I\", got 2 (pbrt-v4 takes only the "
         "temperature)"},
        {"WorldBegin\nLightSource \"ies\"\n",
         "t.pbrt:2:13: unsupported light \"ies\" (\"point\", \"spot\", \"distant\", "
         "\"infinite\", \"goniometric\" or \"projection\")"},
        {"WorldBegin\nAreaLightSource \"diffuse\" \"rgb L\" [1 1 1] \"string filename\" "
         "\"data/scene_checker2x2.png\"\n",
         "t.pbrt:2:27: AreaLightSource \"diffuse\": cannot have both \"L\" and \"filename\" "
         "(pbrt-v4 "
         "refuses it too)"},
        {"WorldBegin\nLightSource \"goniometric\"\n",
         "t.pbrt:2:1: LightSource \"goniometric\" needs \"string filename\" (its image)"},
        {"WorldBegin\nLightSource \"projection\" \"float fov\" 180\n",
         "t.pbrt:2:26: \"float fov\" must be strictly between 0 and 180 degrees, got 180"},
        {"WorldBegin\nLightSource \"projection\" \"rgb I\" [1 1 1] \"string filename\" "
         "\"data/scene_checker2x2.png\"\n",
         "t.pbrt:2:26: unsupported parameter \"rgb I\" for LightSource \"projection\""},
        {"WorldBegin\nLightSource \"point\" \"string I\" \"x\"\n",
         "t.pbrt:2:21: \"string I\" has the wrong type for LightSource \"point\": expected "
         "\"spectrum I\", \"rgb I\", \"blackbody I\" or \"float I\""},
        {"WorldBegin\nLightSource \"spot\" \"float coneangle\" 10 \"float conedeltaangle\" 20\n",
         "t.pbrt:2:41: \"float conedeltaangle\" must be within [0, 10], got 20"},
        {"WorldBegin\nAreaLightSource \"diffuse\" \"bool twosided\" 1\n",
         "t.pbrt:2:43: \"bool twosided\" needs true or false, got 1"},
        {"WorldBegin\nAreaLightSource \"collimated\" \"bool twosided\" true\n",
         "t.pbrt:2:30: unsupported parameter \"bool twosided\" for AreaLightSource \"collimated\""},
        {"WorldBegin\nShape \"disk\" \"float innerradius\" 0.5\n",
         "t.pbrt:2:14: unsupported parameter value: \"float innerradius\" must be 0 (annuli are "
         "not supported)"},
        {"WorldBegin\nShape \"hyperboloid\"\n",
         "t.pbrt:2:7: unsupported shape \"hyperboloid\" (\"sphere\", \"disk\", \"cylinder\", "
         "\"trianglemesh\", \"plymesh\", \"bilinearmesh\", \"loopsubdiv\" or \"curve\")"},
        {"WorldBegin\nTexture \"t\" \"color\" \"constant\"\n",
         "t.pbrt:2:13: texture type \"color\" is pbrt-v3's (\"spectrum\"): a pbrt-v3 file: "
         "`prismfarm upgrade FILE -o NEW.pbrt` rewrites it for pbrt-v4, as `pbrt --upgrade` does"},
        {"WorldBegin\nTexture \"t\" \"colour\" \"constant\"\n",
         "t.pbrt:2:13: unsupported texture type \"colour\" (\"float\" or \"spectrum\")"},
        {"WorldBegin\nMaterial \"uber\"\n",
         "t.pbrt:2:10: pbrt-v3's material \"uber\" (pbrt-v4's \"coateddiffuse\"): a pbrt-v3 file: "
         "`prismfarm upgrade FILE -o NEW.pbrt` rewrites it for pbrt-v4, as `pbrt --upgrade` does"},
        {"WorldBegin\nWorldEnd\n",
         "t.pbrt:2:1: unsupported directive WorldEnd (a pbrt-v3 file: `prismfarm upgrade FILE -o "
         "NEW.pbrt` rewrites it for pbrt-v4, as `pbrt --upgrade` does)"},
        {"WorldBegin\nTexture \"t\" \"float\" \"perlin\"\n",
         "t.pbrt:2:21: unsupported texture \"perlin\" (\"constant\", \"checkerboard\", "
         "\"imagemap\", \"scale\", \"mix\", \"bilerp\", \"dots\", \"fbm\", \"wrinkled\", "
         "\"windy\", "
         "\"marble\" or \"directionmix\")"},
        {"WorldBegin\nTexture \"t\" \"spectrum\" \"fbm\"\n",
         "t.pbrt:2:24: Texture \"t\": \"fbm\" is a float texture in pbrt-v4"},
        {"WorldBegin\nTexture \"t\" \"float\" \"marble\"\n",
         "t.pbrt:2:21: Texture \"t\": \"marble\" is a spectrum texture in pbrt-v4"},
        {"WorldBegin\nTexture \"t\" \"float\" \"wrinkled\" \"integer octaves\" 0\n",
         "t.pbrt:2:32: \"integer octaves\" must be in 1..64, got 0"},
        {"WorldBegin\nTexture \"t\" \"float\" \"imagemap\" \"string filename\" \"x.exr\"\n",
         "t.pbrt:2:32: cannot open image \"x.exr\": No such file or directory"},
        {"WorldBegin\nTexture \"t\" \"float\" \"imagemap\" \"string filename\" \"x.png\"\n",
         "t.pbrt:2:32: cannot open image \"x.png\": No such file or directory"},
        {"WorldBegin\nTexture \"t\" \"float\" \"checkerboard\" \"integer dimension\" 4\n",
         "t.pbrt:2:36: checkerboard \"integer dimension\" must be 2 or 3, got 4"},
        {"WorldBegin\nTexture \"t\" \"float\" \"constant\" \"string mapping\" \"sphere\"\n",
         "t.pbrt:2:32: unsupported texture mapping \"sphere\" (\"uv\", "
         "\"spherical\", \"cylindrical\" or \"planar\")"},
        {"WorldBegin\n\"float radius\" 1\n", "t.pbrt:2:1: expected a directive, got \"float "
                                             "radius\""},
        {"WorldBegin\nShape \"sphere\" \"float radius\" [[1]]\n",
         "t.pbrt:2:32: unexpected [ inside the values of \"float radius\""},
        {"\xff\xfeW\0o\0", "t.pbrt:1:1: file is UTF-16 encoded; scenes must be ASCII or UTF-8"},
    };
    for (size_t i = 0; i < sizeof CASES / sizeof CASES[0]; i++)
        expect_error(CASES[i].text, CASES[i].msg);
}

static void test_syntax_details(void **state)
{
    (void)state;
    /* Comments, escapes, quoted booleans, a single value without brackets, "point" and
     * "color" spellings, integers with signs and hex floats. */
    scene_desc_t *s =
        parse_text_ok("# comment\nWorldBegin # trailing comment\n"
                      "AreaLightSource \"diffuse\" \"color L\" [1 2 3] \"bool twosided\" \"true\"\n"
                      "LightSource \"point\" \"point from\" [+1 -2 0x1p2]\n"
                      "MakeNamedMaterial \"a \\\"quoted\\\" name\" \"string type\" \"interface\"\n"
                      "NamedMaterial \"a \\\"quoted\\\" name\"\n"
                      "Shape \"sphere\" \"float radius\" .5e1\n");
    assert_true(s->area_lights[0].twosided);
    assert_int_equal(s->area_lights[0].L.kind, SCENE_SPECTRUM_RGB);
    testutil_assert_near(s->area_lights[0].L.rgb[2], 3, TOL);
    testutil_assert_near(s->lights[0].from.x, 1, TOL);
    testutil_assert_near(s->lights[0].from.y, -2, TOL);
    testutil_assert_near(s->lights[0].from.z, 4, TOL);
    assert_string_equal(s->materials[1].name, "a \"quoted\" name");
    assert_int_equal(s->shapes[0].material, 1);
    testutil_assert_near(s->shapes[0].radius, 5, TOL);
    assert_int_equal(s->shapes[0].area_light, 0);
    scene_desc_destroy(&s);
}

/* ---- robustness: random mutations of the test scenes ---- */

static uint64_t next_rand(uint64_t *x)
{
    /* xorshift64* (Vigna 2016): fixed seed, so a failure reproduces. */
    *x ^= *x >> 12;
    *x ^= *x << 25;
    *x ^= *x >> 27;
    return *x * 2685821657736338717ull;
}

static void test_mutations_never_crash(void **state)
{
    (void)state;
    static const char *FILES[] = {"data/scenes/options.pbrt",     "data/scenes/materials.pbrt",
                                  "data/scenes/lights.pbrt",      "data/scenes/shapes.pbrt",
                                  "data/scenes/transforms.pbrt",  "data/scenes/instances.pbrt",
                                  "data/scenes/include_main.pbrt"};
    static const char *TOKENS[] = {"\"",
                                   "[",
                                   "]",
                                   "#",
                                   "\\",
                                   "\n",
                                   " ",
                                   "1e999",
                                   "-0",
                                   "true",
                                   "AttributeBegin",
                                   "AttributeEnd",
                                   "ObjectBegin \"o\"",
                                   "ObjectEnd",
                                   "ObjectInstance \"tri\"",
                                   "WorldBegin",
                                   "Include \"inc/cycle_a.pbrt\"",
                                   "\"float radius\"",
                                   "\"integer indices\" [0 1 9]",
                                   "Scale 0 0 0",
                                   "\"point3 P\""};
    uint64_t rng = 0x9e3779b97f4a7c15ull;
    size_t parsed = 0, failed = 0;
    for (size_t fi = 0; fi < sizeof FILES / sizeof FILES[0]; fi++) {
        size_t len = 0;
        char *orig = testutil_slurp(FILES[fi], &len);
        assert_non_null(orig);
        char *buf = malloc(2 * len + 256);
        assert_non_null(buf);
        for (int iter = 0; iter < 150; iter++) {
            memcpy(buf, orig, len);
            size_t n = len;
            int edits = 1 + (int)(next_rand(&rng) % 4);
            for (int e = 0; e < edits && n > 0; e++) {
                size_t at = next_rand(&rng) % n;
                switch (next_rand(&rng) % 4) {
                case 0: /* replace a byte */
                    buf[at] = (char)(next_rand(&rng) % 256);
                    break;
                case 1: { /* delete a span */
                    size_t k = 1 + next_rand(&rng) % 16;
                    if (k > n - at)
                        k = n - at;
                    memmove(buf + at, buf + at + k, n - at - k);
                    n -= k;
                    break;
                }
                case 2: { /* insert a token */
                    const char *tok = TOKENS[next_rand(&rng) % (sizeof TOKENS / sizeof TOKENS[0])];
                    size_t k = strlen(tok);
                    if (n + k > 2 * len + 200)
                        break;
                    memmove(buf + at + k, buf + at, n - at);
                    memcpy(buf + at, tok, k);
                    n += k;
                    break;
                }
                default: { /* truncate */
                    n = at;
                    break;
                }
                }
            }
            err_t err = {{0}};
            scene_desc_t *s = pbrt_parse_string(buf, n, FILES[fi], &err);
            if (s) {
                parsed++;
                scene_desc_destroy(&s);
            } else {
                failed++;
                assert_true(strlen(err.msg) > 0);
            }
        }
        free(buf);
        free(orig);
    }
    /* Both outcomes must occur, or the mutations test nothing. */
    assert_true(parsed > 0);
    assert_true(failed > 0);
}

/* Attribute "shape" ... gives defaults to the shapes that follow until the attribute block
 * ends: a shape's own value wins, a newer Attribute wins over an older one, and a default a
 * shape does not use ("float height" on a sphere) is no unused-parameter error (pbrt-v4). */
static void test_attribute_defaults(void **state)
{
    (void)state;
    scene_desc_t *s = parse_text_ok("WorldBegin\n"
                                    "AttributeBegin\n"
                                    "  Attribute \"shape\" \"float radius\" 2\n"
                                    "  Attribute \"shape\" \"float radius\" 3 \"float height\" 0.25\n"
                                    "  Shape \"sphere\"\n"
                                    "  Shape \"sphere\" \"float radius\" 5\n"
                                    "  Shape \"disk\"\n"
                                    "  Attribute \"light\" \"float scale\" 2\n"
                                    "AttributeEnd\n"
                                    "Shape \"sphere\"\n");
    assert_int_equal(s->nshapes, 4);
    testutil_assert_near(s->shapes[0].radius, 3, TOL);
    testutil_assert_near(s->shapes[1].radius, 5, TOL);
    testutil_assert_near(s->shapes[2].radius, 3, TOL);
    testutil_assert_near(s->shapes[3].radius, 1, TOL); /* AttributeEnd ended the defaults */
    scene_desc_destroy(&s);
    expect_error("WorldBegin\nAttribute \"camera\" \"float fov\" 30\n",
                 "t.pbrt:2:11: unknown Attribute target \"camera\" (\"shape\", "
                 "\"light\", \"material\", \"medium\" or \"texture\")");
    expect_error("Attribute \"shape\" \"float radius\" 2\n",
                 "t.pbrt:1:1: Attribute is only allowed after WorldBegin");
    /* A default is checked where the entity reads it, at the Attribute's own location. */
    expect_error("WorldBegin\nAttribute \"shape\" \"float radius\" -1\nShape \"sphere\"\n",
                 "t.pbrt:2:19: \"float radius\" must be greater than 0, got -1");
}

/* Option "seed" is the default of the sampler's seed (the Sampler's own wins, in either
 * order, as pbrt-v4 reads Options->seed when it makes the sampler); pbrt-v4's other options
 * are checked and warned, "false" switches silently; an unknown one is refused. */
static void test_option_directive(void **state)
{
    (void)state;
    scene_desc_t *s = parse_text_ok("Option \"seed\" 7\nOption \"forcediffuse\" true\n"
                                    "Option \"wavefront\" false\nWorldBegin\n");
    assert_int_equal(s->sampler.seed, 7);
    assert_int_equal(warnings_count(s->warnings), 1);
    assert_string_equal(warnings_at(s->warnings, 0),
                        "t.pbrt:2:1: Option \"forcediffuse\" is not simulated (materials keep "
                        "their own BSDFs)");
    scene_desc_destroy(&s);
    s = parse_text_ok("Sampler \"halton\" \"integer seed\" 3\nOption \"seed\" 7\nWorldBegin\n");
    assert_int_equal(s->sampler.seed, 3);
    scene_desc_destroy(&s);
    expect_error("Option \"seed\" 1.5\nWorldBegin\n",
                 "t.pbrt:1:15: Option \"seed\" expects an integer");
    expect_error("Option \"pixelstats\" 1\nWorldBegin\n",
                 "t.pbrt:1:21: Option \"pixelstats\" expects true or false");
    expect_error("Option \"rendercoordsys\" \"screen\"\nWorldBegin\n",
                 "t.pbrt:1:25: Option \"rendercoordsys\": unknown coordinate system \"screen\" "
                 "(\"camera\", \"cameraworld\" or \"world\")");
    err_t err = {{0}};
    const char *text = "Option \"turbo\" true\nWorldBegin\n";
    assert_null(pbrt_parse_string(text, strlen(text), "t.pbrt", &err));
    assert_non_null(strstr(err.msg, "t.pbrt:1:8: unknown option \"turbo\" (\"seed\", \"disablepixeljitter\", "));
}

/* The thin-film extension on dielectrics and conductors: read with its defaults, bounded, on
 * smooth and rough surfaces. */
static void test_thin_film(void **state)
{
    (void)state;
    scene_desc_t *s = parse_text_ok(
        "WorldBegin\nMaterial \"dielectric\" \"float filmthickness\" [ 450 ]\n"
        "Shape \"sphere\"\nMaterial \"conductor\" \"float filmthickness\" [ 300 ] "
        "\"float filmeta\" [ 1.5 ]\nShape \"sphere\"\nMaterial \"dielectric\"\nShape \"sphere\"\n");
    scene_t *sc = load_scene_ok(s);
    int glass = 0, metal = 0, plain = 0;
    for (size_t i = 0; i < sc->nmaterials; i++) {
        const material_t *m = &sc->materials[i];
        glass += m->kind == MATERIAL_DIELECTRIC && m->film_thickness == 450.0 &&
                 ior_eval(&m->film_ior, 550) == 1.33;
        metal += m->kind == MATERIAL_CONDUCTOR && m->film_thickness == 300.0 &&
                 ior_eval(&m->film_ior, 550) == 1.5;
        plain += m->kind == MATERIAL_DIELECTRIC && m->film_thickness == 0.0;
    }
    assert_int_equal(glass, 1);
    assert_int_equal(metal, 1);
    assert_int_equal(plain, 1);
    scene_destroy(&sc);
    scene_desc_destroy(&s);
    /* Rough surfaces take the film at each microfacet (bsdf/lobe). */
    s = parse_text_ok("WorldBegin\nMaterial \"dielectric\" \"float roughness\" [ 0.1 ] "
                      "\"float filmthickness\" [ 400 ]\nShape \"sphere\"\n");
    sc = load_scene_ok(s);
    int rough_film = 0;
    for (size_t i = 0; i < sc->nmaterials; i++)
        rough_film += sc->materials[i].film_thickness == 400.0;
    assert_int_equal(rough_film, 1);
    scene_destroy(&sc);
    scene_desc_destroy(&s);
    expect_error("WorldBegin\nMaterial \"dielectric\" \"float filmthickness\" [ -1 ]\n",
                 "t.pbrt:2:23: \"float filmthickness\" must be within [0, 100000], got -1");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_options),
        cmocka_unit_test(test_defaults),
        cmocka_unit_test(test_materials_and_textures),
        cmocka_unit_test(test_materials_loaded),
        cmocka_unit_test(test_more_materials),
        cmocka_unit_test(test_thin_film),
        cmocka_unit_test(test_accepted_not_simulated),
        cmocka_unit_test(test_lights),
        cmocka_unit_test(test_shapes),
        cmocka_unit_test(test_ply_import_direct),
        cmocka_unit_test(test_ply_variants_still_load),
        cmocka_unit_test(test_ply_unsafe_refused),
        cmocka_unit_test(test_ply_mutations_never_crash),
        cmocka_unit_test(test_transforms),
        cmocka_unit_test(test_instances),
        cmocka_unit_test(test_includes),
        cmocka_unit_test(test_files_read),
        cmocka_unit_test(test_error_messages),
        cmocka_unit_test(test_attribute_defaults),
        cmocka_unit_test(test_option_directive),
        cmocka_unit_test(test_syntax_details),
        cmocka_unit_test(test_mutations_never_crash),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
