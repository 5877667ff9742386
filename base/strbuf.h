/* strbuf: formatted appends into a fixed buffer whose text may be cut, for the records and
 * reports written into caller-sized buffers (film's EXR records, adaptive's tile list). */
#ifndef PRISMFARM_STRBUF_H
#define PRISMFARM_STRBUF_H

#include <stddef.h>

/* Appends printf-style text to out at *n. *n counts the uncut length (as snprintf's result
 * does), so a caller learns the size it needed; out stays NUL-terminated within size. */
__attribute__((format(printf, 4, 5))) void strbuf_appendf(char *out, size_t size, size_t *n,
                                                          const char *fmt, ...);

#endif
