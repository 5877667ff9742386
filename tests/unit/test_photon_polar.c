/* photon_polar: polarised photon paths (docs/physics.md §14.3) against optics, not against the
 * code, on the photon map itself (deposits are stored as floats: 1e-6): a collimated beam
 * through two polarisers deposits cos^2(theta) / 2 of its power (Malus's law, 0 to 90 degrees:
 * crossed polarisers are dark), and a quarter-wave plate at 45 degrees between crossed ones passes
 * a quarter; light reflected by glass at Brewster's angle is s-polarised (a polariser along p
 * behind it leaves nothing, one along s passes R_s / 2); a glass slab at 60 degrees transmits the
 * mean of the s and p slabs' (1 - R) / (1 + R), not the unpolarised (1 - R) / (1 + R) of the mean
 * R; a calcite plate splits a beam into two spots t tan(rho) apart (rho the walk-off from the two
 * indices), each carrying (1 - R) / (2 (1 + R)) at its own wave's index, polarised across each
 * other (a polariser behind the plate keeps one spot and removes the other); behind a
 * polariser at 30 degrees and a quarter-wave plate the o and e waves take the light's y and x
 * shares (sin^2 30, cos^2 30); and no photon ever carries more than it was emitted with. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "photon.h"
#include "photon_store.h"
#include "scene.h"
#include "scene_builders.h"

#define PI 3.14159265358979323846

/* A scene with a collimated beam of radius r along +z from z = -1 (its disk passes what comes
 * back), then `world`. */
static scene_t *beam_scene_lit(double r, const char *light, const char *integrator,
                               const char *world)
{
    char text[8192];
    snprintf(text, sizeof text,
             "Camera \"orthographic\"\n"
             "Film \"spectral\" \"integer xresolution\" [4] \"integer yresolution\" [4]\n"
             "Integrator \"photon\" %s\n"
             "WorldBegin\n"
             "AttributeBegin\n"
             "AreaLightSource \"collimated\" \"spectrum L\" [300 1 900 1] %s\n"
             "Material \"interface\"\n"
             "Translate 0 0 -1\n"
             "Shape \"disk\" \"float radius\" [%g]\n"
             "AttributeEnd\n%s",
             integrator, light, r, world);
    return sb_load_text(text, NULL);
}

static scene_t *beam_scene(double r, const char *integrator, const char *world)
{
    return beam_scene_lit(r, "", integrator, world);
}

typedef struct traced {
    photon_store_t *store;
    photon_stats_t st;
    double per_photon; /* each photon's emitted power: a beam's are all equal */
} traced_t;

static traced_t trace(const scene_t *s, uint64_t n)
{
    err_t err;
    traced_t t = {0};
    t.store = photon_store_new(s, &err);
    assert_non_null(t.store);
    photon_job_t job = {.seed = 11,
                        .maxdepth = 64,
                        .mindepth = 1,
                        .threshold = 0.0,
                        .monochromerays = 1,
                        .policy = PHOTON_STORE_CAUSTIC};
    if (photon_trace(s, &job, 0, n, t.store, &t.st, &err))
        fail_msg("photon_trace: %s", err.msg);
    assert_int_equal(t.st.nonfinite, 0);
    t.per_photon = t.st.power_emitted / (double)n;
    /* No gain: no photon deposits more than it was emitted with (float storage). */
    const photon_map_t *m = photon_store_map(t.store);
    for (size_t i = 0; i < photon_map_count(m); i++)
        if (!(photon_map_photon(m, i).power <= t.per_photon * (1.0 + 1e-6)))
            fail_msg("photon %zu deposits %.9g of %.9g emitted", i, photon_map_photon(m, i).power,
                     t.per_photon);
    return t;
}

/* Power deposited (over the emitted) within radius r of c, and its centroid. */
static double spot(const traced_t *t, vec3_t c, double r, vec3_t *centroid)
{
    const photon_map_t *m = photon_store_map(t->store);
    double sum = 0.0;
    vec3_t acc = vec3_make(0, 0, 0);
    for (size_t i = 0; i < photon_map_count(m); i++) {
        const photon_info_t ph = photon_map_photon(m, i);
        if (vec3_length(vec3_sub(ph.p, c)) > r)
            continue;
        sum += ph.power;
        acc = vec3_add(acc, vec3_scale(ph.p, ph.power));
    }
    if (centroid)
        *centroid = sum > 0.0 ? vec3_scale(acc, 1.0 / sum) : c;
    return sum / t->st.power_emitted;
}

static void trace_destroy(traced_t *t)
{
    photon_store_destroy(&t->store);
}

/* Two polarisers (z = 0 and 0.5) and a diffuse screen (z = 1) in the beam; a sheet is a
 * specular event, so every photon that passes both is stored on the screen. */
static double through_sheets(const char *sheets)
{
    char world[4096];
    snprintf(world, sizeof world,
             "%s"
             "AttributeBegin\nMaterial \"diffuse\"\nTranslate 0 0 1\n" PBRT_QUAD "AttributeEnd\n",
             sheets);
    scene_t *s = beam_scene(0.05, "", world);
    assert_true(s->settings.polarised);
    traced_t t = trace(s, 2000);
    const double got = spot(&t, vec3_make(0, 0, 1), 0.1, NULL);
    trace_destroy(&t);
    scene_destroy(&s);
    return got;
}

static void test_malus(void **state)
{
    (void)state;
    const int angles[] = {0, 30, 45, 60, 90};
    for (size_t i = 0; i < 5; i++) {
        char sheets[1024];
        snprintf(sheets, sizeof sheets,
                 "AttributeBegin\nMaterial \"polarizer\" \"float angle\" [0]\n" PBRT_QUAD
                 "AttributeEnd\n"
                 "AttributeBegin\nMaterial \"polarizer\" \"float angle\" [%d]\n"
                 "Translate 0 0 0.5\n" PBRT_QUAD "AttributeEnd\n",
                 angles[i]);
        const double got = through_sheets(sheets);
        const double c = cos(angles[i] * PI / 180.0), want = 0.5 * c * c;
        if (!(fabs(got - want) <= 1e-6))
            fail_msg("beam through polarisers at 0 and %d degrees: %.12f, want %.12f", angles[i],
                     got, want);
    }
    /* A quarter-wave plate at 45 degrees between crossed polarisers makes the light circular,
     * of which the second passes half. */
    const double got = through_sheets(
        "AttributeBegin\nMaterial \"polarizer\" \"float angle\" [0]\n" PBRT_QUAD "AttributeEnd\n"
        "AttributeBegin\nMaterial \"retarder\" \"float retardance\" [90] \"float angle\" [45]\n"
        "Translate 0 0 0.25\n" PBRT_QUAD "AttributeEnd\n"
        "AttributeBegin\nMaterial \"polarizer\" \"float angle\" [90]\n"
        "Translate 0 0 0.5\n" PBRT_QUAD "AttributeEnd\n");
    if (!(fabs(got - 0.25) <= 1e-6))
        fail_msg("crossed polarisers with a quarter-wave plate at 45 degrees: %.12f", got);
    /* A beam polarised (degree 1 and 0.5) at 20 degrees through one polariser at theta: the
     * light's angle and the sheet's are both from the shapes' x toward y, so it passes
     * (1 + P cos 2(theta - 20)) / 2. */
    for (int d = 1; d <= 2; d++)
        for (int theta = 0; theta < 180; theta += 45) {
            char light[128], world[1024];
            snprintf(light, sizeof light,
                     "\"float polarization\" [%g] \"float polarizationangle\" [20]", 1.0 / d);
            snprintf(world, sizeof world,
                     "AttributeBegin\nMaterial \"polarizer\" \"float angle\" [%d]\n" PBRT_QUAD
                     "AttributeEnd\n"
                     "AttributeBegin\nMaterial \"diffuse\"\nTranslate 0 0 1\n" PBRT_QUAD
                     "AttributeEnd\n",
                     theta);
            scene_t *s = beam_scene_lit(0.05, light, "", world);
            assert_int_equal(s->polarised_lights, 1);
            traced_t t = trace(s, 1000);
            const double got = spot(&t, vec3_make(0, 0, 1), 0.1, NULL);
            const double want = 0.5 * (1.0 + cos(2.0 * (theta - 20) * PI / 180.0) / d);
            if (!(fabs(got - want) <= 1e-6))
                fail_msg("beam of degree %g at 20 through a polariser at %d: %.9f, want %.9f",
                         1.0 / d, theta, got, want);
            trace_destroy(&t);
            scene_destroy(&s);
        }
}

/* Fresnel's equations written out (Hecht §4.6.2) for light from index 1 into n. */
static void fresnel_rs_rp(double cos_i, double n, double *Rs, double *Rp)
{
    const double sin_t = sqrt(1.0 - cos_i * cos_i) / n, cos_t = sqrt(1.0 - sin_t * sin_t);
    const double rs = (cos_i - n * cos_t) / (cos_i + n * cos_t);
    const double rp = (n * cos_i - cos_t) / (n * cos_i + cos_t);
    *Rs = rs * rs;
    *Rp = rp * rp;
}

/* The beam meets glass (n = 1.5, a single face: what enters never returns) at Brewster's angle;
 * the reflected beam crosses a polariser and lands on a screen across it. The polariser's u is
 * in the plane of incidence (p at angle 0, s at 90). Photons reflect with probability R for
 * their own polarisation, so the screen's share has standard error sqrt(R (1 - R) / N). */
static void test_brewster(void **state)
{
    (void)state;
    const double tb = atan(1.5), deg = 180.0 / PI;
    double Rs, Rp;
    fresnel_rs_rp(cos(tb), 1.5, &Rs, &Rp);
    const uint64_t N = 20000;
    for (int k = 0; k < 2; k++) {
        /* The glass at the origin, turned so that the beam (+z) meets it at theta_B in the x-z
         * plane; the reflected beam leaves along (sin 2 theta_B, 0, -cos 2 theta_B). */
        char world[4096];
        const double a = 2.0 * tb;
        snprintf(world, sizeof world,
                 "AttributeBegin\nMaterial \"dielectric\" \"float eta\" [1.5]\n"
                 "Rotate %.9f 0 1 0\n" PBRT_QUAD_BACK "AttributeEnd\n"
                 "AttributeBegin\nMaterial \"polarizer\" \"float angle\" [%d]\n"
                 "Translate %.9f 0 %.9f\nRotate %.9f 0 1 0\n" PBRT_QUAD "AttributeEnd\n"
                 "AttributeBegin\nMaterial \"diffuse\"\n"
                 "Translate %.9f 0 %.9f\nRotate %.9f 0 1 0\n" PBRT_QUAD "AttributeEnd\n",
                 -tb * deg, 90 * k, 0.5 * sin(a), -0.5 * cos(a), 180.0 - a * deg, sin(a), -cos(a),
                 180.0 - a * deg);
        scene_t *s = beam_scene(0.05, "", world);
        traced_t t = trace(s, N);
        const double got = spot(&t, vec3_make(sin(a), 0, -cos(a)), 0.2, NULL);
        const double want = k ? 0.5 * Rs : 0.0, se = sqrt(0.5 * Rs * (1.0 - 0.5 * Rs) / N);
        print_message("Brewster reflection through a polariser along %s: %.5f, want %.5f\n",
                      k ? "s" : "p", got, want);
        if (k ? !(fabs(got - want) <= 4.0 * se) : !(got <= 1e-12))
            fail_msg("polariser along %s: %.6f, want %.6f (se %.6f)", k ? "s" : "p", got, want, se);
        trace_destroy(&t);
        scene_destroy(&s);
    }
}

/* A glass slab (n = 1.5, 0.1 thick) at 60 degrees in the beam, a screen behind it: the light
 * crossing it, every inter-reflection included, is ((1 - R_s)/(1 + R_s) + (1 - R_p)/(1 + R_p))
 * / 2 = 0.8484 of the beam, where an intensity-only transport finds (1 - R)/(1 + R) with
 * R = (R_s + R_p) / 2, 0.8361: eleven standard errors apart at N = 100000. */
static void test_slab(void **state)
{
    (void)state;
    double Rs, Rp;
    fresnel_rs_rp(cos(60.0 * PI / 180.0), 1.5, &Rs, &Rp);
    const double want = 0.5 * ((1 - Rs) / (1 + Rs) + (1 - Rp) / (1 + Rp));
    const double R = 0.5 * (Rs + Rp), unpolarised = (1 - R) / (1 + R);
    scene_t *s = beam_scene(
        0.02, "\"bool polarized\" true",
        "AttributeBegin\nMaterial \"dielectric\" \"float eta\" [1.5]\nRotate 60 1 0 0\n"
        "Translate 0 0 0.05\n" PBRT_QUAD "Translate 0 0 -0.1\n" PBRT_QUAD_BACK "AttributeEnd\n"
        "AttributeBegin\nMaterial \"diffuse\"\nTranslate 0 0 1\n" PBRT_QUAD "AttributeEnd\n");
    assert_true(s->settings.polarised);
    const uint64_t N = 100000;
    traced_t t = trace(s, N);
    const double got = spot(&t, vec3_make(0, 0, 1), 1.0, NULL);
    const double se = sqrt(want * (1.0 - want) / N);
    print_message("slab at 60 degrees: %.5f, want %.5f (unpolarised %.5f, se %.5f)\n", got, want,
                  unpolarised, se);
    if (!(fabs(got - want) <= 4.0 * se) || !(fabs(got - unpolarised) > 6.0 * se))
        fail_msg("slab at 60 degrees: %.6f, want %.6f (unpolarised %.6f, se %.6f)", got, want,
                 unpolarised, se);
    trace_destroy(&t);
    scene_destroy(&s);
}

/* A calcite plate (n_o 1.658, n_e 1.486, no dispersion) 1 thick, its optic axis at 44.6
 * degrees to its normal in the x-z plane (a cleavage face's), a thin beam at normal incidence
 * and a screen behind: the o ray goes straight, the e ray's energy walks off by
 * rho = atan((n_o / n_e)^2 tan 44.6) - 44.6 degrees (Born & Wolf §15.3), away from the axis,
 * so its spot is tan(rho) from the o spot. Every inter-reflection of either wave leaves
 * through its own spot (at normal incidence an e wave reflected retraces its ray), so each
 * spot carries (1 - R) / (2 (1 + R)), R = ((n - 1) / (n + 1))^2 at n_o and at the e wave's
 * index 1 / sqrt(cos^2 / n_o^2 + sin^2 / n_e^2) of 44.6 degrees. The o wave is polarised along
 * k x c (y), the e wave across it (x): a polariser along y behind the plate keeps the o spot
 * and removes the e spot, one along x the reverse. */
static void test_calcite(void **state)
{
    (void)state;
    const double no = 1.658, ne = 1.486, th = 44.6 * PI / 180.0;
    const double rho = atan(no * no / (ne * ne) * tan(th)) - th;
    const double n_e_wave = 1.0 / sqrt(pow(cos(th) / no, 2.0) + pow(sin(th) / ne, 2.0));
    const double r_o = pow((no - 1) / (no + 1), 2.0),
                 r_e = pow((n_e_wave - 1) / (n_e_wave + 1), 2.0);
    const double want_o = (1 - r_o) / (2 * (1 + r_o)), want_e = (1 - r_e) / (2 * (1 + r_e));
    const uint64_t N = 40000;
    const char *analyser[] = {"", "90", "0"}; /* none, along y, along x */
    for (int k = 0; k < 3; k++) {
        char world[4096], sheet[512] = "";
        if (analyser[k][0])
            snprintf(sheet, sizeof sheet,
                     "AttributeBegin\nMaterial \"polarizer\" \"float angle\" [%s]\n"
                     "Translate 0 0 1.5\n" PBRT_QUAD "AttributeEnd\n",
                     analyser[k]);
        snprintf(world, sizeof world,
                 "AttributeBegin\nMaterial \"uniaxial\" \"float o.eta\" [%g] \"float e.eta\" [%g] "
                 "\"vector3 opticaxis\" [%.12f 0 %.12f]\n" PBRT_QUAD_BACK
                 "Translate 0 0 1\n" PBRT_QUAD "AttributeEnd\n%s"
                 "AttributeBegin\nMaterial \"diffuse\"\nTranslate 0 0 2\n" PBRT_QUAD
                 "AttributeEnd\n",
                 no, ne, sin(th), cos(th), sheet);
        scene_t *s = beam_scene(1e-4, "\"bool polarized\" true", world);
        assert_true(s->settings.polarised);
        traced_t t = trace(s, N);
        vec3_t co, ce;
        const double po = spot(&t, vec3_make(0, 0, 2), 0.02, &co);
        const double pe = spot(&t, vec3_make(-tan(rho), 0, 2), 0.02, &ce);
        const double total = spot(&t, vec3_make(0, 0, 2), 1.0, NULL);
        print_message("calcite plate, analyser %s: o %.5f (want %.5f), e %.5f (want %.5f) at "
                      "x = %.6f (want %.6f), all %.5f\n",
                      analyser[k][0] ? analyser[k] : "none", po, want_o, pe, want_e, ce.x,
                      -tan(rho), total);
        const double se_o = sqrt(want_o * (1 - want_o) / N), se_e = sqrt(want_e * (1 - want_e) / N);
        /* Nothing lands anywhere but the two spots. */
        assert_true(fabs(total - po - pe) <= 1e-12);
        if (k == 0) {
            if (!(fabs(po - want_o) <= 4 * se_o) || !(fabs(pe - want_e) <= 4 * se_e))
                fail_msg("spots o %.6f, e %.6f: want %.6f, %.6f", po, pe, want_o, want_e);
            if (!(fabs(ce.x + tan(rho)) <= 1e-5) || !(fabs(co.x) <= 1e-5) || !(fabs(ce.y) <= 1e-5))
                fail_msg("spots at x = %.7f and %.7f: want %.7f apart", co.x, ce.x, tan(rho));
        } else {
            /* The kept spot is fully polarised along the polariser: it passes whole. */
            const double kept = k == 1 ? po : pe, gone = k == 1 ? pe : po;
            const double want = k == 1 ? want_o : want_e, se = k == 1 ? se_o : se_e;
            if (!(gone <= 1e-12) || !(fabs(kept - want) <= 4 * se))
                fail_msg("polariser at %s: kept %.6f (want %.6f), removed %.3g", analyser[k], kept,
                         want, gone);
        }
        trace_destroy(&t);
        scene_destroy(&s);
    }
}

/* A chain: the beam through a polariser at 30 degrees, a quarter-wave plate along x (which
 * changes neither the x nor the y share of the light, only their phase) and the calcite plate
 * of test_calcite at normal incidence: the o wave (D along y) takes the light's y share,
 * sin^2 30 of the polariser's half, the e wave (D along x) its x share, cos^2 30, each then
 * crossing the plate as in test_calcite: the o spot (1/8) (1 - R_o)/(1 + R_o), the e spot
 * (3/8) (1 - R_e)/(1 + R_e), where an unpolarised split would give both the same share. No
 * photon gains power on the way (trace). */
static void test_chain(void **state)
{
    (void)state;
    const double no = 1.658, ne = 1.486, th = 44.6 * PI / 180.0;
    const double rho = atan(no * no / (ne * ne) * tan(th)) - th;
    const double n_e_wave = 1.0 / sqrt(pow(cos(th) / no, 2.0) + pow(sin(th) / ne, 2.0));
    const double r_o = pow((no - 1) / (no + 1), 2.0),
                 r_e = pow((n_e_wave - 1) / (n_e_wave + 1), 2.0);
    const double want_o = 0.125 * (1 - r_o) / (1 + r_o), want_e = 0.375 * (1 - r_e) / (1 + r_e);
    char world[4096];
    snprintf(world, sizeof world,
             "AttributeBegin\nMaterial \"polarizer\" \"float angle\" [30]\nTranslate 0 0 "
             "-0.6\n" PBRT_QUAD "AttributeEnd\n"
             "AttributeBegin\nMaterial \"retarder\" \"float retardance\" [90]\n"
             "Translate 0 0 -0.3\n" PBRT_QUAD "AttributeEnd\n"
             "AttributeBegin\nMaterial \"uniaxial\" \"float o.eta\" [%g] \"float e.eta\" [%g] "
             "\"vector3 opticaxis\" [%.12f 0 %.12f]\n" PBRT_QUAD_BACK "Translate 0 0 1\n" PBRT_QUAD
             "AttributeEnd\n"
             "AttributeBegin\nMaterial \"diffuse\"\nTranslate 0 0 2\n" PBRT_QUAD "AttributeEnd\n",
             no, ne, sin(th), cos(th));
    scene_t *s = beam_scene(1e-4, "", world);
    const uint64_t N = 40000;
    traced_t t = trace(s, N);
    const double po = spot(&t, vec3_make(0, 0, 2), 0.02, NULL);
    const double pe = spot(&t, vec3_make(-tan(rho), 0, 2), 0.02, NULL);
    /* Each photon carries half its power past the polariser, so a spot's share has standard
     * error (1/2) sqrt(q (1 - q) / N), q = 2 x its share. */
    const double se_o = 0.5 * sqrt(2 * want_o * (1 - 2 * want_o) / N),
                 se_e = 0.5 * sqrt(2 * want_e * (1 - 2 * want_e) / N);
    print_message("chain: o %.5f (want %.5f, se %.5f), e %.5f (want %.5f, se %.5f)\n", po, want_o,
                  se_o, pe, want_e, se_e);
    if (!(fabs(po - want_o) <= 4 * se_o) || !(fabs(pe - want_e) <= 4 * se_e))
        fail_msg("chain: o %.6f (want %.6f), e %.6f (want %.6f)", po, want_o, pe, want_e);
    trace_destroy(&t);
    scene_destroy(&s);
}

/* The optic axis under an object instance: the calcite plate of test_calcite as an object,
 * placed turned 90 degrees about z, turns its axis to the y-z plane, so the e spot is tan(rho)
 * along -y from the o spot, not along -x. */
static void test_instanced_axis(void **state)
{
    (void)state;
    const double no = 1.658, ne = 1.486, th = 44.6 * PI / 180.0;
    const double rho = atan(no * no / (ne * ne) * tan(th)) - th;
    char world[4096];
    snprintf(world, sizeof world,
             "ObjectBegin \"plate\"\n"
             "Material \"uniaxial\" \"float o.eta\" [%g] \"float e.eta\" [%g] "
             "\"vector3 opticaxis\" [%.12f 0 %.12f]\n" PBRT_QUAD_BACK "Translate 0 0 1\n" PBRT_QUAD
             "ObjectEnd\n"
             "AttributeBegin\nRotate 90 0 0 1\nObjectInstance \"plate\"\nAttributeEnd\n"
             "AttributeBegin\nMaterial \"diffuse\"\nTranslate 0 0 2\n" PBRT_QUAD "AttributeEnd\n",
             no, ne, sin(th), cos(th));
    scene_t *s = beam_scene(1e-4, "", world);
    traced_t t = trace(s, 4000);
    vec3_t ce;
    const double po = spot(&t, vec3_make(0, 0, 2), 0.02, NULL);
    const double pe = spot(&t, vec3_make(0, -tan(rho), 2), 0.02, &ce);
    print_message("instanced plate: o %.4f, e %.4f at (%.6f, %.6f)\n", po, pe, ce.x, ce.y);
    if (!(po > 0.4 && pe > 0.4) || !(fabs(ce.y + tan(rho)) <= 1e-5) || !(fabs(ce.x) <= 1e-5))
        fail_msg("instanced plate: o %.4f, e %.4f at (%.7f, %.7f), want (0, %.7f)", po, pe, ce.x,
                 ce.y, -tan(rho));
    trace_destroy(&t);
    scene_destroy(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_malus), cmocka_unit_test(test_brewster),
        cmocka_unit_test(test_slab),  cmocka_unit_test(test_calcite),
        cmocka_unit_test(test_chain), cmocka_unit_test(test_instanced_axis),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
