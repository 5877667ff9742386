/* Shapes and files (issue 15): the PLY reader agrees with itself across ascii and both binary
 * orders and reads the files assimp misread; gzip round trips and refuses bombs; loopsubdiv
 * has Loop's vertex counts and limit masks; cylinder, partial sphere and bilinear patch have
 * their analytic areas and hits; the corpus killeroos load. Runs in tests/. */
#define _XOPEN_SOURCE 700

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
#include <zlib.h>

#include "files_testutil.h"
#include "geometry.h"
#include "gzip_data.h"
#include "loopsubdiv.h"
#include "mesh_import.h"
#include "pbrt_parser.h"
#include "scene.h"
#include "scene_load.h"
#include "shape_tess.h"
#include "warnings.h"

static const double PI = 3.14159265358979323846;

static double mesh_area(const mesh_data_t *m)
{
    double a = 0;
    for (size_t t = 0; t < m->ntriangles; t++) {
        const double *p0 = &m->P[3 * m->indices[3 * t]], *p1 = &m->P[3 * m->indices[3 * t + 1]],
                     *p2 = &m->P[3 * m->indices[3 * t + 2]];
        double e1[3], e2[3];
        for (int k = 0; k < 3; k++)
            e1[k] = p1[k] - p0[k], e2[k] = p2[k] - p0[k];
        double c[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                       e1[0] * e2[1] - e1[1] * e2[0]};
        a += 0.5 * sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    }
    return a;
}

/* ---- PLY ---------------------------------------------------------------------------- */

/* One mesh written three ways. Vertex properties in an unusual order and of mixed types
 * (z double, u float, x float, an extra uchar, y int16 (integer-valued), v double, then
 * nx ny nz as float); faces: a quad, a triangle and a pentagon, with a uchar count and uint
 * (little), a ushort count and int (big), and an extra "face_indices" int after the list.
 * All values are exact in every type. */
#define NV 6
static const double VX[NV] = {0, 1, 1, 0, 0.5, 2}, VY[NV] = {0, 0, 1, 1, 2, 0},
                    VZ[NV] = {0, 0, 0.25, 0, -1, 3}, VU[NV] = {0, 1, 1, 0, 0.5, 0.75},
                    VV[NV] = {0, 0, 1, 1, 0.25, 0.5};
static const int FACES[][6] = {{4, 0, 1, 2, 3}, {3, 1, 5, 2}, {5, 0, 1, 5, 4, 3}};

typedef struct buf {
    unsigned char d[4096];
    size_t n;
} buf_t;

static void put(buf_t *b, const void *p, size_t n, int big)
{
    for (size_t i = 0; i < n; i++)
        b->d[b->n + i] = ((const unsigned char *)p)[big ? n - 1 - i : i];
    b->n += n;
}

static void put_text(buf_t *b, const char *s)
{
    memcpy(b->d + b->n, s, strlen(s));
    b->n += strlen(s);
}

static const char *HEADER_PROPS =
    "element vertex 6\nproperty double z\nproperty float u\ncomment between properties\n"
    "property float x\nproperty uchar red\nproperty int16 y\nproperty double v\n"
    "property float nx\nproperty float ny\nproperty float nz\nelement face 3\n";

static void write_ply(buf_t *b, int format) /* 0 ascii, 1 little, 2 big */
{
    b->n = 0;
    static const char *FMT[] = {"ascii", "binary_little_endian", "binary_big_endian"};
    char h[1024];
    snprintf(h, sizeof h, "ply\nformat %s 1.0\nobj_info three ways\n%s%s", FMT[format],
             HEADER_PROPS,
             format == 2 ? "property list ushort int vertex_indices\nproperty int face_indices\n"
                         : "property list uchar uint vertex_indices\nproperty int face_indices\n");
    put_text(b, h);
    put_text(b, "end_header\n");
    int big = format == 2;
    for (int v = 0; v < NV; v++) {
        float u = (float)VU[v], x = (float)VX[v], n[3] = {0, 0, 1};
        unsigned char red = 200;
        int16_t y = (int16_t)VY[v];
        if (format == 0) {
            char line[256];
            snprintf(line, sizeof line, "%g %g %g %d %d %g 0 0 1\n", VZ[v], VU[v], VX[v], red, y,
                     VV[v]);
            put_text(b, line);
            continue;
        }
        put(b, &VZ[v], 8, big);
        put(b, &u, 4, big);
        put(b, &x, 4, big);
        put(b, &red, 1, big);
        put(b, &y, 2, big);
        put(b, &VV[v], 8, big);
        for (int k = 0; k < 3; k++)
            put(b, &n[k], 4, big);
    }
    for (int f = 0; f < 3; f++) {
        int n = FACES[f][0];
        int32_t fi = -7;
        if (format == 0) {
            char line[128];
            int o = snprintf(line, sizeof line, "%d", n);
            for (int k = 1; k <= n; k++)
                o += snprintf(line + o, sizeof line - (size_t)o, " %d", FACES[f][k]);
            snprintf(line + o, sizeof line - (size_t)o, " -7\n");
            put_text(b, line);
            continue;
        }
        if (big) {
            uint16_t c = (uint16_t)n;
            put(b, &c, 2, 1);
        } else {
            uint8_t c = (uint8_t)n;
            put(b, &c, 1, 0);
        }
        for (int k = 1; k <= n; k++) {
            uint32_t i = (uint32_t)FACES[f][k];
            put(b, &i, 4, big);
        }
        put(b, &fi, 4, big);
    }
}

static void check_mesh(const mesh_data_t *m, const char *what)
{
    if (m->nvertices != NV || m->ntriangles != 2 + 1 + 3)
        fail_msg("%s: %zu vertices, %zu triangles", what, m->nvertices, m->ntriangles);
    assert_non_null(m->N);
    assert_non_null(m->uv);
    for (int v = 0; v < NV; v++) {
        assert_true(m->P[3 * v] == VX[v] && m->P[3 * v + 1] == VY[v] && m->P[3 * v + 2] == VZ[v]);
        assert_true(m->uv[2 * v] == VU[v] && m->uv[2 * v + 1] == VV[v]);
        assert_true(m->N[3 * v + 2] == 1.0);
    }
    /* The quad 0 1 2 3 as (0 1 2) (0 2 3), the triangle as it is, the pentagon 0 1 5 4 3 as
     * the fan (0 1 5) (0 5 4) (0 4 3). */
    static const uint32_t WANT[18] = {0, 1, 2, 0, 2, 3, 1, 5, 2, 0, 1, 5, 0, 5, 4, 0, 4, 3};
    for (int i = 0; i < 18; i++)
        if (m->indices[i] != WANT[i])
            fail_msg("%s: index %d is %u, expected %u", what, i, m->indices[i], WANT[i]);
}

static void test_ply_formats_agree(void **state)
{
    (void)state;
    static const char *NAMES[] = {"ascii.ply", "little.ply", "big.ply"};
    for (int f = 0; f < 3; f++) {
        buf_t b;
        write_ply(&b, f);
        mesh_data_t m;
        err_t err = {{0}};
        if (mesh_import_ply_memory(b.d, b.n, NAMES[f], &m, &err) != 0)
            fail_msg("%s refused: %s", NAMES[f], err.msg);
        check_mesh(&m, NAMES[f]);
        mesh_data_free(&m);
        /* Cut inside the last face: the message names the file, the face and the truncation. */
        if (f == 1) {
            assert_int_equal(mesh_import_ply_memory(b.d, b.n - 9, NAMES[f], &m, &err), -1);
            assert_string_equal(err.msg, "\"little.ply\": face 2 has a list of 5 values, more "
                                         "than the 15 bytes left (truncated)");
        }
        if (f == 2) {
            /* An index past the vertices: the third face's second index 1 becomes 6. */
            b.d[b.n - 4 - 16 - 1] = 6;
            assert_int_equal(mesh_import_ply_memory(b.d, b.n, NAMES[f], &m, &err), -1);
            assert_string_equal(err.msg, "\"big.ply\": face 2 uses vertex 6 but there are only 6");
        }
    }
    /* A bad header line names its number. */
    const char *bad = "ply\nformat ascii 1.0\nelement vertex 3\nproperty flot x\n";
    mesh_data_t m;
    err_t err = {{0}};
    assert_int_equal(mesh_import_ply_memory(bad, strlen(bad), "h.ply", &m, &err), -1);
    assert_string_equal(err.msg, "\"h.ply\": line 4 must be \"property <type> <name>\" or "
                                 "\"property list <integer type> <type> <name>\"");
}

/* assimp 5.2.5 (Debian 12; its issue #5341) misread a binary PLY whose first body byte is
 * 0x0a ('\n'), taking it for the end of the header line. Here the first vertex's x is the
 * float with bits 0x3f80000a (1 + 10 * 2^-23), little-endian: bytes 0a 00 80 3f. */
static void test_ply_first_byte_newline(void **state)
{
    (void)state;
    buf_t b = {.n = 0};
    put_text(&b, "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
                 "property float y\nproperty float z\nelement face 1\n"
                 "property list uchar int vertex_indices\nend_header\n");
    size_t body = b.n;
    uint32_t bits = 0x3f80000a;
    float x0;
    memcpy(&x0, &bits, 4);
    const float v[9] = {x0, 0, 0, 0, 1, 0, 0, 0, 1};
    for (int i = 0; i < 9; i++)
        put(&b, &v[i], 4, 0);
    const unsigned char face[13] = {3, 0, 0, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0};
    memcpy(b.d + b.n, face, sizeof face);
    b.n += sizeof face;
    assert_int_equal(b.d[body], 0x0a);
    mesh_data_t m;
    err_t err = {{0}};
    if (mesh_import_ply_memory(b.d, b.n, "newline.ply", &m, &err) != 0)
        fail_msg("refused: %s", err.msg);
    assert_int_equal(m.nvertices, 3);
    assert_int_equal(m.ntriangles, 1);
    assert_true(m.P[0] == 1.0 + 10.0 / 8388608.0);
    assert_true(m.P[7] == 0.0 && m.P[8] == 1.0);
    mesh_data_free(&m);

    /* The fuzzed header with odd elements that made assimp abort is a valid PLY: its vertex
     * element is the second "vertex"-like one, named exactly "vertex" (4 vertices, 1 face). */
    if (mesh_import_ply("data/scenes/meshes/fuzz_odd_elements.ply", &m, &err) != 0)
        fail_msg("refused: %s", err.msg);
    assert_int_equal(m.nvertices, 4);
    mesh_data_free(&m);
}

/* ---- gzip --------------------------------------------------------------------------- */

static void write_gz(const char *path, const void *data, size_t n)
{
    gzFile g = gzopen(path, "wb9");
    assert_non_null(g);
    assert_int_equal(gzwrite(g, data, (unsigned)n), (int)n);
    assert_int_equal(gzclose(g), Z_OK);
}

static void test_gzip(void **state)
{
    (void)state;
    char dir[256];
    assert_int_equal(testutil_mkdtemp(dir, sizeof dir, "shapes-gz"), 0);
    char ply[300], inc[300], main_path[300];
    snprintf(ply, sizeof ply, "%s/m.ply.gz", dir);
    snprintf(inc, sizeof inc, "%s/geo.pbrt.gz", dir);
    snprintf(main_path, sizeof main_path, "%s/scene.pbrt", dir);
    buf_t b;
    write_ply(&b, 1);
    write_gz(ply, b.d, b.n);
    mesh_data_t m;
    err_t err = {{0}};
    if (mesh_import_ply(ply, &m, &err) != 0)
        fail_msg("%s", err.msg);
    check_mesh(&m, "m.ply.gz");
    mesh_data_free(&m);

    const char *geo = "Shape \"plymesh\" \"string filename\" \"m.ply.gz\"\n";
    write_gz(inc, geo, strlen(geo));
    testutil_write_text(main_path, "WorldBegin\nInclude \"geo.pbrt.gz\"\n", 0644);
    for (int confined = 0; confined < 2; confined++) {
        scene_desc_t *s = confined ? pbrt_parse_file_confined(main_path, dir, NULL, &err)
                                   : pbrt_parse_file(main_path, &err);
        if (!s)
            fail_msg("%s", err.msg);
        assert_int_equal(s->nshapes, 1);
        assert_int_equal(s->shapes[0].mesh.ntriangles, 6);
        /* Both compressed files are in the list a farm bundle carries. */
        int found = 0;
        for (size_t i = 0; i < s->nfiles; i++)
            found += !strcmp(s->files[i].relative, "geo.pbrt.gz") ||
                     !strcmp(s->files[i].relative, "m.ply.gz");
        assert_int_equal(found, 2);
        scene_desc_destroy(&s);
    }

    /* A bomb: 8 MiB of zeros in about 8 KiB, against a 1 MiB limit. */
    size_t big = (size_t)8 << 20;
    char *zeros = calloc(big, 1);
    assert_non_null(zeros);
    char bomb[300];
    snprintf(bomb, sizeof bomb, "%s/bomb.gz", dir);
    write_gz(bomb, zeros, big);
    free(zeros);
    size_t n;
    char *gz = testutil_slurp(bomb, &n);
    assert_true(n < 64 << 10);
    char *out;
    size_t out_len;
    assert_int_equal(gzip_data_inflate(gz, n, (size_t)1 << 20, "bomb.gz", &out, &out_len, &err), -1);
    assert_string_equal(err.msg, "\"bomb.gz\" inflates to more than 1048576 bytes, the most a "
                                 "file may hold (a gzip bomb?)");
    assert_null(out);
    assert_int_equal(gzip_data_inflate(gz, n, big, "bomb.gz", &out, &out_len, &err), 0);
    assert_int_equal(out_len, big);
    free(out);
    /* Truncated compressed data. */
    assert_int_equal(gzip_data_inflate(gz, n / 2, big, "half.gz", &out, &out_len, &err), -1);
    assert_string_equal(err.msg, "\"half.gz\" is not a valid gzip file: it ends before its "
                                 "compressed data does (truncated)");
    free(gz);
    testutil_rmtree(dir);
}

/* ---- loopsubdiv ---------------------------------------------------------------------- */

static void test_loop_counts(void **state)
{
    (void)state;
    /* Tetrahedron (V 4, E 6, F 4) and octahedron (6, 12, 8), consistently oriented. Each level
     * adds a vertex per edge and splits each face in four: V' = V + E, E' = 2E + 3F, F' = 4F. */
    static const double TP[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    static const uint32_t TI[12] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
    static const double OP[18] = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
    static const uint32_t OI[24] = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4,
                                    2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
    const struct {
        const double *P;
        size_t nv;
        const uint32_t *I;
        size_t nt, ne;
    } M[2] = {{TP, 4, TI, 4, 6}, {OP, 6, OI, 8, 12}};
    for (int k = 0; k < 2; k++) {
        size_t V = M[k].nv, E = M[k].ne, F = M[k].nt;
        for (int level = 0; level <= 4; level++) {
            mesh_data_t m;
            err_t err = {{0}};
            if (loopsubdiv_mesh(M[k].P, M[k].nv, M[k].I, M[k].nt, level, &m, &err) != 0)
                fail_msg("%s", err.msg);
            assert_int_equal(m.nvertices, V);
            assert_int_equal(m.ntriangles, F);
            mesh_data_free(&m);
            V += E;
            E = 2 * E + 3 * F;
            F *= 4;
        }
    }
    /* The octahedron's vertices have valence 4: beta = 3 / (8 * 4) = 3/32, the limit weight
     * gamma = 1 / (4 + 3 / (8 beta)) = 1/8, so (1, 0, 0) with its ring (0, +-1, 0) (0, 0, +-1)
     * goes to (1 - 4/8) (1, 0, 0) = (0.5, 0, 0); its normal lies along x. */
    mesh_data_t m;
    err_t err = {{0}};
    assert_int_equal(loopsubdiv_mesh(OP, 6, OI, 8, 0, &m, &err), 0);
    assert_true(fabs(m.P[0] - 0.5) < 1e-12 && fabs(m.P[1]) < 1e-12 && fabs(m.P[2]) < 1e-12);
    double nl = sqrt(m.N[0] * m.N[0] + m.N[1] * m.N[1] + m.N[2] * m.N[2]);
    assert_true(fabs(fabs(m.N[0]) / nl - 1) < 1e-12);
    mesh_data_free(&m);

    /* A non-manifold input is refused by name. */
    static const uint32_t BAD[9] = {0, 1, 2, 0, 1, 3, 1, 0, 2};
    assert_int_equal(loopsubdiv_mesh(TP, 4, BAD, 3, 1, &m, &err), -1);
    assert_string_equal(err.msg, "triangles 0 and 1 run along the edge from vertex 0 to 1 in the "
                                 "same direction: loopsubdiv needs consistently oriented "
                                 "triangles");
}

/* A regular valence-6 interior vertex: the centre (0, 0, h) of a hexagonal fan whose ring
 * lies at z = 0. Loop's limit mask there is 1/2 for the vertex and 1/12 for each neighbour
 * (gamma = 1 / (6 + 3 / (8 / 16)) = 1/12), so its limit is (0, 0, h/2) -- at every level,
 * since subdivision moves control points but not limit points: one level gives the centre
 * 5h/8 and its new neighbours 3h/8, and 5h/16 + 6 (3h/8) / 12 = h/2. The normal is along z. */
static void test_loop_regular_limit(void **state)
{
    (void)state;
    const double h = 0.8;
    double P[21] = {0, 0, h};
    for (int i = 0; i < 6; i++) {
        P[3 + 3 * i] = cos(PI / 3 * i);
        P[3 + 3 * i + 1] = sin(PI / 3 * i);
        P[3 + 3 * i + 2] = 0;
    }
    uint32_t I[18];
    for (uint32_t i = 0; i < 6; i++)
        I[3 * i] = 0, I[3 * i + 1] = 1 + i, I[3 * i + 2] = 1 + (i + 1) % 6;
    for (int level = 0; level <= 3; level++) {
        mesh_data_t m;
        err_t err = {{0}};
        if (loopsubdiv_mesh(P, 7, I, 6, level, &m, &err) != 0)
            fail_msg("%s", err.msg);
        /* the centre keeps index 0 (even vertices keep their numbers) */
        if (fabs(m.P[2] - h / 2) > 1e-12 || fabs(m.P[0]) > 1e-12 || fabs(m.P[1]) > 1e-12)
            fail_msg("level %d: centre at (%g %g %g), expected (0 0 %g)", level, m.P[0], m.P[1],
                     m.P[2], h / 2);
        double nl = sqrt(m.N[0] * m.N[0] + m.N[1] * m.N[1] + m.N[2] * m.N[2]);
        assert_true(nl > 0 && fabs(fabs(m.N[2]) / nl - 1) < 1e-12);
        /* Boundary ring vertices: the boundary limit mask 3/5 itself + 1/5 each boundary
         * neighbour; at level 0 ring vertex (1, 0, 0) goes to 3/5 (1,0,0) + 1/5 ((c, s, 0) +
         * (c, -s, 0)) with c = cos 60 = 1/2: x = 3/5 + 1/5. */
        if (level == 0)
            assert_true(fabs(m.P[3] - 0.8) < 1e-12 && fabs(m.P[5]) < 1e-12);
        mesh_data_free(&m);
    }
}

/* ---- quadrics and patches, through the parser and the loader ------------------------- */

static scene_desc_t *parse(const char *text)
{
    err_t err = {{0}};
    scene_desc_t *s = pbrt_parse_string(text, strlen(text), "t.pbrt", &err);
    if (!s)
        fail_msg("did not parse: %s\n%s", err.msg, text);
    return s;
}

static double shape_area(const scene_shape_t *s)
{
    mesh_data_t m = {.nvertices = s->mesh.nvertices, .P = (double *)s->mesh.P,
                     .ntriangles = s->mesh.ntriangles, .indices = (uint32_t *)s->mesh.indices};
    return mesh_area(&m);
}

static void test_cylinder_and_sphere(void **state)
{
    (void)state;
    scene_desc_t *d = parse("WorldBegin\n"
                            "Shape \"cylinder\" \"float radius\" 2 \"float zmin\" -1 \"float zmax\" 2\n"
                            "Shape \"cylinder\" \"float phimax\" 90\n"
                            "Shape \"cylinder\"\n"
                            "AttributeBegin\nTranslate 10 0 0\n"
                            "Shape \"sphere\" \"float radius\" 1 \"float zmin\" 0\nAttributeEnd\n");
    /* Lateral areas phimax r (zmax - zmin): 2 pi 2 3 = 12 pi, (pi/2) 1 2 = pi, 4 pi; the upper half
     * sphere 2 pi r^2. A polygon of n segments a turn falls short by about (pi/n)^2 / 6:
     * 6.3e-6 around (512), and for the half sphere also 2.5e-5 along its meridian (128 for
     * 90 degrees). */
    const double want[4] = {12 * PI, PI, 4 * PI, 2 * PI};
    for (int i = 0; i < 4; i++)
        if (fabs(shape_area(&d->shapes[i]) / want[i] - 1) > 4e-5)
            fail_msg("shape %d: area %.8g, expected %.8g", i, shape_area(&d->shapes[i]), want[i]);
    err_t err = {{0}};
    scene_t *s = scene_load(d, NULL, &err);
    if (!s)
        fail_msg("%s", err.msg);
    hit_t h;
    /* From (5, 0, 0.5) along -x: the r = 2 cylinder at x = 2 (within its chord's sagitta
     * r (1 - cos(pi / 512)) = 3.8e-5), normal +x; the unit one lies inside it. */
    assert_int_equal(geometry_intersect(s->geometry, vec3_make(5, 0, 0.5), vec3_make(-1, 0, 0), 0,
                                        INFINITY, &h), 1);
    assert_true(fabs(h.t - 3) < 4e-5);
    assert_true(h.ng.x > 0.999);
    /* Along +z from below the first cylinder's reach: the ray (0.5, 0.5) inside misses every
     * wall; at (10, 0, -5) upward, the half sphere (z >= 0) is hit from inside at its top,
     * z = 1, not at z = -1 where it is cut away. */
    assert_int_equal(geometry_intersect(s->geometry, vec3_make(10.1, 0.05, -5), vec3_make(0, 0, 1),
                                        0, INFINITY, &h), 1);
    assert_true(fabs(h.p.z - sqrt(1 - 0.1 * 0.1 - 0.05 * 0.05)) < 1e-4);
    scene_destroy(&s);
    scene_desc_destroy(&d);
}

static void test_bilinear(void **state)
{
    (void)state;
    scene_desc_t *d = parse(
        "WorldBegin\n"
        "Shape \"bilinearmesh\" \"point3 P\" [0 0 0 2 0 0 0 3 0 2 3 0] \"integer indices\" [0 1 2 3]\n"
        "Shape \"bilinearmesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0 1 1 1]\n"
        "Shape \"bilinearmesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0 1 1 0] \"float displacement\" 0.1\n");
    /* The planar 2 x 3 patch: exactly two triangles of area 6, with its own (u, v) at the
     * corners (p11 has (1, 1)). */
    const scene_mesh_t *m = &d->shapes[0].mesh;
    assert_int_equal(m->ntriangles, 2);
    assert_true(fabs(shape_area(&d->shapes[0]) - 6) < 1e-12);
    assert_non_null(m->uv);
    assert_true(m->uv[6] == 1 && m->uv[7] == 1);
    /* The twisted patch z = u v over the unit square: area = integral of sqrt(1 + u^2 + v^2),
     * 1.28079 by a 400 x 400 midpoint rule here; the grid is within 1e-3 of it. */
    double ref = 0;
    for (int i = 0; i < 400; i++)
        for (int j = 0; j < 400; j++) {
            double u = (i + 0.5) / 400, v = (j + 0.5) / 400;
            ref += sqrt(1 + u * u + v * v) / (400.0 * 400.0);
        }
    assert_true(fabs(ref - 1.28079) < 1e-4);
    assert_true(d->shapes[1].mesh.ntriangles > 2);
    assert_true(fabs(shape_area(&d->shapes[1]) / ref - 1) < 1e-3);
    /* displacement: accepted, not simulated, said where */
    assert_int_equal(warnings_count(d->warnings), 1);
    assert_string_equal(warnings_at(d->warnings, 0),
                        "t.pbrt:4:59: Shape \"bilinearmesh\": \"displacement\" is not simulated "
                        "(the surface is rendered undisplaced)");
    scene_desc_destroy(&d);
}

/* ---- corpus -------------------------------------------------------------------------- */

static void test_corpus_killeroos(void **state)
{
    (void)state;
    static const char *SCENES[] = {"../../shared/pbrt-scenes/killeroos/killeroo-simple.pbrt",
                                   "../../shared/pbrt-scenes/killeroos/killeroo-gold.pbrt"};
    char path[512];
    for (size_t i = 0; i < 2; i++) {
        snprintf(path, sizeof path, "%s", SCENES[i]);
        if (access(path, R_OK) != 0) {
            print_message("skipped: %s is absent (the corpus lives in ../shared)\n", path);
            continue;
        }
        err_t err = {{0}};
        scene_desc_t *d = pbrt_parse_file(path, &err);
        if (!d)
            fail_msg("%s: %s", path, err.msg);
        /* killeroo-simple: two killeroos of 8316 control triangles at level 1 (4 each);
         * killeroo-gold: one at level 3 (64 each). */
        size_t want = i == 0 ? 2 * 8316 * 4 : 8316 * 64;
        assert_true(scene_desc_triangle_count(d) >= want);
        scene_t *s = scene_load(d, NULL, &err);
        if (!s)
            fail_msg("%s: %s", path, err.msg);
        scene_destroy(&s);
        scene_desc_destroy(&d);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ply_formats_agree), cmocka_unit_test(test_ply_first_byte_newline),
        cmocka_unit_test(test_gzip),              cmocka_unit_test(test_loop_counts),
        cmocka_unit_test(test_loop_regular_limit), cmocka_unit_test(test_cylinder_and_sphere),
        cmocka_unit_test(test_bilinear),          cmocka_unit_test(test_corpus_killeroos),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
