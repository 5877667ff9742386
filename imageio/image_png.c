#define _POSIX_C_SOURCE 200809L

#include "image_png.h"

#include "files.h"

#include <png.h>

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* libpng reports errors through a callback that must not return: ours records the message in
 * the caller's err_t and longjmps back to the setjmp in png_write_body / png_read_body. Those
 * functions allocate nothing that a longjmp could leak except through volatile pointers or the
 * heap object the caller frees. */
typedef struct png_job {
    const char *path;
    err_t *err;
    FILE *fp;
} png_job_t;

static void png_on_error(png_structp png, png_const_charp msg)
{
    png_job_t *job = png_get_error_ptr(png);
    err_set(job->err, "%s: %s", job->path, msg);
    png_longjmp(png, 1);
}

/* Warnings (an unknown ancillary chunk, an odd gAMA value) do not stop the image. */
static void png_on_warning(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg;
}

/* libpng's stdio reader says only "Read Error" at the end of a file; say what happened. */
static void png_read_bytes(png_structp png, png_bytep data, size_t length)
{
    png_job_t *job = png_get_io_ptr(png);
    size_t got = fread(data, 1, length, job->fp);
    if (got != length)
        png_error(png,
                  ferror(job->fp) ? "read error" : "unexpected end of file (the PNG is truncated)");
}

/* ---------------------------------------------------------------------------------------- */
/* Writing                                                                                  */

static int png_write_body(png_structp png, png_infop info, png_job_t *job, int width, int height,
                          png_bytep *rows)
{
    if (setjmp(png_jmpbuf(png)))
        return -1; /* png_on_error filled job->err */
    png_init_io(png, job->fp);
    png_set_IHDR(png, info, (png_uint_32)width, (png_uint_32)height, 8, PNG_COLOR_TYPE_RGB,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    /* sRGB chunk plus the gAMA 45455 and cHRM values the PNG specification (section 11.3.3.5)
     * asks an encoder to write beside it for decoders that do not know sRGB. */
    png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    png_write_info(png, info);
    png_write_image(png, rows);
    png_write_end(png, NULL);
    return 0;
}

int image_png_write_rgb(const char *path, int width, int height, const uint8_t *rgb, err_t *err)
{
    if (rgb == NULL)
        return err_set(err, "%s: no pixels given", path);
    if (width < 1 || height < 1)
        return err_set(err, "%s: image size %dx%d is not positive", path, width, height);
    if ((size_t)width > SIZE_MAX / 3 / (size_t)height)
        return err_set(err, "%s: image size %dx%d overflows memory", path, width, height);

    size_t path_len = strlen(path);
    char *tmp = malloc(path_len + 5);
    png_bytep *rows = malloc((size_t)height * sizeof *rows);
    if (tmp == NULL || rows == NULL) {
        free(tmp);
        free(rows);
        return err_set(err, "%s: out of memory", path);
    }
    memcpy(tmp, path, path_len);
    memcpy(tmp + path_len, ".tmp", 5);
    for (int y = 0; y < height; y++) {
        /* libpng's row type is not const, but png_write_image only reads the rows. */
        rows[y] = (png_bytep)(uintptr_t)(rgb + (size_t)y * (size_t)width * 3);
    }

    png_job_t job = {.path = path, .err = err, .fp = NULL};
    int status = files_check_replaceable(path, err);
    if (status == 0) {
        /* Never through a link or into a FIFO or device someone left at PATH.tmp. */
        int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC,
                      0644);
        struct stat st;
        if (fd >= 0 && (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode))) {
            (void)close(fd);
            fd = -1;
            errno = EINVAL;
        }
        if (fd >= 0 && !(job.fp = fdopen(fd, "wb")))
            (void)close(fd);
        if (job.fp == NULL)
            status = err_set(err, "%s: cannot create %s: %s", path, tmp,
                             errno == EINVAL ? "it exists and is not a regular file"
                                             : strerror(errno));
    }
    png_structp png = NULL;
    png_infop info = NULL;
    if (status == 0) {
        png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &job, png_on_error, png_on_warning);
        info = png != NULL ? png_create_info_struct(png) : NULL;
        if (png == NULL || info == NULL)
            status = err_set(err, "%s: cannot create the libpng writer (out of memory)", path);
    }
    if (status == 0)
        status = png_write_body(png, info, &job, width, height, rows);
    if (png != NULL)
        png_destroy_write_struct(&png, &info);
    if (job.fp != NULL) {
        if (status == 0 && fflush(job.fp) != 0)
            status = err_set(err, "%s: cannot write: %s", path, strerror(errno));
        if (status == 0 && fsync(fileno(job.fp)) != 0)
            status = err_set(err, "%s: cannot flush to disk: %s", path, strerror(errno));
        if (fclose(job.fp) != 0 && status == 0)
            status = err_set(err, "%s: cannot close: %s", path, strerror(errno));
        if (status == 0)
            status = files_check_replaceable(path, err);
        if (status == 0 && rename(tmp, path) != 0)
            status =
                err_set(err, "%s: cannot rename %s into place: %s", path, tmp, strerror(errno));
        if (status != 0)
            (void)unlink(tmp); /* best effort: the message already names the real failure */
    }
    free(rows);
    free(tmp);
    return status;
}

/* ---------------------------------------------------------------------------------------- */
/* Reading                                                                                  */

struct image_png {
    int width, height;
    int channels;
    uint8_t *rgba;
};

void image_png_destroy(image_png_t **self_p)
{
    if (self_p == NULL || *self_p == NULL)
        return;
    free((*self_p)->rgba);
    free(*self_p);
    *self_p = NULL;
}

int image_png_width(const image_png_t *self)
{
    return self->width;
}
int image_png_height(const image_png_t *self)
{
    return self->height;
}
int image_png_channels(const image_png_t *self)
{
    return self->channels;
}
const uint8_t *image_png_rgba(const image_png_t *self)
{
    return self->rgba;
}

static int png_read_body(png_structp png, png_infop info, image_png_t *img)
{
    /* Allocated after setjmp and freed after a longjmp: volatile so its value survives. */
    png_bytep *volatile rows = NULL;
    if (setjmp(png_jmpbuf(png))) {
        free((void *)rows);
        return -1; /* png_on_error filled the message */
    }
    png_read_info(png, info);
    png_uint_32 w = 0, h = 0;
    int depth = 0, color = 0;
    if (png_get_IHDR(png, info, &w, &h, &depth, &color, NULL, NULL, NULL) == 0)
        png_error(png, "cannot read the image header");
    if (w < 1 || h < 1 || w > INT_MAX || h > INT_MAX || (size_t)w > SIZE_MAX / 4 / (size_t)h)
        png_error(png, "image dimensions are too large");

    /* Bring every colour type to 8-bit RGBA (libpng manual, "Transformations"). */
    int channels = png_get_channels(png, info);
    if (color == PNG_COLOR_TYPE_PALETTE) {
        png_set_palette_to_rgb(png);
        channels = 3;
    }
    if (color == PNG_COLOR_TYPE_GRAY && depth < 8)
        png_set_expand_gray_1_2_4_to_8(png);
    if (png_get_valid(png, info, PNG_INFO_tRNS)) {
        png_set_tRNS_to_alpha(png);
        channels++;
    }
    if (depth == 16)
        png_set_strip_16(png);
    if ((color & PNG_COLOR_MASK_COLOR) == 0)
        png_set_gray_to_rgb(png);
    if ((color & PNG_COLOR_MASK_ALPHA) == 0 && !png_get_valid(png, info, PNG_INFO_tRNS))
        png_set_filler(png, 0xFF, PNG_FILLER_AFTER);
    (void)png_set_interlace_handling(png); /* returns the pass count, which png_read_image uses */
    png_read_update_info(png, info);
    if (png_get_rowbytes(png, info) != (size_t)w * 4)
        png_error(png, "cannot convert the image to 8-bit RGBA");

    img->width = (int)w;
    img->height = (int)h;
    img->channels = channels;
    img->rgba = malloc((size_t)w * (size_t)h * 4);
    rows = malloc((size_t)h * sizeof *rows);
    if (img->rgba == NULL || rows == NULL)
        png_error(png, "out of memory for the pixels");
    for (png_uint_32 y = 0; y < h; y++)
        rows[y] = img->rgba + (size_t)y * (size_t)w * 4;
    png_read_image(png, rows);
    png_read_end(png, NULL);
    free((void *)rows);
    return 0;
}

image_png_t *image_png_read(const char *path, err_t *err)
{
    int fd = files_open_regular(path, err); /* a FIFO would block, a device never end */
    png_job_t job = {.path = path, .err = err, .fp = fd >= 0 ? fdopen(fd, "rb") : NULL};
    if (job.fp == NULL) {
        if (fd >= 0) {
            err_set(err, "%s: cannot open: %s", path, strerror(errno));
            (void)close(fd);
        }
        return NULL;
    }
    unsigned char signature[8];
    size_t got = fread(signature, 1, sizeof signature, job.fp);
    if (got != sizeof signature || png_sig_cmp(signature, 0, sizeof signature) != 0) {
        err_set(err, "%s: not a PNG file (%s)", path,
                got != sizeof signature ? "shorter than the 8-byte signature"
                                        : "the 8-byte signature does not match");
        (void)fclose(job.fp);
        return NULL;
    }

    image_png_t *img = calloc(1, sizeof *img);
    png_structp png = NULL;
    png_infop info = NULL;
    int status = 0;
    if (img == NULL)
        status = err_set(err, "%s: out of memory", path);
    if (status == 0) {
        png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &job, png_on_error, png_on_warning);
        info = png != NULL ? png_create_info_struct(png) : NULL;
        if (png == NULL || info == NULL)
            status = err_set(err, "%s: cannot create the libpng reader (out of memory)", path);
    }
    if (status == 0) {
        png_set_read_fn(png, &job, png_read_bytes);
        png_set_sig_bytes(png, (int)sizeof signature);
        status = png_read_body(png, info, img);
    }
    if (png != NULL)
        png_destroy_read_struct(&png, &info, NULL);
    (void)fclose(job.fp); /* read-only: a failed close loses nothing */
    if (status != 0)
        image_png_destroy(&img);
    return img;
}
