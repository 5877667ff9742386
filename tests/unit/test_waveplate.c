/* waveplate: the retardance of a thin birefringent plate (polar/waveplate.h, docs/physics.md
 * §14.1) against optics, not against the code: at oblique incidence against Snell's law solved
 * by bisection on the extraordinary index n(theta) of the index ellipsoid (Born & Wolf §15.3),
 * a route that never uses the closed form's quadratic; and rendered, the Michel-Levy chart --
 * a plate of retardation Gamma at 45 degrees between crossed polarisers over a D65 light box --
 * against the closed-form colour, the integral of D65 (1/2) sin^2(pi Gamma / lambda) times the
 * CIE 1931 matching functions, for Gamma = 0 to 2000 nm every 100 nm, within 0.01 in linear
 * sRGB with the open light box's Y = 1; the dispersion-free plate ("o.eta", "e.eta" and
 * "thickness") and the path difference ("retardation") alike; the quartz plate by its own
 * dispersion; and the scene syntax's errors. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h> /* after the four headers above, which it needs */

#include <complex.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "cie.h"
#include "crystal.h"
#include "render.h"
#include "scene.h"
#include "scene_builders.h"
#include "spectrum.h"
#include "wavelength.h"
#include "waveplate.h"

#define PI 3.14159265358979323846

/* ---- the retardance against Snell's law ---- */

/* The e-wave's normal component N_e for a ray from air at incidence sin_i in a plane of
 * incidence at azimuth phi from the optic axis (in the plate's plane, the normal z): the wave
 * vector K = (s cos phi, s sin phi, N) with s = sin_i in the axis's frame (x along the axis)
 * must have |K| = n(theta), 1/n^2 = cos^2 theta / n_o^2 + sin^2 theta / n_e^2, theta the angle
 * between K and the axis (Born & Wolf §15.3). Solved for N by bisection on
 * g(N) = |K|^2 - n(theta(N))^2, which changes sign once on [0, 3 max(n_o, n_e)]. */
static double ne_normal_bisect(double n_o, double n_e, double sin_i, double phi)
{
    const double kx = sin_i * cos(phi), ky = sin_i * sin(phi);
    double lo = 0.0, hi = 3.0 * fmax(n_o, n_e);
    for (int it = 0; it < 200; it++) {
        const double mid = 0.5 * (lo + hi);
        const double k2 = kx * kx + ky * ky + mid * mid;
        const double c2 = kx * kx / k2, s2 = 1.0 - c2;
        const double n2 = 1.0 / (c2 / (n_o * n_o) + s2 / (n_e * n_e));
        if (k2 - n2 < 0.0)
            lo = mid;
        else
            hi = mid;
    }
    return 0.5 * (lo + hi);
}

static void test_oblique(void **state)
{
    (void)state;
    const double idx[][2] = {{1.6584, 1.4864}, {1.5443, 1.5534}, {1.7682, 1.7601}, {2.613, 2.909}};
    const vec3_t nrm = vec3_make(0, 0, 1), axis = vec3_make(1, 0, 0);
    const double t_nm = 25000.0, lambda = 550.0;
    int checked = 0;
    for (size_t c = 0; c < sizeof idx / sizeof idx[0]; c++)
        for (int ia = 0; ia <= 80; ia += 10)
            for (int ip = 0; ip < 360; ip += 30) {
                const double th = ia * PI / 180.0, ph = ip * PI / 180.0;
                const double s = sin(th);
                /* The ray travels into the plate (-z) or out of it (+z): the same retardance. */
                for (int side = -1; side <= 1; side += 2) {
                    const vec3_t dir = vec3_make(s * cos(ph), s * sin(ph), side * cos(th));
                    const double got =
                        waveplate_retardance(idx[c][0], idx[c][1], t_nm, lambda, dir, nrm, axis);
                    const double no = sqrt(idx[c][0] * idx[c][0] - s * s); /* Snell with n_o */
                    const double ne = ne_normal_bisect(idx[c][0], idx[c][1], s, ph);
                    const double want = 2.0 * PI * t_nm * (no - ne) / lambda;
                    if (!(fabs(got - want) <= 1e-9 * fabs(2.0 * PI * t_nm / lambda)))
                        fail_msg("n (%g, %g) at %d deg, azimuth %d: %.12g, want %.12g", idx[c][0],
                                 idx[c][1], ia, ip, got, want);
                    checked++;
                }
            }
    assert_int_equal(checked, 4 * 9 * 12 * 2);
    /* Normal incidence: 2 pi (n_o - n_e) t / lambda, positive for calcite (the axis fast). */
    const double d =
        waveplate_retardance(1.6584, 1.4864, 1000.0, 500.0, vec3_make(0, 0, -1), nrm, axis);
    assert_true(fabs(d - 2.0 * PI * (1.6584 - 1.4864) * 2.0) <= 1e-12);
    /* Absurd input stays finite. */
    assert_true(
        isfinite(waveplate_retardance(0.0, 1.5, 1e3, 500.0, vec3_make(0, 0, -1), nrm, axis)));
    assert_true(isfinite(waveplate_retardance(1.5, 1.5, 1e3, 0.0, vec3_make(0, 0, -1), nrm, axis)));
}

#include "michel_levy_testutil.h"

static void test_michel_levy(void **state)
{
    (void)state;
    err_t err;
    spectrum_t *d65 = spectrum_new_cie_d65(&err);
    assert_non_null(d65);
    double open[3], open_hero[3];
    scene_t *o = chart_scene("", FAN);
    render_xyz(o, FAN, open);
    scene_destroy(&o);
    o = chart_scene("", HERO);
    render_xyz(o, HERO, open_hero);
    scene_destroy(&o);
    assert_true(open[1] > 0.0 && open_hero[1] > 0.0);
    double worst = 0.0, spread = 0.0;
    for (int g = 0; g <= 2000; g += 100) {
        /* A dispersion-free plate, n_e - n_o = 0.01, t = Gamma / 0.01, every 100 nm; the path
         * difference itself every 200 (the two must agree). */
        char plate[256];
        snprintf(plate, sizeof plate,
                 "Material \"retarder\" \"float angle\" [45] \"float o.eta\" [1.54] "
                 "\"float e.eta\" [1.55] \"float thickness\" [%.17g]",
                 g / 0.01 / 1000.0);
        double got[3], want[3];
        double e = chart_error(plate, FAN, open, d65, &(plate_t){.gamma_nm = g}, got, want);
        if (!(e <= 0.01))
            fail_msg("Gamma %d nm: linear sRGB (%.4f, %.4f, %.4f), want (%.4f, %.4f, %.4f)", g,
                     got[0], got[1], got[2], want[0], want[1], want[2]);
        worst = fmax(worst, e);
        spread = fmax(spread, fmax(want[0], fmax(want[1], want[2])));
        if (g % 200 == 0) {
            snprintf(plate, sizeof plate,
                     "Material \"retarder\" \"float angle\" [-45] \"float retardation\" [%d]", g);
            e = chart_error(plate, FAN, open, d65, &(plate_t){.gamma_nm = g}, got, want);
            if (!(e <= 0.01))
                fail_msg("retardation %d nm: (%.4f, %.4f, %.4f), want (%.4f, %.4f, %.4f)", g,
                         got[0], got[1], got[2], want[0], want[1], want[2]);
            worst = fmax(worst, e);
        }
    }
    /* The chart is not trivially passed: its colours reach far past the tolerance. */
    assert_true(spread > 0.3);
    /* A quartz plate of 30 um (a petrographic thin section) and of 100 um, with the
     * catalogue's dispersion of n_e - n_o. */
    const crystal_t *q = crystal_find("quartz");
    assert_non_null(q);
    const double um[] = {30.0, 100.0};
    for (size_t i = 0; i < 2; i++) {
        char plate[256];
        snprintf(plate, sizeof plate,
                 "Material \"retarder\" \"float angle\" [45] \"string crystal\" \"quartz\" "
                 "\"float thickness\" [%g]",
                 um[i]);
        double got[3], want[3];
        const double e =
            chart_error(plate, FAN, open, d65,
                        &(plate_t){.crystal = q, .thickness_nm = um[i] * 1000.0}, got, want);
        if (!(e <= 0.01))
            fail_msg("quartz %g um: (%.4f, %.4f, %.4f), want (%.4f, %.4f, %.4f)", um[i], got[0],
                     got[1], got[2], want[0], want[1], want[2]);
    }
    printf("Michel-Levy chart with 47 stratified lanes: largest linear sRGB error %.4f\n", worst);
    /* Oblique incidence, rendered: the plate turned 40 degrees about its own optic axis (at
     * 45 degrees, so that the axis stays across the ray and at 45 degrees to both
     * polarisers), 100 um of n_o 1.54, n_e 1.55: a retardation of 1000 nm at normal
     * incidence, 1100 nm at 40 degrees (a different colour: the check fails for a plate that
     * ignored the angle). */
    for (int deg = 20; deg <= 40; deg += 20) {
        char plate[256];
        snprintf(plate, sizeof plate,
                 "Rotate %d 1 1 0\nMaterial \"retarder\" \"float angle\" [45] \"float o.eta\" "
                 "[1.54] \"float e.eta\" [1.55] \"float thickness\" [100]",
                 deg);
        const plate_t pl = {
            .thickness_nm = 1e5, .n_o = 1.54, .n_e = 1.55, .sin_i = sin(deg * PI / 180.0)};
        double got[3], want[3];
        const double e = chart_error(plate, FAN, open, d65, &pl, got, want);
        if (!(e <= 0.01))
            fail_msg("plate turned %d degrees: (%.4f, %.4f, %.4f), want (%.4f, %.4f, %.4f)", deg,
                     got[0], got[1], got[2], want[0], want[1], want[2]);
        worst = fmax(worst, e);
    }
    /* The default hero wavelengths, drawn by visible importance over 360-830 nm. */
    for (int g = 500; g <= 1500; g += 500) {
        char plate[128];
        snprintf(plate, sizeof plate,
                 "Material \"retarder\" \"float angle\" [45] \"float retardation\" [%d]", g);
        double got[3], want[3];
        const double e =
            chart_error(plate, HERO, open_hero, d65, &(plate_t){.gamma_nm = g}, got, want);
        if (!(e <= 0.01))
            fail_msg("hero lanes, %d nm: (%.4f, %.4f, %.4f), want (%.4f, %.4f, %.4f)", g, got[0],
                     got[1], got[2], want[0], want[1], want[2]);
        worst = fmax(worst, e);
    }
    printf("with hero lanes as well: %.4f\n", worst);
    spectrum_destroy(&d65);
}

/* ---- Optical activity: a quartz plate cut across its optic axis (polar/waveplate.h) ---- */

/* The Jones-to-Mueller conversion against what does not come from it: the diagonal form and
 * the rotator R(psi), which turns linear light at 0 to psi. */
static void test_jones_mueller(void **state)
{
    (void)state;
    const double a[2] = {0.8, -0.3}, b[2] = {-0.2, 0.55};
    const double jd[2][2][2] = {{{a[0], a[1]}, {0, 0}}, {{0, 0}, {b[0], b[1]}}};
    const mueller_t md = mueller_jones(jd), want = mueller_jones_diagonal(a[0], a[1], b[0], b[1]);
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++)
            assert_true(fabs(md.m[r][c] - want.m[r][c]) < 1e-12);
    for (double psi = -1.2; psi < 1.3; psi += 0.3) {
        const double jr[2][2][2] = {{{cos(psi), 0}, {-sin(psi), 0}},
                                    {{sin(psi), 0}, {cos(psi), 0}}};
        const mueller_t mr = mueller_jones(jr);
        const stokes_t out = mueller_apply(&mr, stokes_linear(1.0, 0.0));
        assert_true(fabs(out.s[0] - 1.0) < 1e-12 && fabs(stokes_dop(out) - 1.0) < 1e-12);
        assert_true(fabs(stokes_aop(out) - psi) < 1e-12);
        assert_true(fabs(out.s[3]) < 1e-12);
    }
}

/* The plate's elliptical retarder against Jones's equivalence theorem written out: the
 * product of many thin slices, each a rotator by psi/N between halves of a linear retarder of
 * delta/N with the o wave (along s) lagging, converges to one homogeneous plate (1e-6 with
 * 20000 slices);
 * delta from the index surface with the axis along the normal, computed here. */
static void test_axial_slices(void **state)
{
    (void)state;
    const double n_o = 1.5443, n_e = 1.5534, t_nm = 2e5, lambda = 589.3;
    for (double deg = 0.0; deg <= 30.0; deg += 2.5) {
        const double a = deg * PI / 180.0, q = sin(a);
        const vec3_t k = vec3_make(sin(a), 0.0, cos(a)), n = vec3_make(0.0, 0.0, 1.0);
        const vec3_t x = vec3_make(0.0, -1.0, 0.0); /* s = k x n */
        const double No = sqrt(n_o * n_o - q * q), Ne = n_o * sqrt(1.0 - q * q / (n_e * n_e));
        const double delta = 2.0 * PI * t_nm * (No - Ne) / lambda, psi = -0.379;
        const int N = 20000;
        double complex J[2][2] = {{1, 0}, {0, 1}};
        const double complex h = cexp(-I * delta / (2 * N)); /* half a slice's lag */
        const double cr = cos(psi / N), sr = sin(psi / N);
        for (int i = 0; i < N; i++) {
            /* slice = diag(h, 1) R(psi/N) diag(h, 1) (the symmetric split: error 1/N^2) */
            const double complex S[2][2] = {{h * cr * h, -h * sr}, {sr * h, cr}};
            double complex P[2][2];
            for (int r = 0; r < 2; r++)
                for (int c = 0; c < 2; c++)
                    P[r][c] = S[r][0] * J[0][c] + S[r][1] * J[1][c];
            memcpy(J, P, sizeof J);
        }
        double jj[2][2][2];
        for (int r = 0; r < 2; r++)
            for (int c = 0; c < 2; c++)
                jj[r][c][0] = creal(J[r][c]), jj[r][c][1] = cimag(J[r][c]);
        const mueller_t want = mueller_jones(jj),
                        got = waveplate_axial_mueller(n_o, n_e, psi, t_nm, lambda, k, n, x);
        for (int r = 0; r < 4; r++)
            for (int c = 0; c < 4; c++)
                if (!(fabs(got.m[r][c] - want.m[r][c]) < 1e-6))
                    fail_msg("%g deg: M[%d][%d] %.9f, slices %.9f", deg, r, c, got.m[r][c],
                             want.m[r][c]);
        /* Light sent back through the plate sees the same element in its own frame. */
        const mueller_t back =
            waveplate_axial_mueller(n_o, n_e, psi, t_nm, lambda, vec3_neg(k), n, vec3_neg(x));
        for (int r = 0; r < 4; r++)
            for (int c = 0; c < 4; c++)
                assert_true(fabs(back.m[r][c] - got.m[r][c]) < 1e-12);
    }
}

/* Rendered: unpolarised light through a polariser along x, a right-handed quartz plate 1 mm
 * thick cut across its axis and an analyser at theta, in a narrow band about a spectral line:
 * quartz turns the plane clockwise seen facing the light, so I / I_open = 1/2 cos^2(theta +
 * rho t), rho the handbook's rotation of quartz at 20 C (21.724 deg/mm at 589.3 nm, 41.548 at
 * 435.8 nm: Lowry 1912, not the catalogue's Drude fit), and the dispersion of the fit within
 * 0.2 % of the table at 404.7, 546.1 and 670.8 nm. */
static void test_quartz_rotation(void **state)
{
    (void)state;
    const crystal_t *q = crystal_find("quartz");
    assert_non_null(q);
    const double table[5][2] = {
        {404.7, 48.945}, {435.8, 41.548}, {546.1, 25.538}, {589.3, 21.724}, {670.8, 16.535}};
    for (int i = 0; i < 5; i++) {
        const double got = crystal_rotary_power(&q->rotation, table[i][0]);
        if (!(fabs(got / table[i][1] - 1.0) < 2e-3))
            fail_msg("rho(%g nm) = %.3f deg/mm, table %.3f", table[i][0], got, table[i][1]);
    }
    assert_true(crystal_rotary_power(&crystal_find("calcite")->rotation, 589.3) == 0.0);
    const double lines[2][2] = {{589.3, 21.724}, {435.8, 41.548}};
    const double thetas[6] = {0.0, 30.0, 45.0, 60.0, 90.0, 135.0};
    /* The film, the light box and its lamp, a narrow band about the line (two %g). */
#define QUARTZ_BOX                                                                                 \
    "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"orthographic\"\n"                                        \
    "Film \"spectral\" \"integer xresolution\" [4] \"integer yresolution\" [4] "                   \
    "\"integer nbuckets\" [4] \"float lambdamin\" [%g] \"float lambdamax\" [%g]\n"                 \
    "Sampler \"zsobol\" \"integer pixelsamples\" [4]\n"                                            \
    "Integrator \"path\" \"integer maxdepth\" [5]\nWorldBegin\n"                                   \
    "AttributeBegin\nAreaLightSource \"diffuse\" \"spectrum L\" [300 1 900 1] "                    \
    "\"bool twosided\" true\nTranslate 0 0 -1\n" PBRT_QUAD "AttributeEnd\n"
    const chart_setup_t cs = {4, 4, 0};
    for (int l = 0; l < 2; l++) {
        /* The open light box: the same film without the sheets, once per line. */
        char open[2048];
        snprintf(open, sizeof open, QUARTZ_BOX, lines[l][0] - 0.3, lines[l][0] + 0.3);
        scene_t *o = sb_load_text(open, NULL);
        double xyz_open[3];
        render_xyz(o, cs, xyz_open);
        scene_destroy(&o);
        for (int i = 0; i < 7; i++) {
            /* i = 6: the analyser at extinction, 90 - rho t */
            const double th = i < 6 ? thetas[i] : 90.0 - lines[l][1];
            char text[4096];
            snprintf(
                text, sizeof text,
                QUARTZ_BOX
                "AttributeBegin\nMaterial \"polarizer\" \"float angle\" [0]\n" PBRT_QUAD
                "AttributeEnd\n"
                "AttributeBegin\nTranslate 0 0 1.5\nMaterial \"retarder\" \"string "
                "crystal\" \"quartz\" \"float thickness\" [1000] \"bool axial\" true\n" PBRT_QUAD
                "AttributeEnd\n"
                "AttributeBegin\nTranslate 0 0 3\nMaterial \"polarizer\" \"float "
                "angle\" [%g]\n" PBRT_QUAD "AttributeEnd\n",
                lines[l][0] - 0.3, lines[l][0] + 0.3, th);
            scene_t *s = sb_load_text(text, NULL);
            double xyz[3];
            render_xyz(s, cs, xyz);
            scene_destroy(&s);
            const double want = 0.5 * pow(cos((th + lines[l][1]) * PI / 180.0), 2.0);
            const double got = xyz[1] / xyz_open[1];
            if (!(fabs(got - want) < 2e-3))
                fail_msg("%g nm, analyser %g deg: %.5f of the open box, want %.5f", lines[l][0], th,
                         got, want);
        }
    }
#undef QUARTZ_BOX
}

/* The syntax's errors, each with the file and line. */
static void test_syntax(void **state)
{
    (void)state;
    static const char *bad[] = {
        /* two ways at once */
        "Material \"retarder\" \"float retardance\" [90] \"float retardation\" [500]",
        "Material \"retarder\" \"float retardation\" [500] \"string crystal\" \"quartz\" "
        "\"float thickness\" [30]",
        /* a crystal without thickness, a thickness without a crystal */
        "Material \"retarder\" \"string crystal\" \"quartz\"",
        "Material \"retarder\" \"float thickness\" [30]",
        /* one index only */
        "Material \"retarder\" \"float o.eta\" [1.5] \"float thickness\" [30]",
        /* out of range */
        "Material \"retarder\" \"string crystal\" \"quartz\" \"float thickness\" [-1]",
        "Material \"retarder\" \"float retardation\" [1e9]",
        /* an unknown crystal */
        "Material \"retarder\" \"string crystal\" \"unobtainium\" \"float thickness\" [30]",
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        char text[1024];
        snprintf(text, sizeof text, "Camera \"orthographic\"\nWorldBegin\n%s\n" PBRT_QUAD, bad[i]);
        err_t err = {{0}};
        scene_t *s = sb_load_text(text, &err);
        if (s)
            fail_msg("accepted: %s", bad[i]);
        if (!strstr(err.msg, "t.pbrt:3"))
            fail_msg("no line in \"%s\" for %s", err.msg, bad[i]);
        printf("  %s\n", err.msg);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_oblique),      cmocka_unit_test(test_michel_levy),
        cmocka_unit_test(test_syntax),       cmocka_unit_test(test_jones_mueller),
        cmocka_unit_test(test_axial_slices), cmocka_unit_test(test_quartz_rotation),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
