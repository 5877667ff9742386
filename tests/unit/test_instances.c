/* instances: ObjectInstance as Embree instances. Instanced spheres and meshes are hit where the
 * geometry says, with world-space normals that agree with the flattened placement (the shapes
 * transformed into the world one by one), also under an instance transform that swaps
 * handedness; hits resolve to the right shape, uv and shading normal; a thousand instances of a
 * thousand-triangle mesh cost about one copy of it; and a scene renders the same with
 * instances as flattened, within noise. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geometry.h"
#include "numeric_testutil.h"
#include "pbrt_parser.h"
#include "render.h"
#include "scene.h"
#include "scene_builders.h"
#include "scene_load.h"

static void assert_vec_near(vec3_t a, vec3_t b, double tol, const char *what)
{
    if (!(fabs(a.x - b.x) <= tol && fabs(a.y - b.y) <= tol && fabs(a.z - b.z) <= tol))
        fail_msg("%s: (%.9g, %.9g, %.9g) differs from (%.9g, %.9g, %.9g) by more than %g", what,
                 a.x, a.y, a.z, b.x, b.y, b.z, tol);
}

/* A unit square in the object's z = 0 plane at x in [1, 2], y in [0, 1], wound so that pbrt's
 * normal (p0 - p2) x (p1 - p2) is +z. */
static const double SQUARE_P[12] = {1, 0, 0, 2, 0, 0, 2, 1, 0, 1, 1, 0};
static const uint32_t SQUARE_I[6] = {0, 1, 2, 0, 2, 3};

/* Hand-computed hits: a unit sphere at the object's origin and the square, placed by a
 * translation and by a mirror in x (which swaps handedness). Triangles keep their
 * orientation under the mirror (their normal maps as a normal); the sphere's normal flips, as
 * pbrt-v4 flips a quadric whose transform swaps handedness (and as the flattened placement
 * gives). */
static void test_instanced_hits_and_normals(void **state)
{
    (void)state;
    err_t err;
    geometry_t *g = geometry_new(1, &err);
    assert_non_null(g);
    int obj = geometry_object_new(g, &err);
    assert_int_equal(obj, 0);
    transform_t id = transform_identity();
    assert_int_equal(geometry_object_add_sphere(g, obj, &id, 1.0, 10, 0, &err), 0);
    assert_int_equal(geometry_object_add_mesh(g, obj, SQUARE_P, 4, SQUARE_I, 2, 11, 0, &err), 0);
    transform_t a = transform_translate(vec3_make(5, 0, 0));
    transform_t b = transform_compose(transform_translate(vec3_make(-5, 0, 0)), transform_scale(-1, 1, 1));
    assert_int_equal(geometry_add_instance(g, obj, &a, 100, &err), 0);
    assert_int_equal(geometry_add_instance(g, obj, &b, 101, &err), 0);
    /* The object is committed with its first instance: no more shapes. */
    assert_int_equal(geometry_object_add_sphere(g, obj, &id, 1.0, 12, 0, &err), -1);
    assert_non_null(strstr(err.msg, "after it was instanced"));
    assert_int_equal(geometry_commit(g, &err), 0);

    hit_t h;
    /* Sphere of instance a, seen from -z: t = 4, normal -z (outward). */
    assert_int_equal(geometry_intersect(g, vec3_make(5, 0, -5), vec3_make(0, 0, 1), 0, INFINITY, &h), 1);
    assert_int_equal(h.shape, 10);
    assert_int_equal(h.instance, 100);
    testutil_assert_near(h.t, 4.0, 1e-9);
    assert_vec_near(h.p, vec3_make(5, 0, -1), 1e-9, "p");
    assert_vec_near(h.ng, vec3_make(0, 0, -1), 1e-12, "ng");
    /* pbrt-v4's sphere (u, v) at the point (0, 0, -1) of the sphere: v = 0 at z = -r. */
    testutil_assert_near(h.v, 0.0, 1e-9);
    /* Off-centre: the point (0.6, 0, -0.8) of the sphere, normal (0.6, 0, -0.8). */
    assert_int_equal(geometry_intersect(g, vec3_make(5.6, 0, -5), vec3_make(0, 0, 1), 0, INFINITY, &h), 1);
    testutil_assert_near(h.t, 4.2, 1e-9);
    assert_vec_near(h.ng, vec3_make(0.6, 0, -0.8), 1e-9, "ng");
    /* Sphere of the mirrored instance b: same point, normal flipped. */
    assert_int_equal(geometry_intersect(g, vec3_make(-5.6, 0, -5), vec3_make(0, 0, 1), 0, INFINITY, &h), 1);
    assert_int_equal(h.instance, 101);
    testutil_assert_near(h.t, 4.2, 1e-9);
    assert_vec_near(h.p, vec3_make(-5.6, 0, -0.8), 1e-9, "p");
    assert_vec_near(h.ng, vec3_make(0.6, 0, 0.8), 1e-9, "ng");
    /* Square of instance a at x in [6, 7], from +z: normal +z; barycentrics of (6.75, 0.5):
     * triangle 0 (p0 p1 p2) covers y <= x - 6. */
    assert_int_equal(geometry_intersect(g, vec3_make(6.75, 0.5, 3), vec3_make(0, 0, -1), 0, INFINITY, &h), 1);
    assert_int_equal(h.shape, 11);
    assert_int_equal(h.prim, 0);
    assert_int_equal(h.instance, 100);
    testutil_assert_near(h.t, 3.0, 1e-6);
    assert_vec_near(h.ng, vec3_make(0, 0, 1), 1e-9, "ng");
    /* (6.75, 0.5) = (1 - u - v) (6, 0) + u (7, 0) + v (7, 1): v = 0.5, u = 0.25. */
    testutil_assert_near(h.u, 0.25, 1e-6);
    testutil_assert_near(h.v, 0.5, 1e-6);
    /* Square of the mirrored instance at x in [-7, -6]: still +z. */
    assert_int_equal(geometry_intersect(g, vec3_make(-6.5, 0.5, 3), vec3_make(0, 0, -1), 0, INFINITY, &h), 1);
    assert_int_equal(h.shape, 11);
    assert_int_equal(h.instance, 101);
    assert_vec_near(h.ng, vec3_make(0, 0, 1), 1e-9, "ng");
    /* Between the instances: nothing; occlusion sees instances too. */
    assert_int_equal(geometry_intersect(g, vec3_make(0, 0, -5), vec3_make(0, 0, 1), 0, INFINITY, &h), 0);
    assert_int_equal(geometry_occluded(g, vec3_make(5, 0, -5), vec3_make(0, 0, 1), 0, 3.9), 0);
    assert_int_equal(geometry_occluded(g, vec3_make(5, 0, -5), vec3_make(0, 0, 1), 0, 4.1), 1);
    vec3_t lo, hi;
    geometry_bounds(g, &lo, &hi);
    assert_true(lo.x <= -7 && hi.x >= 7 && lo.z <= -1 && hi.z >= 1);
    geometry_destroy(&g);
}

/* A transform that rotates, scales non-uniformly, mirrors and translates. */
static transform_t messy_transform(void)
{
    transform_t r;
    assert_int_equal(transform_rotate(37, vec3_make(1, 2, 0.5), &r, NULL), 0);
    transform_t t = transform_compose(transform_translate(vec3_make(0.3, -0.2, 0.7)),
                                      transform_compose(r, transform_scale(-1.3, 0.8, 1.1)));
    assert_true(transform_swaps_handedness(&t));
    return t;
}

/* The same shapes placed once by an instance and once flattened (each shape's transform
 * composed with the instance's, flip = ReverseOrientation XOR the composed handedness swap,
 * as the loader did before instancing): every ray gets the same hit. */
static void test_instance_equals_flattened(void **state)
{
    (void)state;
    err_t err;
    transform_t m = messy_transform();
    transform_t sphere_t = transform_compose(transform_translate(vec3_make(0, 0, 1)), transform_scale(1, 1, 0.5));
    transform_t disk_t = transform_translate(vec3_make(0, 0, -1));
    int mflip = transform_swaps_handedness(&m);

    geometry_t *gi = geometry_new(1, &err), *gf = geometry_new(1, &err);
    int obj = geometry_object_new(gi, &err);
    assert_int_equal(geometry_object_add_sphere(gi, obj, &sphere_t, 0.7, 1, 0, &err), 0);
    assert_int_equal(geometry_object_add_disk(gi, obj, &disk_t, 1.5, 0.25, 2, 1, &err), 0);
    assert_int_equal(geometry_object_add_mesh(gi, obj, SQUARE_P, 4, SQUARE_I, 2, 3, 1, &err), 0);
    assert_int_equal(geometry_add_instance(gi, obj, &m, 0, &err), 0);
    assert_int_equal(geometry_commit(gi, &err), 0);

    transform_t fs = transform_compose(m, sphere_t), fd = transform_compose(m, disk_t);
    assert_int_equal(geometry_add_sphere(gf, &fs, 0.7, 1, 0 ^ mflip, &err), 0);
    assert_int_equal(geometry_add_disk(gf, &fd, 1.5, 0.25, 2, 1 ^ mflip, &err), 0);
    double P[12];
    for (int v = 0; v < 4; v++) {
        vec3_t p = transform_point(&m, vec3_make(SQUARE_P[3 * v], SQUARE_P[3 * v + 1], SQUARE_P[3 * v + 2]));
        P[3 * v] = p.x, P[3 * v + 1] = p.y, P[3 * v + 2] = p.z;
    }
    assert_int_equal(geometry_add_mesh(gf, P, 4, SQUARE_I, 2, 3, 1 ^ mflip, &err), 0);
    assert_int_equal(geometry_commit(gf, &err), 0);

    /* Rays from a sphere of origins around the shapes toward random points near them; the
     * float instance transform moves hits by ~1e-7 relative, far below the tolerance. */
    int hits[4] = {0};
    uint64_t x = 0x9E3779B97F4A7C15ull;
    for (int i = 0; i < 4000; i++) {
        double u[6];
        for (int k = 0; k < 6; k++) {
            x ^= x >> 12, x ^= x << 25, x ^= x >> 27; /* xorshift64* (Vigna 2016) */
            u[k] = (double)((x * 2685821657736338717ull) >> 11) / 9007199254740992.0;
        }
        double z = 1 - 2 * u[0], ph = 2 * PF_PI * u[1];
        vec3_t org = vec3_scale(vec3_make(sqrt(1 - z * z) * cos(ph), sqrt(1 - z * z) * sin(ph), z), 8);
        org = vec3_add(org, transform_point(&m, vec3_make(0, 0, 0)));
        vec3_t target = transform_point(&m, vec3_make(4 * u[2] - 2, 4 * u[3] - 2, 4 * u[4] - 2));
        vec3_t dir = vec3_normalize(vec3_sub(target, org));
        hit_t a, b;
        int ha = geometry_intersect(gi, org, dir, 0, INFINITY, &a);
        int hb = geometry_intersect(gf, org, dir, 0, INFINITY, &b);
        if (ha != hb) {
            /* Only a ray grazing an edge may differ between float transforms. */
            hit_t *one = ha ? &a : &b;
            assert_true(one->shape == 3 || one->shape == 2);
            continue;
        }
        if (!ha) {
            hits[0]++;
            continue;
        }
        assert_int_equal(a.shape, b.shape);
        hits[a.shape]++;
        testutil_assert_near(a.t, b.t, 1e-4);
        assert_vec_near(a.p, b.p, 1e-4, "p");
        assert_vec_near(a.ng, b.ng, 1e-4, "ng");
        testutil_assert_near(a.u, b.u, 1e-4);
        testutil_assert_near(a.v, b.v, 1e-4);
        assert_int_equal(a.prim, b.prim);
        assert_int_equal(b.instance, GEOMETRY_NO_INSTANCE);
        assert_int_equal(a.instance, 0);
    }
    /* Every kind of shape was hit many times. */
    for (int k = 1; k < 4; k++)
        assert_true(hits[k] > 100);
    geometry_destroy(&gi);
    geometry_destroy(&gf);
}

/* scene_surface on an instanced mesh: the shape, material, uv and the shading normal mapped
 * to world space by the instance's inverse transpose. */
static void test_surface_of_instanced_mesh(void **state)
{
    (void)state;
    err_t err;
    scene_t *s = scene_new(&err);
    assert_non_null(s);
    material_t m0 = {.kind = MATERIAL_DIFFUSE}, m1 = {.kind = MATERIAL_DIFFUSE};
    assert_int_equal(scene_add_material(s, &m0, &err), 0);
    assert_int_equal(scene_add_material(s, &m1, &err), 1);
    int obj = scene_add_object(s, &err);
    assert_int_equal(obj, 0);
    /* Every vertex normal tilted 45 degrees toward +x, uv = (x, y). */
    double N[12] = {1, 0, 1, 1, 0, 1, 1, 0, 1, 1, 0, 1};
    double UV[8] = {1, 0, 2, 0, 2, 1, 1, 1};
    int sh = scene_add_object_mesh(s, obj, SQUARE_P, 4, SQUARE_I, 2, N, UV, 1, 0, &err);
    assert_true(sh >= 0);
    /* Place it scaled by 2 in x and rotated 90 degrees about z: object x goes to world y. */
    transform_t rz;
    assert_int_equal(transform_rotate(90, vec3_make(0, 0, 1), &rz, NULL), 0);
    transform_t t = transform_compose(rz, transform_scale(2, 1, 1));
    assert_int_equal(scene_add_instance(s, obj, &t, &err), 0);
    assert_int_equal(scene_finish(s, &err), 0);
    /* The object point (1.5, 0.25, 0) is at world (-0.25, 3, 0). */
    hit_t h;
    assert_int_equal(geometry_intersect(s->geometry, vec3_make(-0.25, 3, 2), vec3_make(0, 0, -1), 0, INFINITY, &h), 1);
    surface_t sf;
    scene_surface(s, &h, &sf);
    assert_ptr_equal(sf.shape, &s->shapes[sh]);
    assert_ptr_equal(sf.material, &s->materials[1]);
    assert_int_equal(sf.light, -1);
    testutil_assert_near(sf.u, 1.5, 1e-6);
    testutil_assert_near(sf.v, 0.25, 1e-6);
    assert_vec_near(sf.ng, vec3_make(0, 0, 1), 1e-9, "ng");
    /* Normal (1, 0, 1): the scale maps it to (1/2, 0, 1), the rotation to (0, 1/2, 1). */
    assert_vec_near(sf.ns, vec3_normalize(vec3_make(0, 0.5, 1)), 1e-9, "ns");
    assert_true(sf.smooth);
    scene_destroy(&s);
}

/* A 1000-triangle grid mesh, 10 x 50 cells of two triangles. */
static void grid_mesh(double *P, uint32_t *I)
{
    for (int j = 0; j <= 10; j++)
        for (int i = 0; i <= 50; i++) {
            double *p = P + 3 * (j * 51 + i);
            p[0] = i * 0.02, p[1] = j * 0.1, p[2] = 0.05 * sin(i * 0.7 + j);
        }
    for (int j = 0; j < 10; j++)
        for (int i = 0; i < 50; i++) {
            uint32_t a = (uint32_t)(j * 51 + i), b = a + 1, c = a + 52, d = a + 51;
            uint32_t *t = I + 6 * (j * 50 + i);
            t[0] = a, t[1] = b, t[2] = c, t[3] = a, t[4] = c, t[5] = d;
        }
}

static size_t memory_of(int instances, int flattened_copies, size_t *scene_bytes)
{
    err_t err;
    static double P[3 * 561];
    static uint32_t I[3 * 1000];
    grid_mesh(P, I);
    scene_t *s = scene_new(&err);
    assert_non_null(s);
    material_t m = {.kind = MATERIAL_DIFFUSE};
    assert_int_equal(scene_add_material(s, &m, &err), 0);
    if (instances > 0) {
        int obj = scene_add_object(s, &err);
        assert_true(scene_add_object_mesh(s, obj, P, 561, I, 1000, NULL, NULL, 0, 0, &err) >= 0);
        for (int k = 0; k < instances; k++) {
            transform_t t = transform_translate(vec3_make(k % 32, (k / 32) * 1.1, 0));
            if (scene_add_instance(s, obj, &t, &err) < 0)
                fail_msg("%s", err.msg);
        }
    }
    static double Q[3 * 561];
    for (int k = 0; k < flattened_copies; k++) {
        for (int v = 0; v < 561; v++)
            Q[3 * v] = P[3 * v] + k % 32, Q[3 * v + 1] = P[3 * v + 1] + (k / 32) * 1.1,
                  Q[3 * v + 2] = P[3 * v + 2];
        assert_true(scene_add_mesh(s, Q, 561, I, 1000, NULL, NULL, 0, -1, 0, &err) >= 0);
    }
    assert_int_equal(scene_finish(s, &err), 0);
    size_t bytes = geometry_memory_bytes(s->geometry);
    /* The scene's own copy of the meshes and its instance table. */
    *scene_bytes = s->nshapes * (sizeof(shape_t) + 561 * 3 * sizeof(double) + 1000 * 3 * sizeof(uint32_t)) +
                   s->ninstances * sizeof(instance_t);
    /* Still intersectable: a ray down onto instance 40's grid. */
    if (instances > 40) {
        hit_t h;
        assert_int_equal(geometry_intersect(s->geometry, vec3_make(8.5, 1.1 + 0.55, 5), vec3_make(0, 0, -1), 0, INFINITY, &h), 1);
        assert_int_equal(h.instance, 40);
    }
    scene_destroy(&s);
    return bytes;
}

/* One copy of the mesh whatever the number of instances. Flattening 1000 instances costs 1000
 * copies; instancing costs one copy plus, per instance, a transform and a leaf of the world's
 * BVH -- a few hundred bytes, which against a copy of a 1000-triangle mesh (vertices, indices
 * and its BVH, ~75 kB) is under 0.5 %. So 1000 instances must stay below one copy plus 5. */
static void test_thousand_instances_stay_small(void **state)
{
    (void)state;
    size_t sc1, sc1000, scf;
    size_t one = memory_of(1, 0, &sc1);
    size_t thousand = memory_of(1000, 0, &sc1000);
    size_t flat = memory_of(0, 20, &scf);
    double per_copy = flat / 20.0;
    double per_instance = (double)(thousand - one) / 999.0;
    print_message("Embree memory: 1 instance %zu B, 1000 instances %zu B (%.0f B per extra "
                  "instance); 20 flattened copies %zu B (%.0f B per copy, so 1000 would take "
                  "%.1f MB); renderer arrays %zu B (1 instance), %zu B (1000 instances)\n",
                  one, thousand, per_instance, flat, per_copy, 1000 * per_copy / 1e6, sc1, sc1000);
    assert_true(one > 0 && flat > 0);
    assert_true(per_instance < 0.005 * per_copy);
    assert_true((double)thousand < one + 5.0 * per_copy);
    /* The renderer's own arrays: one mesh, not a thousand, plus the instance table. */
    assert_true(sc1000 == sc1 + 999 * sizeof(instance_t));
}

/* ---- rendering: instanced and flattened scenes agree within noise ---- */

/* The object: a glass sphere, a diffuse mesh with vertex normals and uv, a mirror disk. */
#define OBJECT_SHAPES                                                                              \
    "  AttributeBegin\n"                                                                           \
    "    Material \"dielectric\" \"string glass\" \"N-SF11\"\n"                                    \
    "    Translate 0 0.4 0\n"                                                                      \
    "    Shape \"sphere\" \"float radius\" 0.35\n"                                                 \
    "  AttributeEnd\n"                                                                             \
    "  Material \"diffuse\" \"rgb reflectance\" [0.7 0.3 0.2]\n"                                   \
    "  Shape \"trianglemesh\" \"point3 P\" [-0.5 0 -0.5  0.5 0 -0.5  0.5 0 0.5  -0.5 0 0.5]\n"     \
    "    \"integer indices\" [0 2 1 0 3 2] \"normal N\" [0.3 1 0  0 1 0.2  -0.2 1 0  0 1 0]\n"      \
    "    \"point2 uv\" [0 0 1 0 1 1 0 1]\n"                                                        \
    "  AttributeBegin\n"                                                                           \
    "    Material \"conductor\" \"rgb reflectance\" [0.9 0.9 0.9]\n"                               \
    "    Translate 0.3 0.9 0.2\n"                                                                  \
    "    Rotate 70 1 0 0\n"                                                                        \
    "    Shape \"disk\" \"float radius\" 0.15\n"                                                   \
    "  AttributeEnd\n"

#define SCENE_HEAD                                                                                 \
    "LookAt 0 1.5 -3  0 0.3 0  0 1 0\n"                                                            \
    "Camera \"perspective\" \"float fov\" 50\n"                                                    \
    "Film \"spectral\" \"integer xresolution\" 16 \"integer yresolution\" 12\n"                    \
    "  \"integer nbuckets\" 8 \"float lambdamin\" 400 \"float lambdamax\" 700\n"                   \
    "Sampler \"independent\" \"integer pixelsamples\" 64\n"                                        \
    "Integrator \"path\" \"integer maxdepth\" 8\n"                                                 \
    "WorldBegin\n"                                                                                 \
    "LightSource \"infinite\" \"rgb L\" [0.4 0.45 0.5]\n"                                          \
    "AttributeBegin\n"                                                                             \
    "  AreaLightSource \"diffuse\" \"blackbody L\" 5000 \"float scale\" 4\n"                       \
    "  Translate 0 3 0\n"                                                                          \
    "  Rotate 90 1 0 0\n"                                                                          \
    "  Shape \"disk\" \"float radius\" 1\n"                                                        \
    "AttributeEnd\n"

/* Instance placements: the second mirrors (Scale -1 1 1) and squashes. */
#define PLACE_A "Translate -0.6 0 0 Rotate 20 0 1 0\n"
#define PLACE_B "Translate 0.6 0 0.3 Scale -1 1.2 0.8\n"

static const char *INSTANCED = SCENE_HEAD "ObjectBegin \"thing\"\n" OBJECT_SHAPES "ObjectEnd\n"
                                          "AttributeBegin\n" PLACE_A "ObjectInstance \"thing\"\nAttributeEnd\n"
                                          "AttributeBegin\n" PLACE_B "ObjectInstance \"thing\"\nAttributeEnd\n";

static const char *FLATTENED = SCENE_HEAD "AttributeBegin\n" PLACE_A OBJECT_SHAPES "AttributeEnd\n"
                                          "AttributeBegin\n" PLACE_B OBJECT_SHAPES "AttributeEnd\n";

static tilebuf_t *render_text(const char *text, size_t *ninstances)
{
    err_t err;
    scene_t *s = sb_load_text(text, NULL);
    *ninstances = s->ninstances;
    int w = s->settings.xres, h = s->settings.yres;
    tilebuf_t *t = tilebuf_new(0, 0, w, h, s->settings.grid.n, &err);
    render_stats_t st = {0};
    if (render_tile(s, NULL, 0, 0, w, h, 0, (uint32_t)s->settings.spp, t, &st, &err))
        fail_msg("render: %s", err.msg);
    assert_int_equal(st.nonfinite, 0);
    scene_destroy(&s);
    return t;
}

static void test_render_matches_flattened(void **state)
{
    (void)state;
    size_t ni, nf;
    tilebuf_t *a = render_text(INSTANCED, &ni), *b = render_text(FLATTENED, &nf);
    assert_int_equal(ni, 2);
    assert_int_equal(nf, 0);
    int w = tilebuf_width(a), h = tilebuf_height(a), nb = tilebuf_nbuckets(a);
    /* Both renders use the same random numbers per pixel and sample, so most samples follow
     * the same path; where float rounding of the instance transform sends one elsewhere the
     * two differ by noise. Per bucket, the image means must agree within 4 standard errors
     * of the paired pixel differences (plus rounding). */
    int same = 0;
    for (int k = 0; k < nb; k++) {
        double sum = 0, sq = 0, mean_a = 0;
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                double va = tilebuf_sum(a, x, y, k) / (double)tilebuf_count(a, x, y);
                double vb = tilebuf_sum(b, x, y, k) / (double)tilebuf_count(b, x, y);
                double dlt = va - vb;
                same += fabs(dlt) <= 1e-6 * fmax(1.0, fabs(va));
                sum += dlt;
                sq += dlt * dlt;
                mean_a += va;
            }
        int n = w * h;
        double md = sum / n, se = sqrt(fmax(0.0, sq / n - md * md) / (n - 1));
        mean_a /= n;
        assert_true(mean_a > 0.01);
        if (!(fabs(md) <= 4 * se + 1e-9 * mean_a))
            fail_msg("bucket %d: instanced - flattened = %.6g +- %.6g (mean %.6g)", k, md, se, mean_a);
    }
    print_message("instanced vs flattened: %d of %d pixel-buckets equal to 1e-6\n", same, w * h * nb);
    tilebuf_destroy(&a);
    tilebuf_destroy(&b);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_instanced_hits_and_normals),
        cmocka_unit_test(test_instance_equals_flattened),
        cmocka_unit_test(test_surface_of_instanced_mesh),
        cmocka_unit_test(test_thousand_instances_stay_small),
        cmocka_unit_test(test_render_matches_flattened),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
