/* distrib2d: a piecewise-constant density on the unit square over an nu x nv grid of cells
 * (pbrt-v4's PiecewiseConstant2D, PBR 4th ed. §A.5): a marginal over rows, then the row's
 * conditional over columns, each drawn by inverting its cumulative sum. The density of (u, v) is
 * f(cell) / mean(f), so it integrates to 1 over the square; cells of weight 0 are never drawn.
 * An all-zero grid is uniform. */
#ifndef PRISMFARM_DISTRIB2D_H
#define PRISMFARM_DISTRIB2D_H

#include "err.h"

typedef struct distrib2d distrib2d_t;

/* f[iv * nu + iu] >= 0 and finite, nu, nv >= 1; copied. NULL with err on bad input. */
distrib2d_t *distrib2d_new(const double *f, int nu, int nv, err_t *err);
void distrib2d_destroy(distrib2d_t **self_p);

/* Maps (u0, u1) in [0, 1)^2 to a point (u, v) of the square with its density *pdf (> 0). */
void distrib2d_sample(const distrib2d_t *self, double u0, double u1, double *u, double *v,
                      double *pdf);

/* The density at (u, v) in [0, 1]^2 (clamped to the grid). */
double distrib2d_pdf(const distrib2d_t *self, double u, double v);

#endif
