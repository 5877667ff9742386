/* gzip_data: gzip-compressed files (RFC 1952) as pbrt-v4 reads them (".ply.gz", an Include of
 * ".pbrt.gz"), inflated through zlib. The caller gives the largest decompressed size it
 * accepts, and the data is streamed twice: once through a small window only to count its
 * inflated bytes, refused as soon as the count passes the limit, then, when it fits, into a
 * buffer of exactly that size. A small file that inflates to gigabytes (a gzip bomb) is refused
 * while streaming, holding 64 KiB, never its inflated bytes (issue 26, finding 2: a 4 GiB bomb
 * was inflated to 512 MiB before it was refused). A header can be read without inflating the
 * rest (gzip_data_inflate_prefix), so that counts it declares are charged first. */
#ifndef PRISMFARM_GZIP_DATA_H
#define PRISMFARM_GZIP_DATA_H

#include "err.h"

#include <stdbool.h>
#include <stddef.h>

/* Whether data starts with gzip's magic bytes 1f 8b. */
bool gzip_data_is_gzip(const void *data, size_t len);

/* Inflates data[0..len) (one or more gzip members) into *out (malloc'ed, with a NUL after the
 * *out_len bytes). Fails, naming `name`, when the data is not gzip, is corrupt or truncated,
 * or would inflate to more than limit bytes; the last is found while counting, before
 * anything of the output is allocated. */
int gzip_data_inflate(const void *data, size_t len, size_t limit, const char *name, char **out,
                      size_t *out_len, err_t *err);

/* The first at most `want` inflated bytes of data into out[0..*out_len) (the caller's buffer
 * of want bytes), without inflating further: a file's header before its body. Fails when the
 * data is not gzip or yields no byte; a stream that ends, is truncated or turns corrupt before
 * `want` bytes gives what came before (the full inflate reports the fault). */
int gzip_data_inflate_prefix(const void *data, size_t len, size_t want, const char *name, char *out,
                             size_t *out_len, err_t *err);

#endif
