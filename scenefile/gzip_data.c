#include "gzip_data.h"

#include <limits.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

bool gzip_data_is_gzip(const void *data, size_t len)
{
    const unsigned char *d = data;
    return len >= 2 && d[0] == 0x1f && d[1] == 0x8b;
}

/* The outcome of one pass over the data. */
typedef enum { PASS_END, PASS_STOPPED, PASS_TRUNCATED, PASS_CORRUPT, PASS_NOMEM } pass_t;

/* One pass over the gzip members of in[0..in_len): the first `keep` inflated bytes go to dst
 * (when not NULL), the rest through a window on the stack, counted and dropped; the pass stops
 * once more than `stop` bytes have come out (PASS_STOPPED; at most stop + 1 are produced).
 * *n: the bytes produced. zlib's message for corrupt data into *why. */
static pass_t pass(const unsigned char *in, size_t in_len, unsigned char *dst, size_t keep,
                   size_t stop, size_t *n, const char **why)
{
    z_stream z;
    memset(&z, 0, sizeof z);
    *n = 0;
    *why = NULL;
    /* 15 + 16: a gzip wrapper (not zlib's own), with the largest window. */
    if (inflateInit2(&z, 15 + 16) != Z_OK)
        return PASS_NOMEM;
    unsigned char window[1 << 16];
    size_t out = 0, in_left = in_len;
    pass_t res = PASS_CORRUPT;
    for (;;) {
        if (z.avail_in == 0 && in_left > 0) {
            z.next_in = (unsigned char *)(uintptr_t)in;
            z.avail_in = in_left > UINT32_MAX ? UINT32_MAX : (unsigned)in_left;
            in += z.avail_in;
            in_left -= z.avail_in;
        }
        unsigned char *to = window;
        size_t room = sizeof window;
        if (dst && out < keep) {
            to = dst + out;
            room = keep - out;
        }
        if (room > stop - out + 1)
            room = stop - out + 1; /* out <= stop here: at most one byte past it */
        if (room > UINT_MAX)
            room = UINT_MAX;
        z.next_out = to;
        z.avail_out = (unsigned)room;
        int rc = inflate(&z, Z_NO_FLUSH);
        out += room - z.avail_out;
        if (out > stop) {
            res = PASS_STOPPED;
            break;
        }
        if (rc == Z_STREAM_END) {
            /* Another member may follow (gzip allows concatenation); padding of zeros ends. */
            if ((z.avail_in == 0 && in_left == 0) || *z.next_in == 0) {
                res = PASS_END;
                break;
            }
            if (inflateReset(&z) != Z_OK)
                break;
            continue;
        }
        if (rc == Z_MEM_ERROR) {
            res = PASS_NOMEM;
            break;
        }
        /* No progress possible with output room left: the input ended inside the stream. */
        if ((rc == Z_OK || rc == Z_BUF_ERROR) && z.avail_out > 0 && z.avail_in == 0 &&
            in_left == 0) {
            res = PASS_TRUNCATED;
            break;
        }
        if (rc != Z_OK && rc != Z_BUF_ERROR) {
            *why = z.msg ? z.msg : "corrupt data";
            break;
        }
    }
    /* z.msg points into zlib's tables (static strings), so it outlives inflateEnd. */
    inflateEnd(&z);
    *n = out;
    return res;
}

static int pass_error(pass_t p, const char *why, const char *name, err_t *err)
{
    if (p == PASS_NOMEM)
        return err_set(err, "out of memory inflating \"%s\"", name);
    return err_set(err, "\"%s\" is not a valid gzip file: %s", name,
                   p == PASS_TRUNCATED ? "it ends before its compressed data does (truncated)"
                   : why               ? why
                                       : "corrupt data");
}

int gzip_data_inflate(const void *data, size_t len, size_t limit, const char *name, char **out,
                      size_t *out_len, err_t *err)
{
    *out = NULL;
    *out_len = 0;
    if (!gzip_data_is_gzip(data, len))
        return err_set(err, "\"%s\" is not a gzip file (it does not start with 1f 8b)", name);
    if (limit >= SIZE_MAX - 1)
        limit = SIZE_MAX - 2;
    size_t n;
    const char *why;
    pass_t p = pass(data, len, NULL, 0, limit, &n, &why);
    if (p == PASS_STOPPED)
        return err_set(err,
                       "\"%s\" inflates to more than %zu bytes, the most a file may hold (a gzip "
                       "bomb?)",
                       name, limit);
    if (p != PASS_END)
        return pass_error(p, why, name, err);
    char *buf = malloc(n + 1);
    if (!buf)
        return err_set(err, "out of memory inflating \"%s\" (%zu bytes)", name, n);
    size_t again;
    p = pass(data, len, (unsigned char *)buf, n, n, &again, &why);
    if (p != PASS_END || again != n) {
        free(buf);
        return p == PASS_END || p == PASS_STOPPED
                   ? err_set(err, "\"%s\" changed while inflating", name)
                   : pass_error(p, why, name, err);
    }
    buf[n] = 0;
    *out = buf;
    *out_len = n;
    return 0;
}

int gzip_data_inflate_prefix(const void *data, size_t len, size_t want, const char *name, char *out,
                             size_t *out_len, err_t *err)
{
    *out_len = 0;
    if (!gzip_data_is_gzip(data, len))
        return err_set(err, "\"%s\" is not a gzip file (it does not start with 1f 8b)", name);
    if (want == 0)
        return 0;
    size_t n;
    const char *why;
    pass_t p = pass(data, len, (unsigned char *)out, want, want - 1, &n, &why);
    /* Corrupt data after some output is the body's fault, for the full read to report: the
     * header may be whole before it. */
    if (p == PASS_NOMEM || (p == PASS_CORRUPT && n == 0))
        return pass_error(p, why, name, err);
    *out_len = n < want ? n : want;
    return 0;
}
