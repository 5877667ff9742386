#define _XOPEN_SOURCE 700 /* realpath, strdup, O_NOFOLLOW, O_CLOEXEC */

#include "pbrt_confine.h"

#include "files.h"
#include "gzip_data.h"
#include "paths.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

/* fopen(path, "rb") for a regular file only: opened without blocking and checked with fstat, so
 * that a FIFO named by a scene, an Include or a texture is refused at once instead of blocking
 * the parse for ever (a device would never end). NULL with errno set, or EINVAL and *kind
 * naming what the path is (files_kind). */
FILE *pbrt_confine_open_regular(const char *path, const char **kind)
{
    *kind = NULL;
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0)
        return NULL;
    struct stat st;
    int flags;
    FILE *f = NULL;
    if (fstat(fd, &st) != 0) {
    } else if (!S_ISREG(st.st_mode)) {
        *kind = files_kind(st.st_mode);
        errno = EINVAL;
    } else if ((flags = fcntl(fd, F_GETFL)) >= 0 && fcntl(fd, F_SETFL, flags & ~O_NONBLOCK) == 0) {
        f = fdopen(fd, "rb");
    }
    if (!f) {
        int e = errno;
        (void)close(fd);
        errno = e;
    }
    return f;
}

/* The reason pbrt_confine_open_regular failed. */
const char *pbrt_confine_open_failure(const char *kind, char *buf, size_t size)
{
    if (!kind)
        return strerror(errno);
    snprintf(buf, size, "it is %s, not a regular file", kind);
    return buf;
}

/* The path a file name written in the current file is opened by: against the folder of the
 * current file; if nothing is there, against the main file's folder (pbrt-v4 resolves every
 * name against the main file's folder); if neither exists, the first (so that the error names
 * it). malloc'ed. */
char *pbrt_confine_locate(parser_t *P, const char *name)
{
    P->also[0] = '\0';
    char *first = paths_resolve(P->file, name);
    if (!first || name[0] == '/' || pbrt_confine_present(P, first))
        return first;
    char *second = paths_resolve(P->main_name, name);
    if (second && strcmp(second, first) != 0 && pbrt_confine_present(P, second)) {
        free(first);
        return second;
    }
    if (second && strcmp(second, first) != 0)
        snprintf(P->also, sizeof P->also, " (also looked for \"%.480s\")", second);
    free(second);
    return first;
}

/* Resolves a file name given in the current file into a scene-owned string. */
const char *pbrt_confine_scene_path(parser_t *P, const char *name, pbrt_loc_t loc)
{
    char *path = pbrt_confine_locate(P, name);
    if (!path) {
        pbrt_error(P->err, loc, "out of memory");
        return NULL;
    }
    if (pbrt_confine_bundle_check(P, path, name, loc) != 0) {
        free(path);
        return NULL;
    }
    const char *s = scene_desc_strdup(P->scene, path, P->err);
    free(path);
    return s;
}

/* -1: out of memory; 0: outside; 1: inside. Touches nothing on disk. */
int pbrt_confine_inside(const parser_t *P, const char *path)
{
    char *n = paths_lexical(path);
    int in = n ? paths_is_under(P->root_lex, n) : -1;
    free(n);
    return in;
}

/* Whether a candidate file exists, without looking outside the root of a confined parse. */
bool pbrt_confine_present(const parser_t *P, const char *path)
{
    return (!P->root_lex || pbrt_confine_inside(P, path) == 1) && access(path, F_OK) == 0;
}

/* Counts bytes against the confined parse's total. */
int pbrt_confine_charge(parser_t *P, uint64_t bytes, const pbrt_loc_t *from)
{
    if (bytes > PBRT_TOTAL_BYTES_MAX - P->bytes_charged)
        return pbrt_state_fail_at(P, from, "the scene reads more than %zu bytes in all",
                                  PBRT_TOTAL_BYTES_MAX);
    P->bytes_charged += (size_t)bytes;
    return 0;
}

/* Checks, without opening it, the file path (written as name at *from; the main file when
 * from is NULL; `what` says what it is, for messages): it must lie in the root lexically and
 * after realpath, be a regular file and hold at most PBRT_FILE_BYTES_MAX bytes. Returns its
 * real path (malloc'ed), or NULL with the message. */
char *pbrt_confine_check(parser_t *P, const char *path, const char *name, const pbrt_loc_t *from,
                         const char *what)
{
    int in = pbrt_confine_inside(P, path);
    if (in < 0) {
        pbrt_state_fail_at(P, from, "out of memory");
        return NULL;
    }
    if (!in) {
        pbrt_state_fail_at(P, from, "\"%s\" is outside the scene's folder", name);
        return NULL;
    }
    char *real = realpath(path, NULL);
    if (!real) {
        pbrt_state_fail_at(P, from, "cannot open %s \"%s\": %s%s", what, path, strerror(errno),
                           P->also);
        return NULL;
    }
    struct stat st;
    if (!paths_is_under(P->root_real, real)) {
        pbrt_state_fail_at(P, from, "\"%s\" is outside the scene's folder", name);
    } else if (stat(real, &st) != 0) {
        pbrt_state_fail_at(P, from, "cannot open %s \"%s\": %s", what, path, strerror(errno));
    } else if (!S_ISREG(st.st_mode)) {
        pbrt_state_fail_at(P, from, "\"%s\" is not a regular file", name);
    } else if ((uint64_t)st.st_size > PBRT_FILE_BYTES_MAX) {
        pbrt_state_fail_at(P, from, "\"%s\" is larger than %zu bytes", name, PBRT_FILE_BYTES_MAX);
    } else {
        return real;
    }
    free(real);
    return NULL;
}

/* Opens a file confine() accepted, checking the open descriptor again (the folder could have
 * changed since): O_NOFOLLOW refuses a final symbolic link, O_NONBLOCK keeps a FIFO from
 * blocking the open. Returns the descriptor and the file's size, or -1 with the message. */
int pbrt_confine_open(parser_t *P, const char *real, const char *name, const char *path,
                      const pbrt_loc_t *from, const char *what, size_t *size)
{
    int fd = open(real, O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0)
        return errno == ELOOP ? pbrt_state_fail_at(P, from, "\"%s\" is not a regular file", name)
                              : pbrt_state_fail_at(P, from, "cannot open %s \"%s\": %s", what, path,
                                                   strerror(errno));
    struct stat st;
    int rc = 0;
    if (fstat(fd, &st) != 0)
        rc = pbrt_state_fail_at(P, from, "cannot open %s \"%s\": %s", what, path, strerror(errno));
    else if (!S_ISREG(st.st_mode))
        rc = pbrt_state_fail_at(P, from, "\"%s\" is not a regular file", name);
    else if ((uint64_t)st.st_size > PBRT_FILE_BYTES_MAX)
        rc = pbrt_state_fail_at(P, from, "\"%s\" is larger than %zu bytes", name,
                                PBRT_FILE_BYTES_MAX);
    if (rc != 0) {
        close(fd);
        return -1;
    }
    *size = (size_t)st.st_size;
    return fd;
}

/* Reads a whole file confine() accepted (its size as fstat gives it, charged to the total). */
char *pbrt_confine_read(parser_t *P, const char *real, const char *name, const char *path,
                        const pbrt_loc_t *from, const char *what, size_t *len)
{
    size_t size;
    int fd = pbrt_confine_open(P, real, name, path, from, what, &size);
    if (fd < 0)
        return NULL;
    if (pbrt_confine_charge(P, size, from) != 0) {
        close(fd);
        return NULL;
    }
    char *buf = malloc(size + 1);
    if (!buf) {
        close(fd);
        pbrt_state_fail_at(P, from, "out of memory reading \"%s\"", path);
        return NULL;
    }
    size_t n = 0;
    while (n < size) {
        ssize_t got = read(fd, buf + n, size - n);
        if (got < 0 && errno == EINTR)
            continue;
        if (got <= 0) {
            pbrt_state_fail_at(P, from, "cannot read %s \"%s\": %s", what, path,
                               got < 0 ? strerror(errno) : "it ended early");
            free(buf);
            close(fd);
            return NULL;
        }
        n += (size_t)got;
    }
    close(fd);
    *len = n;
    return buf;
}

/* A file that starts with gzip's magic bytes is inflated (pbrt-v4 reads ".gz" scene files
 * and PLYs through zlib) to at most limit bytes, and in a confined parse to what the scene may
 * still read, the inflated bytes charged like a file's: a small file that inflates to
 * gigabytes is refused once it passes the limit. Replaces *buf (which the caller still frees
 * on failure). */
int pbrt_confine_inflate(parser_t *P, char **buf, size_t *len, size_t limit, const char *name,
                         const pbrt_loc_t *from)
{
    if (!gzip_data_is_gzip(*buf, *len))
        return 0;
    if (P->root_real && PBRT_TOTAL_BYTES_MAX - P->bytes_charged < limit)
        limit = PBRT_TOTAL_BYTES_MAX - P->bytes_charged;
    char *out;
    size_t n;
    err_t e;
    if (gzip_data_inflate(*buf, *len, limit, name, &out, &n, &e) != 0)
        return pbrt_state_fail_at(P, from, "%s", e.msg);
    free(*buf);
    *buf = out;
    *len = n;
    return P->root_real ? pbrt_confine_charge(P, n, from) : 0;
}

/* An imagemap PNG in a confined parse: its IHDR (PNG specification 11.2.2: the 8-byte
 * signature, then a 13-byte chunk "IHDR" whose data begins with the width and height, 4 bytes
 * big-endian each) says how many pixels decoding makes, 64 bytes each (the 8-bit RGBA that
 * image_png decodes, the float RGB and alpha, and the texture's coefficients), charged with the
 * file's own bytes before anything decodes it. A file that is not a PNG is left to the PNG reader's
 * message. */
int pbrt_confine_charge_png(parser_t *P, const char *real, const char *name, const char *path,
                            const pbrt_loc_t *from)
{
    size_t size;
    int fd = pbrt_confine_open(P, real, name, path, from, "image", &size);
    if (fd < 0)
        return -1;
    unsigned char h[24];
    size_t n = 0;
    while (n < sizeof h) {
        ssize_t got = read(fd, h + n, sizeof h - n);
        if (got < 0 && errno == EINTR)
            continue;
        if (got <= 0)
            break;
        n += (size_t)got;
    }
    close(fd);
    uint64_t pixels = 0;
    static const unsigned char SIG[12] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13};
    if (n == sizeof h && !memcmp(h, SIG, sizeof SIG) && !memcmp(h + 12, "IHDR", 4)) {
        uint64_t w = (uint64_t)h[16] << 24 | (uint64_t)h[17] << 16 | (uint64_t)h[18] << 8 | h[19];
        uint64_t ht = (uint64_t)h[20] << 24 | (uint64_t)h[21] << 16 | (uint64_t)h[22] << 8 | h[23];
        pixels = w * ht; /* each below 2^32: no overflow */
    }
    if (pixels > (PBRT_TOTAL_BYTES_MAX - P->bytes_charged) / 64)
        return pbrt_state_fail_at(P, from,
                                  "image \"%s\" decodes to %llu pixels, more than the scene may "
                                  "read (%zu bytes in all)",
                                  name, (unsigned long long)pixels, PBRT_TOTAL_BYTES_MAX);
    return pbrt_confine_charge(P, size + 64 * pixels, from);
}

int pbrt_confine_bundle_check(parser_t *P, const char *path, const char *name, pbrt_loc_t loc)
{
    if (!P->bundle)
        return 0;
    if (name[0] == '/')
        return pbrt_error(P->err, loc,
                          "\"%s\" is an absolute path, so it cannot travel with the job: name "
                          "it relative to the scene's file (the farm reads the scene from a "
                          "folder of its own)",
                          name);
    char *dir = paths_folder(P->main_name);
    char *adir = dir ? paths_lexical(dir[0] ? dir : ".") : NULL;
    char *apath = paths_lexical(path);
    char *rel = adir && apath ? paths_relative_to(adir, apath) : NULL;
    char *root = rel ? paths_lift(adir, paths_ups(rel)) : NULL;
    int rc = root ? 0 : pbrt_error(P->err, loc, "out of memory");
    char *real = rc == 0 ? realpath(path, NULL) : NULL;
    char *real_root = real ? realpath(root, NULL) : NULL;
    if (real && real_root && !paths_is_under(real_root, real))
        rc = pbrt_error(P->err, loc,
                        "\"%s\" is a symbolic link that leads out of the folder the job carries "
                        "(%s), so it cannot travel with the job",
                        name, root);
    free(dir);
    free(adir);
    free(apath);
    free(rel);
    free(root);
    free(real);
    free(real_root);
    return rc;
}
