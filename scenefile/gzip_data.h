/* gzip_data: gzip-compressed files (RFC 1952) as pbrt-v4 reads them (".ply.gz", an Include of
 * ".pbrt.gz"), inflated whole through zlib. The caller gives the largest decompressed size it
 * accepts, so a small file that inflates to gigabytes (a gzip bomb) is refused once its output
 * passes that size, never allocated in full. */
#ifndef PRISMFARM_GZIP_DATA_H
#define PRISMFARM_GZIP_DATA_H

#include "err.h"

#include <stdbool.h>
#include <stddef.h>

/* Whether data starts with gzip's magic bytes 1f 8b. */
bool gzip_data_is_gzip(const void *data, size_t len);

/* Inflates data[0..len) (one or more gzip members) into *out (malloc'ed, with a NUL after the
 * *out_len bytes). Fails, naming `name`, when the data is not gzip, is corrupt or truncated,
 * or would inflate to more than limit bytes. */
int gzip_data_inflate(const void *data, size_t len, size_t limit, const char *name, char **out,
                      size_t *out_len, err_t *err);

#endif
