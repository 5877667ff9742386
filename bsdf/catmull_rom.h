/* catmull_rom: cubic Catmull-Rom splines through tabulated samples on a non-uniform grid, as
 * pbrt-v4 (util/math.h) uses them for its BSSRDF tables: the four weights of an interpolation,
 * the spline's integral with its running CDF, the inverse of a monotone spline, and sampling of
 * a 2D table's rows in proportion to a spline (the row itself an interpolation between rows).
 * The derivative at an interior node is the central difference (f[i+1] - f[i-1]) /
 * (x[i+1] - x[i-1]); at an end, the one-sided difference of its interval (pbrt-v3 §8.6.2,
 * "Catmull-Rom splines"; Catmull & Rom 1974). Every function is finite for finite input. */
#ifndef PRISMFARM_CATMULL_ROM_H
#define PRISMFARM_CATMULL_ROM_H

#include <stdbool.h>
#include <stddef.h>

/* The weights w[0..3] of nodes offset .. offset + 3 (a weight of a node outside 0..n-1 is 0)
 * whose sum with the values f interpolates the spline at x; false when x lies outside
 * [x[0], x[n-1]] (or n < 2). */
bool catmull_rom_weights(const double *x, size_t n, double at, int *offset, double w[4]);

/* The spline's integral over [x[0], x[n-1]], and cdf[i] the integral up to x[i] (cdf[0] = 0). */
double catmull_rom_integrate(const double *x, const double *f, size_t n, double *cdf);

/* The x at which a spline through increasing values f equals v: x[0] below f[0], x[n-1] above
 * f[n-1] (Newton's method safeguarded by bisection, to 1e-9). */
double catmull_rom_invert(const double *x, const double *f, size_t n, double v);

/* Samples x2 in [x2[0], x2[n2-1]] with density proportional to the spline in x2 of the row
 * interpolated at alpha between the rows (n1 of them, at x1) of values (row-major, n1 x n2),
 * whose running integrals cdf are catmull_rom_integrate's per row; u uniform in [0, 1).
 * *fval is the spline's value there and *pdf the density (either may be NULL). Returns -1 when
 * alpha lies outside [x1[0], x1[n1-1]] or the interpolated row integrates to 0. */
double catmull_rom_sample_2d(const double *x1, size_t n1, const double *x2, size_t n2,
                             const double *values, const double *cdf, double alpha, double u,
                             double *fval, double *pdf);

#endif
