/* suggest: the valid name nearest to a misspelt one, for the "did you mean ...?" of an error
 * about an unknown directive, parameter, option, command or integrator. Nearness is the
 * optimal-string-alignment edit distance (insertions, deletions, substitutions and swaps of
 * two neighbours, each 1) ignoring ASCII case; a name is suggested only when it is close
 * enough to be a slip of the hand: at most 1 edit for words of up to 4 characters, 2 up to 8,
 * 3 beyond. Pure and allocation-free; names longer than SUGGEST_MAX_LEN are never suggested. */
#ifndef PRISMFARM_SUGGEST_H
#define PRISMFARM_SUGGEST_H

#include <stddef.h>

#define SUGGEST_MAX_LEN 63

/* A running search over candidates given one at a time (from any table's layout). */
typedef struct suggest {
    const char *word; /* what the user wrote */
    const char *best; /* the nearest candidate so far within the bound, or NULL */
    int dist;         /* its distance */
} suggest_t;

suggest_t suggest_begin(const char *word);

/* Considers one candidate; the first of several at the same distance is kept, so a table's
 * order decides ties. A NULL candidate is skipped. */
void suggest_consider(suggest_t *s, const char *candidate);

/* The nearest candidate within the bound, or NULL: none, or the word itself. */
const char *suggest_result(const suggest_t *s);

/* The nearest of n names (NULL entries skipped), or NULL. */
const char *suggest_nearest(const char *word, const char *const *names, size_t n);

/* The edit distance above, or -1 when either string is longer than SUGGEST_MAX_LEN. */
int suggest_distance(const char *a, const char *b);

#endif
