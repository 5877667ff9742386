/* Curves (pbrt-v4 "curve"), through the parser, the loader and Embree: a "ribbon" is a flat
 * strip that faces its normal (face-on it covers its width, at 60 degrees half of it, edge-on
 * nothing, where a "flat" curve covers its width from every side), its normal slerps from the
 * segment's first normal to its second (the hit's normal exactly, the strip Embree intersects
 * within a degree), v runs across the narrowed width as pbrt-v4's, ReverseOrientation flips
 * the normal, and the parser refuses ribbons without their normals; a thin wavy curve is
 * found where its true centre line is, with v across it. No rendering. */
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
#include "pbrt_parser.h"
#include "scene.h"
#include "scene_builders.h"
#include "scene_load.h"

static const double PI = 3.14159265358979323846;

/* A straight segment along x from -1 to 1, 0.2 wide (u = (x + 1) / 2: its control points are
 * evenly spaced). */
#define STRAIGHT                                                                                   \
    "\"float width\" 0.2 \"point3 P\" [-1 0 0 -0.333333333333 0 0 0.333333333333 0 0 1 0 0]"

/* The fraction of n rays that hit, each along dir from 5 units back, through x = 0 and an
 * offset from -0.2 to 0.2 along across (perpendicular to dir and to x), cell centres so that
 * no ray grazes the strip's own plane. */
static double coverage(const scene_t *s, vec3_t dir, vec3_t across, int n)
{
    int hits = 0;
    for (int i = 0; i < n; i++) {
        double o = -0.2 + 0.4 * (i + 0.5) / n;
        vec3_t target = vec3_scale(across, o);
        hit_t h;
        hits += geometry_intersect(s->geometry, vec3_fma(target, dir, -5.0), dir, 0, INFINITY, &h);
    }
    return (double)hits / n;
}

static void test_ribbon_faces_its_normal(void **state)
{
    (void)state;
    scene_t *r = sb_load_text("WorldBegin\nShape \"curve\" \"string type\" \"ribbon\" " STRAIGHT
                              " \"normal N\" [0 0 1 0 0 1]\n",
                              NULL);
    scene_t *f =
        sb_load_text("WorldBegin\nShape \"curve\" \"string type\" \"flat\" " STRAIGHT "\n", NULL);
    const double a = PI / 3; /* 60 degrees off the normal */
    vec3_t face = vec3_make(0, 0, -1), edge = vec3_make(0, -1, 0),
           tilt = vec3_make(0, -sin(a), -cos(a));
    vec3_t face_x = vec3_make(0, 1, 0), edge_x = vec3_make(0, 0, 1),
           tilt_x = vec3_make(0, cos(a), -sin(a));
    /* Of 400 offsets over 0.4: the 0.2 width is half of them face-on, 0.2 cos 60 = 0.1 a
     * quarter at 60 degrees (pbrt-v4 narrows the width by |n . d|), none edge-on. */
    double rf = coverage(r, face, face_x, 400), rt = coverage(r, tilt, tilt_x, 400),
           re = coverage(r, edge, edge_x, 400);
    if (fabs(rf - 0.5) > 0.01 || fabs(rt - 0.25) > 0.01 || re != 0.0)
        fail_msg("ribbon coverage face-on %.4f (0.5), at 60 degrees %.4f (0.25), edge-on %.4f (0)",
                 rf, rt, re);
    /* The flat curve faces every ray. */
    double ff = coverage(f, face, face_x, 400), fe = coverage(f, edge, edge_x, 400);
    if (fabs(ff - 0.5) > 0.01 || fabs(fe - 0.5) > 0.01)
        fail_msg("flat coverage face-on %.4f, edge-on %.4f (0.5 both)", ff, fe);
    /* The ribbon's hit: its own normal, +z whichever side the ray comes from, and v across
     * the narrowed width (pbrt-v4: 0.5 + distance / width on the side of dir x dp/du). */
    hit_t h;
    assert_int_equal(
        geometry_intersect(r->geometry, vec3_make(0.2, 0.05, 5), face, 0, INFINITY, &h), 1);
    assert_true(h.ng.z > 1 - 1e-9 && fabs(h.t - 5) < 1e-4);
    double want_v = 0.5 + 0.05 / 0.2 * (vec3_cross(face, vec3_make(1, 0, 0)).y > 0 ? 1 : -1);
    if (fabs(h.v - want_v) > 1e-3)
        fail_msg("face-on v %.5f, expected %.5f", h.v, want_v);
    assert_int_equal(geometry_intersect(r->geometry, vec3_fma(vec3_make(0.2, 0.05, 0), tilt, -5),
                                        tilt, 0, INFINITY, &h),
                     1);
    assert_true(h.ng.z > 1 - 1e-9);
    /* 0.05 across in the strip is 0.05 cos 60 seen from the ray, over the width narrowed to
     * 0.2 cos 60: v = 0.5 -+ 0.25 again. */
    if (fabs(fabs(h.v - 0.5) - 0.25) > 1e-3)
        fail_msg("v at 60 degrees %.5f, expected 0.5 -+ 0.25", h.v);
    scene_destroy(&r);
    scene_destroy(&f);
}

static void test_ribbon_normal_interpolates(void **state)
{
    (void)state;
    /* A quarter turn about the curve: +z at x = -1 to +y at x = 1; and the same reversed. */
    scene_t *s = sb_load_text("WorldBegin\nShape \"curve\" \"string type\" \"ribbon\" " STRAIGHT
                              " \"normal N\" [0 0 1 0 1 0]\n",
                              NULL);
    scene_t *rev = sb_load_text("WorldBegin\nReverseOrientation\nShape \"curve\" \"string type\" "
                                "\"ribbon\" " STRAIGHT " \"normal N\" [0 0 1 0 1 0]\n",
                                NULL);
    double worst = 0.0;
    for (int k = 1; k < 16; k++) {
        double u = k / 16.0, x = -1 + 2 * u, phi = u * PI / 2;
        vec3_t n = vec3_make(0, sin(phi), cos(phi)), b = vec3_make(0, cos(phi), -sin(phi));
        /* Face-on along -n, a little off the centre line: the hit's normal is the slerp. */
        hit_t h;
        vec3_t at = vec3_fma(vec3_make(x, 0, 0), b, 0.03);
        assert_int_equal(
            geometry_intersect(s->geometry, vec3_fma(at, n, 5), vec3_neg(n), 0, INFINITY, &h), 1);
        if (vec3_dot(h.ng, n) < 1 - 1e-9)
            fail_msg("u %.4f: normal (%g %g %g), slerp (%g %g %g)", u, h.ng.x, h.ng.y, h.ng.z, n.x,
                     n.y, n.z);
        assert_int_equal(
            geometry_intersect(rev->geometry, vec3_fma(at, n, 5), vec3_neg(n), 0, INFINITY, &h), 1);
        assert_true(vec3_dot(h.ng, n) < -1 + 1e-9);
        /* Edge-on along the strip's width direction b: a ray 0.0017 off its plane (a degree's
         * tilt over the half width 0.1) misses it, one 0.01 off it too (5.7 degrees), and
         * the strip Embree intersects is tilted from the slerp by under that. */
        for (int side = -1; side <= 1; side += 2) {
            vec3_t o = vec3_fma(vec3_make(x, 0, 0), n, side * 0.0017);
            if (geometry_intersect(s->geometry, vec3_fma(o, b, -5), b, 0, INFINITY, &h))
                worst = fmax(worst, u);
        }
    }
    if (worst > 0)
        fail_msg("the strip Embree intersects is tilted over a degree from the slerp (at u %.4f)",
                 worst);
    scene_destroy(&s);
    scene_destroy(&rev);
}

/* A thin wavy curve is hit where its true centre line passes within a radius of the ray (to a
 * tenth of the radius, pbrt-v4's tolerance), and v says where across: Embree intersects
 * straight pieces of each segment, and with its default 4 this one (radius 0.03, second
 * differences 0.6) was found up to a radius off its centre line (the hair scene's 4 %
 * excess, docs/compatibility.md); it wants 17 pieces by the rule, so it
 * goes to Embree as two sub-segments of 9 (test_curve_split_beyond_16 wants 40). */
static void test_thin_wavy_curve(void **state)
{
    (void)state;
    scene_t *s = sb_load_text("WorldBegin\nShape \"curve\" \"float width\" 0.06 "
                              "\"point3 P\" [0 0 0 1 0.2 0 2 -0.2 0 3 0 0]\n",
                              NULL);
    const double cp[12] = {0, 0, 0, 1, 0.2, 0, 2, -0.2, 0, 3, 0, 0}, r = 0.03;
    int wrong = 0, bad_v = 0, n = 0;
    for (int i = 0; i < 60; i++) {
        double x = 0.1 + 2.8 * (i + 0.5) / 60;
        /* The centre line at x (u by bisection: x(u) increases) and its normal in the plane. */
        double lo = 0, hi = 1;
        vec3_t c, t;
        for (int it = 0; it < 60; it++) {
            geometry_bezier(cp, 0.5 * (lo + hi), &c, &t);
            *(c.x < x ? &lo : &hi) = 0.5 * (lo + hi);
        }
        geometry_bezier(cp, 0.5 * (lo + hi), &c, &t);
        vec3_t nrm = vec3_normalize(vec3_make(-t.y, t.x, 0));
        for (int j = 0; j < 41; j++) {
            double o = -2 * r + 4 * r * j / 40; /* across the line, in its plane */
            vec3_t at = vec3_fma(c, nrm, o);
            hit_t h;
            int hit = geometry_intersect(s->geometry, vec3_add(at, vec3_make(0, 0, 5)),
                                         vec3_make(0, 0, -1), 0, INFINITY, &h);
            n++;
            if (fabs(fabs(o) - r) > 0.1 * r && hit != (fabs(o) < r))
                wrong++;
            /* dir x t = (0, 0, -1) x t = (t.y, -t.x, 0) = -nrm: v = 0.5 - o / (2 r). */
            if (hit && fabs(h.v - (0.5 - o / (2 * r))) > 0.1)
                bad_v++;
        }
    }
    if (wrong || bad_v)
        fail_msg("of %d rays, %d hit or missed against the centre line, %d with v off by 0.1", n,
                 wrong, bad_v);
    scene_destroy(&s);
}

/* The centre line of a planar Bezier at u: its point and in-plane unit normal. */
static void centre_at(const double *cp, double u, vec3_t *c, vec3_t *nrm)
{
    vec3_t t;
    geometry_bezier(cp, u, c, &t);
    *nrm = vec3_normalize(vec3_make(-t.y, t.x, 0));
}

/* Whether a ray down -z through the point at offset o along nrm from c hits the scene. */
static int hit_down(const scene_t *s, vec3_t c, vec3_t nrm, double o, hit_t *h)
{
    return geometry_intersect(s->geometry, vec3_add(vec3_fma(c, nrm, o), vec3_make(0, 0, 5)),
                              vec3_make(0, 0, -1), 0, INFINITY, h);
}

/* A curve that wants 40 pieces by pbrt-v4's rule (radius 0.01, second differences 1.23:
 * sqrt(7.5 sqrt 3 1.23 / 0.01) = 40), more than Embree 3's 16: the segment goes to Embree as
 * 3 sub-segments of 14 pieces each, and each hit maps back to the segment (prim 0) and its u.
 * Across the curve at 96 places, the edge between hits and misses (bisected to 2e-5 radii on
 * either side) lies within a tenth of a radius of the true centre line's (pbrt-v4's
 * tolerance; Embree's 16 pieces alone put it up to a third of a radius off near the ends);
 * hits nearer the centre line have v across it and u the true centre line's to 1e-3, also
 * at 1e-4 to 4e-3 either side of the split points u = 1/3 and 2/3, where u runs on without
 * going back. (Not at them: a ray through the very point where two of Embree's segments join
 * misses them within a float ulp either side, as it does at the joint of the same two pieces
 * given as a two-segment curve, measured before the split existed.) With
 * normals, the same curve is a ribbon whose hit normal is pbrt-v4's slerp at the segment's u
 * (not at the sub-segment's). */
static void test_curve_split_beyond_16(void **state)
{
    (void)state;
    const double cp[12] = {0, 0, 0, 1, 0.41, 0, 2, -0.41, 0, 3, 0, 0}, r = 0.01;
    scene_t *s = sb_load_text("WorldBegin\nShape \"curve\" \"float width\" 0.02 "
                              "\"point3 P\" [0 0 0 1 0.41 0 2 -0.41 0 3 0 0]\n",
                              NULL);
    int wrong = 0, bad_v = 0, bad_u = 0, bad_prim = 0, n = 0;
    double worst_edge = 0.0, worst_u = 0.0;
    hit_t h;
    for (int i = 0; i < 96; i++) {
        double u = 0.01 + 0.98 * (i + 0.5) / 96;
        vec3_t c, nrm;
        centre_at(cp, u, &c, &nrm);
        for (int side = -1; side <= 1; side += 2) {
            double in = 0.5 * r, out = 1.5 * r;
            n += 2;
            if (!hit_down(s, c, nrm, side * in, &h) || hit_down(s, c, nrm, side * out, &h)) {
                wrong++;
                continue;
            }
            for (int it = 0; it < 16; it++, n++) {
                double o = 0.5 * (in + out);
                *(hit_down(s, c, nrm, side * o, &h) ? &in : &out) = o;
            }
            worst_edge = fmax(worst_edge, fabs(0.5 * (in + out) - r) / r);
        }
        for (int j = -5; j <= 5; j++, n++) {
            double o = 0.1 * r * j;
            if (!hit_down(s, c, nrm, o, &h)) {
                wrong++;
                continue;
            }
            /* dir x t = (0, 0, -1) x t = -nrm: v = 0.5 - o / (2 r). */
            bad_v += fabs(h.v - (0.5 - o / (2 * r))) > 0.05;
            bad_prim += h.prim != 0;
            worst_u = fmax(worst_u, fabs(h.u - u));
            bad_u += fabs(h.u - u) > 1e-3;
        }
    }
    for (int k = 1; k <= 2; k++) {
        double last = -1;
        for (int i = -20; i < 20; i++, n++) {
            double u = k / 3.0 + 2e-4 * (i + 0.5);
            vec3_t c, nrm;
            centre_at(cp, u, &c, &nrm);
            if (!hit_down(s, c, nrm, 0, &h)) {
                wrong++;
                continue;
            }
            worst_u = fmax(worst_u, fabs(h.u - u));
            bad_u += fabs(h.u - u) > 1e-3 || h.u < last;
            bad_prim += h.prim != 0;
            last = h.u;
        }
    }
    if (wrong || worst_edge > 0.1 || bad_v || bad_u || bad_prim)
        fail_msg("of %d rays: %d missed within half a radius or hit at 1.5 radii; the edge up to "
                 "%.3f radii off the centre line's (0.1 allowed); %d with v off by 0.05, %d with "
                 "u off by 1e-3 (worst %.2e) or going back, %d not on segment 0",
                 n, wrong, worst_edge, bad_v, bad_u, worst_u, bad_prim);
    scene_destroy(&s);

    /* The ribbon: normals +z at u = 0, turning a third of a turn about x to u = 1. */
    scene_t *rb =
        sb_load_text("WorldBegin\nShape \"curve\" \"string type\" \"ribbon\" \"float width\" 0.02 "
                     "\"point3 P\" [0 0 0 1 0.41 0 2 -0.41 0 3 0 0] "
                     "\"normal N\" [0 0 1 0 -0.866025403784 0.5]\n",
                     NULL);
    int bad_n = 0;
    double worst_n = 1.0;
    for (int i = 0; i < 90; i++) {
        double u = 0.01 + 0.98 * (i + 0.5) / 90;
        double phi = u * PI / 3;
        vec3_t ns = vec3_make(0, -sin(phi), cos(phi));
        vec3_t c, t;
        geometry_bezier(cp, u, &c, &t);
        vec3_t tn = vec3_normalize(t);
        vec3_t want = vec3_normalize(vec3_sub(ns, vec3_scale(tn, vec3_dot(ns, tn))));
        if (!geometry_intersect(rb->geometry, vec3_fma(c, ns, 5), vec3_neg(ns), 0, INFINITY, &h) ||
            h.prim != 0 || fabs(h.u - u) > 1e-3) {
            bad_n++;
            continue;
        }
        worst_n = fmin(worst_n, vec3_dot(h.ng, want));
        bad_n += vec3_dot(h.ng, want) < 1 - 1e-4;
    }
    if (bad_n)
        fail_msg("ribbon: %d of 90 rays missed, left segment 0, or found a normal off the slerp "
                 "(worst cos %.9f)",
                 bad_n, worst_n);
    scene_destroy(&rb);
}

static void test_ribbon_refused(void **state)
{
    (void)state;
    static const char *bad[] = {
        "WorldBegin\nShape \"curve\" \"string type\" \"ribbon\" " STRAIGHT "\n",
        "WorldBegin\nShape \"curve\" \"string type\" \"ribbon\" " STRAIGHT
        " \"normal N\" [0 0 1]\n",
        "WorldBegin\nShape \"curve\" \"string type\" \"ribbon\" " STRAIGHT
        " \"normal N\" [0 0 1 0 0 0]\n",
        "WorldBegin\nShape \"curve\" \"string type\" \"ribbon\" " STRAIGHT
        " \"normal N\" [0 0 1 0 0 -1]\n",
    };
    static const char *why[] = {"needs \"normal N\"", "needs 2 normals", "is zero", "opposite"};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        err_t err = {{0}};
        scene_desc_t *d = pbrt_parse_string(bad[i], strlen(bad[i]), "t.pbrt", &err);
        if (d || !strstr(err.msg, why[i]))
            fail_msg("case %zu: %s (wanted \"%s\")", i, d ? "accepted" : err.msg, why[i]);
    }
    /* Normals on a flat curve are ignored, as pbrt-v4 does. */
    scene_t *s =
        sb_load_text("WorldBegin\nShape \"curve\" " STRAIGHT " \"normal N\" [0 0 1 0 0 1]\n", NULL);
    assert_true(fabs(coverage(s, vec3_make(0, -1, 0), vec3_make(0, 0, 1), 100) - 0.5) < 0.02);
    scene_destroy(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ribbon_faces_its_normal),
        cmocka_unit_test(test_ribbon_normal_interpolates),
        cmocka_unit_test(test_thin_wavy_curve),
        cmocka_unit_test(test_curve_split_beyond_16),
        cmocka_unit_test(test_ribbon_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
