#include "spectral_grid.h"

#include <math.h>
#include <stdlib.h>

spectral_grid_t spectral_grid_default(void)
{
    return (spectral_grid_t){SPECTRAL_GRID_DEFAULT_N, SPECTRAL_GRID_DEFAULT_MIN,
                             SPECTRAL_GRID_DEFAULT_MAX};
}

int spectral_grid_validate(spectral_grid_t grid, err_t *err)
{
    if (grid.n < 1 || grid.n > SPECTRAL_GRID_MAX_BUCKETS)
        return err_set(err, "spectral grid: n = %d buckets, must be 1..%d", grid.n,
                       SPECTRAL_GRID_MAX_BUCKETS);
    if (!isfinite(grid.lambda_min) || grid.lambda_min <= 0.0)
        return err_set(err, "spectral grid: lambda_min = %g nm, must be finite and > 0",
                       grid.lambda_min);
    if (!isfinite(grid.lambda_max) || grid.lambda_max <= grid.lambda_min)
        return err_set(err,
                       "spectral grid: lambda_max = %g nm, must be finite and > lambda_min = %g nm",
                       grid.lambda_max, grid.lambda_min);
    return 0;
}

int spectral_grid_init(spectral_grid_t *grid, int n, double lambda_min, double lambda_max,
                       err_t *err)
{
    spectral_grid_t g = {n, lambda_min, lambda_max};
    if (spectral_grid_validate(g, err) != 0)
        return -1;
    *grid = g;
    return 0;
}

double spectral_grid_width(spectral_grid_t grid)
{
    return (grid.lambda_max - grid.lambda_min) / (double)grid.n;
}

double spectral_grid_bucket_min(spectral_grid_t grid, int i)
{
    return grid.lambda_min + (grid.lambda_max - grid.lambda_min) * (double)i / (double)grid.n;
}

double spectral_grid_bucket_max(spectral_grid_t grid, int i)
{
    return i + 1 == grid.n ? grid.lambda_max : spectral_grid_bucket_min(grid, i + 1);
}

double spectral_grid_centre(spectral_grid_t grid, int i)
{
    return grid.lambda_min +
           (grid.lambda_max - grid.lambda_min) * ((double)i + 0.5) / (double)grid.n;
}

int spectral_grid_index(spectral_grid_t grid, double lambda_nm)
{
    if (!isfinite(lambda_nm) || lambda_nm < grid.lambda_min || lambda_nm > grid.lambda_max)
        return -1;
    int i = (int)floor((lambda_nm - grid.lambda_min) / (grid.lambda_max - grid.lambda_min) *
                       (double)grid.n);
    if (i >= grid.n)
        i = grid.n - 1;
    if (i < 0)
        i = 0;
    /* The division can round across a boundary for lambda within an ulp of it; agree with
     * spectral_grid_bucket_min, which defines the boundaries. */
    if (i > 0 && lambda_nm < spectral_grid_bucket_min(grid, i))
        i--;
    else if (i + 1 < grid.n && lambda_nm >= spectral_grid_bucket_min(grid, i + 1))
        i++;
    return i;
}

/* The splat once bucket i (>= 0) of lambda_nm is known: shared by spectral_grid_splat and the
 * table's, so that both give the same bits. */
static int splat_in(spectral_grid_t grid, double width, int i, double *buckets, double lambda_nm,
                    double value, double pdf, spectral_splat_t mode)
{
    double contribution = value / (pdf * width);
    if (!isfinite(contribution))
        return -1; /* a tiny pdf can overflow the quotient */
    if (mode == SPECTRAL_SPLAT_BOX || grid.n == 1) {
        buckets[i] += contribution;
        return 0;
    }
    /* Tent: position in units of buckets measured from the first centre. */
    double pos = (lambda_nm - grid.lambda_min) / width - 0.5;
    if (pos <= 0.0) {
        buckets[0] += contribution;
        return 0;
    }
    if (pos >= (double)(grid.n - 1)) {
        buckets[grid.n - 1] += contribution;
        return 0;
    }
    int lo = (int)pos;
    double f = pos - (double)lo;
    buckets[lo] += (1.0 - f) * contribution;
    buckets[lo + 1] += f * contribution;
    return 0;
}

int spectral_grid_splat(spectral_grid_t grid, double *buckets, double lambda_nm, double value,
                        double pdf, spectral_splat_t mode)
{
    if (!isfinite(lambda_nm) || !isfinite(value) || !isfinite(pdf) || pdf <= 0.0)
        return -1;
    int i = spectral_grid_index(grid, lambda_nm);
    if (i < 0)
        return 0;
    return splat_in(grid, spectral_grid_width(grid), i, buckets, lambda_nm, value, pdf, mode);
}

struct spectral_table {
    spectral_grid_t grid;
    double width; /* spectral_grid_width */
    double min[]; /* [n]: spectral_grid_bucket_min of each bucket */
};

spectral_table_t *spectral_table_new(spectral_grid_t grid, err_t *err)
{
    if (spectral_grid_validate(grid, err))
        return NULL;
    spectral_table_t *self = malloc(sizeof *self + (size_t)grid.n * sizeof self->min[0]);
    if (!self) {
        err_set(err, "out of memory");
        return NULL;
    }
    self->grid = grid;
    self->width = spectral_grid_width(grid);
    for (int i = 0; i < grid.n; i++)
        self->min[i] = spectral_grid_bucket_min(grid, i);
    return self;
}

void spectral_table_destroy(spectral_table_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    free(*self_p);
    *self_p = NULL;
}

int spectral_table_index(const spectral_table_t *self, double lambda_nm)
{
    const spectral_grid_t g = self->grid;
    if (!isfinite(lambda_nm) || lambda_nm < g.lambda_min || lambda_nm > g.lambda_max)
        return -1;
    /* The same quotient as spectral_grid_index; it is >= 0 here, so truncation is its floor. */
    double x = (lambda_nm - g.lambda_min) / (g.lambda_max - g.lambda_min) * (double)g.n;
    int i = (int)x;
    if (i >= g.n)
        i = g.n - 1;
    if (i > 0 && lambda_nm < self->min[i])
        i--;
    else if (i + 1 < g.n && lambda_nm >= self->min[i + 1])
        i++;
    return i;
}

int spectral_table_splat(const spectral_table_t *self, double *buckets, double lambda_nm,
                         double value, double pdf, spectral_splat_t mode)
{
    /* spectral_grid_splat, step for step, with the table's boundaries and width. */
    if (!isfinite(lambda_nm) || !isfinite(value) || !isfinite(pdf) || pdf <= 0.0)
        return -1;
    int i = spectral_table_index(self, lambda_nm);
    if (i < 0)
        return 0;
    return splat_in(self->grid, self->width, i, buckets, lambda_nm, value, pdf, mode);
}
