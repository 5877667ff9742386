#include "cli_json.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The length of the UTF-8 character at p (at most n bytes), or 0 when p starts none: a lead
 * byte, its continuation bytes, no overlong form, no surrogate, nothing above U+10FFFF
 * (RFC 3629, section 4). */
static size_t utf8_char(const unsigned char *p, size_t n)
{
    unsigned c = p[0];
    size_t len = c < 0x80                 ? 1
                 : c >= 0xC2 && c <= 0xDF ? 2
                 : c >= 0xE0 && c <= 0xEF ? 3
                 : c >= 0xF0 && c <= 0xF4 ? 4
                                          : 0;
    if (len == 0 || len > n)
        return 0;
    for (size_t i = 1; i < len; i++)
        if ((p[i] & 0xC0) != 0x80)
            return 0;
    if ((c == 0xE0 && p[1] < 0xA0) || (c == 0xED && p[1] > 0x9F) || (c == 0xF0 && p[1] < 0x90) ||
        (c == 0xF4 && p[1] > 0x8F))
        return 0;
    return len;
}

json_t *cli_json_string(const char *s)
{
    if (!s)
        s = "";
    json_t *v = json_string(s); /* NULL when s is not UTF-8 */
    if (v)
        return v;
    size_t n = strlen(s);
    char *fixed = malloc(3 * n + 1); /* each byte at most the 3 bytes of U+FFFD */
    if (!fixed)
        return NULL;
    size_t out = 0;
    for (size_t i = 0; i < n;) {
        size_t len = utf8_char((const unsigned char *)s + i, n - i);
        if (len) {
            memcpy(fixed + out, s + i, len);
            out += len;
            i += len;
        } else {
            memcpy(fixed + out, "\xEF\xBF\xBD", 3);
            out += 3;
            i++;
        }
    }
    fixed[out] = 0;
    v = json_string(fixed);
    free(fixed);
    return v;
}

int cli_json_print(json_t *v, size_t flags)
{
    int rc = v ? json_dumpf(v, stdout, flags | JSON_PRESERVE_ORDER) : -1;
    if (rc == 0 && fputc('\n', stdout) == EOF)
        rc = -1;
    json_decref(v);
    return rc;
}
