/* Scene budgets (scenefile/budget.h; issue 16, item 4): what one scene from a bundle may make
 * the master build. A scene over the shapes, triangles, texels or merged-image budget is
 * refused at the directive that passes it, naming file, line and the master's option, and
 * before the costly part is built: a loopsubdiv of 12 levels is refused without subdividing
 * (it would make 4^12 triangles of each), a 32768x32768 film before any geometry. A scene
 * within every budget loads; the default budget holds the shipped scenes. Issue 26, finding 2:
 * a PLY's vertices and faces are charged from its header (of a .ply.gz, nothing but the header
 * is inflated), scene text each time it is read (an Include repeated), a .pbrt.gz only up to
 * what the text budget leaves (refused while it is counted), an image's texels from its header
 * before it is decoded, and a parse past its deadline is stopped. */
#define _GNU_SOURCE /* memmem */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "clock.h"
#include "files_testutil.h"
#include "gzip_data.h"
#include "image_exr.h"
#include "pbrt_parser.h"
#include "scene_load.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

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
    /* A Stokes output's image holds four planes of buckets (render_settings_buckets):
     * 1024x1024 with 16 buckets takes 160 MiB, with "bool stokes" (64 + 4) * 8 bytes a pixel. */
    b.image_bytes = (uint64_t)200 << 20;
    const char *film = "Film \"spectral\" \"integer xresolution\" [ 1024 ] \"integer "
                       "yresolution\" [ 1024 ] \"integer nbuckets\" [ 16 ] %s\nWorldBegin\n"
                       "Shape \"sphere\"\n";
    char scene[512];
    snprintf(scene, sizeof scene, film, "");
    err_t e = {{0}};
    scene_t *plain = load("plain.pbrt", scene, &b, &e);
    if (!plain)
        fail_msg("160 MiB against 200: %s", e.msg);
    scene_destroy(&plain);
    snprintf(scene, sizeof scene, film, "\"bool stokes\" true");
    expect_refusal("stokes.pbrt", scene, &b, "stokes.pbrt:1:",
                   "1024x1024 pixels and 64 buckets takes 544.0 MiB, over the master's budget of "
                   "200 MiB");
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

/* data[0..n) appended to f as one gzip member. */
static void write_member(FILE *f, const void *data, size_t n)
{
    uLongf cap = compressBound((uLong)n) + 64;
    unsigned char *out = malloc(cap);
    assert_non_null(out);
    z_stream z;
    memset(&z, 0, sizeof z);
    assert_int_equal(deflateInit2(&z, 9, Z_DEFLATED, 15 + 16, 9, Z_DEFAULT_STRATEGY), Z_OK);
    z.next_in = (unsigned char *)(uintptr_t)data;
    z.avail_in = (uInt)n;
    z.next_out = out;
    z.avail_out = (uInt)cap;
    assert_int_equal(deflate(&z, Z_FINISH), Z_STREAM_END);
    assert_int_equal(fwrite(out, 1, cap - z.avail_out, f), cap - z.avail_out);
    deflateEnd(&z);
    free(out);
}

/* A .ply.gz whose header claims 1000 vertices and 5 faces, followed by bytes that are not
 * gzip at all: only a reader that inflates no more than the header reaches the budget. */
static void write_ply_header_only(const char *name)
{
    FILE *f = fopen(testutil_scratch(name), "wb");
    assert_non_null(f);
    const char *head = "ply\nformat binary_little_endian 1.0\nelement vertex 1000\n"
                       "property float x\nproperty float y\nproperty float z\nelement face 5\n"
                       "property list uchar int vertex_indices\nend_header\n";
    write_member(f, head, strlen(head));
    fputs("this is not deflate data", f);
    assert_int_equal(fclose(f), 0);
}

static void test_ply_header(void **state)
{
    (void)state;
    write_ply_header_only("head.ply.gz");
    char text[2048];
    snprintf(text, sizeof text, HEAD "Shape \"plymesh\" \"string filename\" \"head.ply.gz\"\n");
    err_t err;
    scene_budget_t b = {.vertices = 999};
    expect_refusal("plyv.pbrt", text, &b, "plyv.pbrt:7:",
                   "head.ply.gz\" declares 1000 vertices, which takes the scene over 999 PLY "
                   "vertices, the master's budget (prismfarm master --max-vertices)");
    b = (scene_budget_t){.vertices = 1000, .triangles = 4};
    expect_refusal("plyf.pbrt", text, &b, "plyf.pbrt:7:",
                   "declares 5 faces, more than the 4 triangles of the master's budget (prismfarm "
                   "master --max-triangles)");
    /* Within both, the body is read and found not to be gzip. */
    b = (scene_budget_t){.vertices = 1000, .triangles = 5};
    expect_refusal("plyok.pbrt", text, &b, "plyok.pbrt:7:", "not a valid gzip file");
    /* The vertices of all files together: two of 3 against 5. */
    testutil_write_text(testutil_scratch("tri.ply"),
                        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                        "property float y\nproperty float z\nelement face 1\n"
                        "property list uchar int vertex_indices\nend_header\n"
                        "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
                        0644);
    snprintf(text, sizeof text,
             HEAD "Shape \"plymesh\" \"string filename\" \"tri.ply\"\n"
                  "Shape \"plymesh\" \"string filename\" \"tri.ply\"\n");
    b = (scene_budget_t){.vertices = 5};
    expect_refusal("plyv2.pbrt", text, &b, "plyv2.pbrt:8:", "over 5 PLY vertices");
    b.vertices = 6;
    err = (err_t){{0}};
    scene_t *sc = load("plyv3.pbrt", text, &b, &err);
    if (!sc)
        fail_msg("6 vertices with a budget of 6: %s", err.msg);
    scene_destroy(&sc);
    /* Properties: 10 vertices of 200 floats declare 8000 bytes (and 1 face 13 more), refused
     * from the header of a file that has no body at all. */
    FILE *f = fopen(testutil_scratch("wide.ply"), "w");
    assert_non_null(f);
    fputs("ply\nformat binary_little_endian 1.0\nelement vertex 10\n", f);
    fputs("property float x\nproperty float y\nproperty float z\n", f);
    for (int i = 3; i < 200; i++)
        fprintf(f, "property float extra%d\n", i);
    fputs("element face 1\nproperty list uchar int vertex_indices\nend_header\n", f);
    assert_int_equal(fclose(f), 0);
    snprintf(text, sizeof text, HEAD "Shape \"plymesh\" \"string filename\" \"wide.ply\"\n");
    b = (scene_budget_t){.ply_bytes = 8000};
    expect_refusal("plyb.pbrt", text, &b, "plyb.pbrt:7:",
                   "wide.ply\" declares at least 8001 bytes of vertices and faces, which takes the "
                   "scene over 8000 bytes of PLY data, the master's budget (prismfarm master "
                   "--max-ply-mb)");
    b.ply_bytes = 8001;
    expect_refusal("plyb2.pbrt", text, &b, "plyb2.pbrt:7:", "truncated");
    /* The header alone, inflated from the front. */
    char *gz;
    size_t n, got;
    assert_non_null(gz = testutil_slurp(testutil_scratch("head.ply.gz"), &n));
    char head[64];
    assert_int_equal(gzip_data_inflate_prefix(gz, n, sizeof head, "head", head, &got, &err), 0);
    assert_int_equal(got, sizeof head);
    assert_memory_equal(head, "ply\nformat binary_little_endian", 31);
    free(gz);
}

/* 300 bytes Included 4 times against 1000 bytes of text: the fourth Include is refused; a
 * .pbrt.gz that inflates past what is left is refused while it is counted. */
static void test_text(void **state)
{
    (void)state;
    char part[301];
    memset(part, ' ', 300);
    part[299] = '\n';
    part[300] = 0;
    testutil_write_text(testutil_scratch("part.pbrt"), part, 0644);
    const char *text = "Include \"part.pbrt\"\nInclude \"part.pbrt\"\nInclude \"part.pbrt\"\n"
                       "Include \"part.pbrt\"\nWorldBegin\n";
    scene_budget_t b = {.text_bytes = 1000};
    /* The main file's own bytes count too: 99 + 3 x 300 = 999. */
    expect_refusal("text.pbrt", text, &b, "text.pbrt:4:",
                   "part.pbrt\" (300 bytes) takes the scene over 1000 bytes of text, the master's "
                   "budget (prismfarm master --max-text-mb)");
    b.text_bytes = 1299;
    err_t err = {{0}};
    scene_t *sc = load("text2.pbrt", text, &b, &err);
    if (!sc)
        fail_msg("1299 bytes of text with a budget of 1299: %s", err.msg);
    scene_destroy(&sc);

    FILE *f = fopen(testutil_scratch("spaces.pbrt.gz"), "wb");
    assert_non_null(f);
    char *spaces = malloc(1 << 20);
    assert_non_null(spaces);
    memset(spaces, ' ', 1 << 20);
    write_member(f, spaces, 1 << 20);
    free(spaces);
    assert_int_equal(fclose(f), 0);
    b.text_bytes = 1 << 19;
    expect_refusal("gz.pbrt", "Include \"spaces.pbrt.gz\"\nWorldBegin\n", &b,
                   "gz.pbrt:1:", "spaces.pbrt.gz\" inflates to more than");
}

/* A parse past its deadline stops (here at the main file's text), naming --max-load-seconds. */
static void test_deadline(void **state)
{
    (void)state;
    scene_budget_t b = {.load_seconds = 5};
    scene_budget_start(&b, clock_now_s() - 10);
    expect_refusal("late.pbrt", HEAD "Shape \"sphere\"\n", &b, "",
                   "the scene took longer than 5 s to load, the master's budget (prismfarm master "
                   "--max-load-seconds)");
    scene_budget_start(&b, clock_now_s());
    err_t err = {{0}};
    scene_t *sc = load("intime.pbrt", HEAD "Shape \"sphere\"\n", &b, &err);
    if (!sc)
        fail_msg("a scene within its deadline: %s", err.msg);
    scene_destroy(&sc);
}

/* An EXR whose header claims 100000 x 100000 pixels (a 4x4 file with its data window
 * rewritten): refused from the header by the texel budget, before the decoder sees it. */
static void test_image_header(void **state)
{
    (void)state;
    float rgb[4 * 4 * 3] = {0};
    char path[700];
    snprintf(path, sizeof path, "%s", testutil_scratch("huge.exr"));
    err_t err;
    if (image_exr_write_rgb(path, 4, 4, rgb, 3, NULL, &err))
        fail_msg("%s", err.msg);
    size_t n;
    char *exr = testutil_slurp(path, &n);
    assert_non_null(exr);
    static const char attr[] = "dataWindow\0box2i\0\x10\0\0\0";
    char *at = memmem(exr, n, attr, sizeof attr - 1);
    assert_non_null(at);
    int32_t box[4] = {0, 0, 99999, 99999}; /* little-endian hosts, as the file */
    memcpy(at + sizeof attr - 1, box, sizeof box);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(exr, 1, n, f), n);
    assert_int_equal(fclose(f), 0);
    free(exr);
    char text[2048];
    snprintf(text, sizeof text,
             HEAD "Texture \"t\" \"spectrum\" \"imagemap\" \"string filename\" \"huge.exr\"\n"
                  "Material \"diffuse\" \"texture reflectance\" \"t\"\nShape \"sphere\"\n");
    scene_budget_t b = scene_budget_default();
    expect_refusal("hugeexr.pbrt", text, &b, "hugeexr.pbrt:7:",
                   "this 100000x100000 image takes the scene over 268435456 texels");
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
        cmocka_unit_test(test_ply_header),
        cmocka_unit_test(test_text),
        cmocka_unit_test(test_deadline),
        cmocka_unit_test(test_image_header),
        cmocka_unit_test(test_default_budget_holds_shipped_scenes),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_setup, testutil_scratch_teardown);
}
