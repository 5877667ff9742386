/* warnings: what a scene asks for that prismfarm accepts without simulating it (as pbrt-v4
 * accepts and ignores an unused parameter), each as one line "file:line:col: text", in the
 * order found. The parser and the loader add to the scene's list; `render`, `plan` and the
 * client print it, so a user porting a scene sees every compromise at once. Identical lines
 * are kept once, and past WARNINGS_MAX lines only a count is kept. */
#ifndef PRISMFARM_WARNINGS_H
#define PRISMFARM_WARNINGS_H

#include "err.h"
#include "pbrt_lexer.h"

#include <stddef.h>

#define WARNINGS_MAX 200

typedef struct warnings warnings_t;

warnings_t *warnings_new(err_t *err);
void warnings_destroy(warnings_t **self_p);

/* Adds "file:line:col: " and the formatted text (cut to fit err_t's message size). Fails
 * only when out of memory. */
int warnings_add(warnings_t *self, pbrt_loc_t loc, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* Adds a line as it is (already "file:line:col: text"); identical lines once. */
int warnings_add_text(warnings_t *self, const char *line);

/* Adds every line of from (and its dropped count) to self. */
int warnings_copy(warnings_t *self, const warnings_t *from);

size_t warnings_count(const warnings_t *self);
/* The i-th line, 0 <= i < warnings_count. */
const char *warnings_at(const warnings_t *self, size_t i);
/* Lines past WARNINGS_MAX, counted but not kept. */
size_t warnings_dropped(const warnings_t *self);

#endif
