/* A load on many threads is the load on one (issue 15, "Loading": PLY files, loopsubdiv
 * shapes and image textures are made on the pool, scenefile/pbrt_parser.h's
 * pbrt_parse_opts_t and scene/overrides.h's threads). The same scene parsed with 1 and 4
 * threads has the same meshes, byte for byte, in the same shapes; loaded with 1 and 3 threads
 * it renders the same sums in every pixel and bucket. A failing load fails with the same
 * message whatever the threads, the first failure in file order: a bad PLY before another
 * bad one or before a syntax error, a triangle budget crossed at a PLY, a trianglemesh or a
 * loopsubdiv after queued PLYs or at the third naming of one PLY file (decoded once, its mesh
 * shared), a bad image texture before another, a texel budget crossed at the third texture. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "files_testutil.h"
#include "image_png.h"
#include "pbrt_parser.h"
#include "render.h"
#include "scene_load.h"
#include "tilebuf.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* A binary little-endian PLY: an n x n grid of quads at height y0, with uv, its faces as
 * quads (the importer splits them) or as triangles. */
static void write_ply(const char *path, int n, double x0, double y0, int quads)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        fail_msg("cannot create %s", path);
    int nv = (n + 1) * (n + 1), nf = quads ? n * n : 2 * n * n;
    fprintf(f,
            "ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty float x\n"
            "property float y\nproperty float z\nproperty float u\nproperty float v\n"
            "element face %d\nproperty list uchar int vertex_indices\nend_header\n",
            nv, nf);
    for (int j = 0; j <= n; j++)
        for (int i = 0; i <= n; i++) {
            float v[5] = {(float)(x0 + (double)i / n), (float)(y0 + 0.1 * sin(i + 2.0 * j)),
                          (float)(3.0 * j / n), (float)i / n, (float)j / n};
            fwrite(v, sizeof v, 1, f);
        }
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            int a = j * (n + 1) + i, q[4] = {a, a + 1, a + n + 2, a + n + 1};
            if (quads) {
                unsigned char c = 4;
                fwrite(&c, 1, 1, f);
                fwrite(q, sizeof q, 1, f);
            } else {
                unsigned char c = 3;
                int t0[3] = {q[0], q[1], q[2]}, t1[3] = {q[0], q[2], q[3]};
                fwrite(&c, 1, 1, f);
                fwrite(t0, sizeof t0, 1, f);
                fwrite(&c, 1, 1, f);
                fwrite(t1, sizeof t1, 1, f);
            }
        }
    fclose(f);
}

static void write_png(const char *path, int size, int seed)
{
    uint8_t *px = malloc((size_t)size * size * 3);
    for (int y = 0; y < size; y++)
        for (int x = 0; x < size; x++) {
            uint8_t *p = &px[3 * (y * size + x)];
            p[0] = (uint8_t)(x * 7 + y * 3 + seed * 50);
            p[1] = (uint8_t)((x ^ y) * 4);
            p[2] = (uint8_t)(y * 5 + seed * 31);
        }
    err_t err;
    if (image_png_write_rgb(path, size, size, px, &err))
        fail_msg("%s", err.msg);
    free(px);
}

/* A scene being written line by line, so that a test knows each directive's line. */
typedef struct text {
    char buf[32768];
    size_t len;
    int line; /* the line the next directive starts on */
} text_t;

static int add(text_t *t, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(t->buf + t->len, sizeof t->buf - t->len, fmt, ap);
    va_end(ap);
    if (n < 0 || (size_t)n >= sizeof t->buf - t->len)
        fail_msg("scene text too long");
    int at = t->line;
    for (int i = 0; i < n; i++)
        t->line += t->buf[t->len + i] == '\n';
    t->len += (size_t)n;
    return at;
}

static void head(text_t *t)
{
    t->len = 0;
    t->line = 1;
    add(t, "LookAt 4 8 -2  4 0 1.5  0 1 0\nCamera \"perspective\" \"float fov\" [ 40 ]\n"
           "Film \"rgb\" \"integer xresolution\" [ 24 ] \"integer yresolution\" [ 16 ]\n"
           "Sampler \"independent\" \"integer pixelsamples\" [ 2 ]\n"
           "Integrator \"path\" \"integer maxdepth\" [ 3 ]\nWorldBegin\n"
           "LightSource \"distant\" \"point3 from\" [ 1 10 -2 ] \"point3 to\" [ 0 0 0 ] "
           "\"rgb L\" [ 3 3 3 ]\n");
}

static const char *TETRA = "\"point3 P\" [ 0 0 0  1 0 0  0 1 0  0 0 1 ] "
                           "\"integer indices\" [ 0 2 1  0 1 3  0 3 2  1 2 3 ]";

static char dir[256];

/* The whole scene: 10 PLY files (two of them in an instanced object), m1.ply named twice more
 * (in the object and in the world), 2 loopsubdiv shapes and 3 image textures, interleaved with
 * trianglemeshes. */
static void full_scene(text_t *t)
{
    head(t);
    for (int k = 0; k < 3; k++)
        add(t, "Texture \"t%d\" \"spectrum\" \"imagemap\" \"string filename\" \"tex%d.png\"\n", k,
            k);
    for (int m = 0; m < 8; m++) {
        add(t, "AttributeBegin\nMaterial \"diffuse\" \"texture reflectance\" \"t%d\"\n", m % 3);
        add(t, "Shape \"plymesh\" \"string filename\" \"m%d.ply\"\nAttributeEnd\n", m);
        if (m == 3)
            add(t, "Shape \"trianglemesh\" \"point3 P\" [ 0 0 0  9 0 0  9 0 2 ] "
                   "\"integer indices\" [ 0 1 2 ]\n");
        if (m == 5)
            add(t,
                "AttributeBegin\nTranslate 2 0.5 0\nShape \"loopsubdiv\" \"integer levels\" [ 3 ] "
                "%s\nAttributeEnd\n",
                TETRA);
    }
    add(t,
        "ObjectBegin \"o\"\nShape \"plymesh\" \"string filename\" \"m8.ply\"\n"
        "Shape \"loopsubdiv\" \"integer levels\" [ 2 ] %s\n"
        "Shape \"plymesh\" \"string filename\" \"m9.ply\"\n"
        "Shape \"plymesh\" \"string filename\" \"m1.ply\"\nObjectEnd\n",
        TETRA);
    add(t, "AttributeBegin\nTranslate 0 0 4\nShape \"plymesh\" \"string filename\" \"m1.ply\"\n"
           "AttributeEnd\n");
    add(t, "AttributeBegin\nTranslate 0 1 1\nObjectInstance \"o\"\nAttributeEnd\n"
           "AttributeBegin\nTranslate 5 1 1\nObjectInstance \"o\"\nAttributeEnd\n");
}

static const char *write_scene(const char *name, const text_t *t)
{
    const char *path = testutil_path_in(dir, name);
    testutil_write_text(path, t->buf, 0644);
    return path;
}

static int group_setup(void **state)
{
    (void)state;
    if (testutil_mkdtemp(dir, sizeof dir, "load_threads"))
        return -1;
    for (int m = 0; m < 10; m++) {
        char name[32];
        snprintf(name, sizeof name, "m%d.ply", m);
        write_ply(testutil_path_in(dir, name), 6 + 3 * m, m, 0.0, m % 2);
    }
    for (int k = 0; k < 3; k++) {
        char name[32];
        snprintf(name, sizeof name, "tex%d.png", k);
        write_png(testutil_path_in(dir, name), 48 + 16 * k, k);
    }
    testutil_write_text(testutil_path_in(dir, "bad.ply"),
                        "ply\nformat ascii 1.0\nelement vertex 3\n"
                        "property float x\nend_header\n1\n",
                        0644);
    testutil_write_text(testutil_path_in(dir, "bad.png"), "\x89PNG\r\n\x1a\nnot a png", 0644);
    return 0;
}

static int group_teardown(void **state)
{
    (void)state;
    testutil_rmtree(dir);
    return 0;
}

static scene_desc_t *parse(const char *path, int threads)
{
    err_t err = {{0}};
    scene_desc_t *d = pbrt_parse_file_opts(path, &(pbrt_parse_opts_t){.threads = threads}, &err);
    if (!d)
        fail_msg("parse with %d threads: %s", threads, err.msg);
    return d;
}

static void same_meshes(const scene_shape_t *a, const scene_shape_t *b, size_t n, const char *what)
{
    for (size_t i = 0; i < n; i++) {
        const scene_mesh_t *x = &a[i].mesh, *y = &b[i].mesh;
        if (a[i].type != b[i].type || x->nvertices != y->nvertices ||
            x->ntriangles != y->ntriangles)
            fail_msg("%s %zu: %zu/%zu vertices, %zu/%zu triangles", what, i, x->nvertices,
                     y->nvertices, x->ntriangles, y->ntriangles);
        if (a[i].type != SCENE_SHAPE_MESH)
            continue;
        size_t nv = x->nvertices, nt = x->ntriangles;
        assert_true(nt > 0);
        assert_memory_equal(x->P, y->P, 3 * nv * sizeof *x->P);
        assert_memory_equal(x->indices, y->indices, 3 * nt * sizeof *x->indices);
        assert_int_equal(!x->N, !y->N);
        assert_int_equal(!x->uv, !y->uv);
        if (x->N)
            assert_memory_equal(x->N, y->N, 3 * nv * sizeof *x->N);
        if (x->uv)
            assert_memory_equal(x->uv, y->uv, 2 * nv * sizeof *x->uv);
    }
}

static void test_same_meshes(void **state)
{
    (void)state;
    text_t t;
    full_scene(&t);
    const char *path = write_scene("full.pbrt", &t);
    scene_desc_t *one = parse(path, 1), *four = parse(path, 4), *all = parse(path, 0);
    /* 9 PLYs, 1 trianglemesh, 1 loopsubdiv in the world; 3 PLYs and 1 loopsubdiv in "o" */
    assert_int_equal(one->nshapes, 11);
    assert_int_equal(one->nobject_shapes, 4);
    for (scene_desc_t **d = (scene_desc_t *[]){four, all, NULL}; *d; d++) {
        assert_int_equal((*d)->nshapes, one->nshapes);
        assert_int_equal((*d)->nobject_shapes, one->nobject_shapes);
        same_meshes(one->shapes, (*d)->shapes, one->nshapes, "shape");
        same_meshes(one->object_shapes, (*d)->object_shapes, one->nobject_shapes, "object shape");
        assert_int_equal((*d)->nfiles, one->nfiles);
        for (size_t i = 0; i < one->nfiles; i++)
            assert_string_equal((*d)->files[i].relative, one->files[i].relative);
    }
    /* The meshes are the files': the first PLY's 6x6 grid of quads, as triangles. */
    assert_int_equal(one->shapes[0].mesh.ntriangles, 2 * 6 * 6);
    assert_int_equal(one->shapes[4].mesh.ntriangles, 1);             /* the trianglemesh */
    assert_int_equal(one->shapes[7].mesh.ntriangles, 4 * 64);        /* loopsubdiv, 3 levels */
    assert_int_equal(one->object_shapes[1].mesh.ntriangles, 4 * 16); /* 2 levels */
    /* m1.ply, named three times, is decoded once: the three shapes hold the same mesh. */
    const scene_mesh_t *m1 = &one->shapes[1].mesh;
    assert_int_equal(m1->ntriangles, 81 * 2);
    assert_ptr_equal(one->object_shapes[3].mesh.P, m1->P);
    assert_ptr_equal(one->shapes[10].mesh.indices, m1->indices);
    assert_ptr_equal(one->shapes[10].mesh.uv, m1->uv);
    scene_desc_destroy(&one);
    scene_desc_destroy(&four);
    scene_desc_destroy(&all);
}

static tilebuf_t *load_render(const char *path, int threads)
{
    err_t err = {{0}};
    scene_overrides_t ov = {.seed = -1, .threads = threads};
    scene_t *s = scene_load_file(path, &ov, &err);
    if (!s)
        fail_msg("load with %d threads: %s", threads, err.msg);
    const render_settings_t *rs = &s->settings;
    tilebuf_t *tb = tilebuf_new(0, 0, rs->xres, rs->yres, rs->grid.n, &err);
    if (!tb || render_tile(s, NULL, 0, 0, rs->xres, rs->yres, 0, (uint32_t)rs->spp, tb, NULL, &err))
        fail_msg("render: %s", err.msg);
    scene_destroy(&s);
    return tb;
}

static void test_same_image(void **state)
{
    (void)state;
    text_t t;
    full_scene(&t);
    const char *path = write_scene("image.pbrt", &t);
    tilebuf_t *a = load_render(path, 1), *b = load_render(path, 3);
    int nb = tilebuf_nbuckets(a), lit = 0;
    for (int y = 0; y < tilebuf_height(a); y++)
        for (int x = 0; x < tilebuf_width(a); x++) {
            for (int k = 0; k < nb; k++) {
                double u = tilebuf_sum(a, x, y, k), v = tilebuf_sum(b, x, y, k);
                if (memcmp(&u, &v, sizeof u))
                    fail_msg("pixel (%d, %d) bucket %d: %.17g with 1 thread, %.17g with 3", x, y, k,
                             u, v);
            }
            lit += tilebuf_luminance_sum(a, x, y) > 0.0;
        }
    /* The textured meshes fill much of the view (168 of its 384 pixels): the comparison is of
     * a real image. */
    if (lit < tilebuf_width(a) * tilebuf_height(a) / 3)
        fail_msg("only %d pixels lit", lit);
    tilebuf_destroy(&a);
    tilebuf_destroy(&b);
}

/* The load of path, refused with the same message for 1 and 4 threads, which names where. */
static void same_refusal(const char *path, const char *root, const scene_budget_t *b,
                         const char *where, const char *what)
{
    char first[sizeof(err_t)] = "";
    for (int threads = 1; threads <= 4; threads += 3) {
        err_t err = {{0}};
        scene_overrides_t ov = {.seed = -1, .threads = threads, .budget = b};
        scene_t *s = root ? scene_load_file_confined(path, root, &ov, &err)
                          : scene_load_file(path, &ov, &err);
        if (s)
            fail_msg("%s loaded with %d threads", path, threads);
        if (!strstr(err.msg, where) || !strstr(err.msg, what))
            fail_msg("%s, %d threads: expected '%s' and '%s' in: %s", path, threads, where, what,
                     err.msg);
        if (threads == 1)
            snprintf(first, sizeof first, "%s", err.msg);
        else
            assert_string_equal(err.msg, first);
    }
}

static void test_first_ply_failure(void **state)
{
    (void)state;
    text_t t;
    char where[64];
    /* Two bad files among good ones: the first is named. */
    head(&t);
    for (int m = 0; m < 5; m++)
        add(&t, "Shape \"plymesh\" \"string filename\" \"m%d.ply\"\n", m);
    int bad = add(&t, "Shape \"plymesh\" \"string filename\" \"bad.ply\"\n");
    add(&t, "Shape \"plymesh\" \"string filename\" \"m5.ply\"\n");
    add(&t, "Shape \"plymesh\" \"string filename\" \"bad.png\"\n");
    snprintf(where, sizeof where, "twobad.pbrt:%d:", bad);
    same_refusal(write_scene("twobad.pbrt", &t), NULL, NULL, where, "bad.ply");
    /* A bad file before a syntax error: the file, as when each PLY was read at its line. */
    head(&t);
    add(&t, "Shape \"plymesh\" \"string filename\" \"m0.ply\"\n");
    bad = add(&t, "Shape \"plymesh\" \"string filename\" \"bad.ply\"\n");
    add(&t, "Shape \"plymesh\" \"string filename\" \"m1.ply\"\nNotADirective\n");
    snprintf(where, sizeof where, "syntax.pbrt:%d:", bad);
    same_refusal(write_scene("syntax.pbrt", &t), NULL, NULL, where, "bad.ply");
    /* Good files before a syntax error: the syntax error. */
    head(&t);
    add(&t, "Shape \"plymesh\" \"string filename\" \"m0.ply\"\n");
    bad = add(&t, "NotADirective\n");
    snprintf(where, sizeof where, "syntax2.pbrt:%d:", bad);
    same_refusal(write_scene("syntax2.pbrt", &t), NULL, NULL, where, "NotADirective");
}

static void test_first_budget_failure(void **state)
{
    (void)state;
    text_t t;
    char where[64];
    /* m0..m4: 72, 162, 288, 450, 648 triangles; a budget of 900 is crossed at m3. */
    scene_budget_t b = {.triangles = 900};
    head(&t);
    int line[5];
    for (int m = 0; m < 5; m++)
        line[m] = add(&t, "Shape \"plymesh\" \"string filename\" \"m%d.ply\"\n", m);
    snprintf(where, sizeof where, "plys.pbrt:%d:", line[3]);
    same_refusal(write_scene("plys.pbrt", &t), dir, &b, where,
                 "450 triangles take the scene over 900");
    /* Crossed by a trianglemesh after queued PLYs (72 + 162 + 288 + 1 with a budget of 522). */
    b.triangles = 522;
    head(&t);
    for (int m = 0; m < 3; m++)
        add(&t, "Shape \"plymesh\" \"string filename\" \"m%d.ply\"\n", m);
    int tm = add(&t, "Shape \"trianglemesh\" \"point3 P\" [ 0 0 0  1 0 0  1 0 1 ] "
                     "\"integer indices\" [ 0 1 2 ]\n");
    snprintf(where, sizeof where, "tm.pbrt:%d:", tm);
    same_refusal(write_scene("tm.pbrt", &t), dir, &b, where, "this shape's 1 triangles");
    /* A loopsubdiv of 4 levels (1024 triangles) after queued PLYs (72 + 162): refused at its
     * line, before it is subdivided when it alone is over the budget (1000), after when the
     * PLYs' triangles take it over (1100); but at the PLY when the PLYs cross the budget
     * first (200). */
    head(&t);
    for (int m = 0; m < 2; m++)
        add(&t, "Shape \"plymesh\" \"string filename\" \"m%d.ply\"\n", m);
    int ls = add(&t, "Shape \"loopsubdiv\" \"integer levels\" [ 4 ] %s\n", TETRA);
    snprintf(where, sizeof where, "loop.pbrt:%d:", ls);
    b.triangles = 1000;
    same_refusal(write_scene("loop.pbrt", &t), dir, &b, where, "this shape's 1024 triangles");
    b.triangles = 1100;
    same_refusal(write_scene("loop.pbrt", &t), dir, &b, where, "this shape's 1024 triangles");
    b.triangles = 200;
    snprintf(where, sizeof where, "loop.pbrt:%d:", ls - 1);
    same_refusal(write_scene("loop.pbrt", &t), dir, &b, where, "this shape's 162 triangles");
    /* A file named three times counts three times (decoded once): 3 x 72 over 200. */
    head(&t);
    add(&t, "Shape \"plymesh\" \"string filename\" \"m0.ply\"\n");
    add(&t, "Shape \"plymesh\" \"string filename\" \"m0.ply\"\n");
    int third = add(&t, "Shape \"plymesh\" \"string filename\" \"m0.ply\"\n");
    snprintf(where, sizeof where, "thrice.pbrt:%d:", third);
    same_refusal(write_scene("thrice.pbrt", &t), dir, &b, where, "this shape's 72 triangles");
}

static void test_first_texture_failure(void **state)
{
    (void)state;
    text_t t;
    char where[64];
    head(&t);
    add(&t, "Texture \"a\" \"spectrum\" \"imagemap\" \"string filename\" \"tex0.png\"\n");
    int bad = add(&t, "Texture \"b\" \"spectrum\" \"imagemap\" \"string filename\" \"bad.png\"\n");
    add(&t, "Texture \"c\" \"spectrum\" \"imagemap\" \"string filename\" \"tex1.png\"\n");
    add(&t, "Texture \"d\" \"float\" \"imagemap\" \"string filename\" \"bad.png\"\n");
    add(&t, "Texture \"e\" \"spectrum\" \"imagemap\" \"string filename\" \"tex2.png\"\n");
    add(&t, "Shape \"sphere\"\n");
    snprintf(where, sizeof where, "badtex.pbrt:%d:", bad);
    same_refusal(write_scene("badtex.pbrt", &t), NULL, NULL, where, "texture \"b\"");
    /* 48^2 + 64^2 = 6400 texels, then 80^2: a budget of 10000 is crossed at the third. */
    scene_budget_t b = {.texels = 10000};
    head(&t);
    add(&t, "Texture \"a\" \"spectrum\" \"imagemap\" \"string filename\" \"tex0.png\"\n");
    add(&t, "Texture \"b\" \"float\" \"imagemap\" \"string filename\" \"tex1.png\"\n");
    int third =
        add(&t, "Texture \"c\" \"spectrum\" \"imagemap\" \"string filename\" \"tex2.png\"\n");
    add(&t, "Texture \"d\" \"spectrum\" \"imagemap\" \"string filename\" \"bad.png\"\n");
    add(&t, "Shape \"sphere\"\n");
    snprintf(where, sizeof where, "texels.pbrt:%d:", third);
    same_refusal(write_scene("texels.pbrt", &t), dir, &b, where, "--max-texels");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_same_meshes),           cmocka_unit_test(test_same_image),
        cmocka_unit_test(test_first_ply_failure),     cmocka_unit_test(test_first_budget_failure),
        cmocka_unit_test(test_first_texture_failure),
    };
    return cmocka_run_group_tests(tests, group_setup, group_teardown);
}
