/* Tests for image textures (pbrt-v4 ImageTexture): each reader on a small file made here (PNG
 * through libpng, TGA, Radiance HDR and PFM written as bytes, OpenEXR through OpenEXRCore),
 * the encodings (the IEC 61966-2-1 sRGB curve: 128/255 decodes to 0.2159), the wrap modes
 * (repeat, black, clamp, octahedral sphere) at texel centres outside [0, 1], trilinear
 * filtering between MIP levels whose values are worked out by hand, the per-texel spectrum
 * reproducing its colour (XYZ under D65 within 1 % of the colour's own), and the load time
 * of a 1024x1024 PNG of distinct colours (printed, beside the per-texel fit it replaces). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cie.h"
#include "clock.h"
#include "colour.h"
#include "image_exr.h"
#include "image_png.h"
#include "scene_builders.h"
#include "spectrum.h"
#include "texture.h"

static char dir[] = "/tmp/prismfarm-teximg-XXXXXX";

static const char *in_dir(const char *name)
{
    static char buf[4][256];
    static int k;
    k = (k + 1) % 4;
    snprintf(buf[k], sizeof buf[k], "%s/%s", dir, name);
    return buf[k];
}

static void write_bytes(const char *path, const void *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, n, f), n);
    fclose(f);
}

/* The value of a one-texture scene's material 1 reflectance (the spectrum texture "t" made
 * from the given Texture line's file and extra parameters) at (u, v). */
static scene_t *load_tex(const char *type, const char *path, const char *extra)
{
    char text[2048];
    snprintf(text, sizeof text,
             "WorldBegin\nTexture \"t\" \"%s\" \"imagemap\" \"string filename\" \"%s\" %s\n"
             "Material \"diffuse\" \"texture reflectance\" \"t\"\n",
             type, path, extra ? extra : "");
    if (!strcmp(type, "float"))
        snprintf(text, sizeof text,
                 "WorldBegin\nTexture \"t\" \"float\" \"imagemap\" \"string filename\" \"%s\" %s\n"
                 "Texture \"m\" \"spectrum\" \"mix\" \"float tex1\" 0 \"float tex2\" 1 \"texture amount\" \"t\"\n"
                 "Material \"diffuse\" \"texture reflectance\" \"m\"\n",
                 path, extra ? extra : "");
    return sb_load_text(text, NULL);
}

static double at(const scene_t *s, double u, double v, double lambda)
{
    return texture_eval(s->materials[1].reflectance, u, v, lambda);
}

/* sRGB 128/255 = 0.50196: ((0.50196 + 0.055) / 1.055)^2.4 = 0.21586 (IEC 61966-2-1). */
#define SRGB_128 0.21586

static void test_png_encodings(void **state)
{
    (void)state;
    err_t err;
    uint8_t rgb[6] = {128, 128, 128, 64, 64, 64};
    const char *p = in_dir("a.png");
    assert_int_equal(image_png_write_rgb(p, 2, 1, rgb, &err), 0);
    scene_t *s = load_tex("spectrum", p, NULL);
    assert_true(fabs(at(s, 0.25, 0.5, 550) - SRGB_128) < 1e-4);
    scene_destroy(&s);
    s = load_tex("spectrum", p, "\"string encoding\" \"linear\"");
    assert_true(fabs(at(s, 0.25, 0.5, 500) - 128 / 255.0) < 1e-6);
    assert_true(fabs(at(s, 0.75, 0.5, 500) - 64 / 255.0) < 1e-6);
    scene_destroy(&s);
    s = load_tex("spectrum", p, "\"string encoding\" \"gamma 2\"");
    assert_true(fabs(at(s, 0.75, 0.5, 500) - pow(64 / 255.0, 2)) < 1e-6);
    scene_destroy(&s);
    /* scale and invert (pbrt-v4: invert ? 1 - scale v : scale v, clamped) */
    s = load_tex("spectrum", p, "\"string encoding\" \"linear\" \"float scale\" 2 \"bool invert\" true");
    assert_true(fabs(at(s, 0.75, 0.5, 500) - (1 - 128 / 255.0)) < 1e-6);
    scene_destroy(&s);
}

static void test_tga_hdr_pfm_exr(void **state)
{
    (void)state;
    /* TGA type 2 (uncompressed true colour), 2x1, 24 bits, rows bottom-up (descriptor 0),
     * pixels stored B, G, R: left (R, G, B) = (128, 128, 128), right (255, 0, 0). */
    uint8_t tga[18 + 6] = {0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2, 0, 1, 0, 24, 0,
                           128, 128, 128, 0, 0, 255};
    write_bytes(in_dir("a.tga"), tga, sizeof tga);
    scene_t *s = load_tex("spectrum", in_dir("a.tga"), NULL);
    assert_true(fabs(at(s, 0.25, 0.5, 600) - SRGB_128) < 1e-4);
    scene_destroy(&s);
    /* Radiance RGBE, 2x1 flat (too narrow for run-length): (128, 64, 32, 129) is
     * (128, 64, 32) 2^(129 - 136) = (1, 0.5, 0.25); (128, 128, 128, 128) is grey 0.5. Linear:
     * "encoding" does not apply to float files. A float texture reads the channel mean. */
    const char hdr_head[] = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n";
    uint8_t hdr[sizeof hdr_head - 1 + 8];
    memcpy(hdr, hdr_head, sizeof hdr_head - 1);
    uint8_t px[8] = {128, 64, 32, 129, 128, 128, 128, 128};
    memcpy(hdr + sizeof hdr_head - 1, px, 8);
    write_bytes(in_dir("a.hdr"), hdr, sizeof hdr);
    s = load_tex("float", in_dir("a.hdr"), "\"string encoding\" \"sRGB\"");
    assert_true(fabs(at(s, 0.25, 0.5, 600) - 1.75 / 3) < 1e-6);
    assert_true(fabs(at(s, 0.75, 0.5, 600) - 0.5) < 1e-6);
    scene_destroy(&s);
    /* PFM "Pf" (grey), little-endian (scale -1), 1x2, bottom row first: bottom 0.25, top 0.75. */
    const char pfm_head[] = "Pf\n1 2\n-1.0\n";
    uint8_t pfm[sizeof pfm_head - 1 + 8];
    memcpy(pfm, pfm_head, sizeof pfm_head - 1);
    float f[2] = {0.25f, 0.75f};
    memcpy(pfm + sizeof pfm_head - 1, f, 8);
    write_bytes(in_dir("a.pfm"), pfm, sizeof pfm);
    s = load_tex("spectrum", in_dir("a.pfm"), NULL);
    /* t = 1 - v: v = 0.25 is the bottom row. */
    assert_true(fabs(at(s, 0.5, 0.25, 550) - 0.25) < 1e-6);
    assert_true(fabs(at(s, 0.5, 0.75, 550) - 0.75) < 1e-6);
    scene_destroy(&s);
    /* OpenEXR RGBA: a float texture reads the alpha when it is not all 1 (pbrt-v4
     * MIPMap::Bilerp<Float>). */
    err_t err;
    float rgba[8] = {0.2f, 0.2f, 0.2f, 0.0f, 0.9f, 0.9f, 0.9f, 1.0f};
    assert_int_equal(image_exr_write_rgb(in_dir("a.exr"), 2, 1, rgba, 4, NULL, &err), 0);
    s = load_tex("float", in_dir("a.exr"), NULL);
    assert_true(fabs(at(s, 0.25, 0.5, 550) - 0.0) < 1e-6);
    assert_true(fabs(at(s, 0.75, 0.5, 550) - 1.0) < 1e-6);
    scene_destroy(&s);
    s = load_tex("spectrum", in_dir("a.exr"), NULL);
    assert_true(fabs(at(s, 0.25, 0.5, 550) - 0.2) < 1e-6);
    scene_destroy(&s);
}

/* A grey w x h texture with value(x, y) = vals[y * w + x] (row 0 at the top). */
static texture_t *grey(const double *vals, int w, int h, texture_wrap_t wrap, texture_filter_t filter)
{
    float *rgb = malloc((size_t)w * h * 3 * sizeof *rgb);
    for (int i = 0; i < w * h; i++)
        rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = (float)vals[i];
    texture_image_opts_t o = texture_image_opts_default();
    o.wrap = wrap;
    o.filter = filter;
    err_t err;
    texture_t *t = texture_new_image(rgb, w, h, &o, &err);
    free(rgb);
    assert_non_null(t);
    return t;
}

static void test_wrap_modes(void **state)
{
    (void)state;
    /* 2x2: top row 0.1 0.2, bottom row 0.3 0.4. Texel centres: u 0.25, 0.75; v 0.75 is the
     * top row (t = 1 - v). u = -0.25 is the centre of column -1, u = 1.25 of column 2. */
    const double v4[4] = {0.1, 0.2, 0.3, 0.4};
    texture_t *r = grey(v4, 2, 2, TEXTURE_WRAP_REPEAT, TEXTURE_FILTER_BILINEAR);
    texture_t *b = grey(v4, 2, 2, TEXTURE_WRAP_BLACK, TEXTURE_FILTER_BILINEAR);
    texture_t *c = grey(v4, 2, 2, TEXTURE_WRAP_CLAMP, TEXTURE_FILTER_BILINEAR);
    texture_t *o = grey(v4, 2, 2, TEXTURE_WRAP_OCTAHEDRAL_SPHERE, TEXTURE_FILTER_POINT);
    const double e = 1e-6;
    assert_true(fabs(texture_eval(r, 0.25, 0.75, 550) - 0.1) < e);
    assert_true(fabs(texture_eval(r, -0.25, 0.75, 550) - 0.2) < e);  /* column -1 = 1 */
    assert_true(fabs(texture_eval(r, 1.25, 0.25, 550) - 0.3) < e);   /* column 2 = 0 */
    assert_true(fabs(texture_eval(b, -0.25, 0.75, 550) - 0.0) < e);
    assert_true(fabs(texture_eval(b, 0.0, 0.75, 550) - 0.05) < e);   /* half black, half 0.1 */
    assert_true(fabs(texture_eval(c, -0.25, 0.75, 550) - 0.1) < e);
    assert_true(fabs(texture_eval(c, 1.75, 0.25, 550) - 0.4) < e);
    assert_true(fabs(texture_eval(c, 0.5, 0.75, 550) - 0.15) < e);   /* between 0.1 and 0.2 */
    /* Octahedral sphere: column -1 of the top row folds onto column 0 of the bottom row. */
    assert_true(fabs(texture_eval(o, -0.25, 0.75, 550) - 0.3) < e);
    assert_true(fabs(texture_eval(o, 0.75, 1.25, 550) - 0.1) < e);   /* row -1, column 1 -> row 0, column 0 */
    texture_destroy(&r);
    texture_destroy(&b);
    texture_destroy(&c);
    texture_destroy(&o);
}

/* texture_eval_lanes gives texture_eval_at's bits at every lane: coloured texels (uplifted
 * spectra, not flat), each wrap and filter, on and off the texels' grid and outside [0, 1]^2,
 * alone and under a scale (whose lanes it multiplies itself). */
static void test_lanes_same_bits(void **state)
{
    (void)state;
    const float rgb[3 * 6] = {0.9f, 0.1f, 0.1f, 0.1f, 0.8f, 0.2f, 0.2f, 0.3f, 0.9f,
                              0.5f, 0.5f, 0.0f, 0.0f, 0.0f, 0.0f, 1.0f, 1.0f, 1.0f};
    const double lambda[5] = {380.0, 451.5, 538.25, 612.0, 779.0};
    err_t err;
    texture_t *half = texture_new_constant_value(0.5, &err);
    assert_non_null(half);
    for (int wrap = TEXTURE_WRAP_REPEAT; wrap <= TEXTURE_WRAP_OCTAHEDRAL_SPHERE; wrap++) {
        for (int filter = TEXTURE_FILTER_POINT; filter <= TEXTURE_FILTER_TRILINEAR; filter++) {
            texture_image_opts_t o = texture_image_opts_default();
            o.wrap = (texture_wrap_t)wrap;
            o.filter = (texture_filter_t)filter;
            o.threads = 1;
            texture_t *img = texture_new_image(rgb, 3, 2, &o, &err);
            assert_non_null(img);
            texture_t *sc = texture_new_scale(img, half, &err);
            assert_non_null(sc);
            for (int k = 0; k < 49; k++) {
                const texture_point_t at = {.u = -0.4 + 0.037 * k, .v = 1.3 - 0.041 * k};
                for (int w = 0; w < 2; w++) {
                    const texture_t *t = w ? sc : img;
                    double out[5];
                    texture_eval_lanes(t, &at, lambda, 5, out);
                    for (int j = 0; j < 5; j++) {
                        double one = texture_eval_at(t, &at, lambda[j]);
                        assert_memory_equal(&out[j], &one, sizeof one);
                    }
                }
            }
            texture_destroy(&sc);
            texture_destroy(&img);
        }
    }
    texture_destroy(&half);
}

static void test_trilinear_levels(void **state)
{
    (void)state;
    /* 4x4 with value x / 4 by column: level 1 (2x2) holds 0.125 and 0.625, level 2 (1x1)
     * 0.375. At u = 0.125 (s), v = 0.5: level 0 reads column 0 exactly (0); level 1 sits a
     * quarter texel left of its column 0, so 0.75 0.125 + 0.25 0.625 (repeat) = 0.25. pbrt-v4's
     * level for width w is 2 + log2 w: w 1/4 -> level 0; 1/2 -> 1 (0.25); 2^-1/2 -> 1.5, the
     * mean of levels 1 and 2 (0.3125); 1 -> the top level (0.375). */
    double v[16];
    for (int i = 0; i < 16; i++)
        v[i] = (i % 4) / 4.0;
    texture_t *t = grey(v, 4, 4, TEXTURE_WRAP_REPEAT, TEXTURE_FILTER_TRILINEAR);
    const double e = 1e-6;
    assert_true(fabs(texture_eval_width(t, 0.125, 0.5, 0.25, 550) - 0.0) < e);
    assert_true(fabs(texture_eval_width(t, 0.125, 0.5, 0.5, 550) - 0.25) < e);
    assert_true(fabs(texture_eval_width(t, 0.125, 0.5, sqrt(0.5), 550) - 0.3125) < e);
    assert_true(fabs(texture_eval_width(t, 0.125, 0.5, 1.0, 550) - 0.375) < e);
    assert_true(fabs(texture_eval(t, 0.125, 0.5, 550) - 0.0) < e); /* no width: level 0 */
    texture_destroy(&t);
}

/* XYZ under D65 (white Y = 1) of a texture's spectrum at (u, v), 1 nm over 360-830 nm. */
static xyz_t tex_xyz(const texture_t *t, double u, double v)
{
    double x = 0, y = 0, z = 0, norm = 0;
    for (int l = 360; l <= 830; l++) {
        double s = texture_eval(t, u, v, l), d = cie_d65_eval(l);
        xyz_t c = cie_cmf_eval(l);
        x += s * d * c.x;
        y += s * d * c.y;
        z += s * d * c.z;
        norm += d * c.y;
    }
    return (xyz_t){x / norm, y / norm, z / norm};
}

static void test_uplift_reproduces_rgb(void **state)
{
    (void)state;
    const float cols[][3] = {{0.8f, 0.2f, 0.1f}, {0.1f, 0.5f, 0.9f}, {0.3f, 0.3f, 0.6f},
                             {0.05f, 0.9f, 0.05f}, {0.9f, 0.9f, 0.1f}, {0.5f, 0.5f, 0.5f},
                             {0.7f, 0.05f, 0.6f}, {0.02f, 0.03f, 0.01f}};
    int n = (int)(sizeof cols / sizeof cols[0]);
    float *rgb = malloc((size_t)n * 3 * sizeof *rgb);
    memcpy(rgb, cols, sizeof cols);
    texture_image_opts_t o = texture_image_opts_default();
    o.filter = TEXTURE_FILTER_POINT;
    err_t err;
    texture_t *t = texture_new_image(rgb, n, 1, &o, &err);
    assert_non_null(t);
    for (int i = 0; i < n; i++) {
        xyz_t got = tex_xyz(t, (i + 0.5) / n, 0.5);
        xyz_t want = colour_linear_srgb_to_xyz((rgb_t){cols[i][0], cols[i][1], cols[i][2]});
        double scale = fmax(want.x, fmax(want.y, want.z));
        double d = fmax(fabs(got.x - want.x), fmax(fabs(got.y - want.y), fabs(got.z - want.z)));
        printf("texel (%.2f %.2f %.2f): XYZ off by %.3f %% of its largest\n", cols[i][0], cols[i][1],
               cols[i][2], 100 * d / scale);
        assert_true(d < 0.01 * scale);
    }
    texture_destroy(&t);
    free(rgb);
}

static void test_load_time_1024(void **state)
{
    (void)state;
    /* Distinct colours everywhere (a hash), so that a per-texel fit would refit every texel. */
    int w = 1024, h = 1024;
    uint8_t *px = malloc((size_t)w * h * 3);
    uint32_t z = 12345;
    for (size_t i = 0; i < (size_t)w * h * 3; i++) {
        z = z * 1664525u + 1013904223u;
        px[i] = (uint8_t)(z >> 24);
    }
    err_t err;
    const char *p = in_dir("big.png");
    assert_int_equal(image_png_write_rgb(p, w, h, px, &err), 0);
    free(px);
    double t0 = clock_now_s();
    scene_t *s = load_tex("spectrum", p, NULL);
    double load = clock_now_s() - t0;
    scene_destroy(&s);
    /* What the load cost before: one Jakob-Hanika fit per texel (timed on 200 colours). */
    t0 = clock_now_s();
    for (int i = 0; i < 200; i++) {
        spectrum_sigmoid_t fit;
        z = z * 1664525u + 1013904223u;
        rgb_t c = {(z >> 8 & 255) / 255.0, (z >> 16 & 255) / 255.0, (z >> 24) / 255.0};
        assert_int_equal(spectrum_sigmoid_fit(c, &fit, &err), 0);
    }
    double per_fit = (clock_now_s() - t0) / 200;
    printf("1024x1024 PNG texture: loaded in %.3f s (a fit per texel would take %.1f s: %.0f us a texel)\n",
           load, per_fit * w * h, per_fit * 1e6);
    assert_true(load < 10.0); /* a sanitizer build on two busy cores stays far below */
}

static int setup(void **state)
{
    (void)state;
    return mkdtemp(dir) ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    const char *names[] = {"a.png", "a.tga", "a.hdr", "a.pfm", "a.exr", "big.png"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        unlink(in_dir(names[i]));
    return rmdir(dir);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_png_encodings),  cmocka_unit_test(test_tga_hdr_pfm_exr),
        cmocka_unit_test(test_wrap_modes),     cmocka_unit_test(test_lanes_same_bits),
        cmocka_unit_test(test_trilinear_levels),
        cmocka_unit_test(test_uplift_reproduces_rgb), cmocka_unit_test(test_load_time_1024),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
