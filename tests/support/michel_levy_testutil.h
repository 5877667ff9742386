/* The Michel-Levy chart's fixture and its closed form (docs/physics.md §14.1, §15.2), shared
 * by the retarder sheet's test (test_waveplate) and the coherent uniaxial plate's
 * (test_coherent): an orthographic camera on +z looking at a two-sided D65 light box behind a
 * polariser at 0 degrees (z = 0), the plate (z = 1.5) and a polariser at 90 (z = 3), rendered
 * to its mean XYZ and compared in linear sRGB with the integral of D65 times the light a plate
 * of retardation Gamma(lambda) passes, times the CIE 1931 matching functions. Static functions
 * for one test file each. */
#ifndef PRISMFARM_MICHEL_LEVY_TESTUTIL_H
#define PRISMFARM_MICHEL_LEVY_TESTUTIL_H

#include "cie.h"
#include "crystal.h"
#include "render.h"
#include "scene.h"
#include "scene_builders.h"
#include "spectrum.h"
#include "wavelength.h"

#include <math.h>
#include <stdio.h>

#ifndef PI
#define PI 3.14159265358979323846
#endif

/* The chart's renders carry 47 lanes, one per 10 nm from 360 to 830 nm ("fanout" lanes:
 * wavelengths stratified over the range, so that few samples estimate the colour integral
 * well); the default hero wavelengths are checked at a few retardations with more samples. */
typedef struct chart_setup {
    int res, spp, fan;
} chart_setup_t;

static const chart_setup_t FAN = {8, 16, 1}, HERO = {16, 256, 0};

/* An orthographic camera on +z looking at a two-sided D65 light box behind a polariser at 0
 * degrees (z = 0), the plate (Material and transform lines, z = 1.5) and a polariser at 90 (z = 3);
 * plate
 * "" for the open light box with no sheet at all. */
static scene_t *chart_scene(const char *plate, chart_setup_t cs)
{
    char text[4096];
    int n = snprintf(text, sizeof text,
                     "LookAt 0 0 5  0 0 0  0 1 0\n"
                     "Camera \"orthographic\"\n"
                     "Film \"spectral\" \"integer xresolution\" [%d] \"integer yresolution\" [%d] "
                     "%s\n"
                     "Sampler \"zsobol\" \"integer pixelsamples\" [%d]\n"
                     "Integrator \"path\" \"integer maxdepth\" [5] %s\n"
                     "WorldBegin\n"
                     "AttributeBegin\n"
                     "AreaLightSource \"diffuse\" \"spectrum L\" \"stdillum-D65\" "
                     "\"bool twosided\" true\n"
                     "Translate 0 0 -1\n" PBRT_QUAD "AttributeEnd\n",
                     cs.res, cs.res,
                     cs.fan ? "\"integer nbuckets\" [47] \"float lambdamin\" [360] "
                              "\"float lambdamax\" [830]"
                            : "",
                     cs.spp, cs.fan ? "\"string dispersion\" \"fanout\"" : "");
    if (plate[0])
        snprintf(text + n, sizeof text - (size_t)n,
                 "AttributeBegin\nMaterial \"polarizer\" \"float angle\" [0]\n" PBRT_QUAD
                 "AttributeEnd\n"
                 "AttributeBegin\nTranslate 0 0 1.5\n%s\n" PBRT_QUAD "AttributeEnd\n"
                 "AttributeBegin\nTranslate 0 0 3\nMaterial \"polarizer\" \"float angle\" "
                 "[90]\n" PBRT_QUAD "AttributeEnd\n",
                 plate);
    return sb_load_text(text, NULL);
}

/* The image's mean XYZ. */
static void render_xyz(scene_t *s, chart_setup_t cs, double xyz[3])
{
    err_t err;
    const int res = cs.res;
    tilebuf_t *t = tilebuf_new(0, 0, res, res, render_settings_buckets(&s->settings), &err);
    assert_non_null(t);
    render_stats_t st = {0};
    if (render_tile(s, NULL, 0, 0, res, res, 0, (uint32_t)cs.spp, t, &st, &err))
        fail_msg("render_tile: %s", err.msg);
    assert_int_equal(st.nonfinite, 0);
    xyz[0] = xyz[1] = xyz[2] = 0.0;
    for (int y = 0; y < res; y++)
        for (int x = 0; x < res; x++)
            for (int k = 0; k < 3; k++)
                xyz[k] +=
                    tilebuf_xyz_sum(t, x, y, k) / (double)tilebuf_count(t, x, y) / (res * res);
    tilebuf_destroy(&t);
}

/* Linear sRGB (IEC 61966-2-1's matrix, D65 white) of XYZ. */
static void srgb_of(const double xyz[3], double rgb[3])
{
    rgb[0] = 3.2404542 * xyz[0] - 1.5371385 * xyz[1] - 0.4985314 * xyz[2];
    rgb[1] = -0.9692660 * xyz[0] + 1.8760108 * xyz[1] + 0.0415560 * xyz[2];
    rgb[2] = 0.0556434 * xyz[0] - 0.2040259 * xyz[1] + 1.0572252 * xyz[2];
}

/* A plate's retardation G(lambda) in nm: gamma_nm; or a catalogue crystal's
 * (n_e - n_o) thickness; or, at incidence sin_i across a dispersion-free plate's axis (the
 * e-wave then sees n_e at every angle), (sqrt(n_e^2 - sin_i^2) - sqrt(n_o^2 - sin_i^2)) t,
 * Snell's law for each wave (Born & Wolf §15.3; Hecht §8.7). */
typedef struct plate {
    double gamma_nm;
    const crystal_t *crystal;
    double thickness_nm, n_o, n_e, sin_i;
    /* A real plate of the indices n_o, n_e (or the crystal's) at normal incidence, whose two
     * faces transmit, for each wave, Fresnel's T = (4 n / (n + 1)^2)^2 (Hecht §4.6.2; amplitudes
     * real and positive): between crossed polarisers at 45 degrees the field is
     * (sqrt(T_o) e^{i phi_o} - sqrt(T_e) e^{i phi_e}) / 2 of the first polariser's, so the light
     * passed is (1/8) (T_o + T_e - 2 sqrt(T_o T_e) cos(2 pi Gamma / lambda)) instead of
     * (1/2) sin^2(pi Gamma / lambda) (the same when T_o = T_e = 1). */
    int fresnel;
} plate_t;

static double plate_gamma(const plate_t *p, double lambda)
{
    if (p->crystal)
        return (ior_eval(&p->crystal->ne, lambda) - ior_eval(&p->crystal->no, lambda)) *
               p->thickness_nm;
    if (p->thickness_nm > 0.0) {
        const double s2 = p->sin_i * p->sin_i;
        return (sqrt(p->n_e * p->n_e - s2) - sqrt(p->n_o * p->n_o - s2)) * p->thickness_nm;
    }
    return p->gamma_nm;
}

/* The closed form: XYZ of D65 (1/2) sin^2(pi G(lambda) / lambda) over [lo, hi], divided by
 * the Y of D65 alone over it, by the midpoint rule at 0.05 nm. */
static void chart_colour(const spectrum_t *d65, double lo, double hi, const plate_t *p,
                         double xyz[3])
{
    double sum[3] = {0, 0, 0}, y = 0.0;
    const double h = 0.05;
    for (double l = lo + 0.5 * h; l < hi; l += h) {
        const double e = spectrum_eval(d65, l);
        const xyz_t m = cie_cmf_eval(l);
        const double sn = sin(PI * plate_gamma(p, l) / l);
        double f = 0.5 * sn * sn;
        if (p->fresnel) {
            const double no = p->crystal ? ior_eval(&p->crystal->no, l) : p->n_o;
            const double ne = p->crystal ? ior_eval(&p->crystal->ne, l) : p->n_e;
            const double to = pow(4.0 * no / ((no + 1.0) * (no + 1.0)), 2.0);
            const double te = pow(4.0 * ne / ((ne + 1.0) * (ne + 1.0)), 2.0);
            f = 0.125 * (to + te - 2.0 * sqrt(to * te) * cos(2.0 * PI * plate_gamma(p, l) / l));
        }
        sum[0] += e * f * m.x;
        sum[1] += e * f * m.y;
        sum[2] += e * f * m.z;
        y += e * m.y;
    }
    for (int k = 0; k < 3; k++)
        xyz[k] = sum[k] / y;
}

/* Renders the plate and returns the largest linear-sRGB difference from the closed form. */
static double chart_error(const char *plate, chart_setup_t cs, const double open[3],
                          const spectrum_t *d65, const plate_t *p, double got_rgb[3],
                          double want_rgb[3])
{
    scene_t *s = chart_scene(plate, cs);
    assert_true(s->settings.polarised);
    double xyz[3], want[3];
    render_xyz(s, cs, xyz);
    for (int k = 0; k < 3; k++)
        xyz[k] /= open[1];
    /* The colour is estimated over the wavelengths the lanes are drawn from: hero lanes over
     * the visible range (pbrt-v4's SampleVisibleWavelengths, the default), fan-out lanes over
     * the film's. */
    const int vis = !cs.fan && s->settings.visible_sampling;
    chart_colour(d65, vis ? WAVELENGTH_VISIBLE_MIN : s->settings.grid.lambda_min,
                 vis ? WAVELENGTH_VISIBLE_MAX : s->settings.grid.lambda_max, p, want);
    scene_destroy(&s);
    srgb_of(xyz, got_rgb);
    srgb_of(want, want_rgb);
    double e = 0.0;
    for (int k = 0; k < 3; k++)
        e = fmax(e, fabs(got_rgb[k] - want_rgb[k]));
    return e;
}

#endif
