#include "warnings.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct warnings {
    char **lines;
    size_t count, cap, dropped;
};

warnings_t *warnings_new(err_t *err)
{
    warnings_t *w = calloc(1, sizeof *w);
    if (!w)
        err_set(err, "out of memory");
    return w;
}

void warnings_destroy(warnings_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    warnings_t *w = *self_p;
    for (size_t i = 0; i < w->count; i++)
        free(w->lines[i]);
    free(w->lines);
    free(w);
    *self_p = NULL;
}

static int add_line(warnings_t *self, const char *line);

int warnings_add(warnings_t *self, pbrt_loc_t loc, const char *fmt, ...)
{
    char line[sizeof(((err_t *)0)->msg)];
    int n = snprintf(line, sizeof line, "%s:%d:%d: ", loc.file ? loc.file : "<input>", loc.line, loc.col);
    if (n >= 0 && (size_t)n < sizeof line) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(line + n, sizeof line - (size_t)n, fmt, ap);
        va_end(ap);
    }
    return add_line(self, line);
}

int warnings_add_text(warnings_t *self, const char *line)
{
    return add_line(self, line);
}

int warnings_copy(warnings_t *self, const warnings_t *from)
{
    if (!from)
        return 0;
    for (size_t i = 0; i < from->count; i++)
        if (add_line(self, from->lines[i]))
            return -1;
    self->dropped += from->dropped;
    return 0;
}

static int add_line(warnings_t *self, const char *line)
{
    /* The same construct inside a loop of Includes or instances says the same thing. */
    for (size_t i = 0; i < self->count; i++)
        if (!strcmp(self->lines[i], line))
            return 0;
    if (self->count >= WARNINGS_MAX) {
        self->dropped++;
        return 0;
    }
    if (self->count == self->cap) {
        size_t cap = self->cap ? 2 * self->cap : 8;
        char **p = realloc(self->lines, cap * sizeof *p);
        if (!p)
            return -1;
        self->lines = p;
        self->cap = cap;
    }
    if (!(self->lines[self->count] = strdup(line)))
        return -1;
    self->count++;
    return 0;
}

size_t warnings_count(const warnings_t *self) { return self ? self->count : 0; }

const char *warnings_at(const warnings_t *self, size_t i) { return self->lines[i]; }

size_t warnings_dropped(const warnings_t *self) { return self ? self->dropped : 0; }
