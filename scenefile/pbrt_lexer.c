#include "pbrt_lexer.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct pbrt_lexer {
    const char *text; /* the caller's (not copied), read only within [0, len) */
    size_t len;
    size_t pos;
    int line;
    int col;
    const char *file;
    /* Two scratch buffers so that a peeked token does not overwrite the one before it. */
    char *scratch[2];
    size_t cap[2];
    int which;
    bool has_peek;
    pbrt_token_t peeked;
    err_t peek_err;
    int peek_status;
};

int pbrt_error(err_t *err, pbrt_loc_t loc, const char *fmt, ...)
{
    if (err) {
        int n = snprintf(err->msg, sizeof err->msg, "%s:%d:%d: ", loc.file ? loc.file : "<input>",
                         loc.line, loc.col);
        if (n >= 0 && (size_t)n < sizeof err->msg) {
            va_list ap;
            va_start(ap, fmt);
            vsnprintf(err->msg + n, sizeof err->msg - (size_t)n, fmt, ap);
            va_end(ap);
        }
    }
    return -1;
}

pbrt_lexer_t *pbrt_lexer_new(const char *file, const char *text, size_t len, err_t *err)
{
    pbrt_lexer_t *self = calloc(1, sizeof *self);
    if (!self) {
        err_set(err, "%s: out of memory", file);
        return NULL;
    }
    self->text = text;
    self->len = len;
    self->line = 1;
    self->col = 1;
    self->file = file;
    return self;
}

void pbrt_lexer_destroy(pbrt_lexer_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    pbrt_lexer_t *self = *self_p;
    free(self->scratch[0]);
    free(self->scratch[1]);
    free(self);
    *self_p = NULL;
}

static int scratch_reserve(pbrt_lexer_t *self, int slot, size_t need, err_t *err)
{
    if (need <= self->cap[slot])
        return 0;
    size_t cap = self->cap[slot] ? self->cap[slot] : 64;
    while (cap < need)
        cap *= 2;
    char *p = realloc(self->scratch[slot], cap);
    if (!p)
        return err_set(err, "%s: out of memory", self->file);
    self->scratch[slot] = p;
    self->cap[slot] = cap;
    return 0;
}

static void advance(pbrt_lexer_t *self)
{
    if (self->text[self->pos] == '\n') {
        self->line++;
        self->col = 1;
    } else {
        self->col++;
    }
    self->pos++;
}

static bool is_space(char c)
{
    return c == ' ' || c == '\n' || c == '\t' || c == '\r';
}

static int decode_escape(char c, char *out)
{
    switch (c) {
    case 'b':
        *out = '\b';
        return 0;
    case 'f':
        *out = '\f';
        return 0;
    case 'n':
        *out = '\n';
        return 0;
    case 'r':
        *out = '\r';
        return 0;
    case 't':
        *out = '\t';
        return 0;
    case '\\':
        *out = '\\';
        return 0;
    case '\'':
        *out = '\'';
        return 0;
    case '"':
        *out = '"';
        return 0;
    default:
        return -1;
    }
}

static int lex(pbrt_lexer_t *self, pbrt_token_t *tok, int slot, err_t *err)
{
    if (self->pos == 0 && self->len >= 2) {
        unsigned char b0 = (unsigned char)self->text[0], b1 = (unsigned char)self->text[1];
        if ((b0 == 0xfe && b1 == 0xff) || (b0 == 0xff && b1 == 0xfe))
            return pbrt_error(err, (pbrt_loc_t){self->file, 1, 1},
                              "file is UTF-16 encoded; scenes must be ASCII or UTF-8");
    }
    if (self->pos == 0 && self->len >= 3 && !memcmp(self->text, "\xef\xbb\xbf", 3))
        self->pos = 3; /* a UTF-8 byte-order mark carries no meaning */
    for (;;) {
        while (self->pos < self->len && is_space(self->text[self->pos]))
            advance(self);
        if (self->pos < self->len && self->text[self->pos] == '#') {
            while (self->pos < self->len && self->text[self->pos] != '\n' &&
                   self->text[self->pos] != '\r')
                advance(self);
            continue;
        }
        break;
    }
    pbrt_loc_t loc = {self->file, self->line, self->col};
    tok->loc = loc;
    if (self->pos >= self->len) {
        tok->kind = PBRT_TOKEN_EOF;
        tok->text = "";
        tok->len = 0;
        return 0;
    }
    char c = self->text[self->pos];
    if (c == '\0')
        return pbrt_error(err, loc, "NUL byte in the scene text");
    if (c == '[' || c == ']') {
        advance(self);
        tok->kind = c == '[' ? PBRT_TOKEN_LBRACKET : PBRT_TOKEN_RBRACKET;
        tok->text = c == '[' ? "[" : "]";
        tok->len = 1;
        return 0;
    }
    if (c == '"') {
        advance(self);
        size_t n = 0;
        for (;;) {
            if (self->pos >= self->len)
                return pbrt_error(err, loc,
                                  "unterminated string (end of file before the "
                                  "closing quote)");
            char ch = self->text[self->pos];
            if (ch == '\n' || ch == '\r')
                return pbrt_error(err, loc,
                                  "unterminated string (end of line before the "
                                  "closing quote)");
            if (ch == '\0')
                return pbrt_error(err, (pbrt_loc_t){self->file, self->line, self->col},
                                  "NUL byte in a string");
            if (ch == '"') {
                advance(self);
                break;
            }
            if (ch == '\\') {
                pbrt_loc_t esc_loc = {self->file, self->line, self->col};
                advance(self);
                if (self->pos >= self->len)
                    return pbrt_error(err, loc, "unterminated string (end of file after '\\')");
                char e = self->text[self->pos];
                if (decode_escape(e, &ch) != 0) {
                    if ((unsigned char)e < 0x20 || (unsigned char)e >= 0x7f)
                        return pbrt_error(err, esc_loc, "unknown escape sequence in string");
                    return pbrt_error(err, esc_loc, "unknown escape sequence \"\\%c\" in string",
                                      e);
                }
            }
            if (scratch_reserve(self, slot, n + 2, err) != 0)
                return -1;
            self->scratch[slot][n++] = ch;
            advance(self);
        }
        if (scratch_reserve(self, slot, n + 1, err) != 0)
            return -1;
        self->scratch[slot][n] = '\0';
        tok->kind = PBRT_TOKEN_STRING;
        tok->text = self->scratch[slot];
        tok->len = n;
        return 0;
    }
    size_t start = self->pos;
    while (self->pos < self->len) {
        char ch = self->text[self->pos];
        if (is_space(ch) || ch == '"' || ch == '[' || ch == ']')
            break;
        if (ch == '\0')
            return pbrt_error(err, (pbrt_loc_t){self->file, self->line, self->col},
                              "NUL byte in the scene text");
        advance(self);
    }
    size_t n = self->pos - start;
    if (scratch_reserve(self, slot, n + 1, err) != 0)
        return -1;
    memcpy(self->scratch[slot], self->text + start, n);
    self->scratch[slot][n] = '\0';
    tok->kind = PBRT_TOKEN_WORD;
    tok->text = self->scratch[slot];
    tok->len = n;
    return 0;
}

int pbrt_lexer_next(pbrt_lexer_t *self, pbrt_token_t *tok, err_t *err)
{
    if (self->has_peek) {
        self->has_peek = false;
        if (self->peek_status != 0) {
            if (err)
                *err = self->peek_err;
            return -1;
        }
        *tok = self->peeked;
        return 0;
    }
    int slot = self->which;
    self->which ^= 1;
    return lex(self, tok, slot, err);
}

int pbrt_lexer_peek(pbrt_lexer_t *self, pbrt_token_t *tok, err_t *err)
{
    if (!self->has_peek) {
        int slot = self->which;
        self->which ^= 1;
        self->peek_status = lex(self, &self->peeked, slot, &self->peek_err);
        self->has_peek = true;
    }
    if (self->peek_status != 0) {
        if (err)
            *err = self->peek_err;
        return -1;
    }
    *tok = self->peeked;
    return 0;
}

int pbrt_parse_number(const char *text, double *out)
{
    /* strtod also accepts "inf", "nan" and leading white space: allow only the characters of
     * decimal and hexadecimal numbers so that those never reach a scene. */
    if (!text[0])
        return -1;
    bool hex = false;
    for (const char *p = text; *p; p++) {
        char c = *p;
        if ((c >= '0' && c <= '9') || c == '.' || c == '+' || c == '-' || c == 'e' || c == 'E')
            continue;
        if (c == 'x' || c == 'X') {
            hex = true;
            continue;
        }
        if (hex && ((c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F') || c == 'p' || c == 'P'))
            continue;
        return -1;
    }
    char *end = NULL;
    errno = 0;
    double v = strtod(text, &end);
    if (end == text || *end != '\0')
        return -1;
    if (!isfinite(v))
        return -2;
    *out = v;
    return 0;
}

int pbrt_parse_int(const char *text, int *out)
{
    const char *p = text;
    bool neg = false;
    if (*p == '+' || *p == '-')
        neg = *p++ == '-';
    if (!*p)
        return -1;
    long long v = 0;
    for (; *p; p++) {
        if (*p < '0' || *p > '9')
            return -1;
        v = v * 10 + (*p - '0');
        if (v > (long long)INT_MAX + 1)
            return -2;
    }
    if (neg)
        v = -v;
    if (v > INT_MAX || v < INT_MIN)
        return -2;
    *out = (int)v;
    return 0;
}
