#include "image_info.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <openexr.h>
#include <stb_image.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

static int ends_with_ci(const char *s, const char *suffix)
{
    size_t n = strlen(s), k = strlen(suffix);
    return n >= k && !strcasecmp(s + n - k, suffix);
}

/* Up to size bytes of the file's start (a FIFO must not block the open). */
static int read_start(const char *path, unsigned char *buf, size_t size, size_t *got, err_t *err)
{
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0)
        return err_set(err, "%s: cannot open: %s", path, strerror(errno));
    size_t n = 0;
    while (n < size) {
        ssize_t r = read(fd, buf + n, size - n);
        if (r < 0 && errno == EINTR)
            continue;
        if (r <= 0)
            break;
        n += (size_t)r;
    }
    close(fd);
    *got = n;
    return 0;
}

static int checked(const char *path, int64_t w, int64_t h, int *width, int *height, err_t *err)
{
    if (w < 1 || h < 1 || w > INT_MAX || h > INT_MAX)
        return err_set(err, "%s: image of %lldx%lld pixels is empty or too large", path,
                       (long long)w, (long long)h);
    *width = (int)w;
    *height = (int)h;
    return 0;
}

/* PNG specification 11.2.2: the 8-byte signature, then the 13-byte chunk "IHDR" whose data
 * begins with the width and height, 4 bytes big-endian each. */
static int png_info(const char *path, int *width, int *height, err_t *err)
{
    static const unsigned char SIG[16] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n',
                                          0,    0,   0,   13,  'I',  'H',  'D',  'R'};
    unsigned char h[24];
    size_t n;
    if (read_start(path, h, sizeof h, &n, err) != 0)
        return -1;
    if (n < sizeof h || memcmp(h, SIG, sizeof SIG))
        return err_set(err, "%s: not a PNG file (no IHDR header)", path);
    uint32_t w = (uint32_t)h[16] << 24 | (uint32_t)h[17] << 16 | (uint32_t)h[18] << 8 | h[19];
    uint32_t ht = (uint32_t)h[20] << 24 | (uint32_t)h[21] << 16 | (uint32_t)h[22] << 8 | h[23];
    return checked(path, w, ht, width, height, err);
}

/* "PF" or "Pf", the width and the height, separated by white space (image_pfm.h). */
static int pfm_info(const char *path, int *width, int *height, err_t *err)
{
    unsigned char buf[128];
    size_t n;
    if (read_start(path, buf, sizeof buf - 1, &n, err) != 0)
        return -1;
    buf[n] = 0;
    char magic[3];
    long long w, h;
    if (sscanf((const char *)buf, "%2s %lld %lld", magic, &w, &h) != 3 ||
        (strcmp(magic, "PF") && strcmp(magic, "Pf")))
        return err_set(err, "%s: not a PFM header", path);
    return checked(path, w, h, width, height, err);
}

static void exr_quiet(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    (void)ctxt;
    (void)code;
    (void)msg; /* the decoder reports the file's faults with their context */
}

/* Part 0's data window (OpenEXRCore reads the header attributes only). */
static int exr_info(const char *path, int *width, int *height, err_t *err)
{
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_quiet;
    exr_context_t ctx = NULL;
    exr_attr_box2i_t dw = {0};
    exr_result_t rv = exr_start_read(&ctx, path, &init);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_data_window(ctx, 0, &dw);
    if (ctx)
        exr_finish(&ctx);
    if (rv != EXR_ERR_SUCCESS)
        return err_set(err, "%s: cannot read the EXR header: %s", path,
                       exr_get_default_error_message(rv));
    return checked(path, (int64_t)dw.max.x - dw.min.x + 1, (int64_t)dw.max.y - dw.min.y + 1, width,
                   height, err);
}

int image_info_read(const char *path, int *width, int *height, err_t *err)
{
    *width = *height = 0;
    if (ends_with_ci(path, ".exr"))
        return exr_info(path, width, height, err);
    if (ends_with_ci(path, ".pfm"))
        return pfm_info(path, width, height, err);
    if (ends_with_ci(path, ".png"))
        return png_info(path, width, height, err);
    int w, h, comp;
    if (!stbi_info(path, &w, &h, &comp))
        return err_set(err, "%s: cannot read image: %s", path, stbi_failure_reason());
    return checked(path, w, h, width, height, err);
}
