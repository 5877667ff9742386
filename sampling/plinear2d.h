/* plinear2d: a bilinear density on the unit square, given at nx x ny grid points, optionally
 * conditioned on up to three parameters (a slice of the grid per combination of the
 * parameters' grid values, blended linearly between them), with sampling by a marginal over
 * rows then the row's conditional, and the inverse of that sampling map. This is the warp of
 * Dupuy & Jakob 2018 ("An Adaptive Parameterization for Efficient Material Acquisition and
 * Rendering", §5) as pbrt-v4's PiecewiseLinear2D implements it; pbrt-v4 is the reference for
 * what each value means.
 *
 * Guarantees: a sampling warp's slices are each normalised to integrate to 1 (a slice whose
 * values sum to 0 is taken as uniform), so a blend of slices does too, and sample, invert and
 * pdf agree: invert(sample(u)) = u and the density sample returns is pdf at the point, for
 * any parameters (outside their grid: the nearest end). Every value returned is finite. An
 * evaluation-only warp keeps its values as given: eval is their bilinear interpolation. */
#ifndef PRISMFARM_PLINEAR2D_H
#define PRISMFARM_PLINEAR2D_H

#include "err.h"

#include <stdbool.h>
#include <stddef.h>

#define PLINEAR2D_MAX_PARAMS 3

typedef struct plinear2d plinear2d_t;

/* data: one nx * ny slice (x fastest) per combination of the parameters' grid values, the
 * first parameter slowest (pbrt-v4's layout); nx, ny >= 2; every value finite (and >= 0 when
 * sampling). param_values[k] holds param_res[k] >= 1 strictly increasing finite values.
 * sampling: build the cumulative tables and normalise (else only plinear2d_eval is usable).
 * Copies what it needs. NULL with err (naming `what`) on bad input or no memory. */
plinear2d_t *plinear2d_new(const float *data, int nx, int ny, int nparams, const int *param_res,
                           const float *const *param_values, bool sampling, const char *what,
                           err_t *err);
void plinear2d_destroy(plinear2d_t **self_p);

/* The interpolated value at (x, y) in [0, 1]^2 (clamped); for a sampling warp, the density. */
double plinear2d_eval(const plinear2d_t *self, double x, double y, const double *params);

/* Maps (u0, u1) in [0, 1)^2 to a point out[0..1] of the square and its density *pdf (a
 * sampling warp only). */
void plinear2d_sample(const plinear2d_t *self, double u0, double u1, const double *params,
                      double out[2], double *pdf);

/* The inverse of plinear2d_sample: the (u0, u1) that map to (x, y), and the density there. */
void plinear2d_invert(const plinear2d_t *self, double x, double y, const double *params,
                      double out[2], double *pdf);

/* Bytes held (for messages and budgets). */
size_t plinear2d_bytes(const plinear2d_t *self);

#endif
