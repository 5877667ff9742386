/* colorchecker: the image's colour converges to the colorimetric truth whatever the buckets
 * (issue 14). The 24 patches of the Macbeth ColorChecker (Ohta 1997 reflectances,
 * data/colorchecker_ohta_5nm.csv) are rendered as Lambertian quads filling the view under a
 * uniform D65 environment, at 16 spp, with 8, 16 and 45 buckets, hero wavelengths and fan-out.
 * With "simplepath" every camera sample leaves the flat patch once toward the sky, so its
 * radiance is exactly rho(lambda) L(lambda): the only noise is the wavelengths'. The reference
 * is computed here from the spectra and the CIE tables (1 nm sums), normalised as the loader
 * normalises a light (Y of the illuminant = 1, so a perfect white reads Y = 1), and taken to
 * linear sRGB with the IEC 61966-2-1 matrix (data/srgb_matrices.txt); the image's linear sRGB
 * (film_to_rgb, what the EXR's R, G, B and the PNG are made of) must be within 0.005 of it per
 * channel. The colour of the bucket means (the mechanism before issue 14) is measured too and
 * must miss by more at 8 buckets, so that the test is known to catch it. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cie.h"
#include "colour.h"
#include "film.h"
#include "render.h"
#include "scene_builders.h"

#define NPATCH 24
#define NRHO 81 /* 380..780 nm, 5 nm */
/* Pixels per side. Hero wavelengths: the image's standard error in a channel is at most 0.07 /
 * RES (the white patch's red, measured from the pixels' spread at 16 spp), 0.0015 here, so the
 * tolerance is more than 3 standard errors. Fan-out lanes are stratified over every bucket:
 * 8 pixels suffice (its error is below 2e-4). */
#define RES_HERO 48
#define RES_FANOUT 8
#define RES_MAX RES_HERO
#define SPP 16
#define TOL 0.005

typedef struct patch {
    char name[40];
    double rho[NRHO];
} patch_t;

static patch_t g_patches[NPATCH];

/* IEC 61966-2-1 XYZ -> linear sRGB, the 8-decimal inverse of the standard's matrix
 * (data/srgb_matrices.txt). */
static const double M[3][3] = {{3.24062548, -1.53720797, -0.49862860},
                               {-0.96893071, 1.87575606, 0.04151752},
                               {0.05571012, -0.20402105, 1.05699594}};

static void to_srgb(const double xyz[3], double rgb[3])
{
    for (int i = 0; i < 3; i++)
        rgb[i] = M[i][0] * xyz[0] + M[i][1] * xyz[1] + M[i][2] * xyz[2];
}

static int load_patches(void **state)
{
    (void)state;
    FILE *f = fopen("../data/colorchecker_ohta_5nm.csv", "r");
    if (!f)
        fail_msg("cannot open ../data/colorchecker_ohta_5nm.csv");
    char line[4096];
    int n = -1; /* the header row first */
    while (fgets(line, sizeof line, f)) {
        if (line[0] == '#')
            continue;
        if (n < 0) {
            assert_int_equal(strncmp(line, "patch,380,385,", 14), 0);
            n = 0;
            continue;
        }
        assert_true(n < NPATCH);
        char *comma = strchr(line, ',');
        assert_non_null(comma);
        snprintf(g_patches[n].name, sizeof g_patches[n].name, "%.*s", (int)(comma - line), line);
        char *p = comma + 1;
        for (int k = 0; k < NRHO; k++) {
            char *end;
            g_patches[n].rho[k] = strtod(p, &end);
            assert_true(end != p && g_patches[n].rho[k] > 0.0 && g_patches[n].rho[k] < 1.0);
            p = *end == ',' ? end + 1 : end;
        }
        n++;
    }
    fclose(f);
    assert_int_equal(n, NPATCH);
    return 0;
}

/* The reflectance as the renderer reads a tabulated spectrum: linear between the samples, the
 * end values held outside. */
static double rho_at(const patch_t *p, double lambda)
{
    double t = (lambda - 380.0) / 5.0;
    if (t <= 0.0)
        return p->rho[0];
    if (t >= NRHO - 1)
        return p->rho[NRHO - 1];
    int i = (int)t;
    return p->rho[i] + (t - i) * (p->rho[i + 1] - p->rho[i]);
}

/* D65 at an integer wavelength from its 5 nm table (linear between samples). */
static double d65_at(int lambda)
{
    int i = (lambda - 300) / 5, r = (lambda - 300) % 5;
    double a = cie_d65_table[i], b = r ? cie_d65_table[i + 1] : a;
    return a + (b - a) * r / 5.0;
}

/* XYZ of rho under D65 with Y(D65) = 1: sums at 1 nm over the CIE table's 360-830 nm. */
static void reference_xyz(const patch_t *p, double xyz[3])
{
    double sx = 0, sy = 0, sz = 0, norm = 0;
    for (int l = 360; l <= 830; l++) {
        double d = d65_at(l), r = rho_at(p, l);
        int k = l - 360;
        sx += r * d * cie_x_table[k];
        sy += r * d * cie_y_table[k];
        sz += r * d * cie_z_table[k];
        norm += d * cie_y_table[k];
    }
    xyz[0] = sx / norm;
    xyz[1] = sy / norm;
    xyz[2] = sz / norm;
}

static scene_t *patch_scene(const patch_t *p, int res, int nb, const char *dispersion)
{
    static char text[8192];
    int n = snprintf(text, sizeof text,
                     "LookAt 0 0 5  0 0 0  0 1 0\n"
                     "Camera \"perspective\" \"float fov\" [ 20 ]\n"
                     "Film \"spectral\" \"integer xresolution\" [ %d ] \"integer yresolution\" "
                     "[ %d ] \"integer nbuckets\" [ %d ]\n"
                     "Sampler \"zsobol\" \"integer pixelsamples\" [ %d ]\n"
                     "Integrator \"simplepath\" \"integer maxdepth\" [ 5 ] "
                     "\"string dispersion\" \"%s\"\n"
                     "WorldBegin\n"
                     "LightSource \"infinite\" \"spectrum L\" \"stdillum-D65\"\n"
                     "Material \"diffuse\" \"spectrum reflectance\" [",
                     res, res, nb, SPP, dispersion);
    for (int k = 0; k < NRHO; k++)
        n += snprintf(text + n, sizeof text - (size_t)n, " %d %.3f", 380 + 5 * k, p->rho[k]);
    snprintf(text + n, sizeof text - (size_t)n,
             " ]\nShape \"trianglemesh\" \"point3 P\" [ -10 -10 0  10 -10 0  10 10 0  -10 10 0 ] "
             "\"integer indices\" [ 0 1 2  0 2 3 ]\n");
    return sb_load_text(text, NULL);
}

/* Image-mean linear sRGB of a patch: from the XYZ sums (film_to_rgb) and from the bucket means
 * (the colour of the buckets, as RGB was made before). */
static void render_patch(const patch_t *p, int nb, const char *dispersion, double exact[3],
                         double buckets[3])
{
    const int RES = strcmp(dispersion, "hero") == 0 ? RES_HERO : RES_FANOUT;
    scene_t *s = patch_scene(p, RES, nb, dispersion);
    err_t err;
    tilebuf_t *t = tilebuf_new(0, 0, RES, RES, nb, &err);
    assert_non_null(t);
    if (render_tile(s, NULL, 0, 0, RES, RES, 0, SPP, t, NULL, &err))
        fail_msg("render_tile: %s", err.msg);
    static float rgb[RES_MAX * RES_MAX * 3];
    assert_int_equal(film_to_rgb(t, s->settings.grid, rgb, &err), 0);
    /* The colour of the buckets is linear in them: the image's mean buckets give the image's
     * mean bucket colour. */
    double mean[RENDER_MAX_BUCKETS], image_mean[RENDER_MAX_BUCKETS] = {0};
    for (int c = 0; c < 3; c++)
        exact[c] = 0.0;
    for (int y = 0; y < RES; y++)
        for (int x = 0; x < RES; x++) {
            tilebuf_mean(t, x, y, mean);
            for (int b = 0; b < nb; b++)
                image_mean[b] += mean[b] / (RES * RES);
            for (int c = 0; c < 3; c++)
                exact[c] += rgb[3 * (y * RES + x) + c] / (RES * RES);
        }
    xyz_t bx = colour_buckets_to_xyz(s->settings.grid, image_mean);
    to_srgb((const double[3]){bx.x, bx.y, bx.z}, buckets);
    tilebuf_destroy(&t);
    scene_destroy(&s);
}

/* The largest per-channel error over the 24 patches, exact and bucket colour, and where. */
static void check_chart(int nb, const char *dispersion, double *worst_exact, double *worst_buckets)
{
    double we = 0.0, wb = 0.0;
    int pe = 0, pb = 0, ce = 0, cb = 0;
    for (int i = 0; i < NPATCH; i++) {
        double ref_xyz[3], ref[3], exact[3], buckets[3];
        reference_xyz(&g_patches[i], ref_xyz);
        to_srgb(ref_xyz, ref);
        render_patch(&g_patches[i], nb, dispersion, exact, buckets);
        for (int c = 0; c < 3; c++) {
            double e = fabs(exact[c] - ref[c]), b = fabs(buckets[c] - ref[c]);
            if (e > we)
                we = e, pe = i, ce = c;
            if (b > wb)
                wb = b, pb = i, cb = c;
        }
    }
    printf("colorchecker %-6s %2d buckets: exact XYZ max error %.4f (%s, %c); bucket colour "
           "%.4f (%s, %c)\n",
           dispersion, nb, we, g_patches[pe].name, "RGB"[ce], wb, g_patches[pb].name, "RGB"[cb]);
    *worst_exact = we;
    *worst_buckets = wb;
}

/* The reference itself: the white patch's chromaticity is D65's (the patch is nearly neutral)
 * and the chart's sRGB values are those published for it (BabelColor's and X-Rite's sRGB of
 * the classic chart differ from Ohta's spectra by a few 0.01, so only the order of magnitude
 * and the hues are checked: orange is red > green > blue, blue the reverse). */
static void test_reference(void **state)
{
    (void)state;
    double xyz[3], rgb[3];
    reference_xyz(&g_patches[18], xyz); /* white 9.5 */
    double x = xyz[0] / (xyz[0] + xyz[1] + xyz[2]), y = xyz[1] / (xyz[0] + xyz[1] + xyz[2]);
    assert_true(fabs(x - 0.3127) < 0.003 && fabs(y - 0.3290) < 0.003);
    assert_true(xyz[1] > 0.85 && xyz[1] < 0.92);
    reference_xyz(&g_patches[6], xyz); /* orange */
    to_srgb(xyz, rgb);
    assert_true(rgb[0] > rgb[1] && rgb[1] > rgb[2] && rgb[0] > 0.4 && rgb[0] < 0.9);
    reference_xyz(&g_patches[12], xyz); /* blue */
    to_srgb(xyz, rgb);
    assert_true(rgb[2] > rgb[1] && rgb[2] > rgb[0]);
}

static void test_hero(void **state)
{
    (void)state;
    static const int NB[] = {8, 16, 45};
    for (size_t k = 0; k < sizeof NB / sizeof NB[0]; k++) {
        double e, b;
        check_chart(NB[k], "hero", &e, &b);
        assert_true(e <= TOL);
        /* The bucket colour's bias at 8 buckets is well past the tolerance: the test sees it. */
        if (NB[k] == 8)
            assert_true(b > 2 * TOL);
    }
}

static void test_fanout(void **state)
{
    (void)state;
    static const int NB[] = {8, 16, 45};
    for (size_t k = 0; k < sizeof NB / sizeof NB[0]; k++) {
        double e, b;
        check_chart(NB[k], "fanout", &e, &b);
        assert_true(e <= TOL);
        if (NB[k] == 8)
            assert_true(b > 2 * TOL);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_reference),
        cmocka_unit_test(test_hero),
        cmocka_unit_test(test_fanout),
    };
    return cmocka_run_group_tests(tests, load_patches, NULL);
}
