#include "frame_pattern.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

bool frame_pattern_has(const char *s)
{
    for (const char *p = s; (p = strchr(p, '%')); p += 2)
        if (p[1] != '%')
            return true;
    return false;
}

/* The conversion's flag '0' and width, at s just after its '%'; its length up to and with the
 * 'd', or 0 when it is not one frame_pattern_check takes. */
static size_t conversion_length(const char *s, int *zero, int *width)
{
    size_t k = 0;
    *zero = s[k] == '0';
    k += (size_t)*zero;
    *width = 0;
    while (s[k] >= '0' && s[k] <= '9' && *width < 100)
        *width = *width * 10 + (s[k++] - '0');
    return s[k] == 'd' && *width < 100 ? k + 1 : 0;
}

int frame_pattern_check(const char *pattern, err_t *err)
{
    int conversions = 0, zero, width;
    for (const char *p = pattern; (p = strchr(p, '%'));) {
        if (p[1] == '%') {
            p += 2;
            continue;
        }
        size_t n = conversion_length(p + 1, &zero, &width);
        if (n == 0)
            return err_set(err,
                           "'%s': '%%%.1s...' is not a frame number's conversion (use %%d or "
                           "%%04d; %%%% for a '%%')",
                           pattern, p + 1);
        conversions++;
        p += 1 + n;
    }
    if (conversions != 1)
        return err_set(err, "'%s' has %d frame number conversions, expected one (such as %%04d)",
                       pattern, conversions);
    return 0;
}

int frame_pattern_format(const char *pattern, uint32_t number, char *out, size_t size, err_t *err)
{
    if (frame_pattern_check(pattern, err) < 0)
        return -1;
    size_t k = 0;
    for (const char *p = pattern; *p;) {
        char piece[128];
        size_t len;
        if (p[0] == '%' && p[1] == '%') {
            piece[0] = '%';
            len = 1;
            p += 2;
        } else if (p[0] == '%') {
            int zero, width;
            size_t n = conversion_length(p + 1, &zero, &width);
            len = (size_t)snprintf(piece, sizeof piece, zero ? "%0*u" : "%*u", width, number);
            p += 1 + n;
        } else {
            piece[0] = *p++;
            len = 1;
        }
        if (k + len >= size)
            return err_set(err, "'%s' with frame %u is longer than %zu bytes", pattern, number,
                           size - 1);
        memcpy(out + k, piece, len);
        k += len;
    }
    out[k] = 0;
    return 0;
}

bool frame_pattern_number_of(const char *path, uint32_t *out)
{
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    const char *end = NULL;
    for (const char *p = base; *p; p++)
        if (*p >= '0' && *p <= '9' && (p[1] < '0' || p[1] > '9'))
            end = p + 1;
    if (!end)
        return false;
    const char *start = end;
    while (start > base && start[-1] >= '0' && start[-1] <= '9')
        start--;
    if (end - start > 10)
        return false;
    unsigned long long v = 0;
    for (const char *p = start; p < end; p++)
        v = v * 10 + (unsigned)(*p - '0');
    if (v > UINT32_MAX)
        return false;
    *out = (uint32_t)v;
    return true;
}

int frame_pattern_parse_range(const char *s, size_t max, uint32_t *first, uint32_t *last,
                              err_t *err)
{
    char *end;
    errno = 0;
    unsigned long long a = strtoull(s, &end, 10), b;
    if (end == s || *s == '-' || *s == '+' || *end != '-' || errno)
        return err_set(err, "--frames '%s': expected FIRST-LAST, such as 1-120", s);
    const char *t = end + 1;
    b = strtoull(t, &end, 10);
    if (end == t || *t == '-' || *t == '+' || *end || errno)
        return err_set(err, "--frames '%s': expected FIRST-LAST, such as 1-120", s);
    if (a > UINT32_MAX || b > UINT32_MAX || a > b)
        return err_set(err, "--frames '%s': FIRST must be <= LAST, both 0..%u", s, UINT32_MAX);
    if (b - a + 1 > max)
        return err_set(err, "--frames '%s' is %llu frames, at most %zu in one job", s, b - a + 1,
                       max);
    *first = (uint32_t)a;
    *last = (uint32_t)b;
    return 0;
}
