/* alias: sampling a discrete distribution in O(1) per draw with Vose's alias method (Vose 1991,
 * "A linear algorithm for generating random numbers with a given distribution"). Built once in
 * O(n) from non-negative weights; entries of weight zero are never drawn, and the reported pmf
 * is each weight over their compensated sum, so pmfs sum to 1 within a few ulps. */
#ifndef PRISMFARM_ALIAS_H
#define PRISMFARM_ALIAS_H

#include <stddef.h>

#include "err.h"

typedef struct alias alias_t;

/* Builds the table for weights[0..n-1]. Fails (NULL, err filled naming the index at fault) on
 * n = 0, a NULL array, a negative, NaN or infinite weight, an all-zero set, or weights whose
 * sum overflows a double. The weights are copied; the caller keeps its array. */
alias_t *alias_new(const double *weights, size_t n, err_t *err);

/* Frees the table and sets *self_p to NULL; a NULL or already-NULL pointer is fine. */
void alias_destroy(alias_t **self_p);

size_t alias_size(const alias_t *self);

/* Maps one uniform u in [0, 1) to an index, drawn with probability alias_pmf(self, index),
 * and stores that pmf in *pmf unless pmf is NULL. u outside [0, 1) is clamped. The u's 53 bits
 * are split between the column (log2 n bits) and the coin, so an entry whose probability is
 * below about 2^-53 n is drawn with probability rounded to the coin's resolution. */
size_t alias_sample(const alias_t *self, double u, double *pmf);

/* weight[i] / sum of weights; 0 for i >= n. */
double alias_pmf(const alias_t *self, size_t i);

#endif
