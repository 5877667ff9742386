/* polar_lights: lights that emit partially linearly polarised light (docs/physics.md §14.2)
 * against optics, not against the code: a lamp of degree P polarised at phi seen through the
 * camera's analyser at theta passes (1 + P cos 2(theta - phi)) / 2 of its light (Malus's law
 * for the polarised part, half of the rest), at 0 to 150 degrees; a fully polarised lamp is
 * an unpolarised one behind a polariser sheet at the same angle, twice as bright; through a
 * glass slab at 60 degrees an s-polarised lamp passes T_s = (1 - R_s)/(1 + R_s) and a
 * p-polarised one T_p (Fresnel's equations written out, Hecht §8.6), which tests the lamp's
 * frame through the interfaces' frames; an unpolarised lamp ("polarization" 0) renders bit for
 * bit as one without the parameter, with polarisation off; the emission's Stokes vector of
 * point, spot and distant lights against its definition; and the syntax's errors. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h> /* after the four headers above, which it needs */

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "lights.h"
#include "plan.h"
#include "render.h"
#include "scene.h"
#include "scene_builders.h"

#define PI 3.14159265358979323846

/* The image's summed S0 (the buckets' means over the pixels), and its tile for comparisons. */
static double render_s0(scene_t *s, tilebuf_t **keep)
{
    err_t err;
    const int res = 4, spp = 4;
    const int nb = s->settings.grid.n;
    tilebuf_t *t = tilebuf_new(0, 0, res, res, render_settings_buckets(&s->settings), &err);
    assert_non_null(t);
    render_stats_t st = {0};
    if (render_tile(s, NULL, 0, 0, res, res, 0, spp, t, &st, &err))
        fail_msg("render_tile: %s", err.msg);
    assert_int_equal(st.nonfinite, 0);
    double sum = 0.0;
    for (int y = 0; y < res; y++)
        for (int x = 0; x < res; x++)
            for (int b = 0; b < nb; b++)
                sum += tilebuf_sum(t, x, y, b) / (double)tilebuf_count(t, x, y);
    if (keep)
        *keep = t;
    else
        tilebuf_destroy(&t);
    return sum;
}

/* An orthographic camera on +z (with its extra parameters) looking at a two-sided area light
 * of constant spectrum (with its extra parameters) at z = -1 and, when given, a sheet (a
 * Material line) at z = 0. */
static scene_t *lamp_scene(const char *light, const char *camera, const char *sheet)
{
    char text[4096];
    snprintf(text, sizeof text,
             "LookAt 0 0 5  0 0 0  0 1 0\n"
             "Camera \"orthographic\" %s\n"
             "Film \"spectral\" \"integer xresolution\" [4] \"integer yresolution\" [4]\n"
             "Sampler \"independent\" \"integer pixelsamples\" [4]\n"
             "Integrator \"path\" \"integer maxdepth\" [5]\n"
             "WorldBegin\n"
             "AttributeBegin\n"
             "AreaLightSource \"diffuse\" \"spectrum L\" [300 1 900 1] \"bool twosided\" true %s\n"
             "Translate 0 0 -1\n" PBRT_QUAD "AttributeEnd\n"
             "%s%s%s",
             camera, light, sheet[0] ? "AttributeBegin\n" : "", sheet,
             sheet[0] ? "\n" PBRT_QUAD "AttributeEnd\n" : "");
    return sb_load_text(text, NULL);
}

static void test_malus(void **state)
{
    (void)state;
    scene_t *open = lamp_scene("", "", "");
    assert_false(open->settings.polarised);
    const double i0 = render_s0(open, NULL);
    assert_true(i0 > 0.0);
    scene_destroy(&open);
    const double degree[] = {1.0, 0.5, 0.0};
    const double phi = 30.0;
    for (size_t d = 0; d < 3; d++)
        for (int theta = 0; theta < 180; theta += 30) {
            char light[128], cam[64];
            snprintf(light, sizeof light,
                     "\"float polarization\" [%g] \"float polarizationangle\" [%g]", degree[d],
                     phi);
            snprintf(cam, sizeof cam, "\"float analyzer\" [%d]", theta);
            scene_t *s = lamp_scene(light, cam, "");
            assert_true(s->settings.polarised);
            assert_int_equal(s->polarised_lights, degree[d] > 0.0);
            const double got = render_s0(s, NULL) / i0;
            /* pbrt's LookAt is left-handed: from +z toward -z with +y up the image's right is
             * the world's -x, so the lamp's phi from +x toward +y is -phi from the image's
             * right toward its up, where the analyser's theta is measured. */
            const double want = 0.5 * (1.0 + degree[d] * cos(2.0 * (theta + phi) * PI / 180.0));
            if (!(fabs(got - want) <= 1e-9))
                fail_msg("lamp of degree %g at %g through an analyser at %d: %.12f, want %.12f",
                         degree[d], phi, theta, got, want);
            scene_destroy(&s);
        }
    /* A fully polarised lamp is an unpolarised one behind a polariser at the same angle
     * (which passes half): the shape's x toward y and the sheet's u toward n x u agree. */
    for (int theta = -45; theta <= 90; theta += 45) {
        char cam[64];
        snprintf(cam, sizeof cam, "\"float analyzer\" [%d]", theta);
        scene_t *a =
            lamp_scene("\"float polarization\" [1] \"float polarizationangle\" [70]", cam, "");
        scene_t *b = lamp_scene("", cam, "Material \"polarizer\" \"float angle\" [70]");
        const double ia = render_s0(a, NULL), ib = render_s0(b, NULL);
        if (!(fabs(ia - 2.0 * ib) <= 1e-9 * ia))
            fail_msg("analyser at %d: polarised lamp %.12g, lamp behind a polariser %.12g", theta,
                     ia, ib);
        scene_destroy(&a);
        scene_destroy(&b);
    }
}

/* The Stokes output of a lamp seen directly: degree P, horizontal in the image at 0 degrees
 * (S1 = P S0) and, the world's +45 being the image's -45 (pbrt's LookAt mirrors x), S2 = -P S0
 * at 45 degrees; no circular part. */
static void test_stokes_output(void **state)
{
    (void)state;
    const double cases[][3] = {
        {1.0, 0.0, 1.0}, {0.5, 0.0, 1.0}, {1.0, 45.0, 0.0}, {0.6, 45.0, 0.0}};
    for (size_t i = 0; i < 4; i++) {
        char light[128], text[4096];
        snprintf(light, sizeof light,
                 "\"float polarization\" [%g] \"float polarizationangle\" [%g]", cases[i][0],
                 cases[i][1]);
        snprintf(text, sizeof text,
                 "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"orthographic\"\n"
                 "Film \"spectral\" \"integer xresolution\" [4] \"integer yresolution\" [4] "
                 "\"bool stokes\" true\n"
                 "Sampler \"independent\" \"integer pixelsamples\" [4]\n"
                 "WorldBegin\nAttributeBegin\n"
                 "AreaLightSource \"diffuse\" \"spectrum L\" [300 1 900 1] %s\n"
                 "Translate 0 0 -1\n" PBRT_QUAD "AttributeEnd\n",
                 light);
        scene_t *s = sb_load_text(text, NULL);
        err_t err;
        const int nb = s->settings.grid.n;
        tilebuf_t *t = tilebuf_new(0, 0, 4, 4, 4 * nb, &err);
        assert_non_null(t);
        render_stats_t st = {0};
        if (render_tile(s, NULL, 0, 0, 4, 4, 0, 4, t, &st, &err))
            fail_msg("render_tile: %s", err.msg);
        double S[4] = {0, 0, 0, 0};
        for (int y = 0; y < 4; y++)
            for (int x = 0; x < 4; x++)
                for (int k = 0; k < 4; k++)
                    for (int b = 0; b < nb; b++)
                        S[k] += tilebuf_sum(t, x, y, k * nb + b) / (double)tilebuf_count(t, x, y);
        const double p = cases[i][0], s1 = cases[i][2] * p, s2 = cases[i][1] == 45.0 ? -p : 0.0;
        if (!(S[0] > 0.0) || !(fabs(S[1] / S[0] - s1) <= 1e-9) ||
            !(fabs(S[2] / S[0] - s2) <= 1e-9) || !(fabs(S[3]) <= 1e-9 * S[0]))
            fail_msg("lamp %s: S = (%g, %g, %g, %g)", light, S[0], S[1], S[2], S[3]);
        tilebuf_destroy(&t);
        scene_destroy(&s);
    }
}

/* An unpolarised lamp is unchanged: "polarization" 0 is the default, polarisation stays off
 * and the image is the same to the bit. */
static void test_unpolarised(void **state)
{
    (void)state;
    tilebuf_t *ta, *tb;
    scene_t *a = lamp_scene("", "", "");
    scene_t *b = lamp_scene("\"float polarization\" [0] \"float polarizationangle\" [40]", "", "");
    assert_false(b->settings.polarised);
    assert_int_equal(b->polarised_lights, 0);
    render_s0(a, &ta);
    render_s0(b, &tb);
    const size_t n = 4 * 4 * (size_t)tilebuf_nbuckets(ta);
    assert_int_equal(tilebuf_nbuckets(ta), tilebuf_nbuckets(tb));
    assert_memory_equal(tilebuf_sums(ta), tilebuf_sums(tb), n * sizeof(double));
    assert_memory_equal(tilebuf_xyz_sums(ta), tilebuf_xyz_sums(tb), 4 * 4 * 3 * sizeof(double));
    tilebuf_destroy(&ta);
    tilebuf_destroy(&tb);
    scene_destroy(&a);
    scene_destroy(&b);
}

/* A glass slab (n = 1.5, faces 0.1 apart) tilted 60 degrees about the world's x axis in front
 * of the lamp: the plane of incidence is y-z, so a lamp polarised along x (0 degrees) is
 * s-polarised and passes the sum of its inter-reflections T_s = (1 - R_s)/(1 + R_s), one along
 * y (90 degrees) T_p; R_s and R_p from Fresnel's equations. No analyser: the camera sees the
 * intensity, changed by the lamp's polarisation through the glass alone. */
static void test_slab(void **state)
{
    (void)state;
    const double n = 1.5, th = 60.0 * PI / 180.0, ct = sqrt(1.0 - pow(sin(th) / n, 2.0));
    const double rs = (cos(th) - n * ct) / (cos(th) + n * ct),
                 rp = (n * cos(th) - ct) / (n * cos(th) + ct);
    const double want[2] = {(1.0 - rs * rs) / (1.0 + rs * rs), (1.0 - rp * rp) / (1.0 + rp * rp)};
    for (int k = 0; k < 2; k++) {
        char head[2048], text[4096];
        snprintf(head, sizeof head,
                 "LookAt 0 0 5  0 0 0  0 1 0\n"
                 "Camera \"orthographic\" \"float screenwindow\" [-0.05 0.05 -0.05 0.05]\n"
                 "Film \"spectral\" \"integer xresolution\" [4] \"integer yresolution\" [4]\n"
                 "Integrator \"whitted\" \"integer maxdepth\" [24]\n"
                 "WorldBegin\n"
                 "AttributeBegin\n"
                 "AreaLightSource \"diffuse\" \"spectrum L\" [300 1 900 1] \"bool twosided\" true "
                 "\"float polarization\" [1] \"float polarizationangle\" [%d]\n"
                 "Translate 0 0 -3\nScale 0.5 0.5 1\n" PBRT_QUAD "AttributeEnd\n",
                 90 * k);
        scene_t *open = sb_load_text(head, NULL);
        assert_true(open->settings.polarised);
        const double o = render_s0(open, NULL);
        scene_destroy(&open);
        snprintf(text, sizeof text,
                 "%sAttributeBegin\nMaterial \"dielectric\" \"float eta\" [1.5]\nRotate 60 1 0 0\n"
                 "Translate 0 0 0.05\n" PBRT_QUAD "Translate 0 0 -0.1\n" PBRT_QUAD_BACK
                 "AttributeEnd\n",
                 head);
        scene_t *s = sb_load_text(text, NULL);
        const double got = render_s0(s, NULL) / o;
        scene_destroy(&s);
        if (!(fabs(got - want[k]) <= 1e-4))
            fail_msg("%s-polarised lamp through a slab at 60 degrees: %.6f, want %.6f",
                     k ? "p" : "s", got, want[k]);
    }
}

/* Point, spot and distant lights: the emission's Stokes vector along k in a frame x is
 * (1, P cos 2psi, P sin 2psi, 0), psi the angle from x toward k x x of the light's axis made
 * perpendicular to k. The axis is the light's CTM's x turned toward its y. */
static void test_delta_lights(void **state)
{
    (void)state;
    static const char *kinds[] = {
        "LightSource \"point\" \"point3 from\" [0 0 0]",
        "LightSource \"spot\" \"point3 from\" [0 0 0] \"point3 to\" [0 0 -1]",
        "LightSource \"distant\" \"point3 from\" [0 0 0] \"point3 to\" [0 0 -1]",
    };
    for (size_t i = 0; i < 3; i++) {
        char text[1024];
        /* The CTM turns x into y: an angle of 30 in the light's space is 120 in the world's. */
        snprintf(text, sizeof text,
                 "Camera \"orthographic\"\nWorldBegin\nAttributeBegin\nRotate 90 0 0 1\n%s "
                 "\"float polarization\" [0.8] \"float polarizationangle\" [30]\nAttributeEnd\n",
                 kinds[i]);
        scene_t *s = sb_load_text(text, NULL);
        assert_true(s->settings.polarised);
        assert_int_equal(s->polarised_lights, 1);
        const light_t *l = &s->lights[0];
        assert_true(fabs(l->polarisation - 0.8) <= 1e-15);
        /* Along -z in the frame x = world x, y = k x x = -y: the axis at 120 degrees from x
         * toward world y is at -120 in that frame. */
        double st[4];
        lights_stokes(l, vec3_make(0, 0, -1), vec3_make(1, 0, 0), st);
        const double psi = -120.0 * PI / 180.0;
        if (!(fabs(st[0] - 1.0) <= 1e-15 && fabs(st[1] - 0.8 * cos(2 * psi)) <= 1e-12 &&
              fabs(st[2] - 0.8 * sin(2 * psi)) <= 1e-12 && st[3] == 0.0))
            fail_msg("%s: (%g, %g, %g, %g)", kinds[i], st[0], st[1], st[2], st[3]);
        /* Seen along the axis's own world direction's perpendicular, tilted: the axis made
         * perpendicular to k keeps the full degree. */
        const vec3_t k = vec3_normalize(vec3_make(1, 0, -1));
        const vec3_t x = vec3_make(0, 1, 0);
        lights_stokes(l, k, x, st);
        assert_true(fabs(st[1] * st[1] + st[2] * st[2] - 0.64) <= 1e-12);
        scene_destroy(&s);
    }
}

/* Next-event estimation of a polarised delta light (docs/physics.md §14.2): a distant light of
 * degree P polarised at phi shines straight down (-z) on a glossy metal (a rough conductor, so
 * that only light sampling finds it), seen straight from above through the camera's analyser
 * at theta. Every sample meets the metal at normal incidence, where its Fresnel matrix keeps
 * the light's plane, so the analyser passes (1 + P cos 2(theta + phi)) / 2 of what the open
 * camera sees (Malus's law; +phi in the world is -phi in the image, pbrt's LookAt mirroring x,
 * as in test_malus), to rounding: the same samples, only the matrices differ. */
static double glossy_metal(double degree, double phi, const char *camera)
{
    char text[4096];
    snprintf(text, sizeof text,
             "LookAt 0 0 5  0 0 0  0 1 0\n"
             "Camera \"orthographic\" %s\n"
             "Film \"spectral\" \"integer xresolution\" [4] \"integer yresolution\" [4]\n"
             "Sampler \"independent\" \"integer pixelsamples\" [4]\n"
             "Integrator \"path\" \"integer maxdepth\" [1]\n"
             "WorldBegin\n"
             "LightSource \"distant\" \"point3 from\" [0 0 1] \"point3 to\" [0 0 0] "
             "\"spectrum L\" [300 1 900 1] \"float polarization\" [%g] "
             "\"float polarizationangle\" [%g]\n"
             "Material \"conductor\" \"float roughness\" [0.2] \"spectrum eta\" [300 0.2 900 0.2] "
             "\"spectrum k\" [300 3 900 3]\n" PBRT_QUAD,
             camera, degree, phi);
    scene_t *s = sb_load_text(text, NULL);
    assert_true(s->settings.polarised);
    const double v = render_s0(s, NULL);
    scene_destroy(&s);
    return v;
}

static void test_nee_malus(void **state)
{
    (void)state;
    const double degree[] = {1.0, 0.5}, phi = 20.0;
    for (int d = 0; d < 2; d++) {
        const double open = glossy_metal(degree[d], phi, "");
        assert_true(open > 0.0);
        for (int theta = 0; theta < 180; theta += 30) {
            char cam[64];
            snprintf(cam, sizeof cam, "\"float analyzer\" [%d]", theta);
            const double got = glossy_metal(degree[d], phi, cam) / open;
            const double want = 0.5 * (1.0 + degree[d] * cos(2.0 * (theta + phi) * PI / 180.0));
            if (!(fabs(got - want) <= 1e-9))
                fail_msg("distant light of degree %g at %g on metal, analyser at %d: %.12f, want "
                         "%.12f",
                         degree[d], phi, theta, got, want);
        }
    }
}

/* A polarised spot light on glossy glass (a rough dielectric, alpha 0.05) at Brewster's angle
 * (tan theta_B = n = 1.5), the camera at the mirror direction with a narrow view: p-polarised
 * light (its plane the plane of incidence, x-z) is hardly reflected (R_p vanishes at theta_B
 * and stays below 1e-3 within the few degrees the lobe and the view spread over), s-polarised
 * light is reflected twice as brightly as unpolarised (R_s against (R_s + R_p) / 2), and the two
 * average to the unpolarised light (Stokes vectors add; to 1e-3, as the two axes made
 * perpendicular to beams that leave the spot a little off the plane x-z are not quite
 * perpendicular to each other). */
static double glossy_brewster(const char *polarisation)
{
    const double tb = atan(1.5), d = 6.0;
    char text[4096];
    snprintf(text, sizeof text,
             "LookAt %.9f 0 %.9f  0 0 0  0 0 1\n"
             "Camera \"perspective\" \"float fov\" [1]\n"
             "Film \"spectral\" \"integer xresolution\" [4] \"integer yresolution\" [4]\n"
             "Sampler \"independent\" \"integer pixelsamples\" [4]\n"
             "Integrator \"path\" \"integer maxdepth\" [1]\n"
             "WorldBegin\n"
             "LightSource \"spot\" \"point3 from\" [%.9f 0 %.9f] \"point3 to\" [0 0 0] "
             "\"float coneangle\" [10] \"spectrum I\" [300 1 900 1] %s\n"
             "Material \"dielectric\" \"float eta\" [1.5] \"float roughness\" [0.05]\n" PBRT_QUAD,
             d * sin(tb), d * cos(tb), -d * sin(tb), d * cos(tb), polarisation);
    scene_t *s = sb_load_text(text, NULL);
    const double v = render_s0(s, NULL);
    scene_destroy(&s);
    return v;
}

static void test_nee_brewster(void **state)
{
    (void)state;
    /* The light's CTM is the identity: angle 0 is world x (made perpendicular to the beam: in
     * the plane of incidence, p), 90 world y (s). */
    const double unpolarised = glossy_brewster("");
    const double p = glossy_brewster("\"float polarization\" [1] \"float polarizationangle\" [0]");
    const double sp =
        glossy_brewster("\"float polarization\" [1] \"float polarizationangle\" [90]");
    print_message("glossy glass at Brewster's angle: s %.6g, p %.6g, unpolarised %.6g\n", sp, p,
                  unpolarised);
    assert_true(unpolarised > 0.0);
    if (!(p <= 2e-3 * unpolarised) || !(fabs(sp / unpolarised - 2.0) <= 4e-3) ||
        !(fabs(0.5 * (sp + p) - unpolarised) <= 1e-3 * unpolarised))
        fail_msg("s %.9g, p %.9g, unpolarised %.9g", sp, p, unpolarised);
}

/* The plan turns polarisation on for a polarised light and says which kind sees it. */
static void test_plan(void **state)
{
    (void)state;
    const char *text =
        "Camera \"orthographic\"\nWorldBegin\n"
        "LightSource \"spot\" \"float polarization\" [0.5]\n"
        "AttributeBegin\nAreaLightSource \"diffuse\" \"float polarization\" [1]\n" PBRT_QUAD
        "AttributeEnd\n";
    err_t err = {{0}};
    scene_desc_t *d = pbrt_parse_string(text, strlen(text), "t.pbrt", &err);
    assert_non_null(d);
    scene_t *s = scene_load(d, NULL, &err);
    assert_non_null(s);
    plan_request_t req = plan_request_make(d, NULL);
    plan_t *p = plan_new(s, &req, &err);
    assert_non_null(p);
    const plan_decision_t *pd = plan_decision_of(p, PLAN_POLARISATION);
    assert_true(pd->on);
    if (!strstr(pd->reason, "2 lights emit polarised light") ||
        !strstr(pd->reason, "1 area light") ||
        !strstr(pd->reason, "1 point, spot, distant or collimated"))
        fail_msg("plan: %s", pd->reason);
    plan_destroy(&p);
    scene_destroy(&s);
    scene_desc_destroy(&d);
}

static void test_syntax(void **state)
{
    (void)state;
    static const char *bad[] = {
        "LightSource \"point\" \"float polarization\" [1.5]",
        "LightSource \"spot\" \"float polarization\" [-0.1]",
        "LightSource \"distant\" \"float polarizationangle\" [400]",
        "AreaLightSource \"diffuse\" \"float polarization\" [2]\n" PBRT_QUAD,
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        char text[1024];
        snprintf(text, sizeof text, "Camera \"orthographic\"\nWorldBegin\n%s\n", bad[i]);
        err_t err = {{0}};
        scene_t *s = sb_load_text(text, &err);
        if (s)
            fail_msg("accepted: %s", bad[i]);
        if (!strstr(err.msg, "t.pbrt:3"))
            fail_msg("no line in \"%s\" for %s", err.msg, bad[i]);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_malus),         cmocka_unit_test(test_unpolarised),
        cmocka_unit_test(test_slab),          cmocka_unit_test(test_delta_lights),
        cmocka_unit_test(test_stokes_output), cmocka_unit_test(test_plan),
        cmocka_unit_test(test_syntax),        cmocka_unit_test(test_nee_malus),
        cmocka_unit_test(test_nee_brewster),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
