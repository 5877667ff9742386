/* uniaxial: birefringent crystals (bsdf/uniaxial.h, optics/crystal.h, render/crystal_scatter.h)
 * against optics, not the code: the catalogue against handbook indices; the extraordinary
 * index at 0 and 90 degrees; the ordinary ray obeying Snell and the Fresnel terms of an
 * isotropic dielectric of index n_o; the walk-off against its closed form (Yariv & Yeh) and a
 * calcite plate's double image, traced and rendered, against t tan(walk-off); total internal
 * reflection inside; energy (every event's probabilities sum to 1, the radiance factors of a
 * path in and out multiply to 1, a crystal sphere vanishes in a white furnace); the absorption
 * of a dichroic plate against Beer-Lambert; the scene syntax and its errors. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h> /* after the four headers above, which it needs */

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "crystal.h"
#include "delta.h"
#include "numeric_testutil.h"
#include "polar_fresnel.h"
#include "scene_builders.h"
#include "uniaxial.h"

#define PI 3.14159265358979323846

static double n_at(const ior_model_t *m, double lambda)
{
    return ior_eval(m, lambda);
}

/* The catalogue against handbook values at the sodium D line (589.3 nm): calcite 1.6584 /
 * 1.4864 and quartz 1.5443 / 1.5534 (Bennett, Handbook of Optics II ch. 33, Table 22;
 * Hecht, Optics, Table 8.1), sapphire 1.7682 / 1.7601 (Malitson & Dodge 1972), MgF2
 * 1.3777 / 1.3895 (Dodge 1984), rutile 2.613 / 2.909 (DeVore 1951, his Table at 589 nm). */
static void test_catalogue(void **state)
{
    (void)state;
    const struct {
        const char *name;
        double no, ne, tol;
    } want[] = {{"calcite", 1.6584, 1.4864, 3e-4},  {"quartz", 1.5443, 1.5534, 3e-4},
                {"sapphire", 1.7682, 1.7601, 3e-4}, {"MgF2", 1.3777, 1.3895, 3e-4},
                {"rutile", 2.613, 2.909, 3e-3},     {"tourmaline", 1.640, 1.620, 1e-3}};
    for (size_t i = 0; i < sizeof want / sizeof want[0]; i++) {
        const crystal_t *c = crystal_find(want[i].name);
        assert_non_null(c);
        assert_non_null(c->source);
        testutil_assert_near(n_at(&c->no, 589.3), want[i].no, want[i].tol);
        testutil_assert_near(n_at(&c->ne, 589.3), want[i].ne, want[i].tol);
        err_t err;
        assert_int_equal(ior_validate(&c->no, c->name, 380.0, 720.0, &err), 0);
        assert_int_equal(ior_validate(&c->ne, c->name, 380.0, 720.0, &err), 0);
    }
    assert_ptr_equal(crystal_find("ICELAND-SPAR"), crystal_find("calcite"));
    assert_null(crystal_find("unobtainium"));
    assert_int_equal(crystal_count(), 6);
    /* Only tourmaline absorbs, and its ordinary ray far more than its extraordinary one. */
    double ao, ae;
    crystal_absorption_eval(&crystal_find("tourmaline")->absorption, 550.0, &ao, &ae);
    assert_true(ao > 10.0 * ae && ae > 0.0);
    crystal_absorption_eval(&crystal_find("calcite")->absorption, 550.0, &ao, &ae);
    assert_true(ao == 0.0 && ae == 0.0);
}

/* 1/n^2 = cos^2/n_o^2 + sin^2/n_e^2: n_o along the axis, n_e across it, and at 45 degrees the
 * harmonic mean of the squares. */
static void test_e_index(void **state)
{
    (void)state;
    const double no = 1.6584, ne = 1.4864;
    testutil_assert_near(uniaxial_e_index(no, ne, 1.0), no, 1e-15);
    testutil_assert_near(uniaxial_e_index(no, ne, -1.0), no, 1e-15);
    testutil_assert_near(uniaxial_e_index(no, ne, 0.0), ne, 1e-15);
    testutil_assert_near(uniaxial_e_index(no, ne, sqrt(0.5)),
                         sqrt(2.0 / (1 / (no * no) + 1 / (ne * ne))), 1e-14);
    const vec3_t c = vec3_make(0, 0, 1);
    testutil_assert_near(uniaxial_index(UNIAXIAL_E, vec3_make(1, 0, 0), c, no, ne), ne, 1e-15);
    testutil_assert_near(uniaxial_index(UNIAXIAL_O, vec3_make(1, 0, 0), c, no, ne), no, 1e-15);
    /* The ray and wave directions: one the inverse of the other; along and across the axis
     * they coincide (no walk-off). */
    for (double th = 0.05; th < PI; th += 0.3) {
        vec3_t k = vec3_make(sin(th), 0.0, cos(th));
        vec3_t s = uniaxial_ray_from_wave(UNIAXIAL_E, k, c, no, ne);
        vec3_t k2 = uniaxial_wave_from_ray(UNIAXIAL_E, s, c, no, ne);
        testutil_assert_near(vec3_dot(k, k2), 1.0, 1e-14);
    }
    testutil_assert_near(uniaxial_ray_from_wave(UNIAXIAL_E, c, c, no, ne).z, 1.0, 1e-15);
    testutil_assert_near(uniaxial_ray_from_wave(UNIAXIAL_E, vec3_make(0, 1, 0), c, no, ne).y, 1.0,
                         1e-15);
}

/* The walk-off angle rho of the e-ray against the closed form of Yariv & Yeh (Optical Waves in
 * Crystals, eq. 4.3-8): tan rho = (n_o^2 - n_e^2) sin(th) cos(th) / (n_e^2 cos^2 th + n_o^2 sin^2
 * th) (in magnitude), for the ray the module computes from the wave normal. Calcite at 45 degrees
 * walks off by 6.2 degrees (the textbook figure). */
static void test_walkoff(void **state)
{
    (void)state;
    const double no = 1.6584, ne = 1.4864;
    const vec3_t c = vec3_make(0, 0, 1);
    for (double th = 0.1; th < PI / 2; th += 0.1) {
        const double want = atan(fabs((no * no - ne * ne) * sin(th) * cos(th)) /
                                 (ne * ne * cos(th) * cos(th) + no * no * sin(th) * sin(th)));
        vec3_t k = vec3_make(sin(th), 0.0, cos(th));
        vec3_t s = uniaxial_ray_from_wave(UNIAXIAL_E, k, c, no, ne);
        testutil_assert_near(acos(fmin(1.0, vec3_dot(k, s))), want, 1e-7);
        testutil_assert_near(uniaxial_walkoff(no, ne, th), want, 1e-12);
        assert_true(fabs(s.y) < 1e-15); /* in the plane of k and c */
    }
    testutil_assert_near(uniaxial_walkoff(no, ne, PI / 4) * 180 / PI, 6.2, 0.05);
}

/* The ordinary ray is an isotropic dielectric of index n_o: its direction is Snell's (as
 * bsdf/delta.h's), whatever the axis. With the axis perpendicular to the plane of incidence
 * the o-wave is p-polarised and the e-wave s-polarised at n_e exactly, so each transmits its
 * Fresnel term of Hecht's eq. 4.42-4.43 and the reflection is their mean. */
static void test_ordinary_snell(void **state)
{
    (void)state;
    const double no = 1.6584, ne = 1.4864;
    const vec3_t up = vec3_make(0, 0, 1);
    const vec3_t axes[3] = {vec3_make(0, 1, 0), vec3_normalize(vec3_make(1, 1, 1)),
                            vec3_make(0, 0, 1)};
    for (double deg = 0.0; deg < 89.0; deg += 7.0) {
        const double th = deg * PI / 180.0;
        const vec3_t d = vec3_make(sin(th), 0.0, -cos(th));
        delta_dielectric_t iso;
        delta_dielectric_make(d, up, true, &no, 1, BSDF_IMPORTANCE, &iso);
        for (int a = 0; a < 3; a++) {
            uniaxial_event_t e;
            uniaxial_event_make(d, up, true, UNIAXIAL_O, axes[a], &no, &ne, 1, BSDF_IMPORTANCE, &e);
            assert_int_equal(e.nbranch, 3);
            assert_int_equal(e.branch[1].after, UNIAXIAL_O);
            testutil_assert_near(vec3_dot(e.branch[1].dir, iso.refract), 1.0, 1e-14);
            testutil_assert_near(vec3_dot(e.branch[0].dir, iso.reflect), 1.0, 1e-14);
            testutil_assert_near(e.branch[1].n_after, no, 1e-14);
        }
        /* Axis along y, perpendicular to the plane of incidence xz. */
        uniaxial_event_t e;
        uniaxial_event_make(d, up, true, UNIAXIAL_O, axes[0], &no, &ne, 1, BSDF_IMPORTANCE, &e);
        const double ci = cos(th), si = sin(th);
        const double cto = sqrt(1 - si * si / (no * no)), cte = sqrt(1 - si * si / (ne * ne));
        const double rp_o = (no * ci - cto) / (no * ci + cto);
        const double rs_e = (ci - ne * cte) / (ci + ne * cte);
        testutil_assert_near(e.branch[1].prob, 0.5 * (1 - rp_o * rp_o), 1e-12);
        testutil_assert_near(e.branch[2].prob, 0.5 * (1 - rs_e * rs_e), 1e-12);
        testutil_assert_near(e.branch[2].n_after, ne, 1e-12);
        testutil_assert_near(e.branch[0].prob, 0.5 * (rp_o * rp_o + rs_e * rs_e), 1e-12);
        /* The e-ray across the axis obeys Snell with n_e. */
        testutil_assert_near(e.branch[2].dir.x, si / ne, 1e-12);
        /* The Mueller matrices' [0][0] are the branch probabilities. */
        for (int b = 0; b < 3; b++) {
            mueller_t m = uniaxial_branch_mueller(&e, b);
            testutil_assert_near(m.m[0][0], e.branch[b].prob, 1e-12);
        }
    }
}

/* A calcite plate (faces z = 0 and z = -t) with its axis at 45 degrees in the xz plane, a ray at
 * normal incidence: the o-ray goes straight through, the e-ray walks off by rho and leaves
 * parallel to the incident ray, displaced by t tan(rho) (the double image of Iceland spar);
 * tan(rho) from the indices alone, Yariv & Yeh eq. 4.3-8. Traced through the event functions,
 * radiance mode: the factors in and out multiply to 1 (the path ends where it started, in air). */
static void test_double_image_traced(void **state)
{
    (void)state;
    const crystal_t *cal = crystal_find("calcite");
    const vec3_t up = vec3_make(0, 0, 1), axis = vec3_normalize(vec3_make(1, 0, 1));
    const vec3_t down = vec3_make(0, 0, -1);
    const double t = 2.0;
    for (double lambda = 400.0; lambda <= 700.0; lambda += 100.0) {
        const double no = n_at(&cal->no, lambda), ne = n_at(&cal->ne, lambda), th = PI / 4;
        const double tan_rho = (no * no - ne * ne) * sin(th) * cos(th) /
                               (ne * ne * cos(th) * cos(th) + no * no * sin(th) * sin(th));
        uniaxial_event_t in, out;
        uniaxial_event_make(down, up, true, UNIAXIAL_O, axis, &no, &ne, 1, BSDF_RADIANCE, &in);
        double x[2];
        for (int w = 0; w < 2; w++) {
            const uniaxial_branch_t *b = &in.branch[1 + w];
            /* From (0, 0, 0) along b->dir to the bottom face z = -t. */
            const double s = -t / b->dir.z;
            x[w] = s * b->dir.x;
            uniaxial_event_make(b->dir, up, false, b->after, axis, &no, &ne, 1, BSDF_RADIANCE,
                                &out);
            assert_int_equal(out.nbranch, 3);
            /* At normal incidence nothing is converted: the waves' fields are s and p. */
            testutil_assert_near(out.branch[2].prob, 0.0, 1e-20);
            testutil_assert_near(vec3_dot(out.branch[1].dir, down), 1.0, 1e-12);
            testutil_assert_near(b->factor * out.branch[1].factor, 1.0, 1e-12);
            /* Normal incidence: the same transmittance in and out, 4 n / (n + 1)^2. */
            const double n = b->n_after;
            testutil_assert_near(out.branch[1].prob, 4 * n / ((n + 1) * (n + 1)), 1e-12);
        }
        testutil_assert_near(x[0], 0.0, 1e-14);
        testutil_assert_near(fabs(x[1]), t * tan_rho, 1e-9);
    }
}

/* From inside beyond the critical angle every wave reflects totally, in its own mode; below it
 * some leaves. The o-wave's critical angle is asin(1 / n_o); the e-wave's is where its own
 * n(theta) sin(i) reaches 1. An e-wave reflected stays e and its ray walks off afresh. */
static void test_tir(void **state)
{
    (void)state;
    const double no = 1.6584, ne = 1.4864;
    const vec3_t up = vec3_make(0, 0, 1), axis = vec3_make(0, 1, 0); /* across the plane */
    const double crit_o = asin(1 / no), crit_e = asin(1 / ne);
    for (int w = 0; w < 2; w++) {
        const double crit = w ? crit_e : crit_o;
        for (double f = 0.8; f < 1.25; f += 0.1) {
            const double th = fmin(f * crit, 1.5);
            const vec3_t d = vec3_make(sin(th), 0.0, cos(th)); /* inside, toward the face */
            uniaxial_event_t e;
            uniaxial_event_make(d, up, false, (uniaxial_wave_t)w, axis, &no, &ne, 1,
                                BSDF_IMPORTANCE, &e);
            assert_int_equal(e.branch[0].after, (uniaxial_wave_t)w);
            assert_true(e.branch[0].dir.z < 0.0);
            if (th > crit * 1.0001)
                testutil_assert_near(e.branch[0].prob, 1.0, 0.0);
            else if (th < crit * 0.9999)
                assert_true(e.branch[1].prob > 0.0 && e.branch[0].prob < 1.0);
        }
    }
    /* With the axis tilted the e-wave's reflection changes its angle to the axis (its index) and
     * the radiance factor (n_i / n_r)^2 says so. */
    const vec3_t tilt = vec3_normalize(vec3_make(1, 0, 2));
    const vec3_t k = vec3_normalize(vec3_make(0.9, 0.0, 0.5));
    const vec3_t s = uniaxial_ray_from_wave(UNIAXIAL_E, k, tilt, no, ne);
    uniaxial_event_t e;
    uniaxial_event_make(s, up, false, UNIAXIAL_E, tilt, &no, &ne, 1, BSDF_RADIANCE, &e);
    testutil_assert_near(e.branch[0].prob, 1.0, 0.0);
    const double n_in = uniaxial_index(UNIAXIAL_E, k, tilt, no, ne);
    testutil_assert_near(e.branch[0].n_after,
                         uniaxial_index(UNIAXIAL_E, e.branch[0].wave, tilt, no, ne), 1e-12);
    testutil_assert_near(e.branch[0].factor, pow(n_in / e.branch[0].n_after, 2), 1e-12);
    /* The tangential wave vector is continuous on reflection. */
    testutil_assert_near(n_in * k.x, e.branch[0].n_after * e.branch[0].wave.x, 1e-12);
    testutil_assert_near(n_in * k.y, e.branch[0].n_after * e.branch[0].wave.y, 1e-12);
}

/* Every event conserves energy: the branch probabilities sum to 1, entering and leaving, over
 * many directions, axes and crystals; the Mueller matrices' [0][0] are the probabilities from
 * outside, half of them inside (light in a wave is fully polarised: unpolarised light would
 * pass half). */
static void test_energy_events(void **state)
{
    (void)state;
    uint64_t x = 12345;
    for (int i = 0; i < 4000; i++) {
        double r[6];
        for (int k = 0; k < 6; k++) {
            x = x * 6364136223846793005ULL + 1442695040888963407ULL;
            r[k] = (double)(x >> 11) / 9007199254740992.0;
        }
        const crystal_t *c = crystal_get(i % crystal_count());
        const double no = n_at(&c->no, 400 + 300 * r[5]), ne = n_at(&c->ne, 400 + 300 * r[5]);
        const vec3_t d = vec3_normalize(vec3_make(r[0] - 0.5, r[1] - 0.5, r[2] - 0.5));
        const vec3_t axis = vec3_normalize(vec3_make(r[3] - 0.5, r[4] - 0.5, r[5] - 0.4));
        const vec3_t nrm = vec3_make(0, 0, 1);
        if (!(fabs(d.z) > 1e-3))
            continue;
        for (int mode = 0; mode < 3; mode++) {
            const bool entering = mode == 0 ? d.z < 0 : false;
            const uniaxial_wave_t w = mode == 2 ? UNIAXIAL_E : UNIAXIAL_O;
            uniaxial_event_t e;
            uniaxial_event_make(d, nrm, entering, w, axis, &no, &ne, 1, BSDF_IMPORTANCE, &e);
            double sum = 0.0;
            for (int b = 0; b < e.nbranch; b++) {
                assert_true(e.branch[b].prob >= 0.0 && e.branch[b].prob <= 1.0);
                sum += e.branch[b].prob;
                mueller_t m = uniaxial_branch_mueller(&e, b);
                testutil_assert_near(m.m[0][0], (entering ? 1.0 : 0.5) * e.branch[b].prob, 1e-12);
                if (e.branch[b].prob > 0.0)
                    testutil_assert_near(vec3_length(e.branch[b].dir), 1.0, 1e-12);
            }
            testutil_assert_near(sum, 1.0, 1e-12);
        }
    }
}

/* ---- the boundary's exact amplitudes and mode conversion (polar/uniaxial_fresnel.h) ---- */

static double lcg01(uint64_t *x)
{
    *x = *x * 6364136223846793005ULL + 1442695040888963407ULL;
    return (double)(*x >> 11) / 9007199254740992.0;
}

/* Energy at the interface, from each incident wave (outside s and p, inside o and e): the
 * power reflected into o and e plus the power transmitted is the incident power, for a lossless
 * crystal, over many angles, axis orientations and crystals (the solver's raw fractions, not
 * renormalised). The reflection law of each mode: every wave leaving has the incident tangential
 * wave vector, lies on its own index surface and carries energy away from the face; an o wave
 * reflected inside a tilted crystal feeds the e wave, which leaves at another angle (mode
 * conversion happens: the old model kept the mode). Reciprocity (Stokes-Helmholtz): the power
 * from wave i into wave o equals that from o reversed into i reversed. */
static void test_mode_conversion_energy(void **state)
{
    (void)state;
    uint64_t x = 777;
    int converted = 0, cases = 0;
    double max_conv = 0.0, max_err = 0.0, max_rec = 0.0;
    const vec3_t nrm = vec3_make(0, 0, 1);
    for (int i = 0; i < 3000; i++) {
        const crystal_t *c = crystal_get(i % crystal_count());
        const double lam = 400 + 300 * lcg01(&x);
        const double no = n_at(&c->no, lam), ne = n_at(&c->ne, lam);
        vec3_t axis = vec3_normalize(vec3_make(lcg01(&x) - 0.5, lcg01(&x) - 0.5, lcg01(&x) - 0.5));
        if (i % 7 == 0) /* the axis in the face, as in a cleaved plate */
            axis = vec3_normalize(vec3_make(axis.x, axis.y, 0.0));
        /* A wave inside travelling toward the face z = 0 from below. */
        const double ct = 0.02 + 0.98 * lcg01(&x), ph = 2 * PI * lcg01(&x);
        const vec3_t k = vec3_make(sqrt(1 - ct * ct) * cos(ph), sqrt(1 - ct * ct) * sin(ph), ct);
        for (int w = 0; w < 2; w++) {
            const double n_in = uniaxial_index((uniaxial_wave_t)w, k, axis, no, ne);
            const vec3_t ray = uniaxial_ray_from_wave((uniaxial_wave_t)w, k, axis, no, ne);
            if (!(ray.z > 1e-3))
                continue;
            cases++;
            uniaxial_event_t e;
            uniaxial_event_make(ray, nrm, false, (uniaxial_wave_t)w, axis, &no, &ne, 1,
                                BSDF_IMPORTANCE, &e);
            assert_true(e.fres.ok);
            const int fin = w ? UF_E : UF_O;
            double sum = 0.0;
            for (int o = 0; o < UF_WAVES; o++)
                sum += e.fres.power[fin][o];
            max_err = fmax(max_err, fabs(sum - 1.0));
            testutil_assert_near(sum, 1.0, 1e-9);
            for (int b = 0; b < e.nbranch; b++) {
                const uniaxial_branch_t *br = &e.branch[b];
                if (!(br->prob > 0.0))
                    continue;
                /* n_after k_after - n_in k_in is along the normal. */
                testutil_assert_near(br->n_after * br->wave.x, n_in * k.x, 1e-12);
                testutil_assert_near(br->n_after * br->wave.y, n_in * k.y, 1e-12);
                if (br->after != UNIAXIAL_OUTSIDE) {
                    testutil_assert_near(br->n_after,
                                         uniaxial_index(br->after, br->wave, axis, no, ne), 1e-12);
                    assert_true(br->dir.z < 0.0);
                } else {
                    testutil_assert_near(br->n_after, 1.0, 1e-12);
                    assert_true(br->dir.z > 0.0);
                }
            }
            const double conv = e.branch[2].prob;
            max_conv = fmax(max_conv, conv);
            if (conv > 1e-3)
                converted++;
            /* Reciprocity with the boundary solved for -t. */
            uniaxial_fresnel_t rev;
            uniaxial_fresnel_solve(vec3_neg(e.t), e.m, axis, no, ne, 1.0, vec3_make(1, 0, 0), &rev);
            for (int o = 0; o < UF_WAVES; o++) {
                const double back = o < UF_O ? rev.power[o][fin]  /* outside back into fin */
                                             : rev.power[o][fin]; /* the mode back into fin */
                max_rec = fmax(max_rec, fabs(back - e.fres.power[fin][o]));
                testutil_assert_near(back, e.fres.power[fin][o], 1e-9);
            }
        }
        /* From outside, s and p separately. */
        const vec3_t d = vec3_make(-k.x, -k.y, -k.z);
        uniaxial_event_t e;
        uniaxial_event_make(d, nrm, true, UNIAXIAL_O, axis, &no, &ne, 1, BSDF_IMPORTANCE, &e);
        for (int in = UF_S; in <= UF_P; in++) {
            double sum = 0.0;
            for (int o = 0; o < UF_WAVES; o++)
                sum += e.fres.power[in][o];
            max_err = fmax(max_err, fabs(sum - 1.0));
            testutil_assert_near(sum, 1.0, 1e-9);
        }
    }
    printf("interface energy over %d inside cases: |sum - 1| <= %.1e, reciprocity to %.1e; "
           "converted > 1e-3 in %d, at most %.4f\n",
           cases, max_err, max_rec, converted, max_conv);
    assert_true(converted > cases / 10);
}

/* Closed forms. With the axis across the plane of incidence the o wave is p-polarised at n_o
 * and the e wave s-polarised at n_e: each reflects inside with Fresnel's term of an isotropic
 * medium of its index and nothing is converted. With the axis along the normal the o wave is s
 * (n_o) and the e wave p with r_p = (n_o n_e cos i - sqrt(n_e^2 - sin^2 i)) / (n_o n_e cos i +
 * sqrt(n_e^2 - sin^2 i)) from outside (the TM admittances eps_x / k_z; Yeh 1979, Lekner 1991).
 * In the isotropic limit n_o = n_e a wave's total reflection is its field's s and p shares of
 * Fresnel's R_s and R_p, however the converted part is split. */
static void test_mode_conversion_closed_forms(void **state)
{
    (void)state;
    const double no = 1.6584, ne = 1.4864;
    const vec3_t nrm = vec3_make(0, 0, 1);
    for (double deg = 0.0; deg < 89.0; deg += 4.0) {
        const double th = deg * PI / 180.0, si = sin(th), ci = cos(th);
        /* Inside, the axis along y. */
        const vec3_t y = vec3_make(0, 1, 0);
        for (int w = 0; w < 2; w++) {
            const double n = w ? ne : no;
            uniaxial_event_t e;
            uniaxial_event_make(vec3_make(si, 0, ci), nrm, false, (uniaxial_wave_t)w, y, &no, &ne,
                                1, BSDF_IMPORTANCE, &e);
            const polar_fresnel_t f = polar_fresnel_eval(ci, n, 1.0);
            testutil_assert_near(e.branch[0].prob, w ? f.Rs : f.Rp, 1e-12);
            testutil_assert_near(e.branch[2].prob, 0.0, 1e-14);
        }
        /* From outside, the axis along the normal. */
        uniaxial_event_t e;
        uniaxial_event_make(vec3_make(si, 0, -ci), nrm, true, UNIAXIAL_O, nrm, &no, &ne, 1,
                            BSDF_IMPORTANCE, &e);
        const double q = sqrt(ne * ne - si * si);
        const double rp = (no * ne * ci - q) / (no * ne * ci + q);
        const polar_fresnel_t fs = polar_fresnel_eval(ci, 1.0, no);
        const double Rp = e.fres.power[UF_P][UF_S] + e.fres.power[UF_P][UF_P];
        const double Rs = e.fres.power[UF_S][UF_S] + e.fres.power[UF_S][UF_P];
        testutil_assert_near(Rp, rp * rp, 1e-12);
        testutil_assert_near(Rs, fs.Rs, 1e-12);
        testutil_assert_near(e.fres.power[UF_P][UF_O], 0.0, 1e-14);
        testutil_assert_near(e.fres.power[UF_S][UF_E], 0.0, 1e-14);
    }
    /* The isotropic limit, random axes and angles below the critical angle. */
    uint64_t x = 99;
    double max_conv = 0.0;
    for (int i = 0; i < 500; i++) {
        const double n = 1.5;
        const vec3_t axis =
            vec3_normalize(vec3_make(lcg01(&x) - 0.5, lcg01(&x) - 0.5, lcg01(&x) - 0.5));
        const double th = asin(1 / n) * 0.99 * lcg01(&x);
        const vec3_t k = vec3_make(sin(th), 0, cos(th));
        for (int w = 0; w < 2; w++) {
            uniaxial_event_t e;
            uniaxial_event_make(k, nrm, false, (uniaxial_wave_t)w, axis, &n, &n, 1, BSDF_IMPORTANCE,
                                &e);
            /* The wave's field and its share along s = y (perpendicular to the plane xz). */
            const vec3_t o = vec3_normalize(vec3_cross(k, axis));
            const vec3_t d = w ? vec3_cross(o, k) : o;
            const double fs = d.y * d.y;
            const polar_fresnel_t f = polar_fresnel_eval(cos(th), n, 1.0);
            testutil_assert_near(e.branch[0].prob + e.branch[2].prob, fs * f.Rs + (1 - fs) * f.Rp,
                                 1e-12);
            testutil_assert_near(e.branch[1].prob, fs * f.Ts + (1 - fs) * f.Tp, 1e-12);
            max_conv = fmax(max_conv, e.branch[2].prob);
        }
    }
    /* The split is not trivial: light of mixed s and p reflects into the other mode. */
    assert_true(max_conv > 1e-3);
}

/* Polarised light from outside: the branches' Mueller matrices pass, summed, exactly the light's
 * power whatever its state (the old model's polarisers did so only for unpolarised light); light
 * arriving inside in its wave's polarisation likewise (each branch's [0][0] is half of it). */
static void test_mode_conversion_mueller(void **state)
{
    (void)state;
    uint64_t x = 4242;
    const vec3_t nrm = vec3_make(0, 0, 1);
    const double no = 1.6584, ne = 1.4864;
    for (int i = 0; i < 400; i++) {
        const vec3_t axis =
            vec3_normalize(vec3_make(lcg01(&x) - 0.5, lcg01(&x) - 0.5, lcg01(&x) - 0.5));
        const double ct = 0.05 + 0.95 * lcg01(&x), ph = 2 * PI * lcg01(&x);
        const vec3_t d = vec3_make(sqrt(1 - ct * ct) * cos(ph), sqrt(1 - ct * ct) * sin(ph), -ct);
        const double a = PI * lcg01(&x), chi = 0.5 * PI * (lcg01(&x) - 0.5);
        const stokes_t s =
            stokes_make(1.0, cos(2 * chi) * cos(2 * a), cos(2 * chi) * sin(2 * a), sin(2 * chi));
        uniaxial_event_t e;
        uniaxial_event_make(d, nrm, true, UNIAXIAL_O, axis, &no, &ne, 1, BSDF_IMPORTANCE, &e);
        double sum = 0.0;
        for (int b = 0; b < e.nbranch; b++) {
            const mueller_t m = uniaxial_branch_mueller(&e, b);
            sum += mueller_apply(&m, s).s[0];
        }
        testutil_assert_near(sum, 1.0, 1e-9);
    }
}

/* ---- rendered ---- */

/* A box [-a, a]^2 x [z0, z1] as a triangle mesh, outward normals. */
static void box_text(char *out, size_t size, double a, double z0, double z1)
{
    snprintf(out, size,
             "Shape \"trianglemesh\" \"point3 P\" [ %g %g %g  %g %g %g  %g %g %g  %g %g %g"
             "  %g %g %g  %g %g %g  %g %g %g  %g %g %g ]\n"
             "  \"integer indices\" [ 0 2 1  0 3 2  4 5 6  4 6 7  0 1 5  0 5 4  1 2 6  1 6 5"
             "  2 3 7  2 7 6  3 0 4  3 4 7 ]\n",
             -a, -a, z0, a, -a, z0, a, a, z0, -a, a, z0, -a, -a, z1, a, -a, z1, a, a, z1, -a, a,
             z1);
}

/* Renders s (res x res, spp; with its photon pass if it has one) and splits its light at the
 * luminance centroid's column: the two halves' centroids' distance along x in pixels, the left
 * half's share of the light and the centroids' difference along y in pixels. */
static void two_images(scene_t *s, int res, int spp, double *sep, double *frac, double *dy)
{
    err_t err;
    photon_store_t *photons = NULL;
    if (s->settings.photon.enabled && !(photons = photon_pass_run(s, 0, NULL, NULL, &err)))
        fail_msg("photon pass: %s", err.msg);
    tilebuf_t *t = tilebuf_new(0, 0, res, res, s->settings.grid.n, &err);
    assert_non_null(t);
    render_stats_t rst = {0};
    assert_int_equal(render_tile(s, photons, 0, 0, res, res, 0, (uint32_t)spp, t, &rst, &err), 0);
    assert_int_equal(rst.nonfinite, 0);
    double sum = 0, sx = 0;
    static double L[128][128];
    assert_true(res <= 128);
    for (int y = 0; y < res; y++)
        for (int x = 0; x < res; x++) {
            L[y][x] = tilebuf_luminance_sum(t, x, y) / (double)tilebuf_count(t, x, y);
            sum += L[y][x];
            sx += L[y][x] * (x + 0.5);
        }
    assert_true(sum > 0.0);
    const double cx = sx / sum;
    double w[2] = {0, 0}, m[2] = {0, 0}, my[2] = {0, 0};
    for (int y = 0; y < res; y++)
        for (int x = 0; x < res; x++) {
            int side = x + 0.5 > cx;
            w[side] += L[y][x];
            m[side] += L[y][x] * (x + 0.5);
            my[side] += L[y][x] * (y + 0.5);
        }
    assert_true(w[0] > 0.0 && w[1] > 0.0);
    *sep = m[1] / w[1] - m[0] / w[0];
    *frac = w[0] / sum;
    *dy = my[1] / w[1] - my[0] / w[0];
    tilebuf_destroy(&t);
    photon_store_destroy(&photons);
}

/* The scene of the double-image tests: a calcite plate (thickness 2, axis at 45 degrees in xz)
 * before a small bright disk, seen at res x res through an orthographic camera with
 * camera_extra's parameters ("" for none). */
static void plate_scene_text(char *text, size_t size, int res, const char *camera_extra)
{
    char box[1024];
    box_text(box, sizeof box, 3.0, -1.0, 1.0);
    snprintf(
        text, size,
        "LookAt 0 0 5  0 0 0  0 1 0\n"
        "Camera \"orthographic\" \"float screenwindow\" [ -0.5 0.5 -0.5 0.5 ] %s\n"
        "Film \"spectral\" \"integer xresolution\" [ %d ] \"integer yresolution\" [ %d ]\n"
        "    \"integer nbuckets\" [ 8 ]\n"
        "Sampler \"independent\" \"integer pixelsamples\" [ 16 ]\n"
        "Integrator \"path\" \"integer maxdepth\" [ 20 ] \"string wavelengths\" \"uniform\"\n"
        "WorldBegin\n"
        "AttributeBegin\n"
        "  Material \"uniaxial\" \"string crystal\" \"calcite\" \"vector3 opticaxis\" [ 1 0 1 ]\n"
        "  %s"
        "AttributeEnd\n"
        "AttributeBegin\n"
        "  AreaLightSource \"diffuse\" \"rgb L\" [ 10 10 10 ]\n"
        "  Translate 0 0 -1.5\n"
        "  Shape \"disk\" \"float radius\" [ 0.04 ]\n"
        "AttributeEnd\n",
        camera_extra, res, res, box);
}

/* The rendered double image: an orthographic camera looks straight down through a calcite plate
 * (thickness 2, axis at 45 degrees in xz) at a small bright disk. Two images of it appear,
 * separated along x by t tan(rho), rho from the indices at the luminance-weighted middle of the
 * spectrum (555 nm; the walk-off varies by a few percent over the visible, well inside a pixel
 * here), with equal brightness within noise (the o and e transmittances at normal incidence
 * differ by 1 %). */
static void test_double_image_rendered(void **state)
{
    (void)state;
    const int res = 64;
    char text[4096];
    plate_scene_text(text, sizeof text, res, "");
    scene_t *s = sb_load_text(text, NULL);
    double sep, frac, dy;
    two_images(s, res, 16, &sep, &frac, &dy);
    sep /= res; /* scene units: the view is 1 wide */
    const crystal_t *cal = crystal_find("calcite");
    const double no = n_at(&cal->no, 555.0), ne = n_at(&cal->ne, 555.0), th = PI / 4;
    const double tan_rho = (no * no - ne * ne) * sin(th) * cos(th) /
                           (ne * ne * cos(th) * cos(th) + no * no * sin(th) * sin(th));
    const double px = 1.0 / res;
    print_message("double image: separation %.4f, t tan(rho) %.4f; brightness %.3f : %.3f\n", sep,
                  2.0 * tan_rho, frac, 1 - frac);
    testutil_assert_near(sep, 2.0 * tan_rho, 0.5 * px + 0.03 * 2.0 * tan_rho);
    /* Both images on the same row (the walk-off is in the xz plane). */
    testutil_assert_near(dy, 0.0, 0.5);
    testutil_assert_near(frac, 0.5, 0.08);
    scene_destroy(&s);
}

/* The plate of test_double_image_rendered seen through the camera's analyser (polarised
 * transport, docs/physics.md §15): the o wave leaves polarised perpendicular to the principal
 * plane (the xz plane of the axis and the view: along y), the e wave within it (along x), so an
 * analyser along the image's x passes the e image and all but extinguishes the o image, and one
 * along y the reverse (Born & Wolf §15.3.4; at normal incidence the approximation's magnitudes
 * suffice). Without the analyser, polarised transport gives each image about half, as
 * unpolarised. Renders the plate with the camera's extra parameters, polarised transport forced
 * on or not, into the S0 plane's light per image column (res columns). */
#define ANALYSED_RES 64
static void analysed_columns(const char *camera_extra, int polarised, double *col)
{
    const int res = ANALYSED_RES;
    char text[4096];
    plate_scene_text(text, sizeof text, res, camera_extra);
    scene_t *s = sb_load_text(text, NULL);
    if (polarised)
        s->settings.polarised = 1;
    assert_int_equal(s->settings.polarised, polarised || camera_extra[0]);
    err_t err;
    const int nb = s->settings.grid.n;
    tilebuf_t *t = tilebuf_new(0, 0, res, res, render_settings_buckets(&s->settings), &err);
    assert_non_null(t);
    render_stats_t rst = {0};
    assert_int_equal(render_tile(s, NULL, 0, 0, res, res, 0, 16, t, &rst, &err), 0);
    assert_int_equal(rst.nonfinite, 0);
    for (int x = 0; x < res; x++) {
        col[x] = 0.0;
        for (int y = 0; y < res; y++)
            for (int b = 0; b < nb; b++)
                col[x] += tilebuf_sum(t, x, y, b) / (double)tilebuf_count(t, x, y);
    }
    tilebuf_destroy(&t);
    scene_destroy(&s);
}

/* The light left and right of column cx. */
static void halves(const double *col, double cx, double w[2])
{
    w[0] = w[1] = 0.0;
    for (int x = 0; x < ANALYSED_RES; x++)
        w[x + 0.5 > cx] += col[x];
}

static void test_double_image_analysed(void **state)
{
    (void)state;
    double plain[ANALYSED_RES], polar[ANALYSED_RES], ax[ANALYSED_RES], ay[ANALYSED_RES];
    analysed_columns("", 0, plain);
    analysed_columns("", 1, polar);
    analysed_columns("\"float analyzer\" [ 0 ]", 0, ax);
    analysed_columns("\"float analyzer\" [ 90 ]", 0, ay);
    /* The two images are split at the unpolarised render's centroid column. */
    double sum = 0.0, sx = 0.0;
    for (int x = 0; x < ANALYSED_RES; x++) {
        sum += plain[x];
        sx += plain[x] * (x + 0.5);
    }
    assert_true(sum > 0.0);
    const double cx = sx / sum;
    double wp[2], wq[2], wx[2], wy[2];
    halves(plain, cx, wp);
    halves(polar, cx, wq);
    halves(ax, cx, wx);
    halves(ay, cx, wy);
    print_message("analysed double image (left : right): unpolarised %.2f : %.2f, polarised "
                  "%.2f : %.2f, analyser 0 %.2f : %.2f, analyser 90 %.2f : %.2f\n",
                  wp[0], wp[1], wq[0], wq[1], wx[0], wx[1], wy[0], wy[1]);
    /* Polarised transport without an analyser: the images as without it, about half each. */
    testutil_assert_near(wq[0] / (wq[0] + wq[1]), 0.5, 0.08);
    testutil_assert_near(wq[0] + wq[1], wp[0] + wp[1], 0.02 * (wp[0] + wp[1]));
    /* Each analyser all but extinguishes one image and passes the other, the roles swapped
     * at 90 degrees; each passed image carries about its unanalysed light. */
    const int ex = wx[0] < wx[1] ? 0 : 1;
    assert_true(wx[ex] < 0.05 * wx[1 - ex]);
    assert_true(wy[1 - ex] < 0.05 * wy[ex]);
    testutil_assert_near(wx[1 - ex], wq[1 - ex], 0.1 * wq[1 - ex]);
    testutil_assert_near(wy[ex], wq[ex], 0.1 * wq[ex]);
    /* Which image is which: the one the analyser along y passes (the o wave, polarised
     * perpendicular to the principal plane) lies under the disk, at the image's centre (the o
     * wave is not walked off at normal incidence); the one the analyser along x passes (e)
     * lies t tan(rho) = 0.22 of the view (14 pixels) away. */
    double cy = 0.0, cxe = 0.0, sy = 0.0, sxe = 0.0;
    for (int x = 0; x < ANALYSED_RES; x++) {
        cy += ay[x] * (x + 0.5);
        sy += ay[x];
        cxe += ax[x] * (x + 0.5);
        sxe += ax[x];
    }
    cy /= sy;
    cxe /= sxe;
    print_message("o image (analyser 90) at column %.2f, e image (analyser 0) at %.2f\n", cy, cxe);
    testutil_assert_near(cy, 0.5 * ANALYSED_RES, 1.0);
    testutil_assert_near(fabs(cxe - cy), 0.22 * ANALYSED_RES, 1.0);
}

/* The same plate in the photon pass (importance mode): a narrow collimated beam straight down
 * through it lands on the floor as two spots t tan(rho) apart, each with half the flux, seen
 * from the side below the plate (the spots' offset is across the line of sight, at the
 * distance the view is aimed at: fov 12 degrees spans 2 D tan 6 deg). */
static void test_double_image_photons(void **state)
{
    (void)state;
    const int res = 128;
    char box[1024], text[4096];
    box_text(box, sizeof box, 3.0, 1.0, 3.0);
    snprintf(
        text, sizeof text,
        "LookAt 0 -4 1.2  0 0 0  0 0 1\n"
        "Camera \"perspective\" \"float fov\" [ 12 ]\n"
        "Film \"spectral\" \"integer xresolution\" [ %d ] \"integer yresolution\" [ %d ]\n"
        "    \"integer nbuckets\" [ 8 ]\n"
        "Sampler \"independent\" \"integer pixelsamples\" [ 4 ]\n"
        "Integrator \"photon\" \"integer photons\" [ 100000 ] \"float radius\" [ 0.01 ]\n"
        "    \"integer maxdepth\" [ 8 ]\n"
        "WorldBegin\n"
        "AttributeBegin\n"
        "  Material \"uniaxial\" \"string crystal\" \"calcite\" \"vector3 opticaxis\" [ 1 0 1 ]\n"
        "  %s"
        "AttributeEnd\n"
        "Shape \"trianglemesh\" \"point3 P\" [ -5 -5 0  5 -5 0  5 5 0  -5 5 0 ]\n"
        "    \"integer indices\" [ 0 1 2  0 2 3 ]\n"
        "AttributeBegin\n"
        "  AreaLightSource \"collimated\" \"rgb L\" [ 1 1 1 ]\n"
        "  Translate 0 0 4\n"
        "  ReverseOrientation\n"
        "  Shape \"disk\" \"float radius\" [ 0.03 ]\n"
        "AttributeEnd\n",
        res, res, box);
    scene_t *s = sb_load_text(text, NULL);
    double sep, frac, dy;
    two_images(s, res, 4, &sep, &frac, &dy);
    const double px = 2.0 * sqrt(4.0 * 4.0 + 1.2 * 1.2) * tan(6.0 * PI / 180.0) / res;
    sep *= px;
    const crystal_t *cal = crystal_find("calcite");
    const double no = n_at(&cal->no, 555.0), ne = n_at(&cal->ne, 555.0), th = PI / 4;
    const double tan_rho = (no * no - ne * ne) * sin(th) * cos(th) /
                           (ne * ne * cos(th) * cos(th) + no * no * sin(th) * sin(th));
    print_message("photon double image: separation %.4f, t tan(rho) %.4f; flux %.3f : %.3f\n", sep,
                  2.0 * tan_rho, frac, 1 - frac);
    testutil_assert_near(sep, 2.0 * tan_rho, px + 0.03 * 2.0 * tan_rho);
    testutil_assert_near(frac, 0.5, 0.1);
    scene_destroy(&s);
}

/* A crystal sphere in a white furnace vanishes: no absorption, every event conserves energy
 * and the radiance factors telescope, in hero and fan-out lanes alike. */
static void furnace(const char *crystal, const char *integrator_extra, int spp, double tol)
{
    char text[2048];
    snprintf(
        text, sizeof text,
        "LookAt 0 0 -4  0 0 0  0 1 0\n"
        "Camera \"perspective\" \"float fov\" [ 24 ]\n"
        "Film \"spectral\" \"integer xresolution\" [ 12 ] \"integer yresolution\" [ 12 ]\n"
        "    \"integer nbuckets\" [ 8 ]\n"
        "Sampler \"independent\" \"integer pixelsamples\" [ 4 ]\n"
        "Integrator \"path\" \"integer maxdepth\" [ 200 ] \"string wavelengths\" \"uniform\" %s\n"
        "WorldBegin\n"
        "LightSource \"infinite\" \"spectrum L\" [ 300 1 900 1 ]\n"
        "Rotate 30 1 1 0\n"
        "Material \"uniaxial\" %s \"vector3 opticaxis\" [ 0.3 1 0.2 ]\n"
        "Shape \"sphere\" \"float radius\" [ 1 ]\n",
        integrator_extra, crystal);
    scene_t *s = sb_load_text(text, NULL);
    sb_image_stats_t st = sb_render_stats(s, 12, spp);
    scene_t *e = sb_load_text(
        "LookAt 0 0 -4  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 24 ]\n"
        "Film \"spectral\" \"integer xresolution\" [ 12 ] \"integer yresolution\" [ 12 ]\n"
        "    \"integer nbuckets\" [ 8 ]\n"
        "Integrator \"path\" \"string wavelengths\" \"uniform\"\n"
        "WorldBegin\nLightSource \"infinite\" \"spectrum L\" [ 300 1 900 1 ]\n",
        NULL);
    sb_image_stats_t ref = sb_render_stats(e, 12, 4);
    const double ratio = st.mean / ref.mean, se = st.se / ref.mean;
    print_message("furnace %s %s: %.5f +- %.5f\n", crystal, integrator_extra, ratio, se);
    /* Paths trapped past maxdepth by total reflection are the only loss. */
    if (!(ratio > 1.0 - tol - 4 * se && ratio < 1.0 + 4 * se + 1e-9))
        fail_msg("furnace %s: %.5f +- %.5f", crystal, ratio, se);
    scene_destroy(&s);
    scene_destroy(&e);
}

static void test_furnace(void **state)
{
    (void)state;
    /* Constant indices: every lane follows every branch, so each sample is 1 up to rounding
     * and to the paths maxdepth cuts (none at these indices). */
    furnace("\"float o.eta\" [ 1.6584 ] \"float e.eta\" [ 1.4864 ]", "", 4, 1e-6);
    furnace("\"float o.eta\" [ 2.613 ] \"float e.eta\" [ 2.909 ]", "", 4, 1e-3);
    /* Dispersive: the hero's termination and the fan-out's pick add spectral noise only. */
    furnace("\"string crystal\" \"calcite\"", "", 64, 0.005);
    furnace("\"string crystal\" \"calcite\"", "\"string dispersion\" \"fanout\"", 64, 0.005);
    /* Coherent (render/crystal_coherent.h; polarisation on): both waves as one ray, every
     * internal reflection converting between them in one Jones matrix, the branches chosen by
     * the unpolarised transmittance and divided out of the carrier. */
    furnace("\"float o.eta\" [ 1.6584 ] \"float e.eta\" [ 1.4864 ] \"bool coherent\" true", "", 16,
            1e-3);
    furnace("\"string crystal\" \"quartz\" \"bool coherent\" true", "", 16, 1e-3);
    furnace("\"string crystal\" \"calcite\" \"bool coherent\" true",
            "\"string dispersion\" \"fanout\"", 16, 0.005);
}

/* A tourmaline plate 1 mm thick at normal incidence with its axis in the plate (the e-wave
 * travels across the axis): the o-ray's transmittance is T_in T_out exp(-alpha_o), the
 * e-ray's T_in T_out exp(-alpha_e), Beer-Lambert at the catalogue's coefficients. Traced with
 * crystal_scatter (absorption included) in importance mode over many choices: the mean flux
 * out of the bottom per wave, against the closed form. */
#include "crystal_scatter.h"
static void test_dichroic_plate(void **state)
{
    (void)state;
    const material_uniaxial_t cr = {
        .crystal = *crystal_find("tourmaline"), .optic_axis = {1, 0, 0}, .mm_per_unit = 1.0};
    material_t m = {.kind = MATERIAL_DIELECTRIC, .data_kind = MATERIAL_UNIAXIAL, .data = &cr};
    m.ior = cr.crystal.no;
    const double lambda = 550.0;
    const double no = n_at(&cr.crystal.no, lambda), ne = n_at(&cr.crystal.ne, lambda);
    double ao, ae;
    crystal_absorption_eval(&cr.crystal.absorption, lambda, &ao, &ae);
    shape_t sh = {0};
    surface_t top = {.shape = &sh,
                     .material = &m,
                     .p = vec3_make(0, 0, 0),
                     .ng = vec3_make(0, 0, 1),
                     .ns = vec3_make(0, 0, 1)};
    surface_t bottom = top;
    bottom.p = vec3_make(0, 0, -1.0);
    bottom.ng = bottom.ns = vec3_make(0, 0, -1);
    double out[2] = {0, 0};
    const int N = 20000;
    for (int i = 0; i < N; i++) {
        double w = 1.0;
        int wave = 0, end;
        vec3_t dir;
        const double u = (i + 0.5) / N;
        assert_int_equal(crystal_scatter(&m, &top, cr.optic_axis, vec3_make(0, 0, 1),
                                         vec3_make(0, 0, -1), &wave, 1, &lambda, &w,
                                         BSDF_IMPORTANCE, u, &dir, &end, NULL),
                         0);
        if (dir.z > 0)
            continue; /* reflected */
        const int inw = wave;
        /* Straight down to the bottom (normal incidence, k across the axis: no walk-off), and
         * leaving with the second uniform (a stratified second dimension). */
        const double u2 = fmod(u * 7919.0, 1.0);
        if (crystal_scatter(&m, &bottom, cr.optic_axis, top.p, dir, &wave, 1, &lambda, &w,
                            BSDF_IMPORTANCE, u2, &dir, &end, NULL))
            continue;
        if (dir.z < 0)
            out[inw] += w / N;
    }
    const double To = 4 * no / ((no + 1) * (no + 1)), Te = 4 * ne / ((ne + 1) * (ne + 1));
    const double want_o = 0.5 * To * To * exp(-ao), want_e = 0.5 * Te * Te * exp(-ae);
    print_message("tourmaline 1 mm: o %.5f (want %.5f), e %.5f (want %.5f)\n", out[0], want_o,
                  out[1], want_e);
    testutil_assert_near(out[0], want_o, 0.02 * want_o + 2e-4);
    testutil_assert_near(out[1], want_e, 0.02 * want_e);
}

/* The scene syntax: explicit indices, and errors that name the file and line. */
static void test_syntax(void **state)
{
    (void)state;
    scene_t *s = sb_load_text(
        "WorldBegin\n"
        "Material \"uniaxial\" \"float o.eta\" [ 1.6 ] \"float e.cauchy\" [ 1.5 0.004 ]\n"
        "  \"float sigma_o\" [ 0.5 ] \"float mmperunit\" [ 10 ]\n"
        "Translate 0 0 1  Rotate 90 0 1 0\n"
        "Shape \"sphere\"\n",
        NULL);
    const material_t *m = &s->materials[s->shapes[0].material];
    const material_uniaxial_t *u = material_uniaxial_of(m);
    assert_true(u && m->kind == MATERIAL_DIELECTRIC);
    testutil_assert_near(n_at(&u->crystal.no, 500), 1.6, 1e-15);
    testutil_assert_near(n_at(&u->crystal.ne, 500), 1.5 + 0.004 / 0.25, 1e-12);
    testutil_assert_near(u->mm_per_unit, 10.0, 0.0);
    /* The axis [0 0 1] turned with the shape: a rotation of 90 degrees about y takes z to x. */
    testutil_assert_near(u->optic_axis.x, 1.0, 1e-12);
    scene_destroy(&s);
    err_t err;
    assert_null(sb_load_text(
        "WorldBegin\nMaterial \"uniaxial\" \"float o.eta\" [ 1.6 ]\nShape \"sphere\"\n", &err));
    assert_non_null(strstr(err.msg, "t.pbrt:2"));
    assert_null(sb_load_text("WorldBegin\nMaterial \"uniaxial\"\n  \"string crystal\" "
                             "\"kryptonite\"\nShape \"sphere\"\n",
                             &err));
    assert_non_null(strstr(err.msg, "kryptonite"));
    assert_null(sb_load_text("WorldBegin\nMaterial \"uniaxial\" \"string crystal\" \"calcite\"\n"
                             "  \"vector3 opticaxis\" [ 0 0 0 ]\nShape \"sphere\"\n",
                             &err));
    assert_non_null(strstr(err.msg, "t.pbrt:3"));
}

/* The boundary against an oracle that shares no formula with polar/uniaxial_fresnel.c:
 * tests/unit/uniaxial_oracle.py finds the crystal's four waves from Maxwell's equations alone
 * (the Booker quartic's roots, fitted from sampled determinants, and the null vectors of the
 * wave matrix), picks the waves going in by their Poynting vectors (or decay), and solves the
 * tangential continuity with numpy. Its power fractions, printed to 13 digits, for nine cases:
 * calcite, rutile and quartz under water, general axes, near-grazing outside, the prism's
 * axis (along the face, across the plane of incidence) with a tilted ray, and total internal
 * reflection inside with 14-36 % of the light converted between o and e (the case the old
 * model, which kept the wave, got wrong). Rows per case: s, p, o, e incident; columns: out
 * s + p, o, e. The solver here takes m = -z (the oracle's crystal fills z > 0). */
typedef struct oracle_case {
    double kx, ky, axis[3], no, ne, n1;
    double p[12];
} oracle_case_t;

static const oracle_case_t ORACLE_CASES[] = {
    {0.29999999999999999,
     0.20000000000000001,
     {0.29994001799400205, 0.79984004798400554, 0.51989603118960359},
     1.6584000000000001,
     1.4863999999999999,
     1,
     {6.553058812075e-02, 5.192022703820e-01, 4.152671414972e-01, 4.063515310384e-02,
      4.178050000214e-01, 5.415598468748e-01, 9.336956168550e-01, 6.261558726261e-02,
      3.688795882390e-03, 9.601386419204e-01, 3.771423340141e-04, 3.948421574558e-02}},
    {0.84999999999999998,
     0.10000000000000001,
     {0, 1, 0},
     1.6584000000000001,
     1.4863999999999999,
     1,
     {1.631577924318e-01, 8.461766884870e-03, 8.283804406833e-01, 5.036803235978e-05,
      9.892023274963e-01, 1.074730447133e-02, 9.976640943812e-01, 3.075882651787e-05,
      2.305146792304e-03, 8.391277451546e-01, 2.305146792304e-03, 1.585671080531e-01}},
    {0.69999999999999996,
     0.34999999999999998,
     {0, 1, 0},
     1.6584000000000001,
     1.4863999999999999,
     1,
     {1.252600067004e-01, 1.415973869450e-01, 7.331426063547e-01, 5.096400446679e-03,
      8.259035138777e-01, 1.690000856756e-01, 9.675009008226e-01, 1.754882598341e-02,
      1.495027319395e-02, 9.021426920303e-01, 1.495027319395e-02, 8.290703477577e-02}},
    {1.2,
     0.40000000000000002,
     {0, 1, 0},
     1.6584000000000001,
     1.4863999999999999,
     1,
     {0.000000000000e+00, 0.000000000000e+00, 0.000000000000e+00, 0.000000000000e+00,
      0.000000000000e+00, 0.000000000000e+00, 0.000000000000e+00, 8.582538043165e-01,
      1.417461956835e-01, 0.000000000000e+00, 1.417461956835e-01, 8.582538043165e-01}},
    {1.3,
     0.5,
     {0.50251890762960605, 0.50251890762960605, 0.70352647068144836},
     1.6584000000000001,
     1.4863999999999999,
     1,
     {0.000000000000e+00, 0.000000000000e+00, 0.000000000000e+00, 0.000000000000e+00,
      0.000000000000e+00, 0.000000000000e+00, 0.000000000000e+00, 6.397900076945e-01,
      3.602099923055e-01, 0.000000000000e+00, 3.602099923055e-01, 6.397900076945e-01}},
    {0.999,
     0.01,
     {0.20091625822630407, 0.10045812911315204, 0.97444385239757469},
     1.6584000000000001,
     1.4863999999999999,
     1,
     {8.763428275348e-01, 1.170363675972e-01, 6.620804867996e-03, 6.785273605994e-01,
      1.576079628164e-02, 3.057118431190e-01, 1.263414307485e-01, 8.624241388175e-01,
      1.123443043396e-02, 3.187883811173e-01, 4.778697303666e-03, 6.764329215791e-01}},
    {1.45,
     0.20000000000000001,
     {0.60072129859745493, -0.30036064929872747, 0.74088960160352779},
     1.6584000000000001,
     1.4863999999999999,
     1,
     {0.000000000000e+00, 0.000000000000e+00, 0.000000000000e+00, 0.000000000000e+00,
      0.000000000000e+00, 0.000000000000e+00, 0.000000000000e+00, 8.339283001060e-01,
      1.660716998940e-01, 0.000000000000e+00, 1.660716998940e-01, 8.339283001060e-01}},
    {2,
     0.69999999999999996,
     {0.10018048746260763, 0.90162438716346871, 0.42075804734295202},
     2.613,
     2.9089999999999998,
     1,
     {0.000000000000e+00, 0.000000000000e+00, 0.000000000000e+00, 0.000000000000e+00,
      0.000000000000e+00, 0.000000000000e+00, 0.000000000000e+00, 7.103591796444e-01,
      2.896408203556e-01, 0.000000000000e+00, 2.896408203556e-01, 7.103591796444e-01}},
    {0.5,
     -0.40000000000000002,
     {0.70352647068144847, 0.10050378152592122, -0.70352647068144847},
     1.5443,
     1.5533999999999999,
     1.3300000000000001,
     {8.859491746737e-03, 6.619538100798e-01, 3.291866981735e-01, 3.167940900978e-03,
      3.312104701828e-01, 6.656215889162e-01, 9.964415289023e-01, 2.729189152561e-03,
      8.292819451204e-04, 9.915310384500e-01, 4.106530584820e-03, 4.362430965214e-03}},
};

static void test_maxwell_oracle(void **state)
{
    (void)state;
    double worst = 0.0;
    for (size_t i = 0; i < sizeof ORACLE_CASES / sizeof ORACLE_CASES[0]; i++) {
        const oracle_case_t *c = &ORACLE_CASES[i];
        uniaxial_fresnel_t f;
        uniaxial_fresnel_solve(vec3_make(c->kx, c->ky, 0), vec3_make(0, 0, -1),
                               vec3_make(c->axis[0], c->axis[1], c->axis[2]), c->no, c->ne, c->n1,
                               vec3_make(1, 0, 0), &f);
        assert_true(f.ok);
        for (int in = 0; in < UF_WAVES; in++) {
            const double got[3] = {f.power[in][UF_S] + f.power[in][UF_P], f.power[in][UF_O],
                                   f.power[in][UF_E]};
            for (int k = 0; k < 3; k++) {
                worst = fmax(worst, fabs(got[k] - c->p[3 * in + k]));
                testutil_assert_near(got[k], c->p[3 * in + k], 1e-11);
            }
        }
    }
    print_message("Maxwell oracle: worst |P - P_oracle| %.1e over %zu cases\n", worst,
                  sizeof ORACLE_CASES / sizeof ORACLE_CASES[0]);
}

/* The real-arithmetic solve (every wave propagating) against the complex one it replaces:
 * 20 000 random boundaries -- six crystals, 400-700 nm, random axes (one in five in the face,
 * one in five along the normal), from outside and inside, with the incidence angle drawn near
 * grazing, near each wave's critical angle (|t| within 1e-6..1e-2 of 1, n_o or the e index) or
 * anywhere -- agree in every amplitude and power fraction. The real path repeats the complex
 * path's operations on real parts, so they agree bit for bit; the bound 1e-12 leaves room for
 * a compiler's contraction. A solve of some incident waves only (uniaxial_fresnel_solve_incident)
 * gives those rows exactly as the full solve. */
static void test_real_solve(void **state)
{
    (void)state;
    uint64_t x = 4242;
    double worst = 0.0;
    int real_cases = 0;
    for (int i = 0; i < 20000; i++) {
        const crystal_t *c = crystal_get(i % crystal_count());
        const double lam = 400 + 300 * lcg01(&x);
        const double no = n_at(&c->no, lam), ne = n_at(&c->ne, lam);
        vec3_t axis = vec3_normalize(vec3_make(lcg01(&x) - 0.5, lcg01(&x) - 0.5, lcg01(&x) - 0.5));
        if (i % 5 == 1)
            axis = vec3_normalize(vec3_make(axis.x, axis.y, 0.0));
        else if (i % 5 == 2)
            axis = vec3_make(0, 0, 1);
        const double ph = 2 * PI * lcg01(&x), kind = lcg01(&x);
        const double nmax = fmax(no, ne);
        double tl;
        if (kind < 0.25) /* near grazing from outside */
            tl = 1.0 - pow(10.0, -2.0 - 10.0 * lcg01(&x));
        else if (kind < 0.5) /* near the outside's critical angle, from inside, either side */
            tl = 1.0 + (lcg01(&x) < 0.5 ? -1 : 1) * pow(10.0, -2.0 - 4.0 * lcg01(&x));
        else if (kind < 0.75) /* near the o or the e wave's own limit */
            tl = (lcg01(&x) < 0.5 ? no : ne) * (1.0 - pow(10.0, -2.0 - 6.0 * lcg01(&x)));
        else
            tl = nmax * lcg01(&x);
        const vec3_t t = vec3_make(tl * cos(ph), tl * sin(ph), 0.0);
        const vec3_t m = vec3_make(0, 0, 1);
        uniaxial_fresnel_t a, b;
        uniaxial_fresnel_solve(t, m, axis, no, ne, 1.0, vec3_make(1, 0, 0), &a);
        uniaxial_fresnel_solve_complex(t, m, axis, no, ne, 1.0, vec3_make(1, 0, 0), &b);
        /* A subset of the incident waves: its rows as the full solve's, the others zero. */
        const unsigned mask = 1u + (unsigned)(lcg01(&x) * 15.0);
        uniaxial_fresnel_t sub;
        uniaxial_fresnel_solve_incident(t, m, axis, no, ne, 1.0, vec3_make(1, 0, 0), mask, &sub);
        for (int in = 0; in < UF_WAVES; in++)
            for (int o = 0; o < UF_WAVES; o++) {
                const bool on = mask >> in & 1u;
                assert_true(sub.power[in][o] == (on ? a.power[in][o] : 0.0));
                assert_true(sub.amp[in][o] == (on ? a.amp[in][o] : 0.0));
            }
        assert_int_equal(a.ok, b.ok);
        bool all = true;
        for (int w = 0; w < UF_WAVES; w++)
            all = all && a.in[w].propagating && a.out[w].propagating;
        real_cases += all;
        for (int in = 0; in < UF_WAVES; in++)
            for (int o = 0; o < UF_WAVES; o++) {
                const double d =
                    fmax(fabs(a.power[in][o] - b.power[in][o]), cabs(a.amp[in][o] - b.amp[in][o]));
                worst = fmax(worst, d);
                assert_true(d <= 1e-12);
            }
    }
    /* Most draws must take the real path, or the test proves nothing. */
    assert_true(real_cases > 5000);
    print_message("real solve: %d of 20000 boundaries all-propagating; worst difference %.1e\n",
                  real_cases, worst);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_catalogue),
        cmocka_unit_test(test_e_index),
        cmocka_unit_test(test_walkoff),
        cmocka_unit_test(test_ordinary_snell),
        cmocka_unit_test(test_double_image_traced),
        cmocka_unit_test(test_tir),
        cmocka_unit_test(test_energy_events),
        cmocka_unit_test(test_mode_conversion_energy),
        cmocka_unit_test(test_mode_conversion_closed_forms),
        cmocka_unit_test(test_mode_conversion_mueller),
        cmocka_unit_test(test_maxwell_oracle),
        cmocka_unit_test(test_real_solve),
        cmocka_unit_test(test_dichroic_plate),
        cmocka_unit_test(test_syntax),
        cmocka_unit_test(test_double_image_rendered),
        cmocka_unit_test(test_double_image_photons),
        cmocka_unit_test(test_double_image_analysed),
        cmocka_unit_test(test_furnace),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
