/* envmap: image environments and sphere-light cone sampling, against numbers that do not come
 * from the code: the equal-area map's definition (a uniform square is a uniform sphere), the
 * integral of a density (1), a uniform light of the same radiance, the irradiance of one bright
 * texel computed from the map's geometry by hand, the solid angle a sphere subtends, and a PFM
 * written byte by byte.
 *
 * Tolerances: Monte-Carlo estimates within 5 standard errors (fixed seeds: deterministic);
 * chi-square statistics below the 1e-6 quantile of their distribution (Wilson-Hilferty). */
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
#include "distrib2d.h"
#include "envmap.h"
#include "equal_area.h"
#include "files_testutil.h"
#include "image_pfm.h"
#include "lights.h"
#include "rng.h"
#include "sample.h"
#include "scene_builders.h"
#include "spectrum.h"

#define PI 3.14159265358979323846

/* The 1 - 1e-6 quantile of chi-square with k degrees of freedom (Wilson-Hilferty, z = 4.75). */
static double chi2_limit(int k)
{
    double a = 2.0 / (9.0 * k), z = 4.753;
    double t = 1.0 - a + z * sqrt(a);
    return k * t * t * t;
}

/* ---- the equal-area map ---- */

static void test_equal_area_round_trip(void **state)
{
    (void)state;
    /* Known points: the centre is +z, the corners -z, the edge midpoints the equator. */
    vec3_t c = equal_area_square_to_sphere(0.5, 0.5);
    assert_true(fabs(c.z - 1.0) < 1e-15);
    vec3_t k = equal_area_square_to_sphere(0.0, 1.0);
    assert_true(fabs(k.z + 1.0) < 1e-15);
    vec3_t e = equal_area_square_to_sphere(1.0, 0.5);
    assert_true(fabs(e.x - 1.0) < 1e-12 && fabs(e.z) < 1e-12);
    vec3_t n = equal_area_square_to_sphere(0.5, 1.0);
    assert_true(fabs(n.y - 1.0) < 1e-12 && fabs(n.z) < 1e-12);
    for (int i = 0; i < 100000; i++) {
        double u = rng_uniform(7, (uint64_t)i, 0, 0), v = rng_uniform(7, (uint64_t)i, 0, 1);
        vec3_t d = equal_area_square_to_sphere(u, v);
        assert_true(fabs(vec3_length(d) - 1.0) < 1e-12);
        double u2, v2;
        equal_area_sphere_to_square(d, &u2, &v2);
        if (!(fabs(u - u2) < 1e-9 && fabs(v - v2) < 1e-9))
            fail_msg("(%.12f, %.12f) -> (%g %g %g) -> (%.12f, %.12f)", u, v, d.x, d.y, d.z, u2, v2);
    }
}

/* Uniform points of the square land uniformly on the sphere: z uniform in [-1, 1] and phi
 * uniform, cell by cell (16 z bands x 16 phi sectors, equal solid angles). */
static void test_equal_area_uniform(void **state)
{
    (void)state;
    enum { NZ = 16, NP = 16, N = 512000 };
    static double count[NZ][NP];
    memset(count, 0, sizeof count);
    for (int i = 0; i < N; i++) {
        vec3_t d = equal_area_square_to_sphere(rng_uniform(11, (uint64_t)i, 0, 0),
                                               rng_uniform(11, (uint64_t)i, 0, 1));
        int iz = (int)((d.z + 1.0) * 0.5 * NZ);
        int ip = (int)((atan2(d.y, d.x) + PI) / (2 * PI) * NP);
        iz = iz < 0 ? 0 : iz >= NZ ? NZ - 1 : iz;
        ip = ip < 0 ? 0 : ip >= NP ? NP - 1 : ip;
        count[iz][ip] += 1.0;
    }
    double e = (double)N / (NZ * NP), chi2 = 0.0;
    for (int a = 0; a < NZ; a++)
        for (int b = 0; b < NP; b++)
            chi2 += (count[a][b] - e) * (count[a][b] - e) / e;
    print_message("equal-area uniformity: chi2 %.1f for %d dof (limit %.1f)\n", chi2, NZ * NP - 1,
                  chi2_limit(NZ * NP - 1));
    assert_true(chi2 < chi2_limit(NZ * NP - 1));
}

/* ---- the environment's distribution ---- */

/* A 32x32 map with a smooth gradient, a hot spot and black texels. */
static float *test_image(int n)
{
    float *rgb = malloc((size_t)n * n * 3 * sizeof *rgb);
    for (int y = 0; y < n; y++)
        for (int x = 0; x < n; x++) {
            float *p = rgb + 3 * ((size_t)y * n + x);
            double g = 0.2 + (double)x / n;
            p[0] = (float)g;
            p[1] = (float)(0.5 * g);
            p[2] = (float)(y < 4 ? 0.0 : 0.3);
            if (x == 20 && y == 9)
                p[0] = p[1] = p[2] = 200.0f;
            if (y == 30)
                p[0] = p[1] = p[2] = 0.0f;
        }
    return rgb;
}

/* The pdf integrates to 1 over the sphere (estimated with uniform directions), sampled
 * directions carry the pdf envmap_pdf gives them, and their histogram over 8x8 blocks of
 * texels matches the pdf's integral over each block. */
static void test_envmap_pdf(void **state)
{
    (void)state;
    const int n = 32;
    err_t err;
    float *rgb = test_image(n);
    envmap_t *e = envmap_new(rgb, n, n, "test", &err);
    assert_non_null(e);
    enum { N = 400000 };
    double sum = 0, sum2 = 0;
    for (int i = 0; i < N; i++) {
        vec3_t d = sample_uniform_sphere(rng_uniform(3, (uint64_t)i, 0, 0),
                                         rng_uniform(3, (uint64_t)i, 0, 1));
        double f = envmap_pdf(e, d) * 4 * PI;
        sum += f;
        sum2 += f * f;
    }
    double mean = sum / N, se = sqrt((sum2 / N - mean * mean) / N);
    print_message("integral of the pdf over the sphere: %.5f +- %.5f\n", mean, se);
    assert_true(fabs(mean - 1.0) < 5 * se && se < 0.02);

    /* Expected block probabilities from the texel weights (channel average, pbrt-v4). */
    enum { B = 4 };
    double expect[B][B] = {{0}}, total = 0, count[B][B] = {{0}};
    for (int y = 0; y < n; y++)
        for (int x = 0; x < n; x++) {
            const float *p = rgb + 3 * ((size_t)y * n + x);
            double w = (p[0] + p[1] + p[2]) / 3.0;
            expect[y * B / n][x * B / n] += w;
            total += w;
        }
    for (int i = 0; i < N; i++) {
        size_t texel;
        double pdf;
        vec3_t d = envmap_sample(e, rng_uniform(5, (uint64_t)i, 0, 0),
                                 rng_uniform(5, (uint64_t)i, 0, 1), &texel, &pdf);
        double u, v;
        equal_area_sphere_to_square(d, &u, &v);
        int bx = (int)(u * B), by = (int)(v * B);
        bx = bx >= B ? B - 1 : bx;
        by = by >= B ? B - 1 : by;
        count[by][bx] += 1;
        double q = envmap_pdf(e, d);
        if (!(fabs(q - pdf) <= 1e-9 * pdf))
            fail_msg("sample %d: pdf %g, envmap_pdf %g", i, pdf, q);
        const float *p = rgb + 3 * texel;
        assert_true(p[0] + p[1] + p[2] > 0.0f); /* black texels are never drawn */
    }
    double chi2 = 0;
    int dof = -1;
    for (int a = 0; a < B; a++)
        for (int b = 0; b < B; b++) {
            double ex = N * expect[a][b] / total;
            if (ex > 0) {
                chi2 += (count[a][b] - ex) * (count[a][b] - ex) / ex;
                dof++;
            }
        }
    print_message("sampled directions vs pdf: chi2 %.1f for %d dof (limit %.1f)\n", chi2, dof,
                  chi2_limit(dof));
    assert_true(chi2 < chi2_limit(dof));
    envmap_destroy(&e);
    free(rgb);
}

/* The texels' spectra reproduce their colour: the XYZ of m s(lambda) D65n is the XYZ of rgb
 * (the uplift through the table, within 1 % of the luminance). */
static void test_envmap_colour(void **state)
{
    (void)state;
    const float cols[][3] = {{0.3f, 0.5f, 0.7f},
                             {1.0f, 0.85f, 0.62f},
                             {0.22f, 0.42f, 0.9f},
                             {2.0f, 0.1f, 0.05f},
                             {0.45f, 0.45f, 0.45f}};
    err_t err;
    spectrum_t *d65 = spectrum_new_cie_d65(&err);
    assert_non_null(d65);
    double ynorm = 0;
    for (int l = 360; l <= 830; l++)
        ynorm += spectrum_eval(d65, l) * cie_cmf_eval(l).y;
    for (size_t c = 0; c < sizeof cols / sizeof cols[0]; c++) {
        envmap_t *e = envmap_new(cols[c], 1, 1, "one", &err);
        assert_non_null(e);
        xyz_t xyz = {0, 0, 0};
        for (int l = 360; l <= 830; l++) {
            double v = envmap_texel_value(e, 0, l) * spectrum_eval(d65, l) / ynorm;
            xyz_t m = cie_cmf_eval(l);
            xyz.x += v * m.x;
            xyz.y += v * m.y;
            xyz.z += v * m.z;
        }
        xyz_t want = colour_linear_srgb_to_xyz((rgb_t){cols[c][0], cols[c][1], cols[c][2]});
        double tol = 0.01 * want.y;
        if (!(fabs(xyz.x - want.x) < tol && fabs(xyz.y - want.y) < tol &&
              fabs(xyz.z - want.z) < tol))
            fail_msg("rgb (%g %g %g): XYZ %g %g %g, want %g %g %g", cols[c][0], cols[c][1],
                     cols[c][2], xyz.x, xyz.y, xyz.z, want.x, want.y, want.z);
        envmap_destroy(&e);
    }
    spectrum_destroy(&d65);
}

/* ---- PFM ---- */

static void put_f32(uint8_t *p, float f, int little)
{
    uint32_t b;
    memcpy(&b, &f, 4);
    for (int i = 0; i < 4; i++)
        p[little ? i : 3 - i] = (uint8_t)(b >> (8 * i));
}

/* A 2x2 PF written by hand in each byte order: the file's first row is the image's bottom. */
static void test_pfm(void **state)
{
    (void)state;
    for (int little = 0; little < 2; little++) {
        const char *hdr = little ? "PF\n2 2\n-1.0\n" : "PF\n2 2\n1.0\n";
        size_t h = strlen(hdr);
        uint8_t buf[64 + 48];
        memcpy(buf, hdr, h);
        /* file order: bottom-left, bottom-right, top-left, top-right */
        const float v[4][3] = {{1, 2, 3}, {4, 5, 6}, {7, 8, 9}, {10, 11, 12.5f}};
        for (int p = 0; p < 4; p++)
            for (int c = 0; c < 3; c++)
                put_f32(buf + h + 12 * p + 4 * c, v[p][c], little);
        int w, hh;
        float *rgb;
        err_t err;
        assert_int_equal(image_pfm_decode(buf, h + 48, "t.pfm", &w, &hh, &rgb, &err), 0);
        assert_int_equal(w, 2);
        assert_int_equal(hh, 2);
        /* top row first: the file's last row */
        const float want[12] = {7, 8, 9, 10, 11, 12.5f, 1, 2, 3, 4, 5, 6};
        for (int i = 0; i < 12; i++)
            assert_true(rgb[i] == want[i]);
        free(rgb);
        assert_int_equal(image_pfm_decode(buf, h + 47, "t.pfm", &w, &hh, &rgb, &err), -1);
        assert_non_null(strstr(err.msg, "truncated"));
    }
    /* Grey "Pf" copies its value to R, G and B. */
    uint8_t g[32] = "Pf\n1 1\n-1\n";
    size_t h = strlen((char *)g);
    put_f32(g + h, 0.25f, 1);
    int w, hh;
    float *rgb;
    err_t err;
    assert_int_equal(image_pfm_decode(g, h + 4, "g.pfm", &w, &hh, &rgb, &err), 0);
    assert_true(rgb[0] == 0.25f && rgb[1] == 0.25f && rgb[2] == 0.25f);
    free(rgb);
}

/* ---- scenes ---- */

/* Writes an n x m PFM whose texels are all rgb, except texel (bx, by) (top-row coordinates)
 * set to bright when bx >= 0; returns its path in the scratch folder. */
static const char *write_pfm(const char *name, int n, int m, const float rgb[3], int bx, int by,
                             float bright)
{
    char hdr[64];
    int h = snprintf(hdr, sizeof hdr, "PF\n%d %d\n-1\n", n, m);
    size_t size = (size_t)h + (size_t)n * m * 12;
    uint8_t *buf = malloc(size);
    memcpy(buf, hdr, (size_t)h);
    for (int fy = 0; fy < m; fy++)
        for (int x = 0; x < n; x++)
            for (int c = 0; c < 3; c++) {
                int y = m - 1 - fy;
                float v = (x == bx && y == by) ? bright : rgb[c];
                put_f32(buf + h + 12 * ((size_t)fy * n + x) + 4 * c, v, 1);
            }
    const char *path = testutil_scratch(name);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(buf, 1, size, f), size);
    fclose(f);
    free(buf);
    return path;
}

static scene_t *load_text_file(const char *name, const char *text)
{
    const char *path = testutil_scratch(name);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
    return sb_load_file(path);
}

/* A diffuse floor of albedo 0.5 filling an 8x8 view from above, lit only by the image
 * environment in pfm, rendered with integrator at maxdepth 1. */
static scene_t *floor_scene(const char *name, const char *integrator, const char *pfm)
{
    char text[2048];
    snprintf(text, sizeof text,
             "LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 10\n"
             "Film \"spectral\" \"integer xresolution\" 8 \"integer yresolution\" 8\n"
             "Sampler \"independent\" \"integer pixelsamples\" 16\n"
             "Integrator \"%s\" \"integer maxdepth\" 1\nWorldBegin\n"
             "LightSource \"infinite\" \"string filename\" \"%s\"\n"
             "Material \"diffuse\" \"rgb reflectance\" [0.5 0.5 0.5]\n"
             "Shape \"trianglemesh\" \"point3 P\" [-50 -50 0  50 -50 0  50 50 0  -50 50 0]"
             " \"integer indices\" [0 1 2 0 2 3]\n",
             integrator, pfm);
    return load_text_file(name, text);
}

/* A diffuse ball of albedo 0.5 seen from outside under an environment (light line given). */
static scene_t *ball_scene(const char *name, const char *light, const char *integrator)
{
    char text[2048];
    snprintf(text, sizeof text,
             "LookAt 0 0 -3  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 50\n"
             "Film \"spectral\" \"integer xresolution\" 16 \"integer yresolution\" 16\n"
             "Sampler \"independent\" \"integer pixelsamples\" 16\n"
             "Integrator \"%s\"\nWorldBegin\n"
             "AttributeBegin\nRotate 30 1 0 0\n%s\nAttributeEnd\n"
             "Material \"diffuse\" \"rgb reflectance\" [0.5 0.5 0.5]\n"
             "Shape \"sphere\" \"float radius\" 1\n",
             integrator, light);
    return load_text_file(name, text);
}

/* A constant-colour image environment renders as a uniform "infinite" light of that colour:
 * the same mean luminance and spectrum per bucket within noise. */
static void test_constant_image_is_uniform(void **state)
{
    (void)state;
    const float col[3] = {0.3f, 0.5f, 0.7f};
    const char *pfm = write_pfm("const.pfm", 8, 8, col, -1, -1, 0);
    char light[512];
    snprintf(light, sizeof light, "LightSource \"infinite\" \"string filename\" \"%s\"", pfm);
    scene_t *a = ball_scene("img.pbrt", light, "path");
    scene_t *b = ball_scene("uni.pbrt", "LightSource \"infinite\" \"rgb L\" [0.3 0.5 0.7]", "path");
    sb_image_stats_t sa = sb_render_stats(a, 16, 64), sbb = sb_render_stats(b, 16, 64);
    double se = sqrt(sa.se * sa.se + sbb.se * sbb.se);
    print_message("constant image %.5f +- %.5f, uniform %.5f +- %.5f\n", sa.mean, sa.se, sbb.mean,
                  sbb.se);
    assert_true(fabs(sa.mean - sbb.mean) < 5 * se + 0.003 * sbb.mean);
    for (int k = 0; k < a->settings.grid.n; k++)
        if (!(fabs(sa.buckets[k] - sbb.buckets[k]) < 0.03 * sbb.buckets[k] + 1e-4))
            fail_msg("bucket %d: image %g, uniform %g", k, sa.buckets[k], sbb.buckets[k]);
    scene_destroy(&a);
    scene_destroy(&b);
}

/* One bright texel of luminance V at the map's centre (light space +z, turned to world +z by no
 * transform) over a diffuse floor of albedo 0.5 facing it: the floor's radiance is
 * 0.5 / pi * V * (4 pi / N) * <cos>, N the texel count, <cos> the mean of z over the texel,
 * which the map's definition gives by hand: for 16x16 texels the texel (8, 8) covers
 * u', v' in [0, 1/8] of the [-1, 1] square, where z = 1 - (u' + v')^2, so <cos> = 1 -
 * E[(u' + v')^2] = 1 - (2/3 + 1/2) / 64 = 0.981771. Light sampling (path) finds it with a small
 * variance; BSDF sampling alone (simplepath) has the same mean and a far larger variance. */
static void test_bright_texel(void **state)
{
    (void)state;
    const float black[3] = {0, 0, 0};
    const double V = 100.0;
    const char *pfm = write_pfm("spot.pfm", 16, 16, black, 8, 8, (float)V);
    const double expect = 0.5 / PI * V * (4 * PI / 256) * (1.0 - (2.0 / 3.0 + 0.5) / 64.0);
    sb_image_stats_t st[2];
    const char *integ[2] = {"path", "simplepath"};
    for (int i = 0; i < 2; i++) {
        scene_t *s = floor_scene(i ? "spot_bsdf.pbrt" : "spot_nee.pbrt", integ[i], pfm);
        st[i] = sb_render_stats(s, 8, i ? 4096 : 256);
        scene_destroy(&s);
        print_message("%s: floor %.5f +- %.5f (expected %.5f), per-sample variance %.4g\n",
                      integ[i], st[i].mean, st[i].se, expect, st[i].var);
        assert_true(fabs(st[i].mean - expect) < 5 * st[i].se + 0.005 * expect);
    }
    assert_true(st[0].se < 0.01 * expect);
    assert_true(st[0].var * 20 < st[1].var);
}

/* A map neither square nor 2:1 is refused, naming the file, line and column of "filename"
 * and why. */
static void test_non_square_refused(void **state)
{
    (void)state;
    const float grey[3] = {0.5f, 0.5f, 0.5f};
    const char *pfm = write_pfm("wide.pfm", 3, 2, grey, -1, -1, 0);
    char text[1024];
    snprintf(text, sizeof text,
             "Camera \"perspective\"\nWorldBegin\n"
             "LightSource \"infinite\"\n  \"string filename\" \"%s\"\n"
             "Shape \"sphere\"\n",
             pfm);
    err_t err;
    scene_t *s = sb_load_text(text, &err);
    assert_null(s);
    print_message("%s\n", err.msg);
    assert_non_null(strstr(err.msg, "t.pbrt:4:"));
    assert_non_null(strstr(err.msg, "3x2"));
    assert_non_null(strstr(err.msg, "neither square"));
    /* "L" with "filename" is an error in pbrt-v4. */
    snprintf(text, sizeof text,
             "Camera \"perspective\"\nWorldBegin\n"
             "LightSource \"infinite\" \"rgb L\" [1 1 1] \"string filename\" \"%s\"\n",
             pfm);
    assert_null(sb_load_text(text, &err));
    assert_non_null(strstr(err.msg, "both \"L\" and \"filename\""));
}

/* An analytic environment: a bright cap about +z, a colour that varies with x, a floor. */
static void analytic_env(vec3_t d, float *p)
{
    double cap = d.z > 0 ? pow(d.z, 8) * 6.0 : 0.0;
    p[0] = (float)(0.2 + cap + 0.1 * (d.x + 1.0));
    p[1] = (float)(0.25 + cap);
    p[2] = (float)(0.3 + 0.5 * cap + 0.1 * (1.0 - d.y));
}

/* A 2:1 map is lat-long (pbrt-v3's layout): the same analytic environment as a lat-long and an
 * equal-area map gives the same mean radiance, illuminance normaliser and radiance in each
 * direction (orientation and Jacobian agree); its pdf integrates to 1 over the sphere and
 * sampled directions carry the pdf envmap_pdf gives them. */
static void test_latlong(void **state)
{
    (void)state;
    const int n = 128;
    float *ea = malloc((size_t)n * n * 3 * sizeof *ea),
          *ll = malloc((size_t)2 * n * n * 3 * sizeof *ll);
    for (int y = 0; y < n; y++)
        for (int x = 0; x < n; x++)
            analytic_env(equal_area_square_to_sphere((x + 0.5) / n, (y + 0.5) / n),
                         ea + 3 * ((size_t)y * n + x));
    for (int y = 0; y < n; y++)
        for (int x = 0; x < 2 * n; x++) {
            double phi = 2 * PI * (x + 0.5) / (2 * n), theta = PI * (y + 0.5) / n;
            vec3_t d = vec3_make(sin(theta) * cos(phi), sin(theta) * sin(phi), cos(theta));
            analytic_env(d, ll + 3 * ((size_t)y * 2 * n + x));
        }
    err_t err;
    envmap_t *a = envmap_new(ea, n, n, "ea", &err), *b = envmap_new(ll, 2 * n, n, "ll", &err);
    assert_non_null(a);
    assert_non_null(b);
    assert_false(envmap_is_latlong(a));
    assert_true(envmap_is_latlong(b));
    print_message("mean Y %.5f / %.5f, k_e %.5f / %.5f\n", envmap_mean_luminance(a),
                  envmap_mean_luminance(b), envmap_upper_illuminance(a),
                  envmap_upper_illuminance(b));
    assert_true(fabs(envmap_mean_luminance(b) / envmap_mean_luminance(a) - 1) < 0.005);
    assert_true(fabs(envmap_upper_illuminance(b) / envmap_upper_illuminance(a) - 1) < 0.005);

    enum { N = 200000 };
    double sum = 0, sum2 = 0, dy = 0, ya = 0;
    for (int i = 0; i < N; i++) {
        vec3_t d = sample_uniform_sphere(rng_uniform(7, (uint64_t)i, 0, 0),
                                         rng_uniform(7, (uint64_t)i, 0, 1));
        double f = envmap_pdf(b, d) * 4 * PI;
        sum += f;
        sum2 += f * f;
        const float *pa = ea + 3 * envmap_texel(a, d), *pb = ll + 3 * envmap_texel(b, d);
        dy += fabs((pa[0] + pa[1] + pa[2]) - (pb[0] + pb[1] + pb[2]));
        ya += pa[0] + pa[1] + pa[2];
    }
    double mean = sum / N, se = sqrt((sum2 / N - mean * mean) / N);
    print_message("lat-long pdf over the sphere: %.5f +- %.5f; mean |difference| of the two "
                  "maps' radiance %.4f of the mean\n",
                  mean, se, dy / ya);
    assert_true(fabs(mean - 1.0) < 5 * se && se < 0.02);
    assert_true(dy / ya < 0.02); /* nearest texels of two resolutions, not a flipped map */
    for (int i = 0; i < 20000; i++) {
        size_t texel;
        double pdf;
        vec3_t d = envmap_sample(b, rng_uniform(9, (uint64_t)i, 0, 0),
                                 rng_uniform(9, (uint64_t)i, 0, 1), &texel, &pdf);
        assert_true(isfinite(pdf) && pdf > 0);
        assert_true(fabs(vec3_dot(d, d) - 1) < 1e-9);
        double q = envmap_pdf(b, d);
        if (!(fabs(q - pdf) <= 1e-6 * pdf))
            fail_msg("sample %d: pdf %g, envmap_pdf %g", i, pdf, q);
        assert_int_equal(texel, envmap_texel(b, d));
    }
    /* The poles and the seam: finite, and the pdf never negative. */
    const vec3_t odd[] = {{0, 0, 1}, {0, 0, -1}, {1, -1e-300, 0}, {1, 0, 0}, {1e-300, 0, 1}};
    for (size_t i = 0; i < sizeof odd / sizeof odd[0]; i++) {
        double q = envmap_pdf(b, odd[i]);
        assert_true(isfinite(q) && q >= 0);
        assert_true(envmap_texel(b, odd[i]) < (size_t)2 * n * n);
    }
    envmap_destroy(&a);
    envmap_destroy(&b);
    free(ea);
    free(ll);
}

/* "illuminance" E scales the map as pbrt-v4 does (lights.cpp): by E / k_e with k_e =
 * 2 pi / N times the sum over upper-hemisphere texels of Y cos(theta). A surface facing +z
 * truly receives 4 pi / N times that sum, so pbrt-v4's map gives it 2 E, not E: with a
 * constant map, radiance 2 E / pi. prismfarm follows pbrt-v4 (its scenes are written for
 * it). "portal" is accepted with a warning. */
static void test_illuminance_and_portal(void **state)
{
    (void)state;
    const float grey[3] = {0.3f, 0.3f, 0.3f};
    const char *pfm = write_pfm("grey.pfm", 64, 64, grey, -1, -1, 0);
    char text[1024];
    snprintf(text, sizeof text,
             "Camera \"perspective\"\nWorldBegin\n"
             "LightSource \"infinite\" \"string filename\" \"%s\" \"float illuminance\" 2\n"
             "  \"point3 portal\" [0 0 0  1 0 0  1 1 0  0 1 0]\n"
             "Shape \"sphere\"\n",
             pfm);
    scene_t *s = sb_load_text(text, NULL);
    const light_t *l = &s->lights[0];
    assert_non_null(l->envmap);
    /* radiance Y along any direction: scale * spectrum's Y (1) * texel's Y (0.3) */
    double y = l->scale * 0.3;
    print_message("illuminance 2: radiance Y %.6f (pbrt-v4's %.6f)\n", y, 4.0 / PI);
    assert_true(fabs(y - 4.0 / PI) < 0.01 * (4.0 / PI)); /* texel-centre quadrature, 64x64 */
    int warned = 0;
    for (size_t i = 0; i < warnings_count(s->warnings); i++)
        warned |= strstr(warnings_at(s->warnings, i), "portal") != NULL &&
                  strstr(warnings_at(s->warnings, i), "t.pbrt:4:") != NULL;
    assert_true(warned);
    scene_destroy(&s);
}

/* ---- the compensated distribution ---- */

/* A sun and sky: a sky brighter toward +z and bluish, a darker ground, and a sun of radius
 * 5 degrees and radiance 300 toward (0.3, 0.2, 0.93). */
static void sun_sky(vec3_t d, float *p)
{
    const vec3_t sun = vec3_normalize(vec3_make(0.3, 0.2, 0.93));
    double up = d.z > 0 ? d.z : 0;
    p[0] = (float)(0.25 + 0.15 * up);
    p[1] = (float)(0.3 + 0.25 * up);
    p[2] = (float)(0.35 + 0.5 * up);
    if (d.z < 0)
        p[0] = p[1] = p[2] = 0.15f;
    if (vec3_dot(d, sun) > cos(5.0 * PI / 180.0)) {
        p[0] = 300.0f;
        p[1] = 270.0f;
        p[2] = 220.0f;
    }
}

/* An n x n equal-area (lat-long: 2n x n) image of env, top row first. */
static float *env_image(int n, int latlong, void (*env)(vec3_t, float *))
{
    int w = latlong ? 2 * n : n;
    float *rgb = malloc((size_t)w * n * 3 * sizeof *rgb);
    for (int y = 0; y < n; y++)
        for (int x = 0; x < w; x++) {
            vec3_t d;
            if (latlong) {
                double phi = 2 * PI * (x + 0.5) / w, theta = PI * (y + 0.5) / n;
                d = vec3_make(sin(theta) * cos(phi), sin(theta) * sin(phi), cos(theta));
            } else {
                d = equal_area_square_to_sphere((x + 0.5) / n, (y + 0.5) / n);
            }
            env(d, rgb + 3 * ((size_t)y * w + x));
        }
    return rgb;
}

/* The compensated pdf, for the test image and a lat-long sun and sky: it integrates to 1 over
 * the sphere where it is > 0 (estimated with uniform directions), it is 0 exactly where the
 * texel's channel average is at or below the image's mean over directions (computed here from
 * the texels and their solid angles, and checked at every texel's centre), sampled directions
 * carry the pdf envmap_pdf_as gives them and never land on such a texel, and where it is > 0
 * it is proportional to c - mean (the ratio to the plain pdf, c / (c - mean) up to a constant). */
static void test_compensated_pdf(void **state)
{
    (void)state;
    for (int ll = 0; ll < 2; ll++) {
        const int n = ll ? 64 : 32, w = ll ? 2 * n : n;
        float *rgb = ll ? env_image(n, 1, sun_sky) : test_image(n);
        err_t err;
        envmap_t *e = envmap_new(rgb, w, n, "comp", &err);
        assert_non_null(e);
        assert_true(envmap_has_compensated(e));
        double sum_c = 0, sum_sa = 0;
        for (int y = 0; y < n; y++)
            for (int x = 0; x < w; x++) {
                const float *p = rgb + 3 * ((size_t)y * w + x);
                double sa = ll ? sin(PI * (y + 0.5) / n) : 1.0;
                sum_c += ((double)p[0] + p[1] + p[2]) / 3.0 * sa;
                sum_sa += sa;
            }
        const double avg = sum_c / sum_sa;
        double k = -1; /* comp pdf * (c / (c - avg)) / plain pdf, the same for every texel */
        int zero = 0;
        for (int y = 0; y < n; y++)
            for (int x = 0; x < w; x++) {
                const float *p = rgb + 3 * ((size_t)y * w + x);
                double c = ((double)p[0] + p[1] + p[2]) / 3.0;
                vec3_t d;
                if (ll) {
                    double phi = 2 * PI * (x + 0.5) / w, theta = PI * (y + 0.5) / n;
                    d = vec3_make(sin(theta) * cos(phi), sin(theta) * sin(phi), cos(theta));
                } else {
                    d = equal_area_square_to_sphere((x + 0.5) / n, (y + 0.5) / n);
                }
                double q = envmap_pdf_as(e, true, d), q0 = envmap_pdf(e, d);
                if (c <= avg) {
                    if (q != 0.0)
                        fail_msg("texel (%d, %d): c %g <= mean %g, compensated pdf %g", x, y, c,
                                 avg, q);
                    zero++;
                    continue;
                }
                assert_true(q > 0.0 && q0 > 0.0);
                double r = q * c / ((c - avg) * q0);
                if (k < 0)
                    k = r;
                if (!(fabs(r / k - 1.0) < 1e-6))
                    fail_msg("texel (%d, %d): compensated / plain pdf off by %.9g", x, y, r / k);
            }
        assert_true(zero > 0);
        /* The integral by the midpoint rule on 4x4 points per texel, each weighted by its
         * solid angle (equal-area: 4 pi / points; lat-long: 2 pi^2 sin(theta) / points). */
        const int q = 4;
        double integral = 0;
        for (int y = 0; y < n * q; y++)
            for (int x = 0; x < w * q; x++) {
                double u = (x + 0.5) / (w * q), v = (y + 0.5) / (n * q), jac = 4 * PI;
                vec3_t d = equal_area_square_to_sphere(u, v);
                if (ll) {
                    d = vec3_make(sin(PI * v) * cos(2 * PI * u), sin(PI * v) * sin(2 * PI * u),
                                  cos(PI * v));
                    jac = 2 * PI * PI * sin(PI * v);
                }
                integral += envmap_pdf_as(e, true, d) * jac / ((double)w * q * n * q);
            }
        print_message("%s: compensated pdf over the sphere %.6f; %d of %d texels at or below "
                      "the mean %.4f\n",
                      ll ? "lat-long sun and sky" : "test image", integral, zero, w * n, avg);
        assert_true(fabs(integral - 1.0) < 1e-6);
        for (int i = 0; i < 50000; i++) {
            size_t texel;
            double pdf;
            vec3_t d = envmap_sample_as(e, true, rng_uniform(23, (uint64_t)i, 0, 0),
                                        rng_uniform(23, (uint64_t)i, 0, 1), &texel, &pdf);
            const float *p = rgb + 3 * texel;
            assert_true(((double)p[0] + p[1] + p[2]) / 3.0 > avg);
            double q = envmap_pdf_as(e, true, d);
            if (!(fabs(q - pdf) <= 1e-6 * pdf))
                fail_msg("sample %d: pdf %g, envmap_pdf_as %g", i, pdf, q);
        }
        envmap_destroy(&e);
        free(rgb);
    }
}

/* A uniform image (equal-area and lat-long) has no texel above its average: no compensated
 * distribution, and asking for it gives the plain one, sample for sample. */
static void test_compensated_uniform_falls_back(void **state)
{
    (void)state;
    for (int ll = 0; ll < 2; ll++) {
        const int n = 16, w = ll ? 2 * n : n;
        float *rgb = malloc((size_t)w * n * 3 * sizeof *rgb);
        for (size_t i = 0; i < (size_t)w * n; i++) {
            rgb[3 * i] = 0.3f;
            rgb[3 * i + 1] = 0.7f;
            rgb[3 * i + 2] = 0.1f;
        }
        err_t err;
        envmap_t *e = envmap_new(rgb, w, n, "uniform", &err);
        assert_non_null(e);
        assert_false(envmap_has_compensated(e));
        for (int i = 0; i < 1000; i++) {
            double u0 = rng_uniform(25, (uint64_t)i, 0, 0), u1 = rng_uniform(25, (uint64_t)i, 0, 1);
            size_t ta, tb;
            double pa, pb;
            vec3_t a = envmap_sample_as(e, true, u0, u1, &ta, &pa);
            vec3_t b = envmap_sample(e, u0, u1, &tb, &pb);
            assert_true(a.x == b.x && a.y == b.y && a.z == b.z && ta == tb && pa == pb);
            assert_true(envmap_pdf_as(e, true, a) == envmap_pdf(e, a));
            if (!ll) /* uniform (lat-long: up to the texel's sin(theta) against the point's) */
                assert_true(fabs(pa * 4 * PI - 1.0) < 1e-12);
        }
        envmap_destroy(&e);
        free(rgb);
    }
}

/* The irradiance at the origin on a surface facing +z under the sun and sky, estimated as
 * next-event estimation does it: a light sample (lights_sample, mis as given) and a cosine
 * sample (the Lambertian BSDF's), weighted by the power heuristic with the pdfs lights_pdf
 * gives (with bsdf_mis the mis it asks with; 0 with a compensated light sample is the
 * inconsistent pairing). Returns the mean over N samples, its standard error and the variance
 * of one sample. */
static void mis_irradiance(const scene_t *s, int mis, int bsdf_mis, double lambda, int seed,
                           double *mean, double *se, double *var)
{
    enum { N = 200000 };
    const light_t *l = &s->lights[0];
    const double value = lights_value(l, lambda);
    const lights_at_t at = {.p = vec3_make(0, 0, 0), .n = vec3_make(0, 0, 1), .mis = mis};
    const lights_at_t at_b = {.p = vec3_make(0, 0, 0), .n = vec3_make(0, 0, 1), .mis = bsdf_mis};
    double sum = 0, sum2 = 0;
    for (int i = 0; i < N; i++) {
        double u[4], f = 0;
        rng_uniform4((uint64_t)seed, (uint64_t)i, 0, 0, u);
        light_sample_t ls;
        if (lights_sample(s, &at, u, &ls) && ls.wi.z > 0) {
            /* the pdf in both directions is the same */
            double lp = lights_pdf(s, &at, ls.light, ls.tri, ls.wi, ls.p_light, ls.n_light);
            if (!(fabs(lp - ls.pdf) <= 1e-9 * ls.pdf))
                fail_msg("mis %d: lights_sample pdf %g, lights_pdf %g", mis, ls.pdf, lp);
            double pb = ls.wi.z / PI, a = ls.pdf * ls.pdf;
            f += lights_sample_emission_of(s, &ls, value, lambda) * ls.wi.z / ls.pdf * a /
                 (a + pb * pb);
        }
        vec3_t wi = sample_cosine_hemisphere(rng_uniform((uint64_t)seed, (uint64_t)i, 1, 0),
                                             rng_uniform((uint64_t)seed, (uint64_t)i, 1, 1));
        if (wi.z > 0) {
            double pb = wi.z / PI, lp = lights_pdf(s, &at_b, 0, 0, wi, at.p, wi);
            double L = lights_envmap_radiance(l, lights_envmap_texel(l, wi), value, lambda);
            f += L * wi.z / pb * pb * pb / (pb * pb + lp * lp);
        }
        sum += f;
        sum2 += f * f;
    }
    *mean = sum / N;
    *var = sum2 / N - *mean * *mean;
    *se = sqrt(*var / N);
}

/* Next-event estimation with the compensated distribution is unbiased and sends the light's
 * samples to the sun: the MIS estimate of the irradiance under the sun and sky matches a
 * quadrature of the map (every texel split 8x8) with the plain distribution and with the
 * compensated one, whose variance is lower; a compensated light sample weighed against a BSDF
 * side that asks for the plain pdf (the pairing lights_pdf's at must prevent) misses the
 * quadrature by far more than its noise, so this test can tell. */
static void test_compensated_unbiased(void **state)
{
    (void)state;
    const int n = 64;
    float *rgb = env_image(n, 0, sun_sky);
    char hdr[64];
    int h = snprintf(hdr, sizeof hdr, "PF\n%d %d\n-1\n", n, n);
    const char *pfm = testutil_scratch("sunsky.pfm");
    FILE *fp = fopen(pfm, "wb");
    assert_non_null(fp);
    fwrite(hdr, 1, (size_t)h, fp);
    for (int fy = 0; fy < n; fy++) /* PFM: bottom row first */
        for (int i = 0; i < 3 * n; i++) {
            uint8_t b[4];
            put_f32(b, rgb[3 * (size_t)(n - 1 - fy) * n + i], 1);
            fwrite(b, 1, 4, fp);
        }
    fclose(fp);
    char text[1024];
    snprintf(text, sizeof text,
             "Camera \"perspective\"\nWorldBegin\n"
             "LightSource \"infinite\" \"string filename\" \"%s\"\n",
             pfm);
    scene_t *s = sb_load_text(text, NULL);
    const light_t *l = &s->lights[0];
    assert_non_null(l->envmap);
    assert_true(envmap_has_compensated(l->envmap));
    const double lambda = 550.0, value = lights_value(l, lambda);
    double exact = 0;
    const int k = 8;
    for (int y = 0; y < n * k; y++)
        for (int x = 0; x < n * k; x++) {
            vec3_t d = equal_area_square_to_sphere((x + 0.5) / (n * k), (y + 0.5) / (n * k));
            if (d.z > 0)
                exact += lights_envmap_radiance(l, lights_envmap_texel(l, d), value, lambda) * d.z;
        }
    exact *= 4 * PI / ((double)n * k * n * k);
    double m[3], se[3], var[3];
    mis_irradiance(s, 0, 0, lambda, 31, &m[0], &se[0], &var[0]);
    mis_irradiance(s, 1, 1, lambda, 31, &m[1], &se[1], &var[1]);
    mis_irradiance(s, 1, 0, lambda, 31, &m[2], &se[2], &var[2]);
    print_message("irradiance %.5f: plain %.5f +- %.5f, compensated %.5f +- %.5f (variance %.2fx "
                  "lower), inconsistent pairing %.5f +- %.5f\n",
                  exact, m[0], se[0], m[1], se[1], var[0] / var[1], m[2], se[2]);
    assert_true(fabs(m[0] - exact) < 5 * se[0]);
    assert_true(fabs(m[1] - exact) < 5 * se[1]);
    assert_true(var[1] < var[0]);
    assert_true(fabs(m[2] - exact) > 10 * se[2]);
    scene_destroy(&s);
    free(rgb);
}

/* A diffuse floor under the sun and sky, rendered by "path" (compensated light samples, MIS with
 * the BSDF's) and by "whitted" (one plain light sample, nothing competing): the same mean
 * within noise. */
static void test_compensated_render(void **state)
{
    (void)state;
    const int n = 64;
    float *rgb = env_image(n, 0, sun_sky);
    char hdr[64];
    int h = snprintf(hdr, sizeof hdr, "PF\n%d %d\n-1\n", n, n);
    const char *pfm = testutil_scratch("sunsky_r.pfm");
    FILE *fp = fopen(pfm, "wb");
    assert_non_null(fp);
    fwrite(hdr, 1, (size_t)h, fp);
    for (int fy = 0; fy < n; fy++)
        for (int i = 0; i < 3 * n; i++) {
            uint8_t b[4];
            put_f32(b, rgb[3 * (size_t)(n - 1 - fy) * n + i], 1);
            fwrite(b, 1, 4, fp);
        }
    fclose(fp);
    const char *integ[2] = {"path", "whitted"};
    sb_image_stats_t st[2];
    for (int i = 0; i < 2; i++) {
        scene_t *s = floor_scene(i ? "sunsky_whitted.pbrt" : "sunsky_path.pbrt", integ[i], pfm);
        st[i] = sb_render_stats(s, 8, 512);
        scene_destroy(&s);
        print_message("%s: floor %.5f +- %.5f, per-sample variance %.4g\n", integ[i], st[i].mean,
                      st[i].se, st[i].var);
    }
    assert_true(fabs(st[0].mean - st[1].mean) <
                5 * sqrt(st[0].se * st[0].se + st[1].se * st[1].se));
    free(rgb);
}

/* ---- sphere lights: the cone ---- */

/* From a point outside a sphere light, every sampled direction hits the sphere, its reported
 * pdf is the pdf lights_pdf gives it, cos(theta) about the axis is uniform over
 * [cos theta_max, 1] (chi-square), and the pdf times the solid angle the sphere subtends
 * (estimated with uniform directions: the fraction that hit it, times 4 pi) is 1. */
static void test_sphere_cone(void **state)
{
    (void)state;
    scene_t *s = sb_load_text("Camera \"perspective\"\nWorldBegin\n"
                              "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [1 1 1]\n"
                              "Translate 0.5 3 1\nShape \"sphere\" \"float radius\" 0.7\n"
                              "AttributeEnd\n",
                              NULL);
    const vec3_t p = vec3_make(0, 0, 0), c = vec3_make(0.5, 3, 1);
    const double r = 0.7;
    vec3_t axis = vec3_normalize(vec3_sub(c, p));
    double d = vec3_length(vec3_sub(c, p));
    double cos_max = sqrt(1.0 - r * r / (d * d));
    enum { N = 200000, NB = 20 };
    double hist[NB] = {0}, pdf0 = 0;
    for (int i = 0; i < N; i++) {
        double u[4];
        rng_uniform4(13, (uint64_t)i, 0, 0, u);
        light_sample_t ls;
        assert_true(lights_sample(s, &(lights_at_t){p, {0, 0, 0}, 0}, u, &ls));
        /* the direction meets the sphere at the sampled point */
        vec3_t q = vec3_fma(p, ls.wi, ls.dist);
        assert_true(fabs(vec3_length(vec3_sub(q, c)) - r) < 1e-9);
        double b = vec3_dot(ls.wi, vec3_sub(c, p));
        double disc = b * b - (d * d - r * r);
        assert_true(disc >= -1e-12 && fabs(ls.dist - (b - sqrt(fmax(0, disc)))) < 1e-7);
        double lp = lights_pdf(s, &(lights_at_t){p, {0, 0, 0}, 0}, ls.light, ls.tri, ls.wi,
                               ls.p_light, ls.n_light);
        assert_true(fabs(lp - ls.pdf) <= 1e-12 * ls.pdf);
        pdf0 = ls.pdf;
        double ct = vec3_dot(ls.wi, axis);
        int k = (int)((ct - cos_max) / (1.0 - cos_max) * NB);
        hist[k < 0 ? 0 : k >= NB ? NB - 1 : k] += 1;
    }
    double chi2 = 0, e = (double)N / NB;
    for (int k = 0; k < NB; k++)
        chi2 += (hist[k] - e) * (hist[k] - e) / e;
    assert_true(chi2 < chi2_limit(NB - 1));
    /* The solid angle by brute force. */
    double hits = 0;
    const int M = 2000000;
    for (int i = 0; i < M; i++) {
        vec3_t w = sample_uniform_sphere(rng_uniform(17, (uint64_t)i, 0, 0),
                                         rng_uniform(17, (uint64_t)i, 0, 1));
        double b = vec3_dot(w, vec3_sub(c, p));
        hits += b > 0 && b * b - (d * d - r * r) >= 0;
    }
    double frac = hits / M, omega = 4 * PI * frac, omega_se = 4 * PI * sqrt(frac * (1 - frac) / M);
    print_message("sphere cone: pdf x solid angle %.5f +- %.5f, cos chi2 %.1f\n", pdf0 * omega,
                  pdf0 * omega_se, chi2);
    assert_true(fabs(pdf0 * omega - 1.0) < 5 * pdf0 * omega_se);
    scene_destroy(&s);
}

/* Irradiance from a sphere light on a surface point: cone sampling's estimate
 * E = mean(L cos / pdf) matches the analytic pi L (r / D)^2 cos(beta) (a sphere wholly above
 * the horizon acts as a point of intensity pi r^2 L), as uniform area sampling's does (its
 * far-side samples count 0), and its variance is lower: the ratio is printed. */
static void test_sphere_cone_variance(void **state)
{
    (void)state;
    const vec3_t c = vec3_make(0.5, 0.4, 2.0), n = vec3_make(0, 0, 1), p = vec3_make(0, 0, 0);
    const double r = 0.5, L = 1.0;
    char text[512];
    snprintf(text, sizeof text,
             "Camera \"perspective\"\nWorldBegin\nAttributeBegin\n"
             "AreaLightSource \"diffuse\" \"float L\" 1\nTranslate %g %g %g\n"
             "Shape \"sphere\" \"float radius\" %g\nAttributeEnd\n",
             c.x, c.y, c.z, r);
    scene_t *s = sb_load_text(text, NULL);
    double D = vec3_length(c), cosb = c.z / D;
    double want = PI * L * r * r / (D * D) * cosb;
    enum { N = 200000 };
    double m[2] = {0}, m2[2] = {0};
    for (int i = 0; i < N; i++) {
        double u[4];
        rng_uniform4(19, (uint64_t)i, 0, 0, u);
        light_sample_t ls;
        double f = 0;
        if (lights_sample(s, &(lights_at_t){p, {0, 0, 0}, 0}, u, &ls) &&
            vec3_dot(ls.n_light, ls.wi) < 0)
            f = L * fmax(0, vec3_dot(n, ls.wi)) / ls.pdf;
        m[0] += f;
        m2[0] += f * f;
        /* uniform area sampling, by hand */
        vec3_t q = vec3_fma(c, sample_uniform_sphere(u[2], u[3]), r);
        vec3_t dq = vec3_sub(q, p);
        double d2 = vec3_dot(dq, dq);
        vec3_t wi = vec3_scale(dq, 1 / sqrt(d2)), nq = vec3_normalize(vec3_sub(q, c));
        double cl = -vec3_dot(nq, wi);
        double g = cl > 0 ? L * fmax(0, vec3_dot(n, wi)) * cl * 4 * PI * r * r / d2 : 0;
        m[1] += g;
        m2[1] += g * g;
    }
    double mean[2], var[2];
    for (int k = 0; k < 2; k++) {
        mean[k] = m[k] / N;
        var[k] = m2[k] / N - mean[k] * mean[k];
        assert_true(fabs(mean[k] - want) < 5 * sqrt(var[k] / N));
    }
    print_message("sphere irradiance %.6f (analytic %.6f): cone variance %.4g, area %.4g, ratio "
                  "%.1f\n",
                  mean[0], want, var[0], var[1], var[1] / var[0]);
    assert_true(var[0] * 4 < var[1]);
    scene_destroy(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_equal_area_round_trip),
        cmocka_unit_test(test_equal_area_uniform),
        cmocka_unit_test(test_envmap_pdf),
        cmocka_unit_test(test_envmap_colour),
        cmocka_unit_test(test_pfm),
        cmocka_unit_test(test_constant_image_is_uniform),
        cmocka_unit_test(test_bright_texel),
        cmocka_unit_test(test_non_square_refused),
        cmocka_unit_test(test_latlong),
        cmocka_unit_test(test_illuminance_and_portal),
        cmocka_unit_test(test_compensated_pdf),
        cmocka_unit_test(test_compensated_uniform_falls_back),
        cmocka_unit_test(test_compensated_unbiased),
        cmocka_unit_test(test_compensated_render),
        cmocka_unit_test(test_sphere_cone),
        cmocka_unit_test(test_sphere_cone_variance),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_setup, testutil_scratch_teardown);
}
