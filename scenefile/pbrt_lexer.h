/* pbrt_lexer: splits pbrt-v4 scene text into tokens (quoted strings with escapes decoded,
 * brackets, and bare words: directives, numbers, true/false), skipping # comments.
 * Every token carries its file:line:col; malformed input is an error, never a crash. */
#ifndef PRISMFARM_PBRT_LEXER_H
#define PRISMFARM_PBRT_LEXER_H

#include "err.h"

#include <stdbool.h>
#include <stddef.h>

/* Where a token starts: line and column count from 1, columns in bytes. file points to a
 * string that outlives every token and parsed value made from it (the scene owns it). */
typedef struct pbrt_loc {
    const char *file;
    int line;
    int col;
} pbrt_loc_t;

typedef enum pbrt_token_kind {
    PBRT_TOKEN_EOF,
    PBRT_TOKEN_STRING,   /* text is the decoded contents, without the quotes */
    PBRT_TOKEN_LBRACKET, /* [ */
    PBRT_TOKEN_RBRACKET, /* ] */
    PBRT_TOKEN_WORD,     /* anything else up to white space, a quote or a bracket */
} pbrt_token_kind_t;

typedef struct pbrt_token {
    pbrt_token_kind_t kind;
    const char *text; /* NUL-terminated; valid until the next call on the lexer */
    size_t len;
    pbrt_loc_t loc;
} pbrt_token_t;

typedef struct pbrt_lexer pbrt_lexer_t;

/* A lexer over text[0..len), which must stay unchanged until pbrt_lexer_destroy: it is not
 * copied (a scene file of hundreds of MB is held once) and nothing past len is read, so it
 * needs no terminating NUL. file names the source in locations. */
pbrt_lexer_t *pbrt_lexer_new(const char *file, const char *text, size_t len, err_t *err);
void pbrt_lexer_destroy(pbrt_lexer_t **self_p);

/* Reads the next token (PBRT_TOKEN_EOF at the end, repeatedly). Fails with a located message
 * on an unterminated string, a bad escape, a NUL byte or a UTF-16 file. */
int pbrt_lexer_next(pbrt_lexer_t *self, pbrt_token_t *tok, err_t *err);
/* Looks at the next token without consuming it. */
int pbrt_lexer_peek(pbrt_lexer_t *self, pbrt_token_t *tok, err_t *err);

/* Fills err with "file:line:col: " + the formatted message and returns -1. */
int pbrt_error(err_t *err, pbrt_loc_t loc, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* Parses a whole token as a finite double (decimal or hex, strtod syntax, C locale). */
int pbrt_parse_number(const char *text, double *out);
/* Parses a whole token as a decimal 32-bit integer with an optional sign. */
int pbrt_parse_int(const char *text, int *out);

#endif
