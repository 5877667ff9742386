#include "gzip_data.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

bool gzip_data_is_gzip(const void *data, size_t len)
{
    const unsigned char *d = data;
    return len >= 2 && d[0] == 0x1f && d[1] == 0x8b;
}

int gzip_data_inflate(const void *data, size_t len, size_t limit, const char *name, char **out,
                      size_t *out_len, err_t *err)
{
    *out = NULL;
    *out_len = 0;
    if (!gzip_data_is_gzip(data, len))
        return err_set(err, "\"%s\" is not a gzip file (it does not start with 1f 8b)", name);
    z_stream z;
    memset(&z, 0, sizeof z);
    /* 15 + 16: a gzip wrapper (not zlib's own), with the largest window. */
    if (inflateInit2(&z, 15 + 16) != Z_OK)
        return err_set(err, "\"%s\": cannot start zlib", name);
    size_t cap = len < ((size_t)1 << 20) ? (size_t)1 << 16 : 4 * len, n = 0;
    if (cap > limit + 1)
        cap = limit + 1;
    char *buf = malloc(cap + 1);
    const unsigned char *in = data;
    size_t in_left = len;
    int rc = Z_OK;
    while (buf) {
        if (z.avail_in == 0 && in_left > 0) {
            z.next_in = (unsigned char *)(uintptr_t)in;
            z.avail_in = in_left > UINT32_MAX ? UINT32_MAX : (unsigned)in_left;
            in += z.avail_in;
            in_left -= z.avail_in;
        }
        if (n == cap) {
            if (cap > limit)
                break;
            size_t grown = cap * 2 <= limit + 1 ? cap * 2 : limit + 1;
            char *nb = realloc(buf, grown + 1);
            if (!nb) {
                free(buf);
                buf = NULL;
                break;
            }
            buf = nb;
            cap = grown;
        }
        size_t room = cap - n > UINT32_MAX ? UINT32_MAX : cap - n;
        z.next_out = (unsigned char *)buf + n;
        z.avail_out = (unsigned)room;
        rc = inflate(&z, Z_NO_FLUSH);
        n += room - z.avail_out;
        if (rc == Z_STREAM_END) {
            /* Another member may follow (gzip allows concatenation); padding of zeros ends. */
            if (z.avail_in == 0 && in_left == 0)
                break;
            if (*z.next_in == 0)
                break;
            if (inflateReset(&z) != Z_OK) {
                rc = Z_DATA_ERROR;
                break;
            }
            continue;
        }
        if (rc != Z_OK && !(rc == Z_BUF_ERROR && z.avail_out == 0))
            break;
        if (rc == Z_OK && z.avail_in == 0 && in_left == 0 && z.avail_out > 0) {
            rc = Z_BUF_ERROR; /* the input ended inside the stream */
            break;
        }
    }
    const char *zmsg = z.msg;
    inflateEnd(&z);
    if (!buf)
        return err_set(err, "out of memory inflating \"%s\"", name);
    if (n > limit) {
        free(buf);
        return err_set(err,
                       "\"%s\" inflates to more than %zu bytes, the most a file may hold (a gzip "
                       "bomb?)",
                       name, limit);
    }
    if (rc != Z_STREAM_END) {
        free(buf);
        return err_set(err, "\"%s\" is not a valid gzip file: %s", name,
                       rc == Z_BUF_ERROR ? "it ends before its compressed data does (truncated)"
                                         : zmsg ? zmsg : "corrupt data");
    }
    buf[n] = 0;
    *out = buf;
    *out_len = n;
    return 0;
}
