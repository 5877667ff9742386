#include "alias.h"

#include <math.h>
#include <stdlib.h>

/* One column of the table: keep the column's own index with probability prob, else take
 * alias. Kept together so a draw touches one cache line. */
typedef struct alias_column {
    double prob;
    size_t alias;
} alias_column_t;

struct alias {
    size_t n;
    alias_column_t *table;
    double *pmf;
};

void alias_destroy(alias_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    alias_t *self = *self_p;
    free(self->table);
    free(self->pmf);
    free(self);
    *self_p = NULL;
}

/* Neumaier's compensated sum (Neumaier 1974): the error term carries the low bits lost in
 * each addition, so a sum of weights spanning 1e-9..1e9 over 1e6 entries keeps full
 * precision instead of dropping the small ones. */
static double sum_compensated(const double *x, size_t n)
{
    double s = 0.0, c = 0.0;
    for (size_t i = 0; i < n; i++) {
        double t = s + x[i];
        if (fabs(s) >= fabs(x[i]))
            c += (s - t) + x[i];
        else
            c += (x[i] - t) + s;
        s = t;
    }
    return isfinite(s) ? s + c : s; /* on overflow c is -Inf and s + c would be NaN */
}

alias_t *alias_new(const double *weights, size_t n, err_t *err)
{
    if (!weights || n == 0) {
        err_set(err, "alias_new: empty distribution (weights %s, n = %zu)",
                weights ? "given" : "NULL", n);
        return NULL;
    }
    for (size_t i = 0; i < n; i++) {
        if (!isfinite(weights[i]) || weights[i] < 0.0) {
            err_set(err, "alias_new: weight[%zu] = %g; weights must be finite and >= 0", i,
                    weights[i]);
            return NULL;
        }
    }
    double total = sum_compensated(weights, n);
    if (!isfinite(total)) {
        err_set(err, "alias_new: the sum of the %zu weights overflows a double", n);
        return NULL;
    }
    if (!(total > 0.0)) {
        err_set(err, "alias_new: all %zu weights are zero; nothing can be drawn", n);
        return NULL;
    }

    alias_t *self = calloc(1, sizeof *self);
    double *scaled = malloc(n * sizeof *scaled);
    size_t *work = malloc(n * sizeof *work);
    if (self) {
        self->table = malloc(n * sizeof *self->table);
        self->pmf = malloc(n * sizeof *self->pmf);
    }
    if (!self || !self->table || !self->pmf || !scaled || !work) {
        err_set(err, "alias_new: out of memory for %zu entries", n);
        free(scaled);
        free(work);
        alias_destroy(&self);
        return NULL;
    }
    self->n = n;

    /* Vose 1991: scale the pmf so the mean column holds 1. Columns below 1 ("small") are
     * topped up from one column above 1 ("large"), which is then re-filed by what it has
     * left. Each step settles one column, so the table is built in O(n). The work array
     * holds the small stack at its front and the large stack at its back; together they never
     * hold more than n indices. */
    size_t n_small = 0, n_large = 0, heaviest = 0;
    for (size_t i = 0; i < n; i++) {
        self->pmf[i] = weights[i] / total;
        scaled[i] = self->pmf[i] * (double)n;
        self->table[i] = (alias_column_t){1.0, i};
        if (weights[i] > weights[heaviest])
            heaviest = i;
        if (scaled[i] < 1.0)
            work[n_small++] = i;
        else
            work[n - 1 - n_large++] = i;
    }
    while (n_small > 0 && n_large > 0) {
        size_t s = work[--n_small];
        size_t l = work[n - n_large--];
        self->table[s] = (alias_column_t){scaled[s], l};
        /* Written (l + s) - 1 rather than l - (1 - s): the subtraction of nearly equal values
         * comes last, which loses less (Schwarz 2011, "Darts, Dice, and Coins"). */
        scaled[l] = (scaled[l] + scaled[s]) - 1.0;
        if (scaled[l] < 1.0)
            work[n_small++] = l;
        else
            work[n - 1 - n_large++] = l;
    }
    /* In exact arithmetic both stacks empty together and every leftover holds exactly 1;
     * round-off can leave columns at 1 +- n eps, which keep themselves (prob 1, set above).
     * A zero-weight column must never keep itself, so if one is ever left over it hands its
     * whole column to the heaviest entry; the pmf error this makes is of round-off size. */
    while (n_small > 0) {
        size_t s = work[--n_small];
        if (weights[s] == 0.0)
            self->table[s] = (alias_column_t){0.0, heaviest};
    }
    free(scaled);
    free(work);
    return self;
}

size_t alias_size(const alias_t *self)
{
    return self->n;
}

size_t alias_sample(const alias_t *self, double u, double *pmf)
{
    double x = u * (double)self->n;
    if (!(x > 0.0)) /* also catches NaN */
        x = 0.0;
    size_t col = x < (double)self->n ? (size_t)x : self->n - 1;
    double coin = x - (double)col; /* in [0, 1) except at the clamped top end, where it is >= 1 */
    size_t k = coin < self->table[col].prob ? col : self->table[col].alias;
    if (pmf)
        *pmf = self->pmf[k];
    return k;
}

double alias_pmf(const alias_t *self, size_t i)
{
    return i < self->n ? self->pmf[i] : 0.0;
}
