#define _XOPEN_SOURCE 700 /* strdup, strtok_r */

#include "paths.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* dir(base) + name, unless name is absolute or base has no folder. */
char *paths_resolve(const char *base, const char *name)
{
    const char *slash = strrchr(base, '/');
    if (name[0] == '/' || !slash)
        return strdup(name);
    size_t dlen = (size_t)(slash - base) + 1;
    char *out = malloc(dlen + strlen(name) + 1);
    if (!out)
        return NULL;
    memcpy(out, base, dlen);
    strcpy(out + dlen, name);
    return out;
}

/* Splits a '/'-separated path into its components, lexically normalised: empty and "."
 * components dropped, "x/.." folded; a ".." that cannot fold is kept in a relative path and
 * dropped at the root of an absolute one. The components point into *copy (malloc'ed, as is
 * the returned array); NULL when out of memory. */
static char **split_path(const char *path, char **copy, size_t *count)
{
    *copy = strdup(path);
    char **parts = malloc((strlen(path) / 2 + 2) * sizeof *parts);
    if (!*copy || !parts) {
        free(*copy);
        free(parts);
        return NULL;
    }
    size_t n = 0;
    char *save = NULL;
    for (char *c = strtok_r(*copy, "/", &save); c; c = strtok_r(NULL, "/", &save)) {
        if (!strcmp(c, "."))
            continue;
        if (!strcmp(c, "..")) {
            if (n > 0 && strcmp(parts[n - 1], "..") != 0) {
                n--;
                continue;
            }
            if (path[0] == '/')
                continue;
        }
        parts[n++] = c;
    }
    *count = n;
    return parts;
}

/* Joins "../" times ups, then parts[from..n) with '/', after a leading '/' if absolute. */
static char *join_path(bool absolute, size_t ups, char **parts, size_t from, size_t n)
{
    size_t len = 2 + 3 * ups;
    for (size_t i = from; i < n; i++)
        len += strlen(parts[i]) + 1;
    char *out = malloc(len);
    if (!out)
        return NULL;
    out[0] = 0;
    if (absolute)
        strcat(out, "/");
    for (size_t k = 0; k < ups; k++)
        strcat(out, k + 1 < ups || from < n ? "../" : "..");
    for (size_t i = from; i < n; i++) {
        strcat(out, parts[i]);
        if (i + 1 < n)
            strcat(out, "/");
    }
    return out;
}

char *paths_normalise(const char *path)
{
    char *copy;
    size_t n;
    char **parts = split_path(path, &copy, &n);
    char *out = parts ? join_path(path[0] == '/', 0, parts, 0, n) : NULL;
    free(parts);
    free(copy);
    return out;
}

/* The folder part of a file name ("" when it has none). malloc'ed. */
char *paths_folder(const char *file)
{
    const char *slash = strrchr(file, '/');
    size_t n = slash ? (size_t)(slash - file) + (slash == file ? 1 : 0) : 0;
    char *d = malloc(n + 1);
    if (d) {
        memcpy(d, file, n);
        d[n] = 0;
    }
    return d;
}

/* An absolute version of a relative path, against the working folder. malloc'ed. */
char *paths_absolute(const char *path)
{
    char cwd[4096];
    if (path[0] == '/' || !getcwd(cwd, sizeof cwd))
        return strdup(path);
    char *out = malloc(strlen(cwd) + strlen(path) + 2);
    if (out)
        sprintf(out, "%s/%s", cwd, path);
    return out;
}

/* path relative to the folder dir, both relative or both absolute: as many ".." as dir has
 * components beyond what the two share, then the rest of path. */
char *paths_relative_to(const char *dir, const char *path)
{
    char *cd = NULL, *cp = NULL;
    size_t nd = 0, np = 0;
    char **d = split_path(dir, &cd, &nd), **p = split_path(path, &cp, &np);
    char *out = NULL;
    if (d && p) {
        size_t common = 0;
        while (common < nd && common < np && !strcmp(d[common], p[common]))
            common++;
        out = join_path(false, nd - common, p, common, np);
    }
    free(d);
    free(p);
    free(cd);
    free(cp);
    return out;
}

/* Whether path (absolute, normalised) is the folder dir (same form) or lies under it. */
bool paths_is_under(const char *dir, const char *path)
{
    size_t n = strlen(dir);
    return !strncmp(path, dir, n) &&
           (path[n] == 0 || path[n] == '/' || (n > 0 && dir[n - 1] == '/'));
}

/* The absolute, lexically normalised form of path. malloc'ed. */
char *paths_lexical(const char *path)
{
    char *a = paths_absolute(path);
    char *n = a ? paths_normalise(a) : NULL;
    free(a);
    return n;
}

size_t paths_ups(const char *rel)
{
    size_t n = 0;
    while (rel[0] == '.' && rel[1] == '.' && (rel[2] == '/' || rel[2] == 0)) {
        n++;
        rel += rel[2] ? 3 : 2;
    }
    return n;
}

char *paths_lift(const char *dir, size_t ups)
{
    size_t len = strlen(dir);
    char *joined = malloc(len + 3 * ups + 2);
    if (!joined)
        return NULL;
    memcpy(joined, dir, len + 1);
    for (size_t k = 0; k < ups; k++)
        strcat(joined, "/..");
    char *out = paths_normalise(joined);
    free(joined);
    if (out && !out[0]) { /* "/.." normalises to "" */
        free(out);
        out = strdup("/");
    }
    return out;
}
