#define _XOPEN_SOURCE 700 /* strdup */

#include "pbrt_state.h"

#include "suggest.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

bool pbrt_state_in_list(const char *s, const char **list, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!strcmp(s, list[i]))
            return true;
    return false;
}

int pbrt_state_lookup(parser_t *P, const char *what, const char *s, pbrt_loc_t loc,
                      const pbrt_name_t *table, size_t n, int *value)
{
    return pbrt_names_lookup(table, n, what, s, loc, value, P->err);
}

/* How a token reads in a message. */
void pbrt_state_describe(const pbrt_token_t *t, char *buf, size_t n)
{
    switch (t->kind) {
    case PBRT_TOKEN_EOF:
        snprintf(buf, n, "the end of the file");
        break;
    case PBRT_TOKEN_LBRACKET:
        snprintf(buf, n, "[");
        break;
    case PBRT_TOKEN_RBRACKET:
        snprintf(buf, n, "]");
        break;
    case PBRT_TOKEN_STRING:
        snprintf(buf, n, "\"%.60s%s\"", t->text, t->len > 60 ? "..." : "");
        break;
    case PBRT_TOKEN_WORD:
        snprintf(buf, n, "%.60s%s", t->text, t->len > 60 ? "..." : "");
        break;
    }
}

int pbrt_state_read_string(parser_t *P, const char *directive, pbrt_loc_t dloc, const char *what,
                           str_arg_t *out)
{
    pbrt_token_t t;
    if (pbrt_lexer_next(P->lex, &t, P->err) != 0)
        return -1;
    if (t.kind != PBRT_TOKEN_STRING) {
        char d[96];
        pbrt_state_describe(&t, d, sizeof d);
        return pbrt_error(P->err, t.kind == PBRT_TOKEN_EOF ? dloc : t.loc,
                          "%s expects a quoted %s, got %s", directive, what, d);
    }
    if (t.len >= sizeof out->s)
        return pbrt_error(P->err, t.loc, "%s: the %s is longer than %d characters", directive, what,
                          NAME_MAX_LEN - 1);
    if (strlen(t.text) != t.len)
        return pbrt_error(P->err, t.loc, "%s: the %s contains a NUL byte", directive, what);
    memcpy(out->s, t.text, t.len + 1);
    out->loc = t.loc;
    return 0;
}

static int number_error(parser_t *P, const pbrt_token_t *t, pbrt_loc_t dloc, const char *directive,
                        int n, int i)
{
    char d[96];
    pbrt_state_describe(t, d, sizeof d);
    if (t->kind == PBRT_TOKEN_WORD) {
        double v;
        if (pbrt_parse_number(t->text, &v) == -2)
            return pbrt_error(P->err, t->loc, "non-finite number %s in %s", d, directive);
    }
    return pbrt_error(P->err, t->kind == PBRT_TOKEN_EOF ? dloc : t->loc,
                      "%s expects %d numbers, got %s as number %d", directive, n, d, i + 1);
}

int pbrt_state_read_numbers(parser_t *P, const char *directive, pbrt_loc_t dloc, double *out, int n)
{
    for (int i = 0; i < n; i++) {
        pbrt_token_t t;
        if (pbrt_lexer_next(P->lex, &t, P->err) != 0)
            return -1;
        if (t.kind != PBRT_TOKEN_WORD || pbrt_parse_number(t.text, &out[i]) != 0)
            return number_error(P, &t, dloc, directive, n, i);
    }
    return 0;
}

/* "[" 16 numbers "]", as Transform and ConcatTransform require. */
int pbrt_state_read_matrix(parser_t *P, const char *directive, pbrt_loc_t dloc, double out[16])
{
    pbrt_token_t t;
    char d[96];
    if (pbrt_lexer_next(P->lex, &t, P->err) != 0)
        return -1;
    if (t.kind != PBRT_TOKEN_LBRACKET) {
        pbrt_state_describe(&t, d, sizeof d);
        return pbrt_error(P->err, t.kind == PBRT_TOKEN_EOF ? dloc : t.loc,
                          "%s expects [ and 16 numbers, got %s", directive, d);
    }
    for (int i = 0; i < 16; i++) {
        if (pbrt_lexer_next(P->lex, &t, P->err) != 0)
            return -1;
        if (t.kind == PBRT_TOKEN_RBRACKET)
            return pbrt_error(P->err, t.loc, "%s expects 16 numbers, got %d", directive, i);
        if (t.kind != PBRT_TOKEN_WORD || pbrt_parse_number(t.text, &out[i]) != 0)
            return number_error(P, &t, dloc, directive, 16, i);
    }
    if (pbrt_lexer_next(P->lex, &t, P->err) != 0)
        return -1;
    if (t.kind != PBRT_TOKEN_RBRACKET) {
        pbrt_state_describe(&t, d, sizeof d);
        return pbrt_error(P->err, t.kind == PBRT_TOKEN_EOF ? dloc : t.loc,
                          "%s expects ] after 16 numbers, got %s", directive, d);
    }
    return 0;
}

static int add_value(parser_t *P, params_t *ps, param_t *p, const pbrt_token_t *t)
{
    char d[96];
    pbrt_state_describe(t, d, sizeof d);
    bool is_bool_word =
        t->kind == PBRT_TOKEN_WORD && (!strcmp(t->text, "true") || !strcmp(t->text, "false"));
    switch (p->type) {
    case PARAM_STRING:
    case PARAM_TEXTURE:
        if (t->kind != PBRT_TOKEN_STRING)
            return pbrt_error(P->err, t->loc, "\"%s %s\" needs quoted strings, got %s",
                              p->type_name, p->name, d);
        if (strlen(t->text) != t->len)
            return pbrt_error(P->err, t->loc, "string value of \"%s %s\" contains a NUL byte",
                              p->type_name, p->name);
        return params_push_string(ps, p, t->text, P->err);
    case PARAM_BOOL:
        /* pbrt-v4 writes true/false bare; older files quote them. */
        if (is_bool_word || (t->kind == PBRT_TOKEN_STRING &&
                             (!strcmp(t->text, "true") || !strcmp(t->text, "false"))))
            return params_push_bool(ps, p, !strcmp(t->text, "true"), P->err);
        return pbrt_error(P->err, t->loc, "\"%s %s\" needs true or false, got %s", p->type_name,
                          p->name, d);
    case PARAM_SPECTRUM:
        if (t->kind == PBRT_TOKEN_STRING) {
            if (strlen(t->text) != t->len)
                return pbrt_error(P->err, t->loc, "string value of \"%s %s\" contains a NUL byte",
                                  p->type_name, p->name);
            return params_push_string(ps, p, t->text, P->err);
        }
        break;
    default:
        break;
    }
    if (t->kind != PBRT_TOKEN_WORD || is_bool_word)
        return pbrt_error(P->err, t->loc, "\"%s %s\" needs numbers, got %s", p->type_name, p->name,
                          d);
    if (p->type == PARAM_INTEGER) {
        int v;
        int rc = pbrt_parse_int(t->text, &v);
        if (rc == -2)
            return pbrt_error(P->err, t->loc, "%s is out of range for \"%s %s\" (32-bit integers)",
                              d, p->type_name, p->name);
        if (rc != 0)
            return pbrt_error(P->err, t->loc, "\"%s %s\" needs integers, got %s", p->type_name,
                              p->name, d);
        return params_push_number(ps, p, (double)v, P->err);
    }
    double v;
    int rc = pbrt_parse_number(t->text, &v);
    if (rc == -2)
        return pbrt_error(P->err, t->loc, "non-finite number %s in \"%s %s\"", d, p->type_name,
                          p->name);
    if (rc != 0)
        return pbrt_error(P->err, t->loc, "\"%s %s\" needs numbers, got %s", p->type_name, p->name,
                          d);
    return params_push_number(ps, p, v, P->err);
}

/* The parameter list after a directive: quoted "type name" declarations, each followed by one
 * value or a bracketed list. It ends at the first token that is not a quoted string. */
params_t *pbrt_state_read_params(parser_t *P, const char *context)
{
    params_t *ps = params_new(context, P->err);
    if (!ps)
        return NULL;
    for (;;) {
        pbrt_token_t t;
        if (pbrt_lexer_peek(P->lex, &t, P->err) != 0)
            goto fail;
        if (t.kind != PBRT_TOKEN_STRING)
            return ps;
        if (pbrt_lexer_next(P->lex, &t, P->err) != 0)
            goto fail;
        if (strlen(t.text) != t.len) {
            pbrt_error(P->err, t.loc, "parameter declaration contains a NUL byte");
            goto fail;
        }
        param_t *p = params_declare(ps, t.text, t.loc, P->err);
        if (!p)
            goto fail;
        if (pbrt_lexer_next(P->lex, &t, P->err) != 0)
            goto fail;
        if (t.kind == PBRT_TOKEN_LBRACKET) {
            pbrt_loc_t open = t.loc;
            for (;;) {
                if (pbrt_lexer_next(P->lex, &t, P->err) != 0)
                    goto fail;
                if (t.kind == PBRT_TOKEN_RBRACKET)
                    break;
                if (t.kind == PBRT_TOKEN_EOF) {
                    pbrt_error(P->err, open, "unterminated [ after \"%s %s\"", p->type_name,
                               p->name);
                    goto fail;
                }
                if (t.kind == PBRT_TOKEN_LBRACKET) {
                    pbrt_error(P->err, t.loc, "unexpected [ inside the values of \"%s %s\"",
                               p->type_name, p->name);
                    goto fail;
                }
                if (add_value(P, ps, p, &t) != 0)
                    goto fail;
            }
        } else if (t.kind == PBRT_TOKEN_RBRACKET || t.kind == PBRT_TOKEN_EOF) {
            pbrt_error(P->err, p->loc, "missing value after \"%s %s\"", p->type_name, p->name);
            goto fail;
        } else if (add_value(P, ps, p, &t) != 0) {
            goto fail;
        }
    }
fail:
    params_destroy(&ps);
    return NULL;
}

int pbrt_state_need_world(parser_t *P, const char *directive, pbrt_loc_t loc)
{
    if (!P->world)
        return pbrt_error(P->err, loc, "%s is only allowed after WorldBegin", directive);
    return 0;
}

int pbrt_state_need_options(parser_t *P, const char *directive, pbrt_loc_t loc)
{
    if (P->world)
        return pbrt_error(P->err, loc, "%s must come before WorldBegin (line %d)", directive,
                          P->world_loc.line);
    return 0;
}

/* A transform that a shape, light, camera or instance will use must be invertible, affine and
 * finite, or the renderer would meet NaN. */
int pbrt_state_check_transform(parser_t *P, const transform_t *t, const char *user, pbrt_loc_t loc)
{
    if (!transform_is_finite(t))
        return pbrt_error(P->err, loc,
                          "the current transform has non-finite entries, so %s "
                          "cannot use it",
                          user);
    if (!transform_is_affine(t))
        return pbrt_error(P->err, loc,
                          "the current transform is projective (its last row is not "
                          "0 0 0 1), so %s cannot use it",
                          user);
    if (t->singular)
        return pbrt_error(P->err, loc, "the current transform is singular, so %s cannot use it",
                          user);
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            if (!isfinite(t->m_inv[i][j]))
                return pbrt_error(P->err, loc,
                                  "the current transform is singular, so %s "
                                  "cannot use it",
                                  user);
    return 0;
}

int pbrt_state_push_frame(parser_t *P, int kind, const char *what, pbrt_loc_t loc)
{
    if (P->nframes == P->cap_frames) {
        size_t cap = P->cap_frames ? P->cap_frames * 2 : 16;
        if (cap > 1u << 20)
            return pbrt_error(P->err, loc, "%s nested more than a million deep", what);
        frame_t *f = realloc(P->frames, cap * sizeof *f);
        if (!f)
            return pbrt_error(P->err, loc, "out of memory");
        P->frames = f;
        P->cap_frames = cap;
    }
    P->frames[P->nframes++] = (frame_t){kind, what, loc, P->gs};
    return 0;
}

int pbrt_state_set_coordsys(parser_t *P, const char *name, transform_t t, pbrt_loc_t loc)
{
    for (size_t i = 0; i < P->ncs; i++)
        if (!strcmp(P->cs[i].name, name)) {
            P->cs[i].t = t;
            return 0;
        }
    if (P->ncs == P->cap_cs) {
        size_t cap = P->cap_cs ? P->cap_cs * 2 : 8;
        coordsys_t *c = realloc(P->cs, cap * sizeof *c);
        if (!c)
            return pbrt_error(P->err, loc, "out of memory");
        P->cs = c;
        P->cap_cs = cap;
    }
    char *copy = strdup(name);
    if (!copy)
        return pbrt_error(P->err, loc, "out of memory");
    P->cs[P->ncs++] = (coordsys_t){copy, t};
    return 0;
}

/* A message at *from, or without a location for the main file (from NULL); returns -1. */
__attribute__((format(printf, 3, 4))) int pbrt_state_fail_at(parser_t *P, const pbrt_loc_t *from,
                                                             const char *fmt, ...)
{
    char msg[sizeof P->err->msg];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return from ? pbrt_error(P->err, *from, "%s", msg) : err_set(P->err, "%s", msg);
}

int pbrt_state_check_positive(parser_t *P, params_t *ps, const char *name, double v)
{
    if (v > 0.0)
        return 0;
    param_t *p = params_find(ps, name);
    return pbrt_error(P->err, p ? p->loc : (pbrt_loc_t){P->file, 0, 0},
                      "\"%s %s\" must be greater than 0, got %g", p ? p->type_name : "float", name,
                      v);
}

int pbrt_state_check_range(parser_t *P, params_t *ps, const char *name, double v, double lo,
                           double hi)
{
    if (v >= lo && v <= hi)
        return 0;
    param_t *p = params_find(ps, name);
    return pbrt_error(P->err, p ? p->loc : (pbrt_loc_t){P->file, 0, 0},
                      "\"%s %s\" must be within [%g, %g], got %g", p ? p->type_name : "float", name,
                      lo, hi, v);
}

double *pbrt_state_copy_doubles(parser_t *P, const double *src, size_t n)
{
    double *d = scene_desc_alloc(P->scene, n * sizeof *d, P->err);
    if (d)
        memcpy(d, src, n * sizeof *d);
    return d;
}

/* Gives ps the `Attribute` defaults in effect for kind that it does not set itself; the
 * newest Attribute wins over older ones, as in pbrt-v4. */
int pbrt_state_attr_apply(parser_t *P, params_t *ps, int kind)
{
    for (const attr_node_t *n = P->gs.attr[kind]; n; n = n->older)
        if (params_add_defaults(ps, n->ps, P->err) != 0)
            return -1;
    return 0;
}
