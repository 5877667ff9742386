/* Scene budgets (scenefile/budget.h; issue 16, item 4): what one scene from a bundle may make
 * the master build. A scene over the shapes, triangles, texels or merged-image budget is
 * refused at the directive that passes it, naming file, line and the master's option, and
 * before the costly part is built: a loopsubdiv of 12 levels is refused without subdividing
 * (it would make 4^12 triangles of each), a 32768x32768 film before any geometry. A scene
 * within every budget loads; the default budget holds the shipped scenes. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "files_testutil.h"
#include "pbrt_parser.h"
#include "scene_load.h"

#include <stdio.h>
#include <string.h>

#define HEAD                                                                                       \
    "LookAt 0 1 -3  0 0.5 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 40 ]\n"                \
    "Film \"rgb\" \"integer xresolution\" [ 16 ] \"integer yresolution\" [ 8 ]\n"                 \
    "Sampler \"independent\" \"integer pixelsamples\" [ 1 ]\nWorldBegin\n"                         \
    "LightSource \"point\" \"rgb I\" [ 1 1 1 ]\n"

/* Writes text as NAME in the scratch folder and loads it confined there with budget b:
 * NULL with err when refused. */
static scene_t *load(const char *name, const char *text, const scene_budget_t *b, err_t *err)
{
    const char *path = testutil_scratch(name);
    char copy[600];
    snprintf(copy, sizeof copy, "%s", path);
    testutil_write_text(copy, text, 0644);
    scene_overrides_t ov = {.seed = -1, .budget = b};
    return scene_load_file_confined(copy, testutil_scratch_dir(), &ov, err);
}

static void expect_refusal(const char *name, const char *text, const scene_budget_t *b,
                           const char *where, const char *what)
{
    err_t err = {{0}};
    scene_t *sc = load(name, text, b, &err);
    if (sc)
        fail_msg("%s loaded over its budget", name);
    if (!strstr(err.msg, where) || !strstr(err.msg, what))
        fail_msg("%s: expected '%s' and '%s' in: %s", name, where, what, err.msg);
}

static void test_shapes(void **state)
{
    (void)state;
    scene_budget_t b = {.shapes = 3};
    char text[2048];
    snprintf(text, sizeof text,
             HEAD "Shape \"sphere\"\nShape \"sphere\"\nShape \"sphere\"\n"
                  "Shape \"sphere\" \"float radius\" [ 2 ]\n");
    /* The fourth shape is on line 10 of the file. */
    expect_refusal("shapes.pbrt", text, &b, "shapes.pbrt:10:",
                   "more than 3 shapes and object instances, the master's budget (prismfarm "
                   "master --max-shapes)");
    /* Object instances count too. */
    snprintf(text, sizeof text,
             HEAD "ObjectBegin \"o\"\nShape \"sphere\"\nObjectEnd\nObjectInstance \"o\"\n"
                  "ObjectInstance \"o\"\nObjectInstance \"o\"\n");
    expect_refusal("instances.pbrt", text, &b, "instances.pbrt:12:", "--max-shapes");
    /* Exactly at the budget: loads. */
    snprintf(text, sizeof text, HEAD "Shape \"sphere\"\nShape \"sphere\"\nShape \"sphere\"\n");
    err_t err = {{0}};
    scene_t *sc = load("three.pbrt", text, &b, &err);
    if (!sc)
        fail_msg("three shapes with a budget of three: %s", err.msg);
    scene_destroy(&sc);
}

static void test_triangles(void **state)
{
    (void)state;
    scene_budget_t b = {.triangles = 1000};
    /* 2 triangles, 4 levels: 512; 5 levels: 2048 -- refused before subdividing. */
    const char *quad = "\"point3 P\" [ -1 0 -1  1 0 -1  1 0 1  -1 0 1 ] "
                       "\"integer indices\" [ 0 1 2  0 2 3 ]";
    char text[2048];
    snprintf(text, sizeof text, HEAD "Shape \"loopsubdiv\" \"integer levels\" [ 4 ] %s\n", quad);
    err_t err = {{0}};
    scene_t *sc = load("sub4.pbrt", text, &b, &err);
    if (!sc)
        fail_msg("512 triangles with a budget of 1000: %s", err.msg);
    scene_destroy(&sc);
    snprintf(text, sizeof text,
             HEAD "Shape \"loopsubdiv\" \"integer levels\" [ 4 ] %s\n"
                  "Shape \"loopsubdiv\" \"integer levels\" [ 12 ] %s\n",
             quad, quad);
    expect_refusal("sub12.pbrt", text, &b, "sub12.pbrt:8:",
                   "this shape's 33554432 triangles take the scene over 1000 triangles, the "
                   "master's budget (prismfarm master --max-triangles)");
    /* Meshes count as they are read. */
    b.triangles = 3;
    snprintf(text, sizeof text,
             HEAD "Shape \"trianglemesh\" %s\nShape \"trianglemesh\" %s\n", quad, quad);
    expect_refusal("meshes.pbrt", text, &b, "meshes.pbrt:8:", "--max-triangles");
}

static void test_image_and_texels(void **state)
{
    (void)state;
    /* The default budget refuses the 33.9 GB film of the adversarial test, before geometry. */
    scene_budget_t b = scene_budget_default();
    expect_refusal("huge.pbrt",
                   "Film \"spectral\" \"integer xresolution\" [ 32768 ] \"integer yresolution\" "
                   "[ 32768 ] \"integer nbuckets\" [ 1 ]\nWorldBegin\nShape \"sphere\"\n",
                   &b, "huge.pbrt:1:", "over the master's budget of 4096 MiB (prismfarm master "
                                       "--max-image-mb)");
    /* A 2x2 texture (tests/data/scene_checker2x2.png) against 3 texels. */
    char text[2048], png[700];
    snprintf(png, sizeof png, "%s", testutil_scratch("checker.png"));
    FILE *in = fopen("data/scene_checker2x2.png", "rb"), *out = fopen(png, "wb");
    assert_non_null(in);
    assert_non_null(out);
    char buf[4096];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, in)) > 0)
        assert_int_equal(fwrite(buf, 1, n, out), n);
    fclose(in);
    assert_int_equal(fclose(out), 0);
    snprintf(text, sizeof text,
             HEAD "Texture \"t\" \"spectrum\" \"imagemap\" \"string filename\" \"checker.png\"\n"
                  "Material \"diffuse\" \"texture reflectance\" \"t\"\nShape \"sphere\"\n");
    b = (scene_budget_t){.texels = 3};
    expect_refusal("texels.pbrt", text, &b, "texels.pbrt:7:",
                   "this 2x2 image takes the scene over 3 texels, the master's budget (prismfarm "
                   "master --max-texels)");
    b.texels = 4;
    err_t err = {{0}};
    scene_t *sc = load("texels4.pbrt", text, &b, &err);
    if (!sc)
        fail_msg("4 texels with a budget of 4: %s", err.msg);
    scene_destroy(&sc);
}

/* The shipped scenes load within the default budget. */
static void test_default_budget_holds_shipped_scenes(void **state)
{
    (void)state;
    const char *scenes[] = {"../scenes/jewel.pbrt", "../scenes/materials.pbrt"};
    scene_budget_t b = scene_budget_default();
    for (size_t i = 0; i < sizeof scenes / sizeof *scenes; i++) {
        err_t err = {{0}};
        scene_overrides_t ov = {.seed = -1, .budget = &b};
        scene_t *sc = scene_load_file_confined(scenes[i], "..", &ov, &err);
        if (!sc)
            fail_msg("%s within the default budget: %s", scenes[i], err.msg);
        scene_destroy(&sc);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_shapes),
        cmocka_unit_test(test_triangles),
        cmocka_unit_test(test_image_and_texels),
        cmocka_unit_test(test_default_budget_holds_shipped_scenes),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_setup, testutil_scratch_teardown);
}
