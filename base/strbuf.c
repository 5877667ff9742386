#include "strbuf.h"

#include <stdarg.h>
#include <stdio.h>

void strbuf_appendf(char *out, size_t size, size_t *n, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int k = vsnprintf(out + (*n < size ? *n : size), *n < size ? size - *n : 0, fmt, ap);
    va_end(ap);
    if (k > 0)
        *n += (size_t)k;
}
