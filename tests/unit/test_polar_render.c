/* polar_render: polarised transport rendered (render_settings_t.polarised, docs/physics.md §14)
 * against optics, not against the code: Malus's law through two polariser sheets at 0, 30, 45,
 * 60 and 90 degrees, and through a sheet and the camera's analyser; reflection at Brewster's
 * angle fully s-polarised (degree of polarisation 1 to 1e-3) in the Stokes output; a
 * quarter-wave plate turning 45-degree light circular (S3 = S0, and -S0 for -45); a glass slab
 * at 60 degrees transmitting the polarised sum of its inter-reflections, (T_s + T_p)/2 with
 * T_x = (1 - R_x)/(1 + R_x), partly p-polarised, which the unpolarised sum does not give; every
 * furnace (bare and coated glass, hero and fan-out, path and Whitted, a mirror) still exactly
 * 1 with polarisation on, and rough glass keeping the energy it keeps without; rough conductors
 * and dielectrics converging to the smooth Fresnel polarisation as alpha goes to 0, a rough
 * Brewster reflection partly polarised, and a rough lobe's unpolarised S0 the intensity
 * without polarisation; and polarisation is on only where the scene asks. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h> /* after the four headers above, which it needs */

#include <complex.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "glass.h"
#include "render.h"
#include "scene.h"
#include "scene_builders.h"

#define PI 3.14159265358979323846

/* The sums over the image's pixels and buckets of the mean of each Stokes plane (S1-S3 zero
 * without a Stokes output), rendering s at res x res and spp. */
static void render_stokes(scene_t *s, int res, int spp, double S[4])
{
    err_t err;
    const int nb = s->settings.grid.n, planes = render_settings_buckets(&s->settings) / nb;
    tilebuf_t *t = tilebuf_new(0, 0, res, res, nb * planes, &err);
    assert_non_null(t);
    render_stats_t st = {0};
    if (render_tile(s, NULL, 0, 0, res, res, 0, (uint32_t)spp, t, &st, &err))
        fail_msg("render_tile: %s", err.msg);
    assert_int_equal(st.nonfinite, 0);
    for (int k = 0; k < 4; k++)
        S[k] = 0.0;
    for (int y = 0; y < res; y++)
        for (int x = 0; x < res; x++) {
            const double n = (double)tilebuf_count(t, x, y);
            for (int k = 0; k < planes; k++)
                for (int b = 0; b < nb; b++)
                    S[k] += tilebuf_sum(t, x, y, k * nb + b) / n;
        }
    tilebuf_destroy(&t);
}

/* The same quad facing -z (its winding reversed): the far face of a slab. */
/* An orthographic camera on +z looking at a two-sided area light of constant spectrum behind
 * up to two sheets (each a Material line, "" for none) at z = 0 and z = 1; the camera's
 * extra parameters and the film's. */
static scene_t *sheets_scene(const char *sheet0, const char *sheet1, const char *camera,
                             const char *film)
{
    char text[4096];
    snprintf(text, sizeof text,
             "LookAt 0 0 5  0 0 0  0 1 0\n"
             "Camera \"orthographic\" %s\n"
             "Film \"spectral\" \"integer xresolution\" [4] \"integer yresolution\" [4] %s\n"
             "Sampler \"independent\" \"integer pixelsamples\" [4]\n"
             "Integrator \"path\" \"integer maxdepth\" [5]\n"
             "WorldBegin\n"
             "AttributeBegin\n"
             "AreaLightSource \"diffuse\" \"spectrum L\" [300 1 900 1] \"bool twosided\" true\n"
             "Translate 0 0 -1\n" PBRT_QUAD "AttributeEnd\n"
             "AttributeBegin\n%s\n%s"
             "AttributeEnd\n"
             "AttributeBegin\n%s\nTranslate 0 0 1\n%s"
             "AttributeEnd\n",
             camera, film, sheet0, sheet0[0] ? PBRT_QUAD : "", sheet1, sheet1[0] ? PBRT_QUAD : "");
    return sb_load_text(text, NULL);
}

static double s0_of(scene_t *s)
{
    double S[4];
    render_stokes(s, 4, 4, S);
    return S[0];
}

/* Malus's law: unpolarised light through a polariser at 0 and one at theta leaves
 * I_0/2 cos^2 theta. Every sample's S0 is exact (the sheets choose nothing at random), so the
 * ratios to the open render (same seed, same wavelengths) hold to rounding. */
static void test_malus(void **state)
{
    (void)state;
    scene_t *open = sheets_scene("", "", "", "");
    assert_false(open->settings.polarised); /* nothing in it tells polarisations apart */
    const double i0 = s0_of(open);
    assert_true(i0 > 0.0);
    scene_destroy(&open);
    const double deg[] = {0, 30, 45, 60, 90};
    for (size_t i = 0; i < sizeof deg / sizeof deg[0]; i++) {
        char second[128];
        snprintf(second, sizeof second, "Material \"polarizer\" \"float angle\" [%g]", deg[i]);
        scene_t *s = sheets_scene("Material \"polarizer\" \"float angle\" [0]", second, "", "");
        assert_true(s->settings.polarised);
        const double got = s0_of(s) / i0, c = cos(deg[i] * PI / 180.0);
        const double want = 0.5 * c * c;
        if (!(fabs(got - want) <= 1e-9))
            fail_msg("Malus at %g degrees: I/I0 = %.12f, want %.12f", deg[i], got, want);
        scene_destroy(&s);
    }
    /* One sheet alone passes half of unpolarised light, polarised or not. */
    scene_t *one = sheets_scene("Material \"polarizer\" \"float angle\" [17]", "", "", "");
    assert_true(fabs(s0_of(one) / i0 - 0.5) <= 1e-9);
    scene_destroy(&one);
}

/* The camera's analyser is the second polariser: a horizontal sheet (its axis along the
 * image's x whichever way the camera mirrors) seen through an analyser at theta from the
 * image's right. */
static void test_analyser(void **state)
{
    (void)state;
    scene_t *open = sheets_scene("", "", "", "");
    const double i0 = s0_of(open);
    scene_destroy(&open);
    const double deg[] = {0, 30, 60, 90, -45};
    for (size_t i = 0; i < sizeof deg / sizeof deg[0]; i++) {
        char cam[64];
        snprintf(cam, sizeof cam, "\"float analyzer\" [%g]", deg[i]);
        scene_t *s = sheets_scene("Material \"polarizer\" \"float angle\" [0]", "", cam, "");
        const double c = cos(deg[i] * PI / 180.0), got = s0_of(s) / i0;
        if (!(fabs(got - 0.5 * c * c) <= 1e-9))
            fail_msg("analyser at %g: %.12f, want %.12f", deg[i], got, 0.5 * c * c);
        scene_destroy(&s);
    }
    /* An analyser alone: half of the unpolarised light. */
    scene_t *a = sheets_scene("", "", "\"float analyzer\" [33]", "");
    assert_true(a->settings.polarised);
    assert_true(fabs(s0_of(a) / i0 - 0.5) <= 1e-9);
    scene_destroy(&a);
}

/* A quarter-wave plate with its fast axis at 0 after a polariser at +-45 degrees (the sheets'
 * normals face the camera, so their angles run as stokes.h's frame does along the light):
 * circular light, S3 = +-S0 (Collett, "Field Guide to Polarization", §Retarders), and no
 * linear part left. A half-wave plate leaves it linear. */
static void test_quarter_wave(void **state)
{
    (void)state;
    for (int sign = -1; sign <= 1; sign += 2) {
        char pol[64];
        snprintf(pol, sizeof pol, "Material \"polarizer\" \"float angle\" [%d]", 45 * sign);
        scene_t *s =
            sheets_scene(pol, "Material \"retarder\" \"float angle\" [0] \"float retardance\" [90]",
                         "", "\"bool stokes\" true");
        assert_true(s->settings.stokes);
        double S[4];
        render_stokes(s, 4, 4, S);
        if (!(fabs(S[3] - sign * S[0]) <= 1e-9 * S[0]) || !(fabs(S[1]) <= 1e-9 * S[0]) ||
            !(fabs(S[2]) <= 1e-9 * S[0]))
            fail_msg("quarter wave after %d: S = (%g, %g, %g, %g)", 45 * sign, S[0], S[1], S[2],
                     S[3]);
        scene_destroy(&s);
    }
    scene_t *h =
        sheets_scene("Material \"polarizer\" \"float angle\" [45]",
                     "Material \"retarder\" \"float angle\" [0] \"float retardance\" [180]", "",
                     "\"bool stokes\" true");
    double S[4];
    render_stokes(h, 4, 4, S);
    /* Linear at -45 degrees in the sheets' frame: |S2| = S0, whatever sign the image's frame
     * gives it. */
    assert_true(fabs(fabs(S[2]) - S[0]) <= 1e-9 * S[0]);
    assert_true(fabs(S[3]) <= 1e-9 * S[0]);
    scene_destroy(&h);
}

/* Unpolarised light from the environment reflected by glass of index 1.5 at Brewster's angle
 * atan(1.5) toward the camera, its transmission into a black backing: the Stokes output says
 * fully polarised (DoP 1 to 1e-3) and s-polarised (S1 = S0: s is the camera's horizontal,
 * perpendicular to the plane of incidence, which is vertical). Whitted follows the reflection
 * in every sample. */
static void test_brewster(void **state)
{
    (void)state;
    const double brewster = atan(1.5) * 180.0 / PI;
    char text[4096];
    snprintf(text, sizeof text,
             "LookAt 0 0 0  0 0 -1  0 1 0\n"
             "Camera \"orthographic\" \"float screenwindow\" [-0.01 0.01 -0.01 0.01]\n"
             "Film \"spectral\" \"integer xresolution\" [4] \"integer yresolution\" [4] "
             "\"bool stokes\" true\n"
             "Integrator \"whitted\" \"integer maxdepth\" [3]\n"
             "WorldBegin\n"
             "LightSource \"infinite\" \"spectrum L\" [300 1 900 1]\n"
             "AttributeBegin\nMaterial \"dielectric\" \"float eta\" [1.5]\n"
             "Translate 0 0 -1\nRotate %.12f 1 0 0\n" PBRT_QUAD "AttributeEnd\n"
             "AttributeBegin\nMaterial \"diffuse\" \"spectrum reflectance\" [300 0 900 0]\n"
             "Translate 0 0 -1\nRotate %.12f 1 0 0\nTranslate 0 0 -0.05\n" PBRT_QUAD
             "AttributeEnd\n",
             brewster, brewster);
    scene_t *s = sb_load_text(text, NULL);
    double S[4];
    render_stokes(s, 4, 8, S);
    const double dop = sqrt(S[1] * S[1] + S[2] * S[2] + S[3] * S[3]) / S[0];
    if (!(S[0] > 0.0) || !(fabs(dop - 1.0) <= 1e-3) || !(S[1] / S[0] > 1.0 - 1e-3))
        fail_msg("Brewster: S = (%g, %g, %g, %g), DoP %.6f", S[0], S[1], S[2], S[3], dop);
    scene_destroy(&s);

    /* 10 degrees off Brewster's angle the reflection is only partly polarised, by
     * (R_s - R_p) / (R_s + R_p) of Fresnel's equations (written out here). */
    const double th = (brewster - 10.0) * PI / 180.0, ct = sqrt(1.0 - pow(sin(th) / 1.5, 2.0));
    const double rs = (cos(th) - 1.5 * ct) / (cos(th) + 1.5 * ct),
                 rp = (1.5 * cos(th) - ct) / (1.5 * cos(th) + ct);
    const double want = (rs * rs - rp * rp) / (rs * rs + rp * rp);
    snprintf(text, sizeof text,
             "LookAt 0 0 0  0 0 -1  0 1 0\n"
             "Camera \"orthographic\" \"float screenwindow\" [-0.01 0.01 -0.01 0.01]\n"
             "Film \"spectral\" \"integer xresolution\" [4] \"integer yresolution\" [4] "
             "\"bool stokes\" true\n"
             "Integrator \"whitted\" \"integer maxdepth\" [3]\n"
             "WorldBegin\n"
             "LightSource \"infinite\" \"spectrum L\" [300 1 900 1]\n"
             "AttributeBegin\nMaterial \"dielectric\" \"float eta\" [1.5]\n"
             "Translate 0 0 -1\nRotate %.12f 1 0 0\n" PBRT_QUAD "AttributeEnd\n"
             "AttributeBegin\nMaterial \"diffuse\" \"spectrum reflectance\" [300 0 900 0]\n"
             "Translate 0 0 -1\nRotate %.12f 1 0 0\nTranslate 0 0 -0.05\n" PBRT_QUAD
             "AttributeEnd\n",
             brewster - 10.0, brewster - 10.0);
    s = sb_load_text(text, NULL);
    render_stokes(s, 4, 8, S);
    if (!(fabs(S[1] / S[0] - want) <= 1e-6))
        fail_msg("off Brewster: S1/S0 = %.9f, Fresnel %.9f", S[1] / S[0], want);
    scene_destroy(&s);
}

/* A glass slab (n = 1.5, faces 0.1 apart) tilted 60 degrees about the camera's horizontal in
 * front of a two-sided area light: what reaches the camera is the incoherent sum of the slab's
 * inter-reflections per polarisation, T_x = (1 - R_x)/(1 + R_x) for x = s, p (each
 * polarisation's reflections stay its own), S0 = (T_s + T_p)/2 of the open view and
 * S1/S0 = (T_s - T_p)/(T_s + T_p) (Hecht, "Optics", §8.6: a pile of plates polarises). The
 * unpolarised sum (1 - R)/(1 + R), R = (R_s + R_p)/2, differs by 1.4 %, far beyond the
 * tolerance. */
static void test_slab(void **state)
{
    (void)state;
    const double n = 1.5, th = 60.0 * PI / 180.0, ct = sqrt(1.0 - pow(sin(th) / n, 2.0));
    const double rs = (cos(th) - n * ct) / (cos(th) + n * ct),
                 rp = (n * cos(th) - ct) / (n * cos(th) + ct);
    const double Rs = rs * rs, Rp = rp * rp;
    const double Ts = (1.0 - Rs) / (1.0 + Rs), Tp = (1.0 - Rp) / (1.0 + Rp);
    double T[2], P[2];
    for (int pol = 0; pol < 2; pol++) {
        char head[2048], text[4096];
        snprintf(head, sizeof head,
                 "LookAt 0 0 5  0 0 0  0 1 0\n"
                 "Camera \"orthographic\" \"float screenwindow\" [-0.05 0.05 -0.05 0.05]\n"
                 "Film \"spectral\" \"integer xresolution\" [4] \"integer yresolution\" [4] %s\n"
                 "Integrator \"whitted\" \"integer maxdepth\" [24]\n"
                 "WorldBegin\n"
                 "AttributeBegin\n"
                 "AreaLightSource \"diffuse\" \"spectrum L\" [300 1 900 1] \"bool twosided\" true\n"
                 "Translate 0 0 -3\nScale 0.5 0.5 1\n" PBRT_QUAD "AttributeEnd\n",
                 pol ? "\"bool stokes\" true" : "");
        scene_t *open = sb_load_text(head, NULL);
        double O[4], S[4];
        render_stokes(open, 4, 8, O);
        scene_destroy(&open);
        snprintf(text, sizeof text,
                 "%sAttributeBegin\nMaterial \"dielectric\" \"float eta\" [1.5]\nRotate 60 1 0 0\n"
                 "Translate 0 0 0.05\n" PBRT_QUAD "Translate 0 0 -0.1\n" PBRT_QUAD_BACK
                 "AttributeEnd\n",
                 head);
        scene_t *s = sb_load_text(text, NULL);
        assert_int_equal(s->settings.polarised, pol);
        render_stokes(s, 4, 8, S);
        scene_destroy(&s);
        T[pol] = S[0] / O[0];
        P[pol] = S[1] / S[0];
    }
    const double t_unpolarised = (1.0 - 0.5 * (Rs + Rp)) / (1.0 + 0.5 * (Rs + Rp));
    if (!(fabs(T[1] - 0.5 * (Ts + Tp)) <= 1e-4) || !(fabs(P[1] - (Ts - Tp) / (Ts + Tp)) <= 1e-4))
        fail_msg("slab at 60 degrees: T %.6f (polarised sum %.6f, unpolarised %.6f), S1/S0 %.6f "
                 "(want %.6f)",
                 T[1], 0.5 * (Ts + Tp), t_unpolarised, P[1], (Ts - Tp) / (Ts + Tp));
    /* Without polarisation (the default for a scene with nothing polarising) the renderer
     * gives the unpolarised sum: what ignoring polarisation costs here. */
    if (!(fabs(T[0] - t_unpolarised) <= 1e-4))
        fail_msg("slab unpolarised: T %.6f, want %.6f", T[0], t_unpolarised);
}

/* A plane of material `mat` tilted by deg about the camera's horizontal under a constant,
 * unpolarised environment, seen by a narrow orthographic camera along -z, with a black backing
 * behind it (what the plane transmits is lost): the light the camera records is the plane's
 * reflection of the environment. `film` adds to the Film line. */
static scene_t *tilted_plane(const char *mat, double deg, const char *film, const char *integ)
{
    char text[4096];
    snprintf(text, sizeof text,
             "LookAt 0 0 0  0 0 -1  0 1 0\n"
             "Camera \"orthographic\" \"float screenwindow\" [-0.01 0.01 -0.01 0.01]\n"
             "Film \"spectral\" \"integer xresolution\" [4] \"integer yresolution\" [4] %s\n"
             "Integrator \"%s\" \"integer maxdepth\" [3]\n"
             "WorldBegin\n"
             "LightSource \"infinite\" \"spectrum L\" [300 1 900 1]\n"
             "AttributeBegin\n%s\n"
             "Translate 0 0 -1\nRotate %.12f 1 0 0\n" PBRT_QUAD "AttributeEnd\n"
             "AttributeBegin\nMaterial \"diffuse\" \"spectrum reflectance\" [300 0 900 0]\n"
             "Translate 0 0 -1\nRotate %.12f 1 0 0\nTranslate 0 0 -0.05\n" PBRT_QUAD
             "AttributeEnd\n",
             film, integ, mat, deg, deg);
    return sb_load_text(text, NULL);
}

/* Fresnel's reflectances of an interface from index 1 into n + i k at incidence theta,
 * written out (Born & Wolf §1.5.2, §14.2: Snell's law with the complex index). */
static void fresnel_rs_rp(double theta, double n, double k, double *Rs, double *Rp)
{
    const double complex m = n + I * k, ci = cos(theta), si = sin(theta);
    const double complex ct = csqrt(1.0 - si * si / (m * m));
    const double complex rs = (ci - m * ct) / (ci + m * ct), rp = (m * ci - ct) / (m * ci + ct);
    *Rs = creal(rs * conj(rs));
    *Rp = creal(rp * conj(rp));
}

/* Rough conductors and dielectrics polarise by their microfacets' Fresnel matrices: as alpha
 * goes to 0 the reflection's S1/S0 converges to the smooth surface's (R_s - R_p)/(R_s + R_p)
 * (a dielectric 10 degrees off Brewster's angle, a metal of index 0.2 + 3i at 60 degrees), and
 * at Brewster's angle a rough dielectric's reflection is polarised less than the smooth one's
 * (microfacets tilted off the plane of incidence and off the angle) but clearly polarised. */
static void test_rough_converges(void **state)
{
    (void)state;
    const double brewster = atan(1.5) * 180.0 / PI;
    struct {
        const char *mat;
        double deg, n, k;
    } cases[] = {
        {"Material \"dielectric\" \"float eta\" [1.5] \"float roughness\" [%g] "
         "\"bool remaproughness\" false",
         brewster - 10.0, 1.5, 0.0},
        {"Material \"conductor\" \"spectrum eta\" [300 0.2 900 0.2] \"spectrum k\" [300 3 900 3] "
         "\"float roughness\" [%g] \"bool remaproughness\" false",
         60.0, 0.2, 3.0},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        double Rs, Rp;
        fresnel_rs_rp(cases[i].deg * PI / 180.0, cases[i].n, cases[i].k, &Rs, &Rp);
        const double want = (Rs - Rp) / (Rs + Rp);
        const double alphas[] = {0.1, 0.002};
        for (size_t a = 0; a < sizeof alphas / sizeof alphas[0]; a++) {
            char mat[512];
            snprintf(mat, sizeof mat, cases[i].mat, alphas[a]);
            scene_t *s = tilted_plane(mat, cases[i].deg, "\"bool stokes\" true", "path");
            double S[4];
            render_stokes(s, 4, 8, S);
            scene_destroy(&s);
            const double err = fabs(S[1] / S[0] - want);
            /* At alpha 0.002 the microfacets tilt by about 0.1 degree: S1/S0 within 1e-3. */
            if (alphas[a] < 0.005 && !(err <= 1e-3))
                fail_msg("case %zu alpha %g: S1/S0 %.6f, smooth Fresnel %.6f", i, alphas[a],
                         S[1] / S[0], want);
            if (!(fabs(S[3]) <= 1e-9 * S[0]))
                fail_msg("case %zu: unpolarised light reflected with S3 %g", i, S[3] / S[0]);
        }
    }
    /* Brewster's angle, rough: DoP below the smooth 1, well above 0. */
    scene_t *s = tilted_plane("Material \"dielectric\" \"float eta\" [1.5] \"float roughness\" "
                              "[0.2] \"bool remaproughness\" false",
                              brewster, "\"bool stokes\" true", "path");
    double S[4];
    render_stokes(s, 4, 16, S);
    scene_destroy(&s);
    const double dop = sqrt(S[1] * S[1] + S[2] * S[2] + S[3] * S[3]) / S[0];
    if (!(dop < 0.95) || !(dop > 0.3) || !(S[1] > 0.0))
        fail_msg("rough Brewster (alpha 0.2): S = (%g, %g, %g, %g), DoP %.4f", S[0], S[1], S[2],
                 S[3], dop);
}

/* Unpolarised light reflected once by a rough lobe: the polarised S0 is the intensity the
 * unpolarised renderer gives (the scalar weights are the same; only the carrier's other rows
 * differ), to rounding. */
static void test_rough_s0(void **state)
{
    (void)state;
    const char *mats[] = {
        "Material \"dielectric\" \"float eta\" [1.5] \"float roughness\" [0.3]",
        "Material \"conductor\" \"float roughness\" [0.2]",
    };
    for (size_t i = 0; i < sizeof mats / sizeof mats[0]; i++) {
        double P[4], U[4];
        scene_t *s = tilted_plane(mats[i], 40.0, "\"bool stokes\" true", "path");
        assert_true(s->settings.polarised);
        render_stokes(s, 4, 8, P);
        scene_destroy(&s);
        s = tilted_plane(mats[i], 40.0, "", "path");
        assert_false(s->settings.polarised);
        render_stokes(s, 4, 8, U);
        scene_destroy(&s);
        if (!(fabs(P[0] - U[0]) <= 1e-12 * U[0]) || !(fabs(P[1]) > 1e-3 * P[0]))
            fail_msg("%s: polarised S0 %.15g (S1 %g), unpolarised %.15g", mats[i], P[0], P[1],
                     U[0]);
    }
}

/* Thin films on rough surfaces reach the renderer: at alpha 0.002 a filmed metal (which
 * reflects every sample, so S0 is not a count of random reflections) reflects what the smooth
 * filmed one does, S0 to 2e-3 and S1/S0 to 1e-3 (test_polar_bsdf checks the rough film's lobe
 * against the Airy sum, test_thinfilm the smooth one). */
static void test_rough_film(void **state)
{
    (void)state;
    const char *mats[] = {
        "Material \"conductor\" \"spectrum eta\" [300 0.2 900 0.2] \"spectrum k\" [300 3 900 3] "
        "\"float filmthickness\" [250] \"float filmeta\" [1.45] \"float roughness\" [%g] "
        "\"bool remaproughness\" false",
    };
    for (size_t i = 0; i < sizeof mats / sizeof mats[0]; i++) {
        double S[2][4];
        for (int rough = 0; rough < 2; rough++) {
            char mat[512];
            snprintf(mat, sizeof mat, mats[i], rough ? 0.002 : 0.0);
            scene_t *s = tilted_plane(mat, 50.0, "\"bool stokes\" true", "path");
            render_stokes(s, 4, 8, S[rough]);
            scene_destroy(&s);
        }
        if (!(fabs(S[1][0] / S[0][0] - 1.0) <= 2e-3) ||
            !(fabs(S[1][1] / S[1][0] - S[0][1] / S[0][0]) <= 1e-3))
            fail_msg("%s: rough S0 %.6f S1/S0 %.6f, smooth S0 %.6f S1/S0 %.6f", mats[i], S[1][0],
                     S[1][1] / S[1][0], S[0][0], S[0][1] / S[0][0]);
    }
}

static int furnace_with(integrator_kind_t integ, dispersion_kind_t disp, material_kind_t kind,
                        const char *glass_name, double film_thickness, double roughness,
                        int polarised, double *means)
{
    err_t err;
    const int res = 8, spp = 64;
    scene_t *s = sb_render_scene(integ, disp, res, spp);
    sb_look_at(s, vec3_make(0, 0, -5), vec3_make(0, 0, 0), 20);
    spectrum_t *env = spectrum_new_constant(1.0, &err);
    assert_non_null(env);
    light_t l = {.kind = LIGHT_INFINITE, .spectrum = env, .scale = 1.0};
    assert_int_equal(scene_own_spectrum(s, env, &err), 0);
    assert_true(scene_add_light(s, &l, &err) >= 0);
    material_t m = {.kind = kind, .film_thickness = film_thickness, .film_ior = ior_constant(1.38)};
    m.ior = glass_name ? glass_find(glass_name)->ior : ior_constant(1.5);
    if (roughness > 0.0) {
        texture_t *r = texture_new_constant_value(roughness, &err);
        assert_non_null(r);
        assert_int_equal(scene_own_texture(s, r, &err), 0);
        m.uroughness = m.vroughness = r;
    }
    strcpy(m.name, "furnace");
    int mi = scene_add_material(s, &m, &err);
    transform_t id = transform_identity();
    assert_true(scene_add_sphere(s, &id, 1.0, mi, -1, 0, &err) >= 0);
    s->settings.polarised = polarised;
    s->settings.stokes = polarised;
    /* Light seen directly takes 16 lanes without polarisation and the hero's 4 with it
     * (render.c, direct_lanes): the same estimator for both, so they can be compared bit for
     * bit. */
    s->settings.direct_hero_only = 1;
    if (scene_finish(s, &err))
        fail_msg("%s", err.msg);
    const int nb = s->settings.grid.n;
    assert_true(nb <= 64);
    tilebuf_t *t = tilebuf_new(0, 0, res, res, render_settings_buckets(&s->settings), &err);
    assert_non_null(t);
    render_stats_t st = {0};
    if (render_tile(s, NULL, 0, 0, res, res, 0, (uint32_t)spp, t, &st, &err))
        fail_msg("render_tile: %s", err.msg);
    assert_int_equal(st.nonfinite, 0);
    const int npix = res * res;
    for (int b = 0; b < nb; b++) {
        double sum = 0.0, sq = 0.0, lin = 0.0;
        for (int y = 0; y < res; y++)
            for (int x = 0; x < res; x++) {
                const double c = (double)tilebuf_count(t, x, y), v = tilebuf_sum(t, x, y, b) / c;
                sum += v;
                sq += v * v;
                if (s->settings.stokes)
                    lin += tilebuf_sum(t, x, y, nb + b) / c;
            }
        const double mean = sum / npix, se = sqrt(fmax(0.0, sq / npix - mean * mean) / (npix - 1));
        means[b] = mean;
        if (roughness > 0.0)
            continue; /* a single-scattering microfacet loses energy: compared below */
        if (!(fabs(mean - 1.0) <= 4.0 * se + 1e-6) || !(fabs(lin / npix) <= 4.0 * se + 0.02))
            fail_msg("%s furnace (polarised; integrator %d, dispersion %d, film %g nm, "
                     "roughness %g), bucket %d: S0 %.6f +- %.6f, mean S1 %.6f",
                     glass_name ? glass_name : (kind == MATERIAL_CONDUCTOR ? "mirror" : "n=1.5"),
                     (int)integ, (int)disp, film_thickness, roughness, b, mean, se, lin / npix);
    }
    tilebuf_destroy(&t);
    scene_destroy(&s);
    return nb;
}

static void furnace(integrator_kind_t integ, dispersion_kind_t disp, material_kind_t kind,
                    const char *glass_name, double film_thickness, double roughness)
{
    double pol[64], unpol[64];
    const int nb = furnace_with(integ, disp, kind, glass_name, film_thickness, roughness, 1, pol);
    if (!(roughness > 0.0))
        return;
    /* Rough glass loses what its microfacets scatter more than once (docs/physics.md §10.5):
     * the polarised render must keep the energy the unpolarised one does, up to the noise and
     * to what its polarised Fresnel terms change in the light that two or more interfaces
     * pass (within 1 %; the sphere's mean over the buckets). */
    furnace_with(integ, disp, kind, glass_name, film_thickness, roughness, 0, unpol);
    double sp = 0.0, su = 0.0;
    for (int b = 0; b < nb; b++) {
        sp += pol[b];
        su += unpol[b];
    }
    if (!(fabs(sp - su) <= 0.01 * su))
        fail_msg("rough furnace (kind %d, film %g): polarised %.6f, unpolarised %.6f", (int)kind,
                 film_thickness, sp / nb, su / nb);
}

static void test_furnaces(void **state)
{
    (void)state;
    furnace(INTEGRATOR_PATH, DISPERSION_HERO, MATERIAL_DIELECTRIC, NULL, 0.0, 0.0);
    furnace(INTEGRATOR_PATH, DISPERSION_HERO, MATERIAL_DIELECTRIC, "N-SF11", 0.0, 0.0);
    furnace(INTEGRATOR_PATH, DISPERSION_FANOUT, MATERIAL_DIELECTRIC, "N-SF11", 0.0, 0.0);
    furnace(INTEGRATOR_WHITTED, DISPERSION_HERO, MATERIAL_DIELECTRIC, "N-BK7", 0.0, 0.0);
    furnace(INTEGRATOR_WHITTED, DISPERSION_FANOUT, MATERIAL_DIELECTRIC, NULL, 0.0, 0.0);
    furnace(INTEGRATOR_PATH, DISPERSION_HERO, MATERIAL_DIELECTRIC, NULL, 120.0, 0.0);
    furnace(INTEGRATOR_PATH, DISPERSION_HERO, MATERIAL_CONDUCTOR, NULL, 250.0, 0.0);
    furnace(INTEGRATOR_PATH, DISPERSION_HERO, MATERIAL_CONDUCTOR, NULL, 0.0, 0.0);
    furnace(INTEGRATOR_PATH, DISPERSION_HERO, MATERIAL_DIELECTRIC, NULL, 0.0, 0.3);
    furnace(INTEGRATOR_PATH, DISPERSION_HERO, MATERIAL_DIELECTRIC, "N-SF11", 0.0, 0.1);
    furnace(INTEGRATOR_PATH, DISPERSION_HERO, MATERIAL_DIELECTRIC, NULL, 120.0, 0.3);
}

/* The parser's refusals name the file and line. */
/* Sheets are not bounces for Russian roulette: a diffuse floor (albedo 0.5) under a uniform sky,
 * seen from above through two aligned polarisers (wide enough that every bounce leaves through
 * them again) by simple path tracing (no light sampling): every sample is camera, two sheets,
 * the floor, two sheets, the sky, so every pixel is exactly a quarter (half through the sheets
 * each way) of what it is without them -- unless the roulette, counting the sheets as bounces,
 * ends some paths at the floor and weighs the others up (the speckle behind two sheets). */
#define WIDE_QUAD                                                                                  \
    "Shape \"trianglemesh\" \"point3 P\" [-1e4 -1e4 0  1e4 -1e4 0  1e4 1e4 0  -1e4 1e4 0] "        \
    "\"integer indices\" [0 1 2 0 2 3] \"point2 uv\" [0 0 1 0 1 1 0 1]\n"

static void floor_pixels(const char *sheets, double px[16])
{
    char text[4096];
    snprintf(text, sizeof text,
             "LookAt 0 0 5  0 0 0  0 1 0\n"
             "Camera \"orthographic\" \"float screenwindow\" [-0.3 0.3 -0.3 0.3]\n"
             "Film \"spectral\" \"integer xresolution\" [4] \"integer yresolution\" [4]\n"
             "Sampler \"independent\" \"integer pixelsamples\" [16]\n"
             "Integrator \"simplepath\" \"integer maxdepth\" [8] \"bool polarized\" true\n"
             "WorldBegin\n"
             "LightSource \"infinite\" \"spectrum L\" [300 1 900 1]\n"
             "%s"
             "Material \"diffuse\" \"spectrum reflectance\" [300 0.5 900 0.5]\n" PBRT_QUAD,
             sheets);
    scene_t *s = sb_load_text(text, NULL);
    err_t err;
    const int nb = s->settings.grid.n;
    tilebuf_t *t = tilebuf_new(0, 0, 4, 4, render_settings_buckets(&s->settings), &err);
    assert_non_null(t);
    render_stats_t st = {0};
    if (render_tile(s, NULL, 0, 0, 4, 4, 0, 16, t, &st, &err))
        fail_msg("render_tile: %s", err.msg);
    for (int i = 0; i < 16; i++) {
        px[i] = 0.0;
        for (int b = 0; b < nb; b++)
            px[i] += tilebuf_sum(t, i % 4, i / 4, b) / (double)tilebuf_count(t, i % 4, i / 4);
    }
    tilebuf_destroy(&t);
    scene_destroy(&s);
}

static void test_sheets_roulette(void **state)
{
    (void)state;
    double open[16], behind[16];
    floor_pixels("", open);
    floor_pixels(
        "AttributeBegin\nMaterial \"polarizer\"\nTranslate 0 0 2\n" WIDE_QUAD
        "AttributeEnd\nAttributeBegin\nMaterial \"polarizer\"\nTranslate 0 0 2.5\n" WIDE_QUAD
        "AttributeEnd\n",
        behind);
    for (int i = 0; i < 16; i++)
        if (!(open[i] > 0.0) || !(fabs(behind[i] / open[i] - 0.25) <= 1e-9))
            fail_msg("pixel %d behind two aligned polarisers: %.9g of the open %.9g", i, behind[i],
                     open[i]);
}

static void test_parse_errors(void **state)
{
    (void)state;
    err_t err;
    const char *bad[] = {
        "WorldBegin\nMaterial \"polarizer\" \"float angle\" [400]\n",
        "WorldBegin\nMaterial \"retarder\" \"float retardance\" [-5]\n",
        "Camera \"perspective\" \"float analyzer\" [1000]\nWorldBegin\n",
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        scene_t *s = sb_load_text(bad[i], &err);
        assert_null(s);
        if (!strstr(err.msg, "t.pbrt:"))
            fail_msg("no file:line in \"%s\"", err.msg);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_malus),
        cmocka_unit_test(test_analyser),
        cmocka_unit_test(test_quarter_wave),
        cmocka_unit_test(test_brewster),
        cmocka_unit_test(test_slab),
        cmocka_unit_test(test_furnaces),
        cmocka_unit_test(test_rough_converges),
        cmocka_unit_test(test_rough_s0),
        cmocka_unit_test(test_rough_film),
        cmocka_unit_test(test_sheets_roulette),
        cmocka_unit_test(test_parse_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
