/* pbrt_names: the one lookup of a name a scene writes (a material's type, a light's, a
 * parameter's value from a fixed set) in a table of the names it may take. An unknown name
 * fails with "<what> \"name\" (did you mean \"x\"? \"a\", \"b\" or \"c\")" at the name's
 * place: the list is written from the table, so no message restates it, and the suggestion
 * (base/suggest.h) is given only when a name is near enough. The parser (pbrt_state_lookup)
 * and the scene loader both use it. */
#ifndef PRISMFARM_PBRT_NAMES_H
#define PRISMFARM_PBRT_NAMES_H

#include "err.h"
#include "pbrt_lexer.h"

#include <stddef.h>

/* One row of a name table: a name the scene may write and what it means to the reader. Rows
 * after a row whose name is NULL are aliases (pbrt-v4's "" and "none" for the interface
 * material): accepted, but not listed. */
typedef struct pbrt_name {
    const char *name;
    int value;
} pbrt_name_t;

/* Looks s (written at loc) up in table[0..n): its value into *value and 0; else -1 with err
 * as above. */
int pbrt_names_lookup(const pbrt_name_t *table, size_t n, const char *what, const char *s,
                      pbrt_loc_t loc, int *value, err_t *err);

/* The table's listed names as the lookup's message gives them ("a", "b" or "c"), into buf
 * (truncated to what fits). */
void pbrt_names_list(const pbrt_name_t *table, size_t n, char *buf, size_t size);

#endif
