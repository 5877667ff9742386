#define _POSIX_C_SOURCE 200809L

#include "image_exr.h"

#include "files.h"

#include <openexr.h>

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <locale.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* The file behind an OpenEXRCore context. We do the I/O ourselves (pread/pwrite on our own
 * descriptor) so that a failed read or write records the system's reason where we can report
 * it, and so that the written file can be fsync'ed before it is renamed into place. */
typedef struct exr_io {
    int fd;
    char msg[256]; /* the first message the library reported, "" if none */
} exr_io_t;

/* The exr_io_t of the context this thread is working on, for the library's error handler.
 * The handler must not ask the context for its user data: exr_get_user_data takes the
 * context's lock, which a write context already holds while it calls our write function and
 * then the handler (exr_write_header -> exr_io_write -> handler -> exr_get_user_data: a full
 * disk deadlocked the master, issue 16). A context is used by one thread at a time here, so a
 * thread-local pointer, set while the context lives, reaches the same struct without a lock. */
static _Thread_local exr_io_t *exr_io_current;

static void exr_io_on_error(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    (void)ctxt;
    exr_io_t *io = exr_io_current;
    if (io != NULL && io->msg[0] == '\0')
        snprintf(io->msg, sizeof io->msg, "%s (%s)", msg ? msg : "",
                 exr_get_error_code_as_string(code));
}

/* Records the I/O callback's own reason before telling the library, so that the message does
 * not depend on the handler at all. */
static void exr_io_failed(exr_io_t *io, const char *what, uint64_t size, uint64_t offset,
                          const char *reason)
{
    if (io->msg[0] == '\0')
        snprintf(io->msg, sizeof io->msg,
                 "%s of %" PRIu64 " bytes at offset %" PRIu64 " failed: %s", what, size, offset,
                 reason);
}

static int64_t exr_io_read(exr_const_context_t ctxt, void *user, void *buffer, uint64_t size,
                           uint64_t offset, exr_stream_error_func_ptr_t error_cb)
{
    exr_io_t *io = user;
    uint64_t done = 0;
    while (done < size) {
        ssize_t n =
            pread(io->fd, (char *)buffer + done, (size_t)(size - done), (off_t)(offset + done));
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0) {
            int e = errno;
            exr_io_failed(io, "read", size, offset, strerror(e));
            error_cb(ctxt, EXR_ERR_READ_IO,
                     "read of %" PRIu64 " bytes at offset %" PRIu64 " failed: %s", size, offset,
                     strerror(e));
            return -1;
        }
        if (n == 0)
            break; /* end of file: the library reports the short read with its context */
        done += (uint64_t)n;
    }
    return (int64_t)done;
}

static int64_t exr_io_size(exr_const_context_t ctxt, void *user)
{
    (void)ctxt;
    exr_io_t *io = user;
    struct stat st;
    if (fstat(io->fd, &st) != 0)
        return -1; /* -1 tells the library the size is unknown */
    return (int64_t)st.st_size;
}

static int64_t exr_io_write(exr_const_context_t ctxt, void *user, const void *buffer, uint64_t size,
                            uint64_t offset, exr_stream_error_func_ptr_t error_cb)
{
    exr_io_t *io = user;
    uint64_t done = 0;
    while (done < size) {
        ssize_t n = pwrite(io->fd, (const char *)buffer + done, (size_t)(size - done),
                           (off_t)(offset + done));
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0) {
            const char *why = n < 0 ? strerror(errno) : "no progress";
            exr_io_failed(io, "write", size, offset, why);
            error_cb(ctxt, EXR_ERR_WRITE_IO,
                     "write of %" PRIu64 " bytes at offset %" PRIu64 " failed: %s", size, offset,
                     why);
            return -1;
        }
        done += (uint64_t)n;
    }
    return (int64_t)done;
}

/* "what failed: library message" for a failed OpenEXRCore call. */
static const char *exr_io_reason(const exr_io_t *io, exr_result_t rv)
{
    return io->msg[0] != '\0' ? io->msg : exr_get_default_error_message(rv);
}

static const char *compression_name(exr_compression_t c)
{
    static const char *const names[] = {"NONE",  "RLE", "ZIPS", "ZIP",  "PIZ",
                                        "PXR24", "B44", "B44A", "DWAA", "DWAB"};
    return (c >= 0 && (size_t)c < sizeof names / sizeof names[0]) ? names[c] : "unknown";
}

/* ---------------------------------------------------------------------------------------- */
/* Channel names of the spectral layout (Fichet, Pacanowski & Wilkie 2021, section 3).      */

int image_exr_format_channel_name(double centre_nm, char *buf, size_t size, err_t *err)
{
    return image_exr_format_stokes_channel_name(0, centre_nm, buf, size, err);
}

int image_exr_format_stokes_channel_name(int k, double centre_nm, char *buf, size_t size,
                                         err_t *err)
{
    if (k < 0 || k > 3)
        return err_set(err, "Stokes component %d is not 0..3", k);
    if (!isfinite(centre_nm) || centre_nm <= 0.0)
        return err_set(err, "bucket centre %g nm is not a positive finite wavelength", centre_nm);
    char number[64];
    int n = snprintf(number, sizeof number, "%f", centre_nm);
    if (n < 0 || (size_t)n >= sizeof number)
        return err_set(err, "bucket centre %g nm cannot be formatted", centre_nm);
    /* '.' separates layers in EXR channel names, so the layout writes a decimal comma. The
     * decimal point is whatever the C locale printed: replace the one non-digit character. */
    for (char *c = number; *c != '\0'; c++) {
        if (*c < '0' || *c > '9')
            *c = ',';
    }
    n = snprintf(buf, size, "S%d.%snm", k, number);
    if (n < 0 || (size_t)n >= size || n >= IMAGE_EXR_CHANNEL_NAME_MAX)
        return err_set(err, "bucket centre %g nm gives a channel name longer than %d characters",
                       centre_nm, IMAGE_EXR_CHANNEL_NAME_MAX - 1);
    return 0;
}

/* 10^k in double; exact for |k| <= 22, which covers every SI prefix with the 1e9 for nm. */
static double power_of_ten(int k)
{
    double p = 1.0;
    for (int i = 0; i < (k < 0 ? -k : k); i++)
        p *= 10.0;
    return k < 0 ? 1.0 / p : p;
}

/* Matches \d*,?\d*([Ee][+-]?\d+)? on text[0..len) and returns its value; false if the text does
 * not match or has no mantissa digit. */
static bool parse_layout_number(const char *text, size_t len, double *value)
{
    char copy[64];
    if (len == 0 || len >= sizeof copy)
        return false;
    size_t i = 0;
    int mantissa_digits = 0;
    while (i < len && text[i] >= '0' && text[i] <= '9') {
        i++;
        mantissa_digits++;
    }
    if (i < len && text[i] == ',')
        i++;
    while (i < len && text[i] >= '0' && text[i] <= '9') {
        i++;
        mantissa_digits++;
    }
    if (i < len && (text[i] == 'E' || text[i] == 'e')) {
        i++;
        if (i < len && (text[i] == '+' || text[i] == '-'))
            i++;
        int exponent_digits = 0;
        while (i < len && text[i] >= '0' && text[i] <= '9') {
            i++;
            exponent_digits++;
        }
        if (exponent_digits == 0)
            return false;
    }
    if (i != len || mantissa_digits == 0)
        return false;
    /* strtod reads the locale's decimal point, so put that where the comma was. */
    const char point = localeconv()->decimal_point[0];
    memcpy(copy, text, len);
    copy[len] = '\0';
    for (size_t k = 0; k < len; k++) {
        if (copy[k] == ',')
            copy[k] = point;
    }
    char *end = NULL;
    errno = 0;
    *value = strtod(copy, &end);
    return end == copy + len && errno == 0;
}

bool image_exr_parse_channel_name(const char *name, int *stokes, double *wavelength_nm)
{
    static const struct {
        const char *symbol;
        int exponent;
    } prefixes[] = {{"da", 1}, {"Y", 24}, {"Z", 21}, {"E", 18}, {"P", 15}, {"T", 12},
                    {"G", 9},  {"M", 6},  {"k", 3},  {"h", 2},  {"d", -1}, {"c", -2},
                    {"m", -3}, {"u", -6}, {"n", -9}, {"p", -12}};
    int s;
    const char *p = name;
    if (p[0] == 'S' && p[1] >= '0' && p[1] <= '3') {
        s = p[1] - '0';
        p += 2;
    } else if (p[0] == 'T') {
        s = -1;
        p += 1;
    } else {
        return false;
    }
    if (*p != '.')
        return false;
    p++;

    /* Read the suffix from the end: the unit, then an optional SI prefix. A prefix letter can
     * never be the end of the number (which ends in a digit or a comma), so this is the one way
     * the pattern can match. */
    size_t len = strlen(p);
    bool hertz;
    if (len >= 2 && strcmp(p + len - 2, "Hz") == 0) {
        hertz = true;
        len -= 2;
    } else if (len >= 1 && p[len - 1] == 'm') {
        hertz = false;
        len -= 1;
    } else {
        return false;
    }
    int exponent = 0;
    for (size_t i = 0; i < sizeof prefixes / sizeof prefixes[0]; i++) {
        size_t plen = strlen(prefixes[i].symbol);
        if (len >= plen && strncmp(p + len - plen, prefixes[i].symbol, plen) == 0) {
            exponent = prefixes[i].exponent;
            len -= plen;
            break;
        }
    }
    double value;
    if (!parse_layout_number(p, len, &value))
        return false;

    double nm;
    if (hertz) {
        /* lambda = c / f with c = 299792458 m/s exactly (SI definition); c in nm/s is the exact
         * double 299792458e9. */
        double hz =
            exponent >= 0 ? value * power_of_ten(exponent) : value / power_of_ten(-exponent);
        nm = 299792458e9 / hz;
    } else {
        int k = exponent + 9; /* metres to nanometres */
        nm = k >= 0 ? value * power_of_ten(k) : value / power_of_ten(-k);
    }
    if (!isfinite(nm) || nm <= 0.0)
        return false;
    if (stokes)
        *stokes = s;
    if (wavelength_nm)
        *wavelength_nm = nm;
    return true;
}

/* ---------------------------------------------------------------------------------------- */
/* Writing                                                                                  */

/* Where the floats of one output channel live in the caller's interleaved array. */
typedef struct exr_source {
    char name[IMAGE_EXR_CHANNEL_NAME_MAX];
    const float *first; /* value of pixel (0, 0) */
    int stride;         /* floats from one pixel to the next */
} exr_source_t;

typedef struct exr_string_attr {
    const char *name;
    const char *value; /* NULL: not written */
} exr_string_attr_t;

static int check_finite(const char *path, const char *what, const float *v, size_t count,
                        int per_pixel, int width, err_t *err)
{
    for (size_t i = 0; i < count; i++) {
        if (!isfinite(v[i])) {
            size_t pixel = i / (size_t)per_pixel;
            return err_set(err, "%s: %s value %zu of pixel (%zu, %zu) is %s", path, what,
                           i % (size_t)per_pixel, pixel % (size_t)width, pixel / (size_t)width,
                           isnan(v[i]) ? "NaN" : "infinite");
        }
    }
    return 0;
}

static int check_size(const char *path, int width, int height, int per_pixel, err_t *err)
{
    if (width < 1 || height < 1)
        return err_set(err, "%s: image size %dx%d is not positive", path, width, height);
    if ((size_t)width > SIZE_MAX / (size_t)height / (size_t)per_pixel / sizeof(float))
        return err_set(err, "%s: image size %dx%dx%d overflows memory", path, width, height,
                       per_pixel);
    /* OpenEXRCore takes the distance between rows as an int32 of bytes. */
    if ((size_t)width * (size_t)per_pixel * sizeof(float) > INT32_MAX)
        return err_set(err, "%s: a row of %d pixels x %d channels is too long for OpenEXRCore",
                       path, width, per_pixel);
    return 0;
}

/* Encodes every scanline chunk of part 0 from the sources, matching the library's (sorted)
 * channel list to the sources by name. */
/* OpenEXRCore before 3.4.8 (AcademySoftwareFoundation/openexr#2306) keeps the zlib bytes of a
 * chunk whose compressed size equals its packed size, while every reader takes a chunk of that
 * size as stored raw: the chunk reads back as noise. This runs the library's compressor and then
 * stores such a chunk raw, as the fixed library does. The original routine travels in
 * encoding_user_data. */
typedef struct exr_compress_guard {
    exr_result_t (*compress)(exr_encode_pipeline_t *enc);
} exr_compress_guard_t;

static exr_result_t exr_compress_guarded(exr_encode_pipeline_t *enc)
{
    const exr_compress_guard_t *g = enc->encoding_user_data;
    exr_result_t rv = g->compress(enc);
    if (rv == EXR_ERR_SUCCESS && enc->compressed_bytes == enc->packed_bytes &&
        enc->compressed_buffer != NULL && enc->compressed_buffer != enc->packed_buffer)
        memcpy(enc->compressed_buffer, enc->packed_buffer, enc->packed_bytes);
    return rv;
}

static int exr_encode_all(exr_context_t ctx, const exr_io_t *io, const char *path, int width,
                          int height, const exr_source_t *sources, int n_sources, err_t *err)
{
    int32_t lines = 0;
    exr_result_t rv = exr_get_scanlines_per_chunk(ctx, 0, &lines);
    if (rv != EXR_ERR_SUCCESS || lines < 1)
        return err_set(err, "%s: cannot query scanlines per chunk: %s", path,
                       exr_io_reason(io, rv));

    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    exr_compress_guard_t guard = {NULL};
    bool initialised = false;
    int status = 0;
    for (int y = 0; y < height && status == 0; y += lines) {
        exr_chunk_info_t chunk;
        rv = exr_write_scanline_chunk_info(ctx, 0, y, &chunk);
        if (rv == EXR_ERR_SUCCESS)
            rv = initialised ? exr_encoding_update(ctx, 0, &chunk, &enc)
                             : exr_encoding_initialize(ctx, 0, &chunk, &enc);
        if (rv != EXR_ERR_SUCCESS) {
            status = err_set(err, "%s: cannot prepare the chunk at scanline %d: %s", path, y,
                             exr_io_reason(io, rv));
            break;
        }
        initialised = true;
        for (int c = 0; c < enc.channel_count && status == 0; c++) {
            exr_coding_channel_info_t *ch = &enc.channels[c];
            const exr_source_t *src = NULL;
            for (int s = 0; s < n_sources; s++) {
                if (strcmp(sources[s].name, ch->channel_name) == 0)
                    src = &sources[s];
            }
            if (src == NULL) {
                status = err_set(err, "%s: the library lists channel '%s' that was not added", path,
                                 ch->channel_name);
                break;
            }
            ch->user_data_type = EXR_PIXEL_FLOAT;
            ch->user_bytes_per_element = (int16_t)sizeof(float);
            ch->user_pixel_stride = (int32_t)(src->stride * (int)sizeof(float));
            ch->user_line_stride = (int32_t)((size_t)width * (size_t)src->stride * sizeof(float));
            ch->encode_from_ptr =
                (const uint8_t *)(src->first +
                                  (size_t)(chunk.start_y) * (size_t)width * (size_t)src->stride);
        }
        if (status != 0)
            break;
        rv = exr_encoding_choose_default_routines(ctx, 0, &enc);
        /* (The routines may be kept from the previous chunk: never wrap the guard itself.) */
        if (rv == EXR_ERR_SUCCESS && enc.compress_fn != NULL &&
            enc.compress_fn != exr_compress_guarded) {
            guard.compress = enc.compress_fn;
            enc.encoding_user_data = &guard;
            enc.compress_fn = exr_compress_guarded;
        }
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_encoding_run(ctx, 0, &enc);
        if (rv != EXR_ERR_SUCCESS)
            status = err_set(err, "%s: cannot encode the chunk at scanline %d: %s", path, y,
                             exr_io_reason(io, rv));
    }
    if (initialised) {
        rv = exr_encoding_destroy(ctx, &enc);
        if (rv != EXR_ERR_SUCCESS && status == 0)
            status =
                err_set(err, "%s: cannot release the encoder: %s", path, exr_io_reason(io, rv));
    }
    return status;
}

/* Writes a single-part FLOAT scanline ZIP file to PATH.tmp, fsyncs it and renames it over
 * PATH, so that a crash leaves either the old file or the new one, never half of one. */
static int exr_write_file(const char *path, int width, int height, const exr_source_t *sources,
                          int n_sources, const exr_string_attr_t *attrs, int n_attrs, err_t *err)
{
    size_t path_len = strlen(path);
    char *tmp = malloc(path_len + 5);
    if (tmp == NULL)
        return err_set(err, "%s: out of memory", path);
    memcpy(tmp, path, path_len);
    memcpy(tmp + path_len, ".tmp", 5);

    exr_io_t io = {.fd = -1, .msg = ""};
    if (files_check_replaceable(path, err) < 0) {
        free(tmp);
        return -1;
    }
    /* Never through a link or into a FIFO or device someone left at PATH.tmp. */
    io.fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC, 0644);
    struct stat tmp_st;
    if (io.fd >= 0 && (fstat(io.fd, &tmp_st) != 0 || !S_ISREG(tmp_st.st_mode))) {
        (void)close(io.fd);
        io.fd = -1;
        errno = EINVAL;
    }
    if (io.fd < 0) {
        int e = errno;
        free(tmp);
        return err_set(err, "%s: cannot create %s.tmp: %s", path, path,
                       e == EINVAL ? "it exists and is not a regular file" : strerror(e));
    }

    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_io_on_error;
    init.user_data = &io;
    init.write_fn = exr_io_write;

    exr_context_t ctx = NULL;
    int status = 0;
    exr_io_current = &io;
    exr_result_t rv = exr_start_write(&ctx, tmp, EXR_WRITE_FILE_DIRECTLY, &init);
    if (rv != EXR_ERR_SUCCESS)
        status = err_set(err, "%s: cannot start the EXR writer: %s", path, exr_io_reason(&io, rv));

    int part = -1;
    if (status == 0) {
        rv = exr_add_part(ctx, NULL, EXR_STORAGE_SCANLINE, &part);
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_initialize_required_attr_simple(ctx, part, width, height, EXR_COMPRESSION_ZIP);
        /* Rendered float spectra are noise in their low bits: zlib's default level 6 shrank a
         * 960x540 16-bucket image by 5 % more than level 1 at three times the time (0.6 s of
         * a 1.7 s render), and the master writes this file while its workers wait. */
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_set_zip_compression_level(ctx, part, 1);
        if (rv != EXR_ERR_SUCCESS)
            status =
                err_set(err, "%s: cannot set up the image part: %s", path, exr_io_reason(&io, rv));
    }
    for (int s = 0; s < n_sources && status == 0; s++) {
        /* FLOAT, never HALF: radiance above 65504 (a sun-like source) would overflow. The
         * perceptual hint only matters to lossy codecs; ZIP is lossless. */
        rv = exr_add_channel(ctx, part, sources[s].name, EXR_PIXEL_FLOAT,
                             EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
        if (rv != EXR_ERR_SUCCESS)
            status = err_set(err, "%s: cannot add channel '%s': %s", path, sources[s].name,
                             exr_io_reason(&io, rv));
    }
    if (status == 0) {
        /* R, G, B are linear sRGB: the Rec. 709 primaries and the D65 white point of
         * IEC 61966-2-1 (data/srgb_matrices.txt). */
        const exr_attr_chromaticities_t srgb = {0.6400f, 0.3300f, 0.3000f, 0.6000f,
                                                0.1500f, 0.0600f, 0.3127f, 0.3290f};
        rv = exr_attr_set_chromaticities(ctx, part, "chromaticities", &srgb);
        if (rv != EXR_ERR_SUCCESS)
            status =
                err_set(err, "%s: cannot set chromaticities: %s", path, exr_io_reason(&io, rv));
    }
    for (int a = 0; a < n_attrs && status == 0; a++) {
        if (attrs[a].value == NULL)
            continue;
        rv = exr_attr_set_string(ctx, part, attrs[a].name, attrs[a].value);
        if (rv != EXR_ERR_SUCCESS)
            status = err_set(err, "%s: cannot set attribute '%s': %s", path, attrs[a].name,
                             exr_io_reason(&io, rv));
    }
    if (status == 0) {
        rv = exr_write_header(ctx);
        if (rv != EXR_ERR_SUCCESS)
            status = err_set(err, "%s: cannot write the header: %s", path, exr_io_reason(&io, rv));
    }
    if (status == 0)
        status = exr_encode_all(ctx, &io, path, width, height, sources, n_sources, err);
    if (ctx != NULL) {
        /* exr_finish writes the chunk offset table, so its failure is a failed write. */
        rv = exr_finish(&ctx);
        if (rv != EXR_ERR_SUCCESS && status == 0)
            status = err_set(err, "%s: cannot finish the file: %s", path, exr_io_reason(&io, rv));
    }
    exr_io_current = NULL;
    if (status == 0 && fsync(io.fd) != 0)
        status = err_set(err, "%s: cannot flush to disk: %s", path, strerror(errno));
    if (close(io.fd) != 0 && status == 0)
        status = err_set(err, "%s: cannot close: %s", path, strerror(errno));
    if (status == 0)
        status = files_check_replaceable(path, err);
    if (status == 0 && rename(tmp, path) != 0)
        status = err_set(err, "%s: cannot rename %s into place: %s", path, tmp, strerror(errno));
    if (status != 0)
        (void)unlink(tmp); /* best effort: the message already names the real failure */
    free(tmp);
    return status;
}

int image_exr_write_rgb(const char *path, int width, int height, const float *rgb, int channels,
                        const char *info, err_t *err)
{
    if (channels != 3 && channels != 4)
        return err_set(err, "%s: %d channels per pixel (expected 3 for RGB or 4 for RGBA)", path,
                       channels);
    if (rgb == NULL)
        return err_set(err, "%s: no pixels given", path);
    if (check_size(path, width, height, channels, err) != 0)
        return -1;
    size_t count = (size_t)width * (size_t)height * (size_t)channels;
    if (check_finite(path, "RGB(A)", rgb, count, channels, width, err) != 0)
        return -1;

    static const char *const names[] = {"R", "G", "B", "A"};
    exr_source_t sources[4];
    for (int c = 0; c < channels; c++) {
        snprintf(sources[c].name, sizeof sources[c].name, "%s", names[c]);
        sources[c].first = rgb + c;
        sources[c].stride = channels;
    }
    const exr_string_attr_t attrs[] = {{"prismfarm", info}};
    return exr_write_file(path, width, height, sources, channels, attrs, 1, err);
}

int image_exr_write_spectral(const char *path, int width, int height, const float *rgb,
                             const float *spectral, int n_buckets, const double *centres_nm,
                             const char *emissive_units, const char *info, err_t *err)
{
    return image_exr_write_stokes(path, width, height, rgb, spectral, n_buckets, 1, centres_nm,
                                  emissive_units, info, err);
}

int image_exr_write_stokes(const char *path, int width, int height, const float *rgb,
                           const float *spectral, int n_buckets, int planes,
                           const double *centres_nm, const char *emissive_units, const char *info,
                           err_t *err)
{
    if (planes != 1 && planes != 4)
        return err_set(err, "%s: %d Stokes planes (1 or 4)", path, planes);
    if (n_buckets < 1)
        return err_set(err, "%s: %d spectral buckets (need at least 1)", path, n_buckets);
    if (rgb == NULL || spectral == NULL || centres_nm == NULL)
        return err_set(err, "%s: missing RGB pixels, spectral pixels or bucket centres", path);
    if (emissive_units == NULL)
        emissive_units = IMAGE_EXR_DEFAULT_EMISSIVE_UNITS;
    if (emissive_units[0] == '\0')
        return err_set(err, "%s: empty emissiveUnits", path);
    const int nch = planes * n_buckets;
    if (check_size(path, width, height, nch + 3, err) != 0)
        return -1;
    size_t n_pixels = (size_t)width * (size_t)height;
    if (check_finite(path, "RGB", rgb, n_pixels * 3, 3, width, err) != 0 ||
        check_finite(path, "spectral", spectral, n_pixels * (size_t)nch, nch, width, err) != 0)
        return -1;

    exr_source_t *sources = calloc((size_t)nch + 3, sizeof *sources);
    if (sources == NULL)
        return err_set(err, "%s: out of memory for %d channels", path, nch + 3);
    static const char *const names[] = {"R", "G", "B"};
    for (int c = 0; c < 3; c++) {
        snprintf(sources[c].name, sizeof sources[c].name, "%s", names[c]);
        sources[c].first = rgb + c;
        sources[c].stride = 3;
    }
    int status = 0;
    for (int c = 0; c < nch && status == 0; c++) {
        const int k = c % n_buckets, plane = c / n_buckets;
        exr_source_t *s = &sources[3 + c];
        if (image_exr_format_stokes_channel_name(plane, centres_nm[k], s->name, sizeof s->name,
                                                 err) != 0) {
            status = err_prefix(err, "%s: bucket %d: ", path, k);
            break;
        }
        for (int j = 0; j < k && plane == 0; j++) {
            if (strcmp(sources[3 + j].name, s->name) == 0)
                status = err_set(err,
                                 "%s: buckets %d and %d (%.9g and %.9g nm) both give the "
                                 "channel name %s",
                                 path, j, k, centres_nm[j], centres_nm[k], s->name);
        }
        s->first = spectral + c;
        s->stride = nch;
    }
    if (status == 0) {
        const exr_string_attr_t attrs[] = {
            {"spectralLayoutVersion", "1.0"},
            {"emissiveUnits", emissive_units},
            {"prismfarm", info},
            {"polarisationHandedness", "right"},
        };
        status =
            exr_write_file(path, width, height, sources, nch + 3, attrs, planes == 4 ? 4 : 3, err);
    }
    free(sources);
    return status;
}

/* ---------------------------------------------------------------------------------------- */
/* Reading                                                                                  */

struct image_exr {
    int width, height;
    float *rgb;
    float *alpha;
    int n_spectral;
    double *wavelengths_nm;
    float *spectral;
    float *stokes[3]; /* S1, S2, S3 laid out as spectral; NULL without a full set */
    int n_attrs;
    char **attr_names;
    char **attr_values;
};

/* Where the decoder puts one input channel in our arrays. */
typedef struct exr_dest {
    const char *name; /* points into the library's channel list */
    float *first;
    int stride;
    double wavelength_nm; /* spectral channels only, for sorting */
} exr_dest_t;

void image_exr_destroy(image_exr_t **self_p)
{
    if (self_p == NULL || *self_p == NULL)
        return;
    image_exr_t *self = *self_p;
    free(self->rgb);
    free(self->alpha);
    free(self->wavelengths_nm);
    free(self->spectral);
    for (int k = 0; k < 3; k++)
        free(self->stokes[k]);
    for (int i = 0; i < self->n_attrs; i++) {
        free(self->attr_names[i]);
        free(self->attr_values[i]);
    }
    free(self->attr_names);
    free(self->attr_values);
    free(self);
    *self_p = NULL;
}

int image_exr_width(const image_exr_t *self)
{
    return self->width;
}
int image_exr_height(const image_exr_t *self)
{
    return self->height;
}
const float *image_exr_rgb(const image_exr_t *self)
{
    return self->rgb;
}
const float *image_exr_alpha(const image_exr_t *self)
{
    return self->alpha;
}
int image_exr_n_spectral(const image_exr_t *self)
{
    return self->n_spectral;
}
const double *image_exr_wavelengths_nm(const image_exr_t *self)
{
    return self->wavelengths_nm;
}
const float *image_exr_spectral(const image_exr_t *self)
{
    return self->spectral;
}

const float *image_exr_stokes(const image_exr_t *self, int k)
{
    return k >= 1 && k <= 3 ? self->stokes[k - 1] : NULL;
}

const char *image_exr_attribute(const image_exr_t *self, const char *name)
{
    for (int i = 0; i < self->n_attrs; i++) {
        if (strcmp(self->attr_names[i], name) == 0)
            return self->attr_values[i];
    }
    return NULL;
}

static int compare_dest_wavelength(const void *a, const void *b)
{
    double la = ((const exr_dest_t *)a)->wavelength_nm;
    double lb = ((const exr_dest_t *)b)->wavelength_nm;
    return (la > lb) - (la < lb);
}

/* Decodes one chunk whose top-left pixel is (x0, y0) in data-window coordinates. */
static int exr_decode_chunk(exr_const_context_t ctx, const exr_io_t *io, const char *path,
                            exr_compression_t compression, const exr_chunk_info_t *chunk, int x0,
                            int y0, const image_exr_t *img, const exr_dest_t *dests, int n_dests,
                            exr_decode_pipeline_t *dec, bool *initialised, err_t *err)
{
    if (x0 < 0 || y0 < 0 || chunk->width < 1 || chunk->height < 1 ||
        x0 + chunk->width > img->width || y0 + chunk->height > img->height)
        return err_set(err, "%s: chunk %d (%dx%d at %d,%d) lies outside the %dx%d data window",
                       path, chunk->idx, chunk->width, chunk->height, x0, y0, img->width,
                       img->height);
    exr_result_t rv = *initialised ? exr_decoding_update(ctx, 0, chunk, dec)
                                   : exr_decoding_initialize(ctx, 0, chunk, dec);
    if (rv != EXR_ERR_SUCCESS)
        return err_set(err, "%s: cannot prepare chunk %d (pixel row %d): %s", path, chunk->idx, y0,
                       exr_io_reason(io, rv));
    *initialised = true;
    for (int c = 0; c < dec->channel_count; c++) {
        exr_coding_channel_info_t *ch = &dec->channels[c];
        const exr_dest_t *dest = NULL;
        for (int d = 0; d < n_dests; d++) {
            if (strcmp(dests[d].name, ch->channel_name) == 0)
                dest = &dests[d];
        }
        if (dest == NULL) {
            ch->decode_to_ptr = NULL; /* a channel we do not keep: the decoder skips it */
            continue;
        }
        ch->user_data_type = EXR_PIXEL_FLOAT;
        ch->user_bytes_per_element = (int16_t)sizeof(float);
        ch->user_pixel_stride = (int32_t)(dest->stride * (int)sizeof(float));
        ch->user_line_stride = (int32_t)((size_t)img->width * (size_t)dest->stride * sizeof(float));
        ch->decode_to_ptr =
            (uint8_t *)(dest->first +
                        ((size_t)y0 * (size_t)img->width + (size_t)x0) * (size_t)dest->stride);
    }
    rv = exr_decoding_choose_default_routines(ctx, 0, dec);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_decoding_run(ctx, 0, dec);
    if (rv == EXR_ERR_FEATURE_NOT_IMPLEMENTED)
        return err_set(err,
                       "%s: compression %s is not supported by this OpenEXRCore library "
                       "(re-save the file with ZIP or PIZ compression)",
                       path, compression_name(compression));
    if (rv != EXR_ERR_SUCCESS)
        return err_set(err,
                       "%s: cannot decode chunk %d (pixel row %d; %s compression; file "
                       "truncated or corrupt?): %s",
                       path, chunk->idx, y0, compression_name(compression), exr_io_reason(io, rv));
    return 0;
}

static int exr_decode_all(exr_const_context_t ctx, const exr_io_t *io, const char *path,
                          exr_storage_t storage, exr_compression_t compression, exr_attr_box2i_t dw,
                          const image_exr_t *img, const exr_dest_t *dests, int n_dests, err_t *err)
{
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    bool initialised = false;
    int status = 0;
    exr_result_t rv;
    if (storage == EXR_STORAGE_SCANLINE) {
        int32_t lines = 0;
        rv = exr_get_scanlines_per_chunk(ctx, 0, &lines);
        if (rv != EXR_ERR_SUCCESS || lines < 1)
            return err_set(err, "%s: cannot query scanlines per chunk: %s", path,
                           exr_io_reason(io, rv));
        for (int64_t y = dw.min.y; y <= dw.max.y && status == 0; y += lines) {
            exr_chunk_info_t chunk;
            rv = exr_read_scanline_chunk_info(ctx, 0, (int)y, &chunk);
            if (rv != EXR_ERR_SUCCESS) {
                status = err_set(err,
                                 "%s: cannot locate the chunk of scanline %" PRId64
                                 " (file truncated or corrupt?): %s",
                                 path, y, exr_io_reason(io, rv));
                break;
            }
            status = exr_decode_chunk(ctx, io, path, compression, &chunk, chunk.start_x - dw.min.x,
                                      chunk.start_y - dw.min.y, img, dests, n_dests, &dec,
                                      &initialised, err);
        }
    } else {
        /* Tiled: level (0, 0) is the full-resolution image whatever the mip/rip mode. The chunk
         * info of a tile holds tile indices, so pixel positions come from the tile size. */
        int32_t tile_w = 0, tile_h = 0;
        rv = exr_get_tile_sizes(ctx, 0, 0, 0, &tile_w, &tile_h);
        if (rv != EXR_ERR_SUCCESS || tile_w < 1 || tile_h < 1)
            return err_set(err, "%s: cannot query the tile size: %s", path, exr_io_reason(io, rv));
        int tiles_x = (int)(((int64_t)img->width + tile_w - 1) / tile_w);
        int tiles_y = (int)(((int64_t)img->height + tile_h - 1) / tile_h);
        for (int ty = 0; ty < tiles_y && status == 0; ty++) {
            for (int tx = 0; tx < tiles_x && status == 0; tx++) {
                exr_chunk_info_t chunk;
                rv = exr_read_tile_chunk_info(ctx, 0, tx, ty, 0, 0, &chunk);
                if (rv != EXR_ERR_SUCCESS) {
                    status = err_set(err,
                                     "%s: cannot locate tile (%d, %d) (file truncated or "
                                     "corrupt?): %s",
                                     path, tx, ty, exr_io_reason(io, rv));
                    break;
                }
                status =
                    exr_decode_chunk(ctx, io, path, compression, &chunk, tx * tile_w, ty * tile_h,
                                     img, dests, n_dests, &dec, &initialised, err);
            }
        }
    }
    if (initialised) {
        rv = exr_decoding_destroy(ctx, &dec);
        if (rv != EXR_ERR_SUCCESS && status == 0)
            status =
                err_set(err, "%s: cannot release the decoder: %s", path, exr_io_reason(io, rv));
    }
    return status;
}

static int exr_copy_string_attributes(exr_const_context_t ctx, const exr_io_t *io, const char *path,
                                      image_exr_t *img, err_t *err)
{
    int32_t count = 0;
    exr_result_t rv = exr_get_attribute_count(ctx, 0, &count);
    if (rv != EXR_ERR_SUCCESS)
        return err_set(err, "%s: cannot count attributes: %s", path, exr_io_reason(io, rv));
    if (count < 1)
        return 0;
    img->attr_names = calloc((size_t)count, sizeof *img->attr_names);
    img->attr_values = calloc((size_t)count, sizeof *img->attr_values);
    if (img->attr_names == NULL || img->attr_values == NULL)
        return err_set(err, "%s: out of memory for %d attributes", path, count);
    for (int32_t i = 0; i < count; i++) {
        const exr_attribute_t *attr = NULL;
        rv = exr_get_attribute_by_index(ctx, 0, EXR_ATTR_LIST_FILE_ORDER, i, &attr);
        if (rv != EXR_ERR_SUCCESS)
            return err_set(err, "%s: cannot read attribute %d: %s", path, i, exr_io_reason(io, rv));
        if (attr->type != EXR_ATTR_STRING || attr->string == NULL)
            continue;
        size_t len = attr->string->length > 0 ? (size_t)attr->string->length : 0;
        char *name = strdup(attr->name);
        char *value = malloc(len + 1);
        if (name == NULL || value == NULL) {
            free(name);
            free(value);
            return err_set(err, "%s: out of memory for attribute '%s'", path, attr->name);
        }
        if (len > 0)
            memcpy(value, attr->string->str, len);
        value[len] = '\0';
        img->attr_names[img->n_attrs] = name;
        img->attr_values[img->n_attrs] = value;
        img->n_attrs++;
    }
    return 0;
}

/* Finds R, G, B, A and the S0 channels, allocates the arrays and fills dests (capacity: the
 * number of channels in the file). */
static int exr_plan_channels(const char *path, const exr_attr_chlist_t *chlist, image_exr_t *img,
                             exr_dest_t *dests, int *n_dests, err_t *err)
{
    static const char *const rgba[] = {"R", "G", "B", "A"};
    int rgba_index[4] = {-1, -1, -1, -1};
    int n_spectral = 0, n_polar = 0;
    for (int i = 0; i < chlist->num_channels; i++) {
        const char *name = chlist->entries[i].name.str;
        int stokes;
        double nm;
        for (int c = 0; c < 4; c++) {
            if (strcmp(name, rgba[c]) == 0)
                rgba_index[c] = i;
        }
        if (image_exr_parse_channel_name(name, &stokes, &nm)) {
            n_spectral += stokes == 0;
            n_polar += stokes > 0;
        }
    }
    /* S1-S3 are read when all three planes cover the S0 channels (image_exr_write_stokes'
     * layout); any other set of them is left unread, as before they were read at all. */
    const int planes = n_spectral > 0 && n_polar == 3 * n_spectral ? 4 : 1;
    for (int c = 0; c < 3; c++) {
        if (rgba_index[c] < 0)
            return err_set(err,
                           "%s: no channel named '%s' (the file has %d channels%s; prismfarm "
                           "reads R, G and B)",
                           path, rgba[c], chlist->num_channels,
                           n_spectral > 0 ? ", spectral ones among them" : "");
    }

    size_t n_pixels = (size_t)img->width * (size_t)img->height;
    if (n_pixels > SIZE_MAX / sizeof(float) / (size_t)(planes * n_spectral + 4) ||
        (size_t)img->width * (size_t)(planes * n_spectral + 3) * sizeof(float) > INT32_MAX)
        return err_set(err, "%s: %dx%d pixels with %d channels are too large to read", path,
                       img->width, img->height, n_spectral + 4);
    img->rgb = calloc(n_pixels * 3, sizeof(float));
    if (rgba_index[3] >= 0)
        img->alpha = calloc(n_pixels, sizeof(float));
    if (n_spectral > 0) {
        img->spectral = calloc(n_pixels * (size_t)n_spectral, sizeof(float));
        img->wavelengths_nm = calloc((size_t)n_spectral, sizeof(double));
    }
    for (int k = 0; k < 3 && planes > 1; k++)
        if (!(img->stokes[k] = calloc(n_pixels * (size_t)n_spectral, sizeof(float))))
            return err_set(err, "%s: out of memory for %dx%d pixels", path, img->width,
                           img->height);
    if (img->rgb == NULL || (rgba_index[3] >= 0 && img->alpha == NULL) ||
        (n_spectral > 0 && (img->spectral == NULL || img->wavelengths_nm == NULL)))
        return err_set(err, "%s: out of memory for %dx%d pixels", path, img->width, img->height);
    img->n_spectral = n_spectral;

    int n = 0;
    for (int c = 0; c < 4; c++) {
        if (rgba_index[c] < 0)
            continue;
        dests[n].name = chlist->entries[rgba_index[c]].name.str;
        dests[n].first = c < 3 ? img->rgb + c : img->alpha;
        dests[n].stride = c < 3 ? 3 : 1;
        n++;
    }
    exr_dest_t *spectral = dests + n;
    int k = 0;
    for (int i = 0; i < chlist->num_channels; i++) {
        int stokes;
        double nm;
        const char *name = chlist->entries[i].name.str;
        if (image_exr_parse_channel_name(name, &stokes, &nm) && stokes == 0) {
            spectral[k].name = name;
            spectral[k].wavelength_nm = nm;
            k++;
        }
    }
    /* The file stores channels sorted by name ("S0.1000,0nm" before "S0.380,0nm"): order the
     * buckets by wavelength instead, and refuse two channels for the same wavelength. */
    qsort(spectral, (size_t)n_spectral, sizeof *spectral, compare_dest_wavelength);
    for (k = 0; k < n_spectral; k++) {
        if (k > 0 && !(spectral[k].wavelength_nm > spectral[k - 1].wavelength_nm))
            return err_set(err, "%s: channels '%s' and '%s' give the same wavelength %.9g nm", path,
                           spectral[k - 1].name, spectral[k].name, spectral[k].wavelength_nm);
        spectral[k].first = img->spectral + k;
        spectral[k].stride = n_spectral;
        img->wavelengths_nm[k] = spectral[k].wavelength_nm;
    }
    n += n_spectral;
    for (int i = 0; i < chlist->num_channels && planes > 1; i++) {
        int stokes;
        double nm;
        const char *name = chlist->entries[i].name.str;
        if (!image_exr_parse_channel_name(name, &stokes, &nm) || stokes == 0)
            continue;
        int at = 0;
        while (at < n_spectral && img->wavelengths_nm[at] != nm)
            at++;
        if (at == n_spectral)
            return err_set(err, "%s: channel '%s' has no S0 channel at its wavelength", path, name);
        dests[n].name = name;
        dests[n].first = img->stokes[stokes - 1] + at;
        dests[n].stride = n_spectral;
        n++;
    }

    for (int d = 0; d < n; d++) {
        for (int i = 0; i < chlist->num_channels; i++) {
            const exr_attr_chlist_entry_t *e = &chlist->entries[i];
            if (e->name.str == dests[d].name && (e->x_sampling != 1 || e->y_sampling != 1))
                return err_set(err,
                               "%s: channel '%s' is subsampled (%d x %d), which prismfarm "
                               "does not read",
                               path, e->name.str, e->x_sampling, e->y_sampling);
        }
    }
    *n_dests = n;
    return 0;
}

image_exr_t *image_exr_read(const char *path, err_t *err)
{
    exr_io_t io = {.fd = -1, .msg = ""};
    io.fd = files_open_regular(path, err); /* a FIFO would block, a device never end */
    if (io.fd < 0)
        return NULL;
    /* Check the magic number ourselves to say plainly what is wrong with, say, a PNG. */
    unsigned char magic[4] = {0};
    ssize_t got = pread(io.fd, magic, sizeof magic, 0);
    if (got != (ssize_t)sizeof magic || magic[0] != 0x76 || magic[1] != 0x2f || magic[2] != 0x31 ||
        magic[3] != 0x01) {
        err_set(err, "%s: not an OpenEXR file (%s)", path,
                got < (ssize_t)sizeof magic ? "shorter than the 4-byte magic number"
                                            : "magic number is not 76 2f 31 01");
        (void)close(io.fd); /* read-only: a failed close loses nothing */
        return NULL;
    }

    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_io_on_error;
    init.user_data = &io;
    init.read_fn = exr_io_read;
    init.size_fn = exr_io_size;
    /* A damaged file is reported, not silently patched up. */
    init.flags = EXR_CONTEXT_FLAG_DISABLE_CHUNK_RECONSTRUCTION;

    image_exr_t *img = calloc(1, sizeof *img);
    exr_dest_t *dests = NULL;
    exr_context_t ctx = NULL;
    int status = 0;
    if (img == NULL)
        status = err_set(err, "%s: out of memory", path);
    exr_result_t rv = EXR_ERR_SUCCESS;
    exr_io_current = &io;
    if (status == 0) {
        rv = exr_start_read(&ctx, path, &init);
        if (rv != EXR_ERR_SUCCESS)
            status =
                err_set(err, "%s: cannot read the EXR header: %s", path, exr_io_reason(&io, rv));
    }

    exr_storage_t storage = EXR_STORAGE_SCANLINE;
    exr_compression_t compression = EXR_COMPRESSION_NONE;
    exr_attr_box2i_t dw = {0};
    const exr_attr_chlist_t *chlist = NULL;
    if (status == 0) {
        rv = exr_get_storage(ctx, 0, &storage);
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_get_compression(ctx, 0, &compression);
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_get_data_window(ctx, 0, &dw);
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_get_channels(ctx, 0, &chlist);
        if (rv != EXR_ERR_SUCCESS || chlist == NULL)
            status = err_set(err, "%s: cannot read the header of part 0: %s", path,
                             exr_io_reason(&io, rv));
    }
    if (status == 0 && storage != EXR_STORAGE_SCANLINE && storage != EXR_STORAGE_TILED)
        status = err_set(err, "%s: part 0 holds deep data, which prismfarm does not read", path);
    /* OpenEXRCore 3.1.5 (Debian 12) decodes B44 and B44A wrongly: FLOAT channels come back
     * shuffled and the last partial row of 4x4 blocks of a HALF tile comes back as garbage
     * (checked against the C++ library on files from exrmaketiled -z b44). Refusing is better
     * than returning wrong radiance. */
    if (status == 0 && (compression == EXR_COMPRESSION_B44 || compression == EXR_COMPRESSION_B44A))
        status = err_set(err,
                         "%s: compression %s is not supported (OpenEXRCore 3.1 decodes it "
                         "incorrectly); re-save the file with ZIP or PIZ compression",
                         path, compression_name(compression));
    if (status == 0) {
        int64_t w = (int64_t)dw.max.x - dw.min.x + 1;
        int64_t h = (int64_t)dw.max.y - dw.min.y + 1;
        if (w < 1 || h < 1 || w > INT32_MAX || h > INT32_MAX)
            status = err_set(err, "%s: data window (%d,%d)-(%d,%d) is empty or too large", path,
                             dw.min.x, dw.min.y, dw.max.x, dw.max.y);
        else {
            img->width = (int)w;
            img->height = (int)h;
        }
    }
    int n_dests = 0;
    if (status == 0) {
        dests = calloc((size_t)chlist->num_channels + 4, sizeof *dests);
        if (dests == NULL)
            status = err_set(err, "%s: out of memory", path);
    }
    if (status == 0)
        status = exr_plan_channels(path, chlist, img, dests, &n_dests, err);
    if (status == 0)
        status = exr_decode_all(ctx, &io, path, storage, compression, dw, img, dests, n_dests, err);
    if (status == 0)
        status = exr_copy_string_attributes(ctx, &io, path, img, err);

    if (ctx != NULL) {
        rv = exr_finish(&ctx);
        if (rv != EXR_ERR_SUCCESS && status == 0)
            status =
                err_set(err, "%s: cannot close the EXR reader: %s", path, exr_io_reason(&io, rv));
    }
    exr_io_current = NULL;
    if (close(io.fd) != 0 && status == 0)
        status = err_set(err, "%s: cannot close: %s", path, strerror(errno));
    free(dests);
    if (status != 0)
        image_exr_destroy(&img);
    return img;
}
