#define _POSIX_C_SOURCE 200809L /* strdup, strndup */

#include "params.h"

#include "suggest.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A parameter with the capacity of its value array; param_t comes first so that a param_t *
 * handed out converts back. */
typedef struct slot {
    param_t p;
    size_t cap;
} slot_t;

#define PARAMS_ASKED_MAX 48

struct params {
    char *context;
    slot_t **items;
    size_t count;
    size_t cap;
    /* Names looked up and absent: what the entity reads that the file did not give, the
     * candidates for a misspelt parameter's suggestion. Copied, NUL after NUL (some names are
     * built in a caller's buffer: "interface.roughness"); allocated at the first miss. */
    char *asked;
    size_t asked_len, asked_cap, nasked;
};

static const struct {
    const char *word;
    param_type_t type;
} TYPE_WORDS[] = {
    {"integer", PARAM_INTEGER},   {"float", PARAM_FLOAT},
    {"point2", PARAM_POINT2},     {"vector2", PARAM_VECTOR2},
    {"point3", PARAM_POINT3},     {"point", PARAM_POINT3},
    {"vector3", PARAM_VECTOR3},   {"vector", PARAM_VECTOR3},
    {"normal3", PARAM_NORMAL3},   {"normal", PARAM_NORMAL3},
    {"rgb", PARAM_RGB},           {"color", PARAM_RGB},
    {"spectrum", PARAM_SPECTRUM}, {"blackbody", PARAM_BLACKBODY},
    {"bool", PARAM_BOOL},         {"string", PARAM_STRING},
    {"texture", PARAM_TEXTURE},
};

const char *param_type_name(param_type_t type)
{
    switch (type) {
    case PARAM_INTEGER:
        return "integer";
    case PARAM_FLOAT:
        return "float";
    case PARAM_POINT2:
        return "point2";
    case PARAM_VECTOR2:
        return "vector2";
    case PARAM_POINT3:
        return "point3";
    case PARAM_VECTOR3:
        return "vector3";
    case PARAM_NORMAL3:
        return "normal3";
    case PARAM_RGB:
        return "rgb";
    case PARAM_SPECTRUM:
        return "spectrum";
    case PARAM_BLACKBODY:
        return "blackbody";
    case PARAM_BOOL:
        return "bool";
    case PARAM_STRING:
        return "string";
    case PARAM_TEXTURE:
        return "texture";
    }
    return "?";
}

int param_type_arity(param_type_t type)
{
    switch (type) {
    case PARAM_POINT2:
    case PARAM_VECTOR2:
        return 2;
    case PARAM_POINT3:
    case PARAM_VECTOR3:
    case PARAM_NORMAL3:
    case PARAM_RGB:
        return 3;
    default:
        return 1;
    }
}

params_t *params_new(const char *context, err_t *err)
{
    params_t *self = calloc(1, sizeof *self);
    if (self)
        self->context = strdup(context ? context : "");
    if (!self || !self->context) {
        free(self);
        err_set(err, "out of memory for a parameter list");
        return NULL;
    }
    return self;
}

static void slot_free(slot_t *s)
{
    if (!s)
        return;
    free((char *)s->p.type_name);
    free((char *)s->p.name);
    free(s->p.numbers);
    if (s->p.strings)
        for (size_t i = 0; i < s->p.count; i++)
            free(s->p.strings[i]);
    free(s->p.strings);
    free(s->p.bools);
    free(s);
}

void params_destroy(params_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    params_t *self = *self_p;
    for (size_t i = 0; i < self->count; i++)
        slot_free(self->items[i]);
    free(self->items);
    free(self->context);
    free(self->asked);
    free(self);
    *self_p = NULL;
}

size_t params_count(const params_t *self)
{
    return self->count;
}
param_t *params_at(const params_t *self, size_t i)
{
    return i < self->count ? &self->items[i]->p : NULL;
}
const char *params_context(const params_t *self)
{
    return self->context;
}

static bool is_blank(char c)
{
    return c == ' ' || c == '\t';
}

param_t *params_declare(params_t *self, const char *decl, pbrt_loc_t loc, err_t *err)
{
    const char *p = decl;
    while (is_blank(*p))
        p++;
    const char *type_start = p;
    while (*p && !is_blank(*p))
        p++;
    size_t type_len = (size_t)(p - type_start);
    while (is_blank(*p))
        p++;
    const char *name_start = p;
    while (*p && !is_blank(*p))
        p++;
    size_t name_len = (size_t)(p - name_start);
    while (is_blank(*p))
        p++;
    if (type_len == 0) {
        pbrt_error(err, loc, "empty parameter declaration \"%s\" (expected \"type name\")", decl);
        return NULL;
    }
    int type = -1;
    for (size_t i = 0; i < sizeof TYPE_WORDS / sizeof TYPE_WORDS[0]; i++)
        if (strlen(TYPE_WORDS[i].word) == type_len &&
            !strncmp(TYPE_WORDS[i].word, type_start, type_len))
            type = (int)TYPE_WORDS[i].type;
    if (type < 0) {
        pbrt_error(err, loc, "unknown parameter type \"%.*s\" in \"%s\"", (int)type_len, type_start,
                   decl);
        return NULL;
    }
    if (name_len == 0) {
        pbrt_error(err, loc, "parameter declaration \"%s\" has no name", decl);
        return NULL;
    }
    if (*p) {
        pbrt_error(err, loc, "parameter declaration \"%s\" has more than a type and a name", decl);
        return NULL;
    }
    for (size_t i = 0; i < self->count; i++) {
        const param_t *q = &self->items[i]->p;
        if (strlen(q->name) == name_len && !strncmp(q->name, name_start, name_len)) {
            pbrt_error(err, loc, "parameter \"%s\" is given twice for %s (first at %d:%d)", q->name,
                       self->context, q->loc.line, q->loc.col);
            return NULL;
        }
    }
    if (self->count == self->cap) {
        size_t cap = self->cap ? self->cap * 2 : 8;
        slot_t **items = realloc(self->items, cap * sizeof *items);
        if (!items) {
            pbrt_error(err, loc, "out of memory");
            return NULL;
        }
        self->items = items;
        self->cap = cap;
    }
    slot_t *s = calloc(1, sizeof *s);
    if (s) {
        s->p.type = (param_type_t)type;
        s->p.type_name = strndup(type_start, type_len);
        s->p.name = strndup(name_start, name_len);
        s->p.loc = loc;
    }
    if (!s || !s->p.type_name || !s->p.name) {
        slot_free(s);
        pbrt_error(err, loc, "out of memory");
        return NULL;
    }
    self->items[self->count++] = s;
    return &s->p;
}

static int reserve(slot_t *s, size_t elem, void **array, err_t *err)
{
    if (s->p.count < s->cap)
        return 0;
    size_t cap = s->cap ? s->cap * 2 : 4;
    if (cap > SIZE_MAX / elem)
        return pbrt_error(err, s->p.loc, "too many values for \"%s\"", s->p.name);
    void *a = realloc(*array, cap * elem);
    if (!a)
        return pbrt_error(err, s->p.loc, "out of memory for the values of \"%s\"", s->p.name);
    *array = a;
    s->cap = cap;
    return 0;
}

static int check_kind(param_t *p, param_values_t kind, err_t *err)
{
    if (p->values != PARAM_VALUES_NONE && p->values != kind)
        return pbrt_error(err, p->loc, "\"%s %s\" mixes numbers, strings and booleans",
                          p->type_name, p->name);
    p->values = kind;
    return 0;
}

int params_push_number(params_t *self, param_t *p, double v, err_t *err)
{
    (void)self;
    slot_t *s = (slot_t *)p;
    if (check_kind(p, PARAM_VALUES_NUMBERS, err) != 0 ||
        reserve(s, sizeof(double), (void **)&p->numbers, err) != 0)
        return -1;
    p->numbers[p->count++] = v;
    return 0;
}

int params_push_string(params_t *self, param_t *p, const char *str, err_t *err)
{
    (void)self;
    slot_t *s = (slot_t *)p;
    if (check_kind(p, PARAM_VALUES_STRINGS, err) != 0 ||
        reserve(s, sizeof(char *), (void **)&p->strings, err) != 0)
        return -1;
    char *copy = strdup(str);
    if (!copy)
        return pbrt_error(err, p->loc, "out of memory");
    p->strings[p->count++] = copy;
    return 0;
}

int params_push_bool(params_t *self, param_t *p, bool b, err_t *err)
{
    (void)self;
    slot_t *s = (slot_t *)p;
    if (check_kind(p, PARAM_VALUES_BOOLS, err) != 0 ||
        reserve(s, sizeof(bool), (void **)&p->bools, err) != 0)
        return -1;
    p->bools[p->count++] = b;
    return 0;
}

int params_add_defaults(params_t *self, const params_t *defaults, err_t *err)
{
    for (size_t i = 0; i < defaults->count; i++) {
        const param_t *d = &defaults->items[i]->p;
        bool given = false;
        for (size_t j = 0; j < self->count && !given; j++)
            given = !strcmp(self->items[j]->p.name, d->name);
        if (given)
            continue;
        /* Declared again as written, so that messages say "point" where the file did. */
        size_t len = strlen(d->type_name) + strlen(d->name) + 2;
        char *decl = malloc(len);
        if (!decl)
            return pbrt_error(err, d->loc, "out of memory");
        snprintf(decl, len, "%s %s", d->type_name, d->name);
        param_t *p = params_declare(self, decl, d->loc, err);
        free(decl);
        if (!p)
            return -1;
        for (size_t k = 0; k < d->count; k++) {
            int rc = d->values == PARAM_VALUES_NUMBERS   ? params_push_number(self, p, d->numbers[k], err)
                     : d->values == PARAM_VALUES_STRINGS ? params_push_string(self, p, d->strings[k], err)
                                                         : params_push_bool(self, p, d->bools[k], err);
            if (rc != 0)
                return -1;
        }
        /* A default need not apply to every entity it reaches (pbrt-v4 marks attribute
         * parameters "may be unused"): it is never an unused-parameter error. */
        p->used = true;
    }
    return 0;
}

/* Best effort: a name that does not fit, or no memory, only costs the suggestion. */
static void remember_asked(params_t *self, const char *name)
{
    size_t n = strlen(name) + 1;
    if (self->nasked >= PARAMS_ASKED_MAX || n > SUGGEST_MAX_LEN + 1)
        return;
    if (self->asked_len + n > self->asked_cap) {
        size_t cap = self->asked_cap ? 2 * self->asked_cap : 256;
        while (cap < self->asked_len + n)
            cap *= 2;
        char *grown = realloc(self->asked, cap);
        if (!grown)
            return;
        self->asked = grown;
        self->asked_cap = cap;
    }
    memcpy(self->asked + self->asked_len, name, n);
    self->asked_len += n;
    self->nasked++;
}

param_t *params_find(params_t *self, const char *name)
{
    for (size_t i = 0; i < self->count; i++) {
        param_t *p = &self->items[i]->p;
        if (!strcmp(p->name, name)) {
            p->used = true;
            return p;
        }
    }
    remember_asked(self, name);
    return NULL;
}

int params_wrong_type(const params_t *self, const param_t *p, const char *expected, err_t *err)
{
    return pbrt_error(err, p->loc, "\"%s %s\" has the wrong type for %s: expected %s", p->type_name,
                      p->name, self->context, expected);
}

static int expect_type(const params_t *self, const param_t *p, param_type_t type, err_t *err)
{
    if (p->type == type)
        return 0;
    char expected[160];
    snprintf(expected, sizeof expected, "\"%s %s\"", param_type_name(type), p->name);
    return params_wrong_type(self, p, expected, err);
}

static const char *unit_word(const param_t *p, size_t n)
{
    switch (p->type) {
    case PARAM_STRING:
    case PARAM_TEXTURE:
        return n == 1 ? "string" : "strings";
    case PARAM_BOOL:
        return n == 1 ? "value" : "values";
    default:
        return n == 1 ? "number" : "numbers";
    }
}

static int expect_count(const param_t *p, size_t n, err_t *err)
{
    if (p->count == n)
        return 0;
    return pbrt_error(err, p->loc, "expected %zu %s after \"%s %s\", got %zu", n, unit_word(p, n),
                      p->type_name, p->name, p->count);
}

int params_get_int(params_t *self, const char *name, int def, int *out, err_t *err)
{
    param_t *p = params_find(self, name);
    if (!p) {
        *out = def;
        return 0;
    }
    if (expect_type(self, p, PARAM_INTEGER, err) != 0 || expect_count(p, 1, err) != 0)
        return -1;
    *out = (int)p->numbers[0];
    return 0;
}

int params_get_float(params_t *self, const char *name, double def, double *out, err_t *err)
{
    param_t *p = params_find(self, name);
    if (!p) {
        *out = def;
        return 0;
    }
    if (expect_type(self, p, PARAM_FLOAT, err) != 0 || expect_count(p, 1, err) != 0)
        return -1;
    *out = p->numbers[0];
    return 0;
}

int params_get_bool(params_t *self, const char *name, bool def, bool *out, err_t *err)
{
    param_t *p = params_find(self, name);
    if (!p) {
        *out = def;
        return 0;
    }
    if (expect_type(self, p, PARAM_BOOL, err) != 0 || expect_count(p, 1, err) != 0)
        return -1;
    *out = p->bools[0];
    return 0;
}

int params_get_string(params_t *self, const char *name, const char *def, const char **out,
                      err_t *err)
{
    param_t *p = params_find(self, name);
    if (!p) {
        *out = def;
        return 0;
    }
    if (expect_type(self, p, PARAM_STRING, err) != 0 || expect_count(p, 1, err) != 0)
        return -1;
    *out = p->strings[0];
    return 0;
}

int params_get_point3(params_t *self, const char *name, vec3_t def, vec3_t *out, err_t *err)
{
    param_t *p = params_find(self, name);
    if (!p) {
        *out = def;
        return 0;
    }
    if (expect_type(self, p, PARAM_POINT3, err) != 0 || expect_count(p, 3, err) != 0)
        return -1;
    *out = vec3_make(p->numbers[0], p->numbers[1], p->numbers[2]);
    return 0;
}

int params_get_array(params_t *self, const char *name, param_type_t type, param_t **out, err_t *err)
{
    *out = NULL;
    param_t *p = params_find(self, name);
    if (!p)
        return 0;
    if (expect_type(self, p, type, err) != 0)
        return -1;
    size_t arity = (size_t)param_type_arity(type);
    if (p->count == 0)
        return pbrt_error(err, p->loc, "no values after \"%s %s\"", p->type_name, p->name);
    if (p->count % arity != 0)
        return pbrt_error(err, p->loc,
                          "expected a multiple of %zu numbers after \"%s %s\", got %zu", arity,
                          p->type_name, p->name, p->count);
    *out = p;
    return 0;
}

void params_accept_all(params_t *self)
{
    for (size_t i = 0; i < self->count; i++)
        self->items[i]->p.used = true;
}

int params_check_unused(const params_t *self, err_t *err)
{
    for (size_t i = 0; i < self->count; i++) {
        const param_t *p = &self->items[i]->p;
        if (!p->used) {
            suggest_t near = suggest_begin(p->name);
            for (size_t at = 0; at < self->asked_len; at += strlen(self->asked + at) + 1)
                suggest_consider(&near, self->asked + at);
            const char *best = suggest_result(&near);
            if (best)
                return pbrt_error(err, p->loc,
                                  "unsupported parameter \"%s %s\" for %s (did you mean \"%s\"?)",
                                  p->type_name, p->name, self->context, best);
            return pbrt_error(err, p->loc, "unsupported parameter \"%s %s\" for %s", p->type_name,
                              p->name, self->context);
        }
    }
    return 0;
}
