#include "err.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

int err_set(err_t *err, const char *fmt, ...)
{
    if (err) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err->msg, sizeof err->msg, fmt, ap);
        va_end(ap);
    }
    return -1;
}

int err_prefix(err_t *err, const char *fmt, ...)
{
    if (err) {
        char prefix[sizeof err->msg];
        char old[sizeof err->msg];
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(prefix, sizeof prefix, fmt, ap);
        va_end(ap);
        memcpy(old, err->msg, sizeof old);
        /* Truncation is acceptable here: the message stays one readable, bounded line. */
        size_t n = strlen(prefix);
        memcpy(err->msg, prefix, n);
        size_t room = sizeof err->msg - 1 - n;
        const char *end = memchr(old, 0, room);
        size_t m = end ? (size_t)(end - old) : room;
        memcpy(err->msg + n, old, m);
        err->msg[n + m] = 0;
    }
    return -1;
}
