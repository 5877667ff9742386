/* image_png: byte-exact round trips at odd sizes, the sRGB/gAMA/cHRM chunks checked by walking
 * the file's chunks against the values of the PNG specification, expansion of grey, grey+alpha,
 * palette and 16-bit files written by libpng's simplified API, and errors (truncated file, not
 * a PNG, failed write keeping the old file). The sanitizer build checks that the longjmp error
 * paths leak nothing. */
#define _POSIX_C_SOURCE 200809L

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
/* cmocka needs the four headers above first */
#include <cmocka.h>

#include <png.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "files_testutil.h"
#include "image_png.h"

/* A byte pattern that exercises every value and differs between neighbours, so a swapped
 * channel, row or column shows. */
static uint8_t *make_pixels(int width, int height, uint32_t seed)
{
    size_t n = (size_t)width * (size_t)height * 3;
    uint8_t *p = malloc(n);
    assert_non_null(p);
    uint32_t s = seed;
    for (size_t i = 0; i < n; i++) {
        s = s * 1664525u + 1013904223u; /* Numerical Recipes LCG */
        p[i] = (uint8_t)(s >> 24);
    }
    return p;
}

static void roundtrip(int width, int height)
{
    const char *path = testutil_scratch("rt.png");
    uint8_t *rgb = make_pixels(width, height, (uint32_t)(width * 1000 + height));
    err_t err = {{0}};
    if (image_png_write_rgb(path, width, height, rgb, &err) != 0)
        fail_msg("write %dx%d: %s", width, height, err.msg);
    char tmp[160];
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    assert_int_equal(access(tmp, F_OK), -1); /* renamed into place */
    image_png_t *img = image_png_read(path, &err);
    if (img == NULL)
        fail_msg("read %dx%d: %s", width, height, err.msg);
    assert_int_equal(image_png_width(img), width);
    assert_int_equal(image_png_height(img), height);
    assert_int_equal(image_png_channels(img), 3);
    const uint8_t *rgba = image_png_rgba(img);
    for (size_t p = 0; p < (size_t)width * (size_t)height; p++) {
        assert_memory_equal(&rgba[p * 4], &rgb[p * 3], 3);
        assert_int_equal(rgba[p * 4 + 3], 255);
    }
    image_png_destroy(&img);
    assert_null(img);
    free(rgb);
}

static void test_roundtrip(void **state)
{
    (void)state;
    static const int sizes[][2] = {{1, 1}, {17, 33}, {33, 17}, {1, 100}, {100, 1}, {64, 48}};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++)
        roundtrip(sizes[i][0], sizes[i][1]);
}

static uint32_t be32(const unsigned char *p)
{
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | (uint32_t)p[3];
}

/* Walks the chunks (PNG spec section 5.3: length, type, data, CRC) and checks the colour
 * chunks against the specification's sRGB values (section 11.3.3.5: gAMA 45455; cHRM white
 * 0.3127 0.3290, red 0.64 0.33, green 0.30 0.60, blue 0.15 0.06, times 100000). */
static void test_srgb_chunks(void **state)
{
    (void)state;
    const char *path = testutil_scratch("chunks.png");
    uint8_t *rgb = make_pixels(5, 3, 1);
    err_t err;
    assert_int_equal(image_png_write_rgb(path, 5, 3, rgb, &err), 0);
    free(rgb);
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    unsigned char buf[4096];
    size_t len = fread(buf, 1, sizeof buf, f);
    fclose(f);
    static const unsigned char signature[8] = {137, 80, 78, 71, 13, 10, 26, 10};
    assert_true(len > 8);
    assert_memory_equal(buf, signature, 8);
    bool seen_srgb = false, seen_gama = false, seen_chrm = false, seen_idat = false;
    size_t pos = 8;
    int index = 0;
    while (pos + 12 <= len) {
        uint32_t n = be32(buf + pos);
        const unsigned char *type = buf + pos + 4, *data = buf + pos + 8;
        assert_true(pos + 12 + n <= len);
        if (index == 0) {
            assert_memory_equal(type, "IHDR", 4);
            assert_int_equal(be32(data), 5);     /* width */
            assert_int_equal(be32(data + 4), 3); /* height */
            assert_int_equal(data[8], 8);        /* bit depth */
            assert_int_equal(data[9], 2);        /* colour type: truecolour */
        }
        if (memcmp(type, "sRGB", 4) == 0) {
            assert_int_equal(n, 1);
            assert_int_equal(data[0], 0); /* perceptual */
            assert_false(seen_idat);      /* colour chunks precede the image data */
            seen_srgb = true;
        }
        if (memcmp(type, "gAMA", 4) == 0) {
            assert_int_equal(n, 4);
            assert_int_equal(be32(data), 45455);
            assert_false(seen_idat);
            seen_gama = true;
        }
        if (memcmp(type, "cHRM", 4) == 0) {
            static const uint32_t want[8] = {31270, 32900, 64000, 33000, 30000, 60000, 15000, 6000};
            assert_int_equal(n, 32);
            for (int i = 0; i < 8; i++)
                assert_int_equal(be32(data + 4 * i), want[i]);
            assert_false(seen_idat);
            seen_chrm = true;
        }
        if (memcmp(type, "IDAT", 4) == 0)
            seen_idat = true;
        pos += 12 + n;
        index++;
        if (memcmp(type, "IEND", 4) == 0)
            break;
    }
    assert_int_equal(pos, len); /* IEND is the last chunk */
    assert_true(seen_srgb && seen_gama && seen_chrm && seen_idat);
}

/* Files in other colour types, written by libpng's simplified API from known samples. */
static void write_simplified(const char *path, png_uint_32 format, int width, int height,
                             const void *pixels, const void *colormap, int colormap_entries)
{
    png_image image;
    memset(&image, 0, sizeof image);
    image.version = PNG_IMAGE_VERSION;
    image.format = format;
    image.width = (png_uint_32)width;
    image.height = (png_uint_32)height;
    image.colormap_entries = (png_uint_32)colormap_entries;
    if (!png_image_write_to_file(&image, path, 0, pixels, 0, colormap))
        fail_msg("libpng could not write the test file: %s", image.message);
    png_image_free(&image);
}

static void test_other_colour_types(void **state)
{
    (void)state;
    const char *path;
    err_t err;

    path = testutil_scratch("grey.png");
    const uint8_t grey[6] = {0, 1, 127, 128, 254, 255};
    write_simplified(path, PNG_FORMAT_GRAY, 3, 2, grey, NULL, 0);
    image_png_t *img = image_png_read(path, &err);
    if (img == NULL)
        fail_msg("%s", err.msg);
    assert_int_equal(image_png_channels(img), 1);
    for (int p = 0; p < 6; p++) {
        const uint8_t want[4] = {grey[p], grey[p], grey[p], 255};
        assert_memory_equal(&image_png_rgba(img)[p * 4], want, 4);
    }
    image_png_destroy(&img);

    path = testutil_scratch("grey_alpha.png");
    const uint8_t ga[4] = {10, 0, 200, 255}; /* two pixels: (grey, alpha) */
    write_simplified(path, PNG_FORMAT_GA, 2, 1, ga, NULL, 0);
    img = image_png_read(path, &err);
    assert_non_null(img);
    assert_int_equal(image_png_channels(img), 2);
    const uint8_t want_ga[8] = {10, 10, 10, 0, 200, 200, 200, 255};
    assert_memory_equal(image_png_rgba(img), want_ga, 8);
    image_png_destroy(&img);

    path = testutil_scratch("rgba.png");
    const uint8_t rgba[8] = {1, 2, 3, 4, 250, 251, 252, 253};
    write_simplified(path, PNG_FORMAT_RGBA, 1, 2, rgba, NULL, 0);
    img = image_png_read(path, &err);
    assert_non_null(img);
    assert_int_equal(image_png_channels(img), 4);
    assert_memory_equal(image_png_rgba(img), rgba, 8);
    image_png_destroy(&img);

    /* A palette with transparency: written as PLTE + tRNS, read back as RGBA. */
    path = testutil_scratch("palette.png");
    const uint8_t colormap[3 * 4] = {255, 0, 0, 255, 0, 255, 0, 128, 0, 0, 255, 0};
    const uint8_t indices[4] = {0, 1, 2, 1};
    write_simplified(path, PNG_FORMAT_RGBA | PNG_FORMAT_FLAG_COLORMAP, 4, 1, indices, colormap, 3);
    img = image_png_read(path, &err);
    assert_non_null(img);
    assert_int_equal(image_png_channels(img), 4);
    for (int p = 0; p < 4; p++)
        assert_memory_equal(&image_png_rgba(img)[p * 4], &colormap[indices[p] * 4], 4);
    image_png_destroy(&img);

    /* 16-bit linear grey: the reader keeps the high byte (png_set_strip_16). */
    path = testutil_scratch("grey16.png");
    const uint16_t g16[3] = {0x0000, 0xABCD, 0xFFFF};
    write_simplified(path, PNG_FORMAT_LINEAR_Y, 3, 1, g16, NULL, 0);
    img = image_png_read(path, &err);
    assert_non_null(img);
    assert_int_equal(image_png_channels(img), 1);
    const uint8_t want16[12] = {0, 0, 0, 255, 0xAB, 0xAB, 0xAB, 255, 0xFF, 0xFF, 0xFF, 255};
    assert_memory_equal(image_png_rgba(img), want16, 12);
    image_png_destroy(&img);
}

static void test_truncated(void **state)
{
    (void)state;
    const char *path = testutil_scratch("whole.png"), *cut = testutil_scratch("cut.png");
    /* Pseudo-random pixels barely compress, so the file is long and a cut lands in IDAT. */
    uint8_t *rgb = make_pixels(64, 64, 7);
    err_t err;
    assert_int_equal(image_png_write_rgb(path, 64, 64, rgb, &err), 0);
    free(rgb);
    struct stat st;
    assert_int_equal(stat(path, &st), 0);
    assert_true(st.st_size > 64 * 64 * 3 / 2);

    /* In the image data, just before IEND's CRC, inside IHDR. */
    const long keep[] = {(long)st.st_size / 2, (long)st.st_size - 1, 20};
    for (size_t i = 0; i < sizeof keep / sizeof keep[0]; i++) {
        testutil_truncate_copy(path, cut, keep[i]);
        image_png_t *img = image_png_read(cut, &err);
        if (img != NULL)
            fail_msg("a file cut to %ld of %ld bytes was read", keep[i], (long)st.st_size);
        assert_non_null(strstr(err.msg, cut));
        if (strstr(err.msg, "truncated") == NULL)
            fail_msg("cut to %ld bytes: message does not say truncated: %s", keep[i], err.msg);
    }
    testutil_truncate_copy(path, cut, 5);
    assert_null(image_png_read(cut, &err));
    assert_non_null(strstr(err.msg, "not a PNG file"));
}

static void test_not_a_png(void **state)
{
    (void)state;
    const char *path = testutil_scratch("text.png");
    testutil_write_text(path, "this is not an image at all\n", 0644);
    err_t err;
    assert_null(image_png_read(path, &err));
    assert_non_null(strstr(err.msg, path));
    assert_non_null(strstr(err.msg, "not a PNG file"));

    /* A PNG signature followed by a chunk whose CRC is wrong. */
    path = testutil_scratch("badcrc.png");
    uint8_t *rgb = make_pixels(4, 4, 3);
    assert_int_equal(image_png_write_rgb(path, 4, 4, rgb, &err), 0);
    free(rgb);
    FILE *f = fopen(path, "r+b");
    assert_non_null(f);
    assert_int_equal(fseek(f, 16, SEEK_SET), 0); /* IHDR width */
    assert_int_equal(fputc(0x7f, f), 0x7f);
    assert_int_equal(fclose(f), 0);
    assert_null(image_png_read(path, &err));
    assert_non_null(strstr(err.msg, path));

    path = testutil_scratch("missing.png");
    assert_null(image_png_read(path, &err));
    assert_non_null(strstr(err.msg, "cannot open"));
}

static void test_write_errors(void **state)
{
    (void)state;
    char tmp[160];
    const char *path = testutil_scratch("keep.png");
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    const uint8_t old_px[3] = {10, 20, 30}, new_px[3] = {99, 99, 99};
    err_t err;
    assert_int_equal(image_png_write_rgb(path, 0, 1, old_px, &err), -1);
    assert_int_equal(image_png_write_rgb(path, 1, 1, NULL, &err), -1);
    assert_int_equal(image_png_write_rgb("/nonexistent-dir/x.png", 1, 1, old_px, &err), -1);
    assert_non_null(strstr(err.msg, "cannot create"));

    /* A failed write leaves the previous file: PATH.tmp is a directory, so it cannot be
     * created, and PATH keeps the old pixels. */
    assert_int_equal(image_png_write_rgb(path, 1, 1, old_px, &err), 0);
    assert_int_equal(mkdir(tmp, 0700), 0);
    assert_int_equal(image_png_write_rgb(path, 1, 1, new_px, &err), -1);
    assert_int_equal(rmdir(tmp), 0);
    image_png_t *img = image_png_read(path, &err);
    assert_non_null(img);
    assert_memory_equal(image_png_rgba(img), old_px, 3);
    image_png_destroy(&img);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_roundtrip),          cmocka_unit_test(test_srgb_chunks),
        cmocka_unit_test(test_other_colour_types), cmocka_unit_test(test_truncated),
        cmocka_unit_test(test_not_a_png),          cmocka_unit_test(test_write_errors),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_setup, testutil_scratch_teardown);
}
