#include "settings.h"

#include <stdarg.h>
#include <stdio.h>

/* The settings the loader takes (LOADER in job_settings.h), each to its scene_overrides_t
 * field of the same name. */
#define LOADER_TAKES_LOADER(field) .field = s->field,
#define LOADER_TAKES_MASTER(field)
#define TO_OVERRIDE(field, kind, keep, wire_key, wire, load, ...) LOADER_TAKES_##load(field)

scene_overrides_t settings_to_overrides(const proto_settings_t *s)
{
    return (scene_overrides_t){JOB_SETTINGS(TO_OVERRIDE)};
}

/* " field=value" appended to key at *at (kept below SETTINGS_KEY_SIZE). NULL (the file's) is
 * "-", a name is quoted: they never meet. A name is cut at 64 characters, past the longest the
 * loader knows, so a cut name is one it refuses. */
static void key_add(char *key, size_t *at, const char *field, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
static void key_add(char *key, size_t *at, const char *field, const char *fmt, ...)
{
    char value[80];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(value, sizeof value, fmt, ap);
    va_end(ap);
    int n = snprintf(key + *at, SETTINGS_KEY_SIZE - *at, " %s=%s", field, value);
    if (n > 0)
        *at = *at + (size_t)n < SETTINGS_KEY_SIZE ? *at + (size_t)n : SETTINGS_KEY_SIZE - 1;
}

#define KEY_INT(field) key_add(key, &at, #field, "%d", s->field);
#define KEY_LLONG(field) key_add(key, &at, #field, "%lld", (long long)s->field);
#define KEY_DOUBLE(field) key_add(key, &at, #field, "%a", s->field);
#define KEY_NAME(field)                                                                            \
    if (s->field)                                                                                  \
        key_add(key, &at, #field, "\"%.64s\"", s->field);                                          \
    else                                                                                           \
        key_add(key, &at, #field, "-");
#define KEY_OF_LOADER(field, kind) KEY_##kind(field)
#define KEY_OF_MASTER(field, kind)
#define KEY_OF(field, kind, keep, wire_key, wire, load, ...) KEY_OF_##load(field, kind)

void settings_scene_key(const char *hash, const char *main, const proto_settings_t *s,
                        char key[SETTINGS_KEY_SIZE])
{
    int n = snprintf(key, SETTINGS_KEY_SIZE, "%s", hash);
    size_t at = n > 0 ? (size_t)n : 0;
    JOB_SETTINGS(KEY_OF)
    /* main last: a bundle path may hold spaces, and nothing follows it to be confused with. */
    snprintf(key + at, SETTINGS_KEY_SIZE - at, " main=%.*s", PROTO_MAX_STRING, main);
}
