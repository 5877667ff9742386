/* image_exr: bit-exact float32 round trips, the spectral layout's channel names checked against
 * the reference regular expression of Fichet, Pacanowski & Wilkie (JCGT 2021), unit conversions
 * of channel names, a hand-assembled HALF file built from the OpenEXR file-layout document,
 * files re-encoded by the OpenEXR C++ tools (exrheader, exrmaketiled) and error messages. */
#define _GNU_SOURCE /* unshare and mount, for the full tmpfs of diskfull_testutil.h */

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
/* cmocka needs the four headers above first */
#include <cmocka.h>

#include <float.h>
#include <math.h>
#include <openexr.h>
#include <regex.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "diskfull_testutil.h"
#include "files_testutil.h"
#include "image_exr.h"

/* The layout's reference pattern (paper section 3, reference code's channelType), with the
 * ECMAScript \d written as the POSIX class [0-9]. */
static const char *const LAYOUT_REGEX =
    "^((S([0-3]))|T)\\.([0-9]*,?[0-9]*([Ee][+-]?[0-9]+)?)(Y|Z|E|P|T|G|M|k|h|da|d|c|m|u|n|p)?"
    "(m|Hz)$";

static bool matches_layout_regex(const char *name)
{
    regex_t re;
    assert_int_equal(regcomp(&re, LAYOUT_REGEX, REG_EXTENDED | REG_NOSUB), 0);
    bool ok = regexec(&re, name, 0, NULL, 0) == 0;
    regfree(&re);
    return ok;
}

/* Deterministic values spanning what float32 holds and half does not: 1e30 and 1e-30 (half
 * overflows above 65504 and flushes below 6e-8), a float32 subnormal, FLT_MAX, negatives. */
static float test_value(size_t i)
{
    static const float special[] = {1e30f, 1e-30f,   1e-40f,      FLT_MAX, -2.5f,
                                    0.0f,  65505.0f, 3.14159265f, -1e-30f, 123456.789f};
    size_t n = sizeof special / sizeof special[0];
    if (i % 3 == 0)
        return special[(i / 3) % n];
    return (float)((double)i * 0.001 - 7.0);
}

static float *make_values(size_t count, size_t offset)
{
    float *v = malloc(count * sizeof *v);
    assert_non_null(v);
    for (size_t i = 0; i < count; i++)
        v[i] = test_value(i + offset);
    return v;
}

static bool path_exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

/* ---------------------------------------------------------------------------------------- */

static void test_channel_name_format(void **state)
{
    (void)state;
    static const struct {
        double nm;
        const char *name;
    } cases[] = {
        {550.0, "S0.550,000000nm"},   /* the example of Fichet et al. 2021 (docs/core.md) */
        {390.625, "S0.390,625000nm"}, /* bucket 0 of 16 over 380-720 nm */
        {1000.0, "S0.1000,000000nm"},
        {0.5, "S0.0,500000nm"},
        {383.7777777777778, "S0.383,777778nm"}, /* rounds to 6 decimals like printf */
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char buf[IMAGE_EXR_CHANNEL_NAME_MAX];
        err_t err;
        assert_int_equal(image_exr_format_channel_name(cases[i].nm, buf, sizeof buf, &err), 0);
        assert_string_equal(buf, cases[i].name);
        assert_true(matches_layout_regex(buf));
    }
    char buf[IMAGE_EXR_CHANNEL_NAME_MAX];
    err_t err;
    assert_int_equal(image_exr_format_channel_name(NAN, buf, sizeof buf, &err), -1);
    assert_int_equal(image_exr_format_channel_name(-1.0, buf, sizeof buf, &err), -1);
    assert_int_equal(image_exr_format_channel_name(1e30, buf, sizeof buf, &err), -1);
    assert_non_null(strstr(err.msg, "longer than"));
}

/* Expected wavelengths are computed by hand from the SI prefixes and, for frequencies, from
 * lambda = c / f with c = 299792458 m/s (exact by the SI definition of the metre). */
static void test_channel_name_parse(void **state)
{
    (void)state;
    static const struct {
        const char *name;
        int stokes;
        double nm;
        double tol;
    } good[] = {
        {"S0.550,000000nm", 0, 550.0, 0.0},
        {"S0.550nm", 0, 550.0, 0.0},
        {"S0.550,nm", 0, 550.0, 0.0},
        {"S0.,5nm", 0, 0.5, 0.0},
        {"S0.5,5E2nm", 0, 550.0, 1e-12},
        {"S0.5,5e-7m", 0, 550.0, 1e-9},
        {"S0.0,55um", 0, 550.0, 1e-9},
        {"S0.5500Ym", 0, 5.5e36, 5.5e36 * 1e-15}, /* yottametres: scale only */
        {"S0.5,5dam", 0, 5.5e10, 1e-3},           /* 5.5 decametres */
        {"S0.550000pm", 0, 550.0, 1e-9},
        /* 299792458 / 550e-9 Hz = 545.07719636... THz; 10 significant digits keep the
         * wavelength within 550 * 1e-12 nm. */
        {"S0.545,0771963636THz", 0, 550.0, 1e-6},
        {"S3.700nm", 3, 700.0, 0.0},
        {"T.400,5nm", -1, 400.5, 1e-12},
    };
    for (size_t i = 0; i < sizeof good / sizeof good[0]; i++) {
        int stokes = 99;
        double nm = 0.0;
        assert_true(matches_layout_regex(good[i].name));
        if (!image_exr_parse_channel_name(good[i].name, &stokes, &nm))
            fail_msg("'%s' should parse", good[i].name);
        assert_int_equal(stokes, good[i].stokes);
        if (fabs(nm - good[i].nm) > good[i].tol)
            fail_msg("'%s' gave %.17g nm, expected %.17g", good[i].name, nm, good[i].nm);
    }
    /* Names the reference pattern rejects; the parser must reject them too. */
    static const char *const bad[] = {"R",         "G",           "A",
                                      "S4.550nm",  "S0.550",      "S0.550nmx",
                                      "S0.5E nm",  "S0.55,0,0nm", "S0.-550nm",
                                      "S0.550 nm", "S0550nm",     "s0.550nm",
                                      "S0.550Km",  "S0.550nHZ",   "S0.550,0e+nm",
                                      "T550nm",    "S0.550nmm2",  "",
                                      "S0.",       "S0.5,5E2"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        assert_false(matches_layout_regex(bad[i]));
        if (image_exr_parse_channel_name(bad[i], NULL, NULL))
            fail_msg("'%s' should not parse", bad[i]);
    }
    /* The pattern allows an empty number, which names no wavelength: matched but refused. */
    assert_true(matches_layout_regex("S0.nm"));
    assert_false(image_exr_parse_channel_name("S0.nm", NULL, NULL));
    assert_false(image_exr_parse_channel_name("S0.0nm", NULL, NULL));
}

/* Opens a file with OpenEXRCore directly (not through the module) and checks the header:
 * every channel FLOAT, ZIP compression, sRGB chromaticities. Returns the channel count. */
static int check_header_independently(const char *path, char names[][IMAGE_EXR_CHANNEL_NAME_MAX],
                                      int max_names)
{
    exr_context_t ctx = NULL;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    assert_int_equal(exr_start_read(&ctx, path, &init), EXR_ERR_SUCCESS);
    const exr_attr_chlist_t *ch = NULL;
    assert_int_equal(exr_get_channels(ctx, 0, &ch), EXR_ERR_SUCCESS);
    exr_compression_t comp;
    assert_int_equal(exr_get_compression(ctx, 0, &comp), EXR_ERR_SUCCESS);
    assert_int_equal(comp, EXR_COMPRESSION_ZIP);
    exr_storage_t storage;
    assert_int_equal(exr_get_storage(ctx, 0, &storage), EXR_ERR_SUCCESS);
    assert_int_equal(storage, EXR_STORAGE_SCANLINE);
    exr_attr_chromaticities_t chr;
    assert_int_equal(exr_attr_get_chromaticities(ctx, 0, "chromaticities", &chr), EXR_ERR_SUCCESS);
    /* IEC 61966-2-1 / Rec. 709 primaries and D65 (data/srgb_matrices.txt). */
    assert_true(chr.red_x == 0.64f && chr.red_y == 0.33f && chr.green_x == 0.30f &&
                chr.green_y == 0.60f && chr.blue_x == 0.15f && chr.blue_y == 0.06f &&
                chr.white_x == 0.3127f && chr.white_y == 0.3290f);
    assert_true(ch->num_channels <= max_names);
    for (int i = 0; i < ch->num_channels; i++) {
        assert_int_equal(ch->entries[i].pixel_type, EXR_PIXEL_FLOAT);
        snprintf(names[i], IMAGE_EXR_CHANNEL_NAME_MAX, "%s", ch->entries[i].name.str);
    }
    int n = ch->num_channels;
    assert_int_equal(exr_finish(&ctx), EXR_ERR_SUCCESS);
    return n;
}

static void roundtrip_rgb(int width, int height, int channels)
{
    const char *path = testutil_scratch("rgb.exr");
    size_t count = (size_t)width * (size_t)height * (size_t)channels;
    float *rgb = make_values(count, (size_t)width);
    err_t err = {{0}};
    if (image_exr_write_rgb(path, width, height, rgb, channels, "job=7\nspp=16", &err) != 0)
        fail_msg("write failed: %s", err.msg);
    char tmp[160];
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    assert_false(path_exists(tmp)); /* renamed into place */

    char names[8][IMAGE_EXR_CHANNEL_NAME_MAX];
    assert_int_equal(check_header_independently(path, names, 8), channels);

    image_exr_t *img = image_exr_read(path, &err);
    if (img == NULL)
        fail_msg("read failed: %s", err.msg);
    assert_int_equal(image_exr_width(img), width);
    assert_int_equal(image_exr_height(img), height);
    assert_int_equal(image_exr_n_spectral(img), 0);
    assert_null(image_exr_spectral(img));
    assert_null(image_exr_wavelengths_nm(img));
    const float *got = image_exr_rgb(img);
    const float *alpha = image_exr_alpha(img);
    if (channels == 4)
        assert_non_null(alpha);
    else
        assert_null(alpha);
    for (size_t p = 0; p < (size_t)width * (size_t)height; p++) {
        /* Bit-identical: memcmp also tells -0 from +0 and keeps subnormals. */
        assert_memory_equal(&got[p * 3], &rgb[p * (size_t)channels], 3 * sizeof(float));
        if (channels == 4)
            assert_memory_equal(&alpha[p], &rgb[p * 4 + 3], sizeof(float));
    }
    assert_string_equal(image_exr_attribute(img, "prismfarm"), "job=7\nspp=16");
    assert_null(image_exr_attribute(img, "spectralLayoutVersion"));
    assert_null(image_exr_attribute(img, "no such attribute"));
    image_exr_destroy(&img);
    assert_null(img);
    free(rgb);
}

static void test_rgb_roundtrip(void **state)
{
    (void)state;
    static const int sizes[][2] = {{1, 1}, {17, 33}, {64, 35}, {3, 16}, {5, 17}};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) {
        roundtrip_rgb(sizes[i][0], sizes[i][1], 3);
        roundtrip_rgb(sizes[i][0], sizes[i][1], 4);
    }
}

static void roundtrip_spectral(int width, int height, int n)
{
    const char *path = testutil_scratch("spectral.exr");
    size_t n_pixels = (size_t)width * (size_t)height;
    float *rgb = make_values(n_pixels * 3, 11);
    float *spectral = make_values(n_pixels * (size_t)n, 5);
    double *centres = malloc((size_t)n * sizeof *centres);
    assert_non_null(centres);
    /* The default film range, 380-720 nm (docs/physics.md §1.2), split into n equal buckets. */
    for (int k = 0; k < n; k++)
        centres[k] = 380.0 + (k + 0.5) * (720.0 - 380.0) / n;
    err_t err = {{0}};
    if (image_exr_write_spectral(path, width, height, rgb, spectral, n, centres,
                                 "W.m^-2.sr^-1.nm^-1", "buckets=n", &err) != 0)
        fail_msg("write failed: %s", err.msg);

    char names[64][IMAGE_EXR_CHANNEL_NAME_MAX];
    int n_names = check_header_independently(path, names, 64);
    assert_int_equal(n_names, n + 3);
    int n_layout = 0;
    bool r = false, g = false, b = false;
    for (int i = 0; i < n_names; i++) {
        r |= strcmp(names[i], "R") == 0;
        g |= strcmp(names[i], "G") == 0;
        b |= strcmp(names[i], "B") == 0;
        if (matches_layout_regex(names[i]))
            n_layout++;
        else
            assert_true(strlen(names[i]) == 1);
    }
    assert_true(r && g && b);
    assert_int_equal(n_layout, n);

    image_exr_t *img = image_exr_read(path, &err);
    if (img == NULL)
        fail_msg("read failed: %s", err.msg);
    assert_int_equal(image_exr_width(img), width);
    assert_int_equal(image_exr_height(img), height);
    assert_int_equal(image_exr_n_spectral(img), n);
    const double *wl = image_exr_wavelengths_nm(img);
    for (int k = 0; k < n; k++) {
        /* The name keeps 6 decimals, so the centre comes back within half a unit of the 6th. */
        if (fabs(wl[k] - centres[k]) > 0.5e-6 + 1e-12)
            fail_msg("bucket %d: wavelength %.9f nm, written %.9f nm", k, wl[k], centres[k]);
    }
    assert_memory_equal(image_exr_spectral(img), spectral, n_pixels * (size_t)n * sizeof(float));
    assert_memory_equal(image_exr_rgb(img), rgb, n_pixels * 3 * sizeof(float));
    assert_null(image_exr_alpha(img));
    assert_string_equal(image_exr_attribute(img, "spectralLayoutVersion"), "1.0");
    assert_string_equal(image_exr_attribute(img, "emissiveUnits"), "W.m^-2.sr^-1.nm^-1");
    assert_string_equal(image_exr_attribute(img, "prismfarm"), "buckets=n");
    image_exr_destroy(&img);
    free(rgb);
    free(spectral);
    free(centres);
}

static void test_spectral_roundtrip(void **state)
{
    (void)state;
    static const int buckets[] = {8, 16, 32, 45};
    static const int sizes[][2] = {{1, 1}, {17, 33}};
    for (size_t b = 0; b < sizeof buckets / sizeof buckets[0]; b++) {
        for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++)
            roundtrip_spectral(sizes[s][0], sizes[s][1], buckets[b]);
    }
}

/* Channels are stored sorted by name, where "S0.1000,..." comes before "S0.400,...": the reader
 * must order buckets by wavelength and carry each bucket's pixels along. */
static void test_spectral_sorted_by_wavelength(void **state)
{
    (void)state;
    const char *path = testutil_scratch("unsorted.exr");
    const double centres[4] = {700.0, 400.0, 1000.0, 550.0};
    const float rgb[3] = {1.0f, 2.0f, 3.0f};
    const float spectral[4] = {70.0f, 40.0f, 100.0f, 55.0f}; /* one pixel */
    err_t err;
    assert_int_equal(
        image_exr_write_spectral(path, 1, 1, rgb, spectral, 4, centres, NULL, NULL, &err), 0);
    image_exr_t *img = image_exr_read(path, &err);
    assert_non_null(img);
    assert_int_equal(image_exr_n_spectral(img), 4);
    const double want_nm[4] = {400.0, 550.0, 700.0, 1000.0};
    const float want_v[4] = {40.0f, 55.0f, 70.0f, 100.0f};
    for (int k = 0; k < 4; k++) {
        assert_true(image_exr_wavelengths_nm(img)[k] == want_nm[k]);
        assert_true(image_exr_spectral(img)[k] == want_v[k]);
    }
    assert_string_equal(image_exr_attribute(img, "emissiveUnits"),
                        IMAGE_EXR_DEFAULT_EMISSIVE_UNITS);
    assert_null(image_exr_attribute(img, "prismfarm"));
    image_exr_destroy(&img);
}

/* Looks for an executable on PATH; NULL when absent. */
static const char *find_tool(const char *name, char *buf, size_t size)
{
    const char *path = getenv("PATH");
    if (path == NULL)
        path = "/usr/bin:/bin";
    while (*path != '\0') {
        size_t len = strcspn(path, ":");
        snprintf(buf, size, "%.*s/%s", (int)len, path, name);
        if (access(buf, X_OK) == 0)
            return buf;
        path += len;
        if (*path == ':')
            path++;
    }
    return NULL;
}

static char *run_command(const char *cmd)
{
    FILE *p = popen(cmd, "r");
    assert_non_null(p);
    size_t cap = 1 << 16, len = 0;
    char *out = malloc(cap);
    assert_non_null(out);
    size_t got;
    while ((got = fread(out + len, 1, cap - 1 - len, p)) > 0)
        len += got;
    out[len] = '\0';
    int rc = pclose(p);
    if (rc != 0)
        fail_msg("'%s' exited with status %d:\n%s", cmd, rc, out);
    return out;
}

static void write_test_spectral(const char *path, int width, int height, int n, float **rgb_out,
                                float **spectral_out)
{
    size_t n_pixels = (size_t)width * (size_t)height;
    float *rgb = make_values(n_pixels * 3, 0);
    float *spectral = make_values(n_pixels * (size_t)n, 1);
    double centres[64];
    assert_true(n <= 64);
    /* 16 buckets of 20 nm from 390 nm: bucket 8 is centred on 550 nm exactly. */
    for (int k = 0; k < n; k++)
        centres[k] = 390.0 + 20.0 * k;
    err_t err;
    if (image_exr_write_spectral(path, width, height, rgb, spectral, n, centres, NULL, "tool=test",
                                 &err) != 0)
        fail_msg("write failed: %s", err.msg);
    *rgb_out = rgb;
    *spectral_out = spectral;
}

/* Debian's exrheader (OpenEXR's C++ library) must list what the spectral layout asks for. */
static void test_exrheader_lists_layout(void **state)
{
    (void)state;
    char tool[512];
    if (find_tool("exrheader", tool, sizeof tool) == NULL) {
        print_message("exrheader not found (Debian package 'openexr'): test skipped\n");
        skip();
    }
    const char *path = testutil_scratch("header.exr");
    float *rgb, *spectral;
    write_test_spectral(path, 7, 5, 16, &rgb, &spectral);
    char cmd[1200];
    snprintf(cmd, sizeof cmd, "'%s' '%s' 2>&1", tool, path);
    char *out = run_command(cmd);
    assert_non_null(strstr(out, "S0.550,000000nm, 32-bit floating-point"));
    assert_non_null(strstr(out, "S0.390,000000nm, 32-bit floating-point"));
    assert_non_null(strstr(out, "S0.690,000000nm, 32-bit floating-point"));
    assert_non_null(strstr(out, "R, 32-bit floating-point"));
    assert_non_null(strstr(out, "spectralLayoutVersion (type string): \"1.0\""));
    assert_non_null(strstr(out, "emissiveUnits (type string): \"W.m^-2.sr^-1\""));
    assert_non_null(strstr(out, "prismfarm (type string): \"tool=test\""));
    assert_non_null(strstr(out, "zip"));
    assert_null(strstr(out, "16-bit floating-point")); /* never half */
    free(out);
    free(rgb);
    free(spectral);
}

/* The C++ library's exrmaketiled re-encodes our file as tiles (with partial tiles at the right
 * and bottom) in other lossless codecs, one level or mip/rip-mapped (the reader takes level 0,
 * the full image); the reader must return the same floats. Codecs the reader refuses must be
 * named in the error. */
static void test_tiled_files_from_exrmaketiled(void **state)
{
    (void)state;
    char tool[512];
    if (find_tool("exrmaketiled", tool, sizeof tool) == NULL) {
        print_message("exrmaketiled not found (Debian package 'openexr'): test skipped\n");
        skip();
    }
    char cmd[1400];
    const char *src = testutil_scratch("scan.exr"), *dst = testutil_scratch("tiled.exr");
    const int w = 37, h = 21, n = 16;
    float *rgb, *spectral;
    write_test_spectral(src, w, h, n, &rgb, &spectral);
    static const char *const lossless[] = {"-o -z none", "-o -z rle", "-o -z zip",
                                           "-o -z piz",  "-m -z zip", "-r -z piz"};
    for (size_t i = 0; i < sizeof lossless / sizeof lossless[0]; i++) {
        snprintf(cmd, sizeof cmd, "'%s' -t 16 8 %s '%s' '%s' 2>&1", tool, lossless[i], src, dst);
        free(run_command(cmd));
        err_t err;
        image_exr_t *img = image_exr_read(dst, &err);
        if (img == NULL)
            fail_msg("%s: %s", lossless[i], err.msg);
        assert_int_equal(image_exr_width(img), w);
        assert_int_equal(image_exr_height(img), h);
        assert_int_equal(image_exr_n_spectral(img), n);
        assert_memory_equal(image_exr_rgb(img), rgb, (size_t)w * h * 3 * sizeof(float));
        assert_memory_equal(image_exr_spectral(img), spectral, (size_t)w * h * n * sizeof(float));
        assert_string_equal(image_exr_attribute(img, "spectralLayoutVersion"), "1.0");
        image_exr_destroy(&img);
    }
    static const struct {
        const char *option, *name;
    } refused[] = {{"dwaa", "DWAA"}, {"dwab", "DWAB"}, {"b44", "B44"}};
    for (size_t i = 0; i < sizeof refused / sizeof refused[0]; i++) {
        snprintf(cmd, sizeof cmd, "'%s' -o -t 16 8 -z %s '%s' '%s' 2>&1", tool, refused[i].option,
                 src, dst);
        free(run_command(cmd));
        err_t err;
        assert_null(image_exr_read(dst, &err));
        assert_non_null(strstr(err.msg, dst));
        char want[64];
        snprintf(want, sizeof want, "compression %s is not supported", refused[i].name);
        if (strstr(err.msg, want) == NULL)
            fail_msg("-z %s: unexpected message: %s", refused[i].option, err.msg);
    }
    free(rgb);
    free(spectral);
}

/* ---------------------------------------------------------------------------------------- */
/* A file assembled byte by byte from "OpenEXR File Layout" (openexr.com): magic, version 2,
 * attributes (name\0 type\0 int32 size, value), a 0 byte, the offset table (one uint64 per
 * chunk; NO_COMPRESSION holds one scanline per chunk), then per chunk int32 y, int32 size and
 * each channel's row in channel-name order. All little-endian. */

typedef struct bytes {
    unsigned char data[4096];
    size_t len;
} bytes_t;

static void put(bytes_t *b, const void *p, size_t n)
{
    assert_true(b->len + n <= sizeof b->data);
    memcpy(b->data + b->len, p, n);
    b->len += n;
}
static void put_u8(bytes_t *b, unsigned v)
{
    unsigned char c = (unsigned char)v;
    put(b, &c, 1);
}
static void put_i32(bytes_t *b, int32_t v)
{
    uint32_t u = (uint32_t)v;
    for (int i = 0; i < 4; i++)
        put_u8(b, (u >> (8 * i)) & 0xffu);
}
static void put_u64(bytes_t *b, uint64_t v)
{
    for (int i = 0; i < 8; i++)
        put_u8(b, (unsigned)((v >> (8 * i)) & 0xffu));
}
static void put_f32(bytes_t *b, float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    put_i32(b, (int32_t)u);
}
static void put_str(bytes_t *b, const char *s)
{
    put(b, s, strlen(s) + 1);
}
static void put_attr_header(bytes_t *b, const char *name, const char *type, int32_t size)
{
    put_str(b, name);
    put_str(b, type);
    put_i32(b, size);
}

/* IEEE 754 binary16 encodings and the values they stand for. */
static const struct {
    uint16_t bits;
    float value;
} HALVES[] = {
    {0x3C00, 1.0f},
    {0x4000, 2.0f},
    {0xC000, -2.0f},
    {0x3800, 0.5f},
    {0x7BFF, 65504.0f},
    {0x0001, 5.9604644775390625e-8f}, /* smallest subnormal, 2^-24 */
    {0x3555, 0.333251953125f},
    {0x5640, 100.0f},
    {0x0000, 0.0f},
    {0x8000, -0.0f},
    {0x3E00, 1.5f},
    {0x4900, 10.0f},
};

/* 3x2 pixels at data window (5,7)-(7,8); channels (sorted) from names[], all HALF; pixel value
 * of channel c at (x, y) is HALVES[(c * 6 + y * 3 + x) % 12]. */
static void build_half_file(const char *path, const char *const *names, int n_channels)
{
    const int x0 = 5, y0 = 7, w = 3, h = 2;
    bytes_t b = {{0}, 0};
    put_i32(&b, 20000630); /* magic 76 2f 31 01 */
    put_i32(&b, 2);        /* version 2, single-part scanline, short names */
    int32_t chlist_size = 1;
    for (int c = 0; c < n_channels; c++)
        chlist_size += (int32_t)strlen(names[c]) + 1 + 16;
    put_attr_header(&b, "channels", "chlist", chlist_size);
    for (int c = 0; c < n_channels; c++) {
        put_str(&b, names[c]);
        put_i32(&b, 1); /* HALF */
        put_u8(&b, 0);  /* pLinear */
        put_u8(&b, 0);
        put_u8(&b, 0);
        put_u8(&b, 0);
        put_i32(&b, 1); /* xSampling */
        put_i32(&b, 1); /* ySampling */
    }
    put_u8(&b, 0);
    put_attr_header(&b, "compression", "compression", 1);
    put_u8(&b, 0); /* NO_COMPRESSION */
    put_attr_header(&b, "dataWindow", "box2i", 16);
    put_i32(&b, x0);
    put_i32(&b, y0);
    put_i32(&b, x0 + w - 1);
    put_i32(&b, y0 + h - 1);
    put_attr_header(&b, "displayWindow", "box2i", 16);
    put_i32(&b, 0);
    put_i32(&b, 0);
    put_i32(&b, 9);
    put_i32(&b, 9);
    put_attr_header(&b, "lineOrder", "lineOrder", 1);
    put_u8(&b, 0);
    put_attr_header(&b, "owner", "string", 4);
    put(&b, "hand", 4); /* string attributes carry no terminating NUL */
    put_attr_header(&b, "pixelAspectRatio", "float", 4);
    put_f32(&b, 1.0f);
    put_attr_header(&b, "screenWindowCenter", "v2f", 8);
    put_f32(&b, 0.0f);
    put_f32(&b, 0.0f);
    put_attr_header(&b, "screenWindowWidth", "float", 4);
    put_f32(&b, 1.0f);
    put_u8(&b, 0); /* end of header */

    size_t table = b.len;
    for (int y = 0; y < h; y++)
        put_u64(&b, 0); /* patched below */
    for (int y = 0; y < h; y++) {
        uint64_t offset = b.len;
        memcpy(b.data + table + 8 * (size_t)y, &offset, 8); /* little-endian host (x86-64) */
        put_i32(&b, y0 + y);
        put_i32(&b, n_channels * w * 2);
        for (int c = 0; c < n_channels; c++) {
            for (int x = 0; x < w; x++) {
                uint16_t bits = HALVES[(c * 6 + y * 3 + x) % 12].bits;
                put_u8(&b, bits & 0xffu);
                put_u8(&b, bits >> 8);
            }
        }
    }
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(b.data, 1, b.len, f), b.len);
    assert_int_equal(fclose(f), 0);
}

static void test_handbuilt_half_file(void **state)
{
    (void)state;
    uint16_t probe = 1;
    unsigned char first;
    memcpy(&first, &probe, 1);
    assert_int_equal(first, 1); /* the offset table patch assumes a little-endian host */

    const char *path = testutil_scratch("hand.exr");
    /* Sorted as the format requires; 0,55 um is 550 nm, 4,5E2 nm is 450 nm. */
    const char *const names[] = {"A", "B", "G", "R", "S0.0,55um", "S0.4,5E2nm", "Z"};
    build_half_file(path, names, 7);
    err_t err;
    image_exr_t *img = image_exr_read(path, &err);
    if (img == NULL)
        fail_msg("%s", err.msg);
    assert_int_equal(image_exr_width(img), 3);
    assert_int_equal(image_exr_height(img), 2);
    assert_int_equal(image_exr_n_spectral(img), 2);
    assert_true(fabs(image_exr_wavelengths_nm(img)[0] - 450.0) < 1e-9);
    assert_true(fabs(image_exr_wavelengths_nm(img)[1] - 550.0) < 1e-9);
    /* channel indices in names[]: A 0, B 1, G 2, R 3, 550 nm 4, 450 nm 5 */
    for (int y = 0; y < 2; y++) {
        for (int x = 0; x < 3; x++) {
            size_t p = (size_t)y * 3 + (size_t)x;
#define HALF_OF(c) HALVES[((c)*6 + y * 3 + x) % 12].value
            const float want_rgb[3] = {HALF_OF(3), HALF_OF(2), HALF_OF(1)};
            const float want_spectral[2] = {HALF_OF(5), HALF_OF(4)};
            const float want_alpha = HALF_OF(0);
#undef HALF_OF
            assert_memory_equal(&image_exr_rgb(img)[p * 3], want_rgb, sizeof want_rgb);
            assert_memory_equal(&image_exr_spectral(img)[p * 2], want_spectral,
                                sizeof want_spectral);
            assert_memory_equal(&image_exr_alpha(img)[p], &want_alpha, sizeof want_alpha);
        }
    }
    assert_string_equal(image_exr_attribute(img, "owner"), "hand");
    assert_null(image_exr_attribute(img, "emissiveUnits"));
    image_exr_destroy(&img);
}

static void test_missing_channel(void **state)
{
    (void)state;
    const char *path = testutil_scratch("nogreen.exr");
    const char *const names[] = {"B", "R", "S0.550nm"};
    build_half_file(path, names, 3);
    err_t err;
    assert_null(image_exr_read(path, &err));
    assert_non_null(strstr(err.msg, path));
    assert_non_null(strstr(err.msg, "no channel named 'G'"));

    path = testutil_scratch("dup.exr");
    const char *const dup[] = {"B", "G", "R", "S0.550,0nm", "S0.550nm"};
    build_half_file(path, dup, 5);
    assert_null(image_exr_read(path, &err));
    assert_non_null(strstr(err.msg, "same wavelength"));
}

static void test_not_an_exr(void **state)
{
    (void)state;
    const char *path = testutil_scratch("text.exr");
    testutil_write_text(path, "P3\n1 1\n255\n0 0 0\n", 0644);
    err_t err;
    assert_null(image_exr_read(path, &err));
    assert_non_null(strstr(err.msg, path));
    assert_non_null(strstr(err.msg, "not an OpenEXR file"));

    path = testutil_scratch("missing.exr");
    assert_null(image_exr_read(path, &err));
    assert_non_null(strstr(err.msg, "cannot open"));
}

static void test_truncated_exr(void **state)
{
    (void)state;
    const char *path = testutil_scratch("whole.exr"), *cut = testutil_scratch("cut.exr");
    float *rgb, *spectral;
    write_test_spectral(path, 40, 40, 8, &rgb, &spectral);
    struct stat st;
    assert_int_equal(stat(path, &st), 0);
    /* Cut in the pixel data, in the offset table, and inside the header. */
    const long keep[] = {(long)st.st_size / 2, (long)st.st_size - 1, 700, 40};
    for (size_t i = 0; i < sizeof keep / sizeof keep[0]; i++) {
        testutil_truncate_copy(path, cut, keep[i]);
        err_t err;
        image_exr_t *img = image_exr_read(cut, &err);
        if (img != NULL)
            fail_msg("a file cut to %ld of %ld bytes was read", keep[i], (long)st.st_size);
        assert_non_null(strstr(err.msg, cut));
    }
    free(rgb);
    free(spectral);
}

static void test_write_errors(void **state)
{
    (void)state;
    const char *path = testutil_scratch("bad.exr");
    float px[8] = {1, 2, 3, 4, 5, 6, 7, 8};
    err_t err;
    assert_int_equal(image_exr_write_rgb(path, 1, 1, px, 2, NULL, &err), -1);
    assert_non_null(strstr(err.msg, "2 channels"));
    assert_int_equal(image_exr_write_rgb(path, 0, 1, px, 3, NULL, &err), -1);
    px[4] = NAN;
    assert_int_equal(image_exr_write_rgb(path, 2, 1, px, 3, NULL, &err), -1);
    assert_non_null(strstr(err.msg, "pixel (1, 0) is NaN"));
    px[4] = 5;
    const double same[2] = {550.0000001, 550.0000002}; /* equal to 6 decimals */
    assert_int_equal(image_exr_write_spectral(path, 1, 1, px, px, 2, same, NULL, NULL, &err), -1);
    assert_non_null(strstr(err.msg, "S0.550,000000nm"));
    const double negative[2] = {550.0, -1.0};
    assert_int_equal(image_exr_write_spectral(path, 1, 1, px, px, 2, negative, NULL, NULL, &err),
                     -1);
    assert_non_null(strstr(err.msg, "bucket 1"));
    assert_int_equal(image_exr_write_rgb("/nonexistent-dir/x.exr", 1, 1, px, 3, NULL, &err), -1);
    assert_non_null(strstr(err.msg, "cannot create"));
    assert_false(path_exists(path));
}

/* A failed write leaves the previous file untouched: the new data goes to PATH.tmp first. */
static void test_failed_write_keeps_old_file(void **state)
{
    (void)state;
    char tmp[160];
    const char *path = testutil_scratch("keep.exr");
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    const float old_px[3] = {0.25f, 0.5f, 0.75f};
    err_t err;
    assert_int_equal(image_exr_write_rgb(path, 1, 1, old_px, 3, NULL, &err), 0);
    assert_int_equal(mkdir(tmp, 0700), 0); /* PATH.tmp cannot be created as a file */
    const float new_px[3] = {9.0f, 9.0f, 9.0f};
    assert_int_equal(image_exr_write_rgb(path, 1, 1, new_px, 3, NULL, &err), -1);
    assert_int_equal(rmdir(tmp), 0);
    image_exr_t *img = image_exr_read(path, &err);
    assert_non_null(img);
    assert_memory_equal(image_exr_rgb(img), old_px, sizeof old_px);
    image_exr_destroy(&img);
}

/* A write error (a full disk) comes back as an error naming the file and the system's reason,
 * wherever in the file it happens: the header (exr_write_header, where OpenEXRCore's error
 * handler once re-took the context's lock and hung the process), a chunk, the offset table. The
 * writer runs in a child with a deadline, so the old deadlock fails the test instead of hanging
 * it; no temporary file is left behind to fill the disk further. */
typedef struct full_write {
    const char *path;
    int width, height;
    bool spectral;
    const char *reason; /* strerror of the errno the failing write gives */
    const char *filler; /* a file to fill the disk with first, or NULL */
} full_write_t;

/* Writes path until the file system is full (ENOSPC); the disk of a full spool. */
static void fill_disk(const char *path)
{
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    static const char block[4096];
    while (fd >= 0 && write(fd, block, sizeof block) > 0)
        ;
    if (fd >= 0)
        close(fd);
}

static int full_write_child(void *arg, char *msg, size_t size)
{
    const full_write_t *fw = arg;
    if (fw->filler)
        fill_disk(fw->filler);
    size_t n = (size_t)fw->width * (size_t)fw->height;
    float *rgb = make_values(n * 3, 0);
    float *spectral = make_values(n * 4, 17);
    const double centres[4] = {400, 500, 600, 700};
    err_t err = {{0}};
    int rc = fw->spectral ? image_exr_write_spectral(fw->path, fw->width, fw->height, rgb,
                                                     spectral, 4, centres, NULL, "job=1", &err)
                          : image_exr_write_rgb(fw->path, fw->width, fw->height, rgb, 3, NULL,
                                                &err);
    free(rgb);
    free(spectral);
    char tmp[600];
    snprintf(tmp, sizeof tmp, "%s.tmp", fw->path);
    if (rc == 0) {
        snprintf(msg, size, "the write succeeded");
        return 1;
    }
    snprintf(msg, size, "%s", err.msg);
    if (!strstr(err.msg, fw->path) || !strstr(err.msg, fw->reason))
        return 2;
    if (path_exists(tmp) || path_exists(fw->path))
        return 3;
    return 0;
}

static void expect_full_write(long limit, bool spectral)
{
    full_write_t fw = {.path = testutil_scratch("full.exr"), .width = 64, .height = 64,
                       .spectral = spectral, .reason = strerror(EFBIG)};
    diskfull_result_t r = diskfull_run(full_write_child, &fw, limit, NULL, 0);
    if (r.status != 0)
        fail_msg("file size limit %ld: status %d: %s", limit, r.status, r.msg);
    print_message("limit %ld bytes: %s\n", limit, r.msg);
}

static void test_write_error_on_full_disk(void **state)
{
    (void)state;
    expect_full_write(0, false);    /* the first write: the header */
    expect_full_write(300, false);  /* the header's end */
    expect_full_write(8192, false); /* a chunk */
    expect_full_write(8192, true);
}

/* The same on a real full file system: a 16 KiB tmpfs of the child's own, full before the write
 * (the header fails) and full during it (64x64 pixels of noise that ZIP cannot shrink below
 * 16 KiB: a chunk fails). */
static void test_write_error_on_full_tmpfs(void **state)
{
    (void)state;
    const char *dir = testutil_scratch("tmpfs");
    assert_int_equal(mkdir(dir, 0755), 0);
    char path[600];
    snprintf(path, sizeof path, "%s/out.exr", dir);
    char filler[600];
    snprintf(filler, sizeof filler, "%s/filler", dir);
    for (int full_before = 0; full_before < 2; full_before++) {
        full_write_t fw = {.path = path, .width = 64, .height = 64, .spectral = true,
                           .reason = strerror(ENOSPC), .filler = full_before ? filler : NULL};
        diskfull_result_t r = diskfull_run(full_write_child, &fw, 0, dir, 16);
        if (r.status == DISKFULL_SKIP) {
            rmdir(dir);
            print_message("skipped: %s\n", r.msg);
            skip();
        }
        if (r.status != 0)
            fail_msg("full tmpfs (%s): status %d: %s", full_before ? "before" : "during",
                     r.status, r.msg);
        print_message("full tmpfs (%s): %s\n", full_before ? "before" : "during", r.msg);
    }
    rmdir(dir);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_channel_name_format),
        cmocka_unit_test(test_channel_name_parse),
        cmocka_unit_test(test_rgb_roundtrip),
        cmocka_unit_test(test_spectral_roundtrip),
        cmocka_unit_test(test_spectral_sorted_by_wavelength),
        cmocka_unit_test(test_exrheader_lists_layout),
        cmocka_unit_test(test_tiled_files_from_exrmaketiled),
        cmocka_unit_test(test_handbuilt_half_file),
        cmocka_unit_test(test_missing_channel),
        cmocka_unit_test(test_not_an_exr),
        cmocka_unit_test(test_truncated_exr),
        cmocka_unit_test(test_write_errors),
        cmocka_unit_test(test_failed_write_keeps_old_file),
        cmocka_unit_test(test_write_error_on_full_disk),
        cmocka_unit_test(test_write_error_on_full_tmpfs),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_setup, testutil_scratch_teardown);
}
