/* coherent: a thin uniaxial crystal whose o and e waves cross it as one ray ("bool coherent",
 * render/crystal_coherent.h, docs/physics.md §15.2), rendered, against optics rather than the
 * code: a plate with its axis in its plane at 45 degrees between crossed polarisers passes, per
 * wavelength, the two waves' interference (1/8)(T_o + T_e - 2 sqrt(T_o T_e) cos(2 pi dn t /
 * lambda)) -- (T/2) sin^2(pi dn t / lambda) with Fresnel's T at each face -- and its colour over
 * D65 is the closed-form Michel-Levy integral the retarder sheet is held to (test_waveplate's
 * oracle, tests/support/michel_levy_testutil.h), 0 to 2000 nm; a quartz plate cut across its
 * axis turns linear light by the handbook's rotation rho(lambda) t (Malus through an analyser);
 * without polarisation a coherent crystal is the crystal traced as before. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h> /* after the four headers above, which it needs */

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "michel_levy_testutil.h"
#include "overrides.h"
#include "pbrt_parser.h"

/* A slab 0.1 scene units thick (faces at z = 1.5 facing the camera and 1.4 facing the light,
 * chart_scene's quad the front) of the material text. */
static void slab(char *out, size_t size, const char *material)
{
    snprintf(out, size, "%s\nAttributeBegin\nTranslate 0 0 -0.1\n" PBRT_QUAD_BACK "AttributeEnd\n",
             material);
}

/* Fresnel's normal-incidence transmittance through both faces for a wave of index n. */
static double t_faces(double n)
{
    return pow(4.0 * n / ((n + 1.0) * (n + 1.0)), 2.0);
}

/* The dispersion-free plate n_o 1.54, n_e 1.55 (dn 0.01) of retardation gamma_nm, coherent,
 * its axis at 45 degrees in its plane: the slab's 0.1 units are gamma / 0.01 nm. */
static void plate_dispersion_free(char *out, size_t size, double gamma_nm)
{
    char m[512];
    const double t_mm = fmax(gamma_nm / 0.01 * 1e-6, 1e-9);
    snprintf(m, sizeof m,
             "Material \"uniaxial\" \"float o.eta\" [1.54] \"float e.eta\" [1.55] "
             "\"vector3 opticaxis\" [1 1 0] \"bool coherent\" true \"float mmperunit\" [%.17g]",
             t_mm / 0.1);
    slab(out, size, m);
}

/* Per wavelength: 0.6 nm bands about 450, 550 and 650 nm, a plate of 1000 nm retardation
 * (a phase difference of 4.4, 3.6 and 3.1 rad: dark, mid and bright). */
static void test_per_wavelength(void **state)
{
    (void)state;
    const double lines[3] = {450.0, 550.0, 650.0};
    const double gamma = 1000.0;
#define LINE_BOX                                                                                   \
    "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"orthographic\"\n"                                        \
    "Film \"spectral\" \"integer xresolution\" [4] \"integer yresolution\" [4] "                   \
    "\"integer nbuckets\" [4] \"float lambdamin\" [%g] \"float lambdamax\" [%g]\n"                 \
    "Sampler \"zsobol\" \"integer pixelsamples\" [64]\n"                                           \
    "Integrator \"path\" \"integer maxdepth\" [5]\nWorldBegin\n"                                   \
    "AttributeBegin\nAreaLightSource \"diffuse\" \"spectrum L\" [300 1 900 1] "                    \
    "\"bool twosided\" true\nTranslate 0 0 -1\n" PBRT_QUAD "AttributeEnd\n"
    const chart_setup_t cs = {4, 64, 0};
    for (int l = 0; l < 3; l++) {
        char open[2048], text[8192], plate[1024];
        snprintf(open, sizeof open, LINE_BOX, lines[l] - 0.3, lines[l] + 0.3);
        scene_t *o = sb_load_text(open, NULL);
        double xyz_open[3], xyz[3];
        render_xyz(o, cs, xyz_open);
        scene_destroy(&o);
        plate_dispersion_free(plate, sizeof plate, gamma);
        snprintf(text, sizeof text,
                 LINE_BOX "AttributeBegin\nMaterial \"polarizer\" \"float angle\" [0]\n" PBRT_QUAD
                          "AttributeEnd\n"
                          "AttributeBegin\nTranslate 0 0 1.5\n%s\n" PBRT_QUAD "AttributeEnd\n"
                          "AttributeBegin\nTranslate 0 0 3\nMaterial \"polarizer\" \"float "
                          "angle\" [90]\n" PBRT_QUAD "AttributeEnd\n",
                 lines[l] - 0.3, lines[l] + 0.3, plate);
        scene_t *s = sb_load_text(text, NULL);
        assert_true(s->settings.polarised);
        render_xyz(s, cs, xyz);
        scene_destroy(&s);
        const double to = t_faces(1.54), te = t_faces(1.55);
        const double d = 2.0 * PI * gamma / lines[l];
        const double want = 0.125 * (to + te - 2.0 * sqrt(to * te) * cos(d));
        const double got = xyz[1] / xyz_open[1];
        const double sn = sin(0.5 * d);
        print_message("%g nm: %.5f of the open box, want %.5f ((T/2) sin^2 %.5f)\n", lines[l], got,
                      want, 0.5 * sqrt(to * te) * sn * sn);
        if (!(fabs(got - want) < 1e-3))
            fail_msg("%g nm: %.5f of the open box, want %.5f", lines[l], got, want);
    }
}

/* The chart: 0-2000 nm every 200 with 47 stratified lanes, and a quartz thin section of 30 um
 * with the catalogue's dispersion, within 0.01 in linear sRGB. */
static void test_chart(void **state)
{
    (void)state;
    err_t err;
    spectrum_t *d65 = spectrum_new_cie_d65(&err);
    assert_non_null(d65);
    double open[3];
    scene_t *o = chart_scene("", FAN);
    render_xyz(o, FAN, open);
    scene_destroy(&o);
    double worst = 0.0, spread = 0.0;
    for (int g = 0; g <= 2000; g += 200) {
        char plate[1024];
        plate_dispersion_free(plate, sizeof plate, g);
        double got[3], want[3];
        const plate_t pl = {.gamma_nm = g, .n_o = 1.54, .n_e = 1.55, .fresnel = 1};
        const double e = chart_error(plate, FAN, open, d65, &pl, got, want);
        if (!(e <= 0.01))
            fail_msg("Gamma %d nm: linear sRGB (%.4f, %.4f, %.4f), want (%.4f, %.4f, %.4f)", g,
                     got[0], got[1], got[2], want[0], want[1], want[2]);
        worst = fmax(worst, e);
        spread = fmax(spread, fmax(want[0], fmax(want[1], want[2])));
    }
    assert_true(spread > 0.3);
    const crystal_t *q = crystal_find("quartz");
    assert_non_null(q);
    char m[512], plate[1024];
    snprintf(m, sizeof m,
             "Material \"uniaxial\" \"string crystal\" \"quartz\" \"vector3 opticaxis\" [1 1 0] "
             "\"bool coherent\" true \"float mmperunit\" [%.17g]",
             0.030 / 0.1);
    slab(plate, sizeof plate, m);
    double got[3], want[3];
    const plate_t pl = {.crystal = q, .thickness_nm = 30e3, .fresnel = 1};
    const double e = chart_error(plate, FAN, open, d65, &pl, got, want);
    if (!(e <= 0.01))
        fail_msg("quartz 30 um: (%.4f, %.4f, %.4f), want (%.4f, %.4f, %.4f)", got[0], got[1],
                 got[2], want[0], want[1], want[2]);
    worst = fmax(worst, e);
    print_message("coherent uniaxial Michel-Levy chart: largest linear sRGB error %.4f\n", worst);
    spectrum_destroy(&d65);
}

/* Optical activity: a 1 mm quartz plate cut across its axis between a polariser at 0 and an
 * analyser at theta passes (T/2) cos^2(theta + rho t) in narrow bands about the sodium D and
 * mercury 435.8 nm lines, rho the handbook's 21.724 and 41.548 deg/mm (Lowry 1912), T Fresnel's
 * through both faces at n_o (along the axis both waves have it). */
static void test_quartz_rotation(void **state)
{
    (void)state;
    const crystal_t *q = crystal_find("quartz");
    const double lines[2][2] = {{589.3, 21.724}, {435.8, 41.548}};
    const double thetas[5] = {0.0, 30.0, 60.0, 90.0, 135.0};
    const chart_setup_t cs = {4, 64, 0};
    for (int l = 0; l < 2; l++) {
        char open[2048];
        snprintf(open, sizeof open, LINE_BOX, lines[l][0] - 0.3, lines[l][0] + 0.3);
        scene_t *o = sb_load_text(open, NULL);
        double xyz_open[3];
        render_xyz(o, cs, xyz_open);
        scene_destroy(&o);
        const double no = ior_eval(&q->no, lines[l][0]), tf = t_faces(no);
        for (int i = 0; i < 6; i++) {
            const double th = i < 5 ? thetas[i] : 90.0 - lines[l][1];
            char text[8192], plate[1024];
            slab(plate, sizeof plate,
                 "Material \"uniaxial\" \"string crystal\" \"quartz\" \"vector3 opticaxis\" "
                 "[0 0 1] \"bool coherent\" true \"float mmperunit\" [10]");
            snprintf(text, sizeof text,
                     LINE_BOX
                     "AttributeBegin\nMaterial \"polarizer\" \"float angle\" [0]\n" PBRT_QUAD
                     "AttributeEnd\n"
                     "AttributeBegin\nTranslate 0 0 1.5\n%s\n" PBRT_QUAD "AttributeEnd\n"
                     "AttributeBegin\nTranslate 0 0 3\nMaterial \"polarizer\" \"float "
                     "angle\" [%g]\n" PBRT_QUAD "AttributeEnd\n",
                     lines[l][0] - 0.3, lines[l][0] + 0.3, plate, th);
            scene_t *s = sb_load_text(text, NULL);
            double xyz[3];
            render_xyz(s, cs, xyz);
            scene_destroy(&s);
            const double want = 0.5 * tf * pow(cos((th + lines[l][1]) * PI / 180.0), 2.0);
            const double got = xyz[1] / xyz_open[1];
            print_message("%g nm, analyser %g: %.5f, want %.5f\n", lines[l][0], th, got, want);
            if (!(fabs(got - want) < 1e-3))
                fail_msg("%g nm, analyser %g deg: %.5f of the open box, want %.5f", lines[l][0], th,
                         got, want);
        }
    }
}

/* Polarisation forced off (--polarized off): a coherent crystal is traced as the crystal always
 * was, bit for bit (the o and e waves apart); left to the file, "coherent" turns it on. */
static scene_t *load_with(const char *text, int polarized)
{
    const scene_overrides_t ov = {.seed = -1, .polarized = polarized};
    return sb_load_text_with(text, &ov, NULL);
}

static void test_polarisation_off(void **state)
{
    (void)state;
    const char *fmt = "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" [30]\n"
                      "Film \"spectral\" \"integer xresolution\" [8] \"integer yresolution\" [8]\n"
                      "Sampler \"zsobol\" \"integer pixelsamples\" [8]\n"
                      "Integrator \"path\" \"integer maxdepth\" [8]\nWorldBegin\n"
                      "LightSource \"infinite\" \"spectrum L\" [300 1 900 1]\n"
                      "Rotate 30 1 1 0\nMaterial \"uniaxial\" \"string crystal\" \"calcite\" "
                      "\"vector3 opticaxis\" [0.3 1 0.2] %s\n"
                      "Shape \"sphere\" \"float radius\" [1]\n";
    char a[2048], b[2048];
    snprintf(a, sizeof a, fmt, "\"bool coherent\" true");
    snprintf(b, sizeof b, fmt, "");
    scene_t *on = load_with(a, SCENE_POLARIZED_FILE), *off = load_with(a, SCENE_POLARIZED_OFF),
            *plain = load_with(b, SCENE_POLARIZED_FILE);
    assert_true(on->settings.polarised);
    assert_false(off->settings.polarised);
    assert_false(plain->settings.polarised);
    err_t err;
    tilebuf_t *t[2];
    scene_t *sc[2] = {off, plain};
    for (int k = 0; k < 2; k++) {
        t[k] = tilebuf_new(0, 0, 8, 8, render_settings_buckets(&sc[k]->settings), &err);
        assert_non_null(t[k]);
        render_stats_t st = {0};
        if (render_tile(sc[k], NULL, 0, 0, 8, 8, 0, 8, t[k], &st, &err))
            fail_msg("render_tile: %s", err.msg);
    }
    double sum = 0.0;
    for (int y = 0; y < 8; y++)
        for (int x = 0; x < 8; x++)
            for (int k = 0; k < 3; k++) {
                assert_true(tilebuf_xyz_sum(t[0], x, y, k) == tilebuf_xyz_sum(t[1], x, y, k));
                sum += tilebuf_xyz_sum(t[0], x, y, k);
            }
    assert_true(sum > 0.0);
    tilebuf_destroy(&t[0]);
    tilebuf_destroy(&t[1]);
    scene_destroy(&on);
    scene_destroy(&off);
    scene_destroy(&plain);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_per_wavelength),
        cmocka_unit_test(test_chart),
        cmocka_unit_test(test_quartz_rotation),
        cmocka_unit_test(test_polarisation_off),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
