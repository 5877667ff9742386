/* Tests for texture: the checkerboard's cells (pbrt-v4 Checkerboard: cell (floor(u s_u),
 * floor(v s_v)) shows tex1 when the sum of the two is even, tex2 when odd), including negative
 * cells and coordinates so large that every double is an even integer, and a constant texture
 * inside it returning its spectrum's value exactly. pbrt-v4's procedural textures by what
 * their definitions imply: bilerp's corners and centre; dots always outside at a cell's corners
 * (0.5 sqrt 2 from the centre, more than the radius 0.35 plus the largest shift 0.15 sqrt 2)
 * and inside at its centre exactly when the noise there is positive; the 3D checkerboard's
 * parity in the texture's own space; fbm, wrinkled and windy as their noise sums at the point
 * the CTM's inverse gives (one octave: 0 at the texture space's lattice points); marble's spline at
 * t = 1/2 (the grey control point 0.5, times 1.5) and at t = 0 and 1 (the first and last points);
 * directionmix by |n . dir|. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "noise.h"
#include "texture.h"

#include <math.h>

static texture_t *constant(double v)
{
    err_t err;
    texture_t *t = texture_new_constant_value(v, &err);
    assert_non_null(t);
    return t;
}

static void test_bilerp(void **state)
{
    (void)state;
    err_t err;
    texture_t *c[4] = {constant(0.1), constant(0.2), constant(0.3), constant(0.4)};
    /* s = 2 u - 1, t = 2 v - 1: (s, t) = (0, 0) at uv (0.5, 0.5). */
    texture_t *b =
        texture_new_bilerp(c[0], c[1], c[2], c[3], (texture_uv_map_t){2, 2, -1, -1}, &err);
    assert_non_null(b);
    const double e = 1e-12;
    assert_true(fabs(texture_eval(b, 0.5, 0.5, 550) - 0.1) < e); /* v00 */
    assert_true(fabs(texture_eval(b, 0.5, 1.0, 550) - 0.2) < e); /* v01: t = 1 */
    assert_true(fabs(texture_eval(b, 1.0, 0.5, 550) - 0.3) < e); /* v10: s = 1 */
    assert_true(fabs(texture_eval(b, 1.0, 1.0, 550) - 0.4) < e);
    assert_true(fabs(texture_eval(b, 0.75, 0.75, 550) - 0.25) < e);
    texture_destroy(&b);
    for (int i = 0; i < 4; i++)
        texture_destroy(&c[i]);
}

static void test_dots(void **state)
{
    (void)state;
    err_t err;
    texture_t *in = constant(1.0), *out = constant(0.0);
    texture_t *d = texture_new_dots(in, out, (texture_uv_map_t){1, 1, 0, 0}, &err);
    assert_non_null(d);
    int dotted = 0, cells = 0;
    for (int i = -10; i < 10; i++)
        for (int j = -10; j < 10; j++) {
            /* Cells are centred on integer (s, t). */
            for (int k = 0; k < 4; k++) {
                double s = i + ((k & 1) ? 0.4999 : -0.4999), t = j + ((k & 2) ? 0.4999 : -0.4999);
                assert_true(texture_eval(d, s, t, 550) == 0.0);
            }
            int want = noise_perlin(vec3_make(i + 0.5, j + 0.5, 0.5)) > 0.0;
            assert_true(texture_eval(d, i, j, 550) == (want ? 1.0 : 0.0));
            dotted += want;
            cells++;
        }
    /* About half the cells hold a dot. */
    assert_true(dotted > cells / 5 && dotted < cells * 4 / 5);
    texture_destroy(&d);
    texture_destroy(&in);
    texture_destroy(&out);
}

static double at_point(const texture_t *t, vec3_t p, vec3_t n, double lambda)
{
    const texture_point_t at = {.u = 0.3, .v = 0.7, .p = p, .n = n};
    return texture_eval_at(t, &at, lambda);
}

static void test_checkerboard3d(void **state)
{
    (void)state;
    err_t err;
    texture_t *a = constant(0.25), *b = constant(0.75);
    /* The texture's space is the world scaled by 2: cells of side 0.5 in the world. */
    transform_t to_tex = transform_inverse(transform_scale(0.5, 0.5, 0.5));
    texture_t *c = texture_new_checkerboard3d(a, b, to_tex, &err);
    assert_non_null(c);
    const vec3_t n = vec3_make(0, 0, 1);
    for (int x = -3; x <= 3; x++)
        for (int y = -3; y <= 3; y++)
            for (int z = -3; z <= 3; z++) {
                vec3_t p = vec3_make(0.5 * x + 0.25, 0.5 * y + 0.25, 0.5 * z + 0.25);
                double want = ((x + y + z) % 2 == 0) ? 0.25 : 0.75;
                assert_true(at_point(c, p, n, 550) == want);
            }
    texture_destroy(&c);
    texture_destroy(&a);
    texture_destroy(&b);
}

static void test_noise_textures(void **state)
{
    (void)state;
    err_t err;
    transform_t ctm = transform_translate(vec3_make(3, -1, 2));
    transform_t to_tex = transform_inverse(ctm);
    texture_t *f = texture_new_fbm(to_tex, 5, 0.7, &err);
    texture_t *w = texture_new_wrinkled(to_tex, 4, 0.5, &err);
    texture_t *y = texture_new_windy(to_tex, &err);
    assert_non_null(f);
    assert_non_null(w);
    assert_non_null(y);
    const vec3_t n = vec3_make(0, 1, 0);
    for (int i = 0; i < 50; i++) {
        vec3_t p = vec3_make(0.37 * i - 4.0, 0.11 * i + 0.3, 1.7 - 0.05 * i);
        vec3_t q = vec3_sub(p, vec3_make(3, -1, 2));
        assert_true(fabs(at_point(f, p, n, 550) - noise_fbm(q, 0.7, 5)) < 1e-12);
        assert_true(fabs(at_point(w, p, n, 550) - noise_turbulence(q, 0.5, 4)) < 1e-12);
        double windy = fabs(noise_fbm(vec3_scale(q, 0.1), 0.5, 3)) * noise_fbm(q, 0.5, 6);
        assert_true(fabs(at_point(y, p, n, 550) - windy) < 1e-12);
    }
    /* A one-octave fbm is the noise itself: 0 at a lattice point of the texture's space. */
    texture_t *one = texture_new_fbm(to_tex, 1, 0.7, &err);
    assert_non_null(one);
    assert_true(at_point(one, vec3_make(3 + 4, -1 - 2, 2 + 1), n, 550) == 0.0);
    assert_true(at_point(one, vec3_make(3 + 4.5, -1 - 2, 2 + 1), n, 550) != 0.0 ||
                at_point(one, vec3_make(3 + 4.5, -1 - 2.5, 2 + 1.5), n, 550) != 0.0);
    texture_destroy(&one);
    assert_null(texture_new_fbm(to_tex, 0, 0.5, &err));
    assert_null(texture_new_fbm(transform_scale(0, 1, 1), 8, 0.5, &err));
    texture_destroy(&f);
    texture_destroy(&w);
    texture_destroy(&y);
}

static void test_marble(void **state)
{
    (void)state;
    err_t err;
    /* variation 0: m = scale p.y, t = 0.5 + 0.5 sin(m). */
    texture_t *m = texture_new_marble(transform_inverse(transform_translate(vec3_make(0, 0, 0))), 8,
                                      0.5, 2.0, 0.0, &err);
    assert_non_null(m);
    const vec3_t n = vec3_make(0, 1, 0);
    const double pi = 3.14159265358979323846;
    for (double lambda = 400; lambda <= 700; lambda += 50) {
        /* t = 1/2: segment 3 at its start, the grey point 0.5, times 1.5: a flat 0.75. */
        assert_true(fabs(at_point(m, vec3_make(0.3, 0.0, -0.2), n, lambda) - 0.75) < 2e-3);
        /* t = 0 and t = 1: the first and the last control points (.58, .58, .6) x 1.5, a
         * near-grey of about 0.88. */
        double lo = at_point(m, vec3_make(0, -pi / 4, 0), n, lambda);
        double hi = at_point(m, vec3_make(0, pi / 4, 0), n, lambda);
        assert_true(fabs(lo - hi) < 1e-9);
        assert_true(lo > 0.84 && lo < 0.93);
    }
    /* Anywhere, a reflectance: within [0, 1]. */
    texture_t *v =
        texture_new_marble(transform_inverse(transform_scale(1, 1, 1)), 8, 0.5, 1.0, 0.2, &err);
    assert_non_null(v);
    for (int i = 0; i < 200; i++) {
        double x = at_point(v, vec3_make(0.1 * i, 0.07 * i - 3, 0.3), n, 380 + 2 * i);
        assert_true(x >= 0.0 && x <= 1.0);
    }
    texture_destroy(&m);
    texture_destroy(&v);
}

static void test_directionmix(void **state)
{
    (void)state;
    err_t err;
    texture_t *a = constant(1.0), *b = constant(0.0);
    texture_t *d = texture_new_directionmix(a, b, vec3_make(0, 2, 0), &err);
    assert_non_null(d);
    const vec3_t p = vec3_make(0, 0, 0);
    assert_true(fabs(at_point(d, p, vec3_make(0, 1, 0), 550) - 1.0) < 1e-12);
    assert_true(fabs(at_point(d, p, vec3_make(0, -1, 0), 550) - 1.0) < 1e-12);
    assert_true(fabs(at_point(d, p, vec3_make(1, 0, 0), 550) - 0.0) < 1e-12);
    double c = sqrt(0.5);
    assert_true(fabs(at_point(d, p, vec3_make(c, c, 0), 550) - c) < 1e-12);
    assert_null(texture_new_directionmix(a, b, vec3_make(0, 0, 0), &err));
    texture_destroy(&d);
    texture_destroy(&a);
    texture_destroy(&b);
}

static void test_checkerboard_cells(void **state)
{
    (void)state;
    err_t err;
    texture_t *a = texture_new_constant_value(0.25, &err);
    texture_t *b = texture_new_constant_value(0.75, &err);
    assert_non_null(a);
    assert_non_null(b);
    texture_t *c = texture_new_checkerboard(a, b, 4.0, 2.0, &err);
    assert_non_null(c);
    /* Cell centres (i + 0.5) / 4, (j + 0.5) / 2 over negative and positive cells. */
    for (int i = -9; i <= 9; i++)
        for (int j = -9; j <= 9; j++) {
            double u = (i + 0.5) / 4.0, v = (j + 0.5) / 2.0;
            double want = ((i + j) % 2 == 0) ? 0.25 : 0.75;
            assert_true(texture_eval(c, u, v, 550.0) == want);
        }
    /* Cell boundaries belong to the cell above (floor): u = -0.25 is cell -1, u = 0 cell 0. */
    assert_true(texture_eval(c, -0.25, 0.25, 550.0) == 0.75);
    assert_true(texture_eval(c, 0.0, 0.25, 550.0) == 0.25);
    /* From 2^53 on every double is even: u s_u = 2^54 and 2^54 + 4 are even cells, and with
     * v's cell 1 (odd) they show tex2; 2^52 + 1 (exact) is odd, with cell 1 even: tex1. */
    assert_true(texture_eval(c, 0x1p54 / 4.0, 0.75, 550.0) == 0.75);
    assert_true(texture_eval(c, (0x1p54 + 4.0) / 4.0, 0.75, 550.0) == 0.75);
    assert_true(texture_eval(c, (0x1p52 + 1.0) / 4.0, 0.75, 550.0) == 0.25);
    assert_true(texture_eval(c, -(0x1p52 + 1.0) / 4.0, 0.75, 550.0) == 0.25);
    /* A non-finite cell falls back to tex1. */
    assert_true(texture_eval(c, INFINITY, 0.75, 550.0) == 0.25);
    texture_destroy(&c);
    texture_destroy(&a);
    texture_destroy(&b);
    assert_null(c);
}

static void test_mappings(void **state)
{
    (void)state;
    err_t err;
    texture_t *z = constant(0.0), *o = constant(1.0);
    const texture_uv_map_t id = {1, 1, 0, 0};
    /* bilerp(v00, v01, v10, v11): s alone with v10 = v11 = 1, t alone with v01 = v11 = 1. */
    texture_t *ss = texture_new_bilerp(z, z, o, o, id, &err),
              *tt = texture_new_bilerp(z, o, z, o, id, &err);
    assert_non_null(ss);
    assert_non_null(tt);
    const vec3_t c = vec3_make(1, 2, 3), zero = vec3_make(0, 0, 0);
    const transform_t to_tex = transform_inverse(transform_translate(c));
    texture_t *sph[2], *cyl[2], *pla[2];
    texture_t *in[2] = {ss, tt};
    for (int k = 0; k < 2; k++) {
        sph[k] = texture_new_mapped(in[k], TEXTURE_MAP_SPHERICAL, to_tex, zero, zero, 0, 0, &err);
        cyl[k] = texture_new_mapped(in[k], TEXTURE_MAP_CYLINDRICAL, to_tex, zero, zero, 0, 0, &err);
        pla[k] = texture_new_mapped(in[k], TEXTURE_MAP_PLANAR, to_tex, vec3_make(1, 0, 0),
                                    vec3_make(0, 0, 1), 0.5, -1, &err);
        assert_non_null(sph[k]);
        assert_non_null(cyl[k]);
        assert_non_null(pla[k]);
    }
    const vec3_t n = vec3_make(0, 0, 1);
    const double e = 1e-12;
    const struct {
        vec3_t q; /* texture space */
        double s, t;
    } S[] = {{{0, 0, 2}, 0.0, 0.0},
             {{1, 0, 0}, 0.5, 0.0},
             {{0, 1, 0}, 0.5, 0.25},
             {{0, -3, 0}, 0.5, 0.75},
             {{0, 0, -1}, 1.0, 0.0}},
      C[] = {{{1, 0, 5}, 0.5, 5.0}, {{0, 1, -2}, 0.75, -2.0}, {{0, -1, 0}, 0.25, 0.0}},
      P[] = {{{2, 3, 4}, 2.5, 3.0}, {{-1, 7, 0}, -0.5, -1.0}};
    for (size_t i = 0; i < sizeof S / sizeof S[0]; i++) {
        vec3_t p = vec3_add(S[i].q, c);
        assert_true(fabs(at_point(sph[0], p, n, 550) - S[i].s) < e);
        assert_true(fabs(at_point(sph[1], p, n, 550) - S[i].t) < e);
    }
    for (size_t i = 0; i < sizeof C / sizeof C[0]; i++) {
        vec3_t p = vec3_add(C[i].q, c);
        assert_true(fabs(at_point(cyl[0], p, n, 550) - C[i].s) < e);
        assert_true(fabs(at_point(cyl[1], p, n, 550) - C[i].t) < e);
    }
    for (size_t i = 0; i < sizeof P / sizeof P[0]; i++) {
        vec3_t p = vec3_add(P[i].q, c);
        assert_true(fabs(at_point(pla[0], p, n, 550) - P[i].s) < e);
        assert_true(fabs(at_point(pla[1], p, n, 550) - P[i].t) < e);
    }
    for (int k = 0; k < 2; k++) {
        texture_destroy(&sph[k]);
        texture_destroy(&cyl[k]);
        texture_destroy(&pla[k]);
    }
    texture_destroy(&ss);
    texture_destroy(&tt);
    texture_destroy(&z);
    texture_destroy(&o);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_checkerboard_cells),
        cmocka_unit_test(test_bilerp),
        cmocka_unit_test(test_dots),
        cmocka_unit_test(test_checkerboard3d),
        cmocka_unit_test(test_noise_textures),
        cmocka_unit_test(test_marble),
        cmocka_unit_test(test_directionmix),
        cmocka_unit_test(test_mappings),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
