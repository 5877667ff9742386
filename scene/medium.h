/* medium: the participating media of a scene (pbrt-v4 media.h) as the volume code reads them:
 * a homogeneous medium or a uniform density grid (pbrt-v4 "uniformgrid", GridMedium) with
 * spectral absorption and scattering coefficients, a Henyey-Greenstein asymmetry and an
 * optional emission. Guarantees: every coefficient is finite and >= 0 (sigma is clamped to
 * MEDIUM_SIGMA_MAX, so a huge "scale" cannot overflow), the density is trilinear, >= 0 and 0
 * outside the grid's bounds, and the majorant segments bound the density from above on every
 * point of each segment. A grid is dense (uniformgrid) or a NanoVDB file's (nanovdb.h).
 * Immutable after medium_new_*: safe to read from many threads. */
#ifndef PRISMFARM_MEDIUM_H
#define PRISMFARM_MEDIUM_H

#include "err.h"
#include "nanovdb.h"
#include "spectrum.h"
#include "transform.h"
#include "vec3.h"

#include <stddef.h>

typedef struct medium medium_t;

typedef enum medium_kind {
    MEDIUM_HOMOGENEOUS, /* density 1 everywhere */
    MEDIUM_GRID,        /* density from an nx x ny x nz grid over the box [p0, p1] */
} medium_kind_t;

/* Coefficients above this (per unit length) are clamped: optical depths stay far from
 * overflow for any distance a double scene holds, and exp(-sigma t) is exactly 0 long before. */
#define MEDIUM_SIGMA_MAX 1e150

/* The majorant grid's resolution per axis (pbrt-v4 GridMedium: 16^3; NanoVDBMedium: 64^3). */
#define MEDIUM_MAJORANT_RES 16
#define MEDIUM_VDB_MAJORANT_RES 64

/* The spectral description shared by both kinds. Spectra are borrowed (the scene owns them)
 * and must outlive the medium; Le may be NULL (no emission). */
typedef struct medium_params {
    const spectrum_t *sigma_a, *sigma_s; /* per unit density, before scale */
    double scale;                        /* multiplies both (pbrt-v4 "scale") */
    double g;                            /* Henyey-Greenstein asymmetry */
    const spectrum_t *Le;                /* emitted radiance per unit sigma_a, or NULL */
    double Le_scale;                     /* multiplies Le */
} medium_params_t;

medium_t *medium_new_homogeneous(const medium_params_t *p, err_t *err);

/* density holds nx * ny * nz values >= 0 (x fastest, then y, then z: pbrt-v4's order),
 * copied; [p0, p1] is the grid's box in medium space and medium_to_world places it (the CTM
 * at MakeNamedMedium; invertible). Errors name what is wrong. */
medium_t *medium_new_grid(const medium_params_t *p, int nx, int ny, int nz, const double *density,
                          vec3_t p0, vec3_t p1, const transform_t *medium_to_world, err_t *err);

/* pbrt-v4's "nanovdb" medium (NanoVDBMedium): the density grid's values (>= 0) over its
 * bounds, joined with the optional temperature grid's; outside, no density. Both grids are
 * taken (the pointers are nulled, the grids freed on failure too); temperature may be NULL.
 * The emission is p->Le_scale times the blackbody of (T - temperature_offset)
 * temperature_scale kelvin where that exceeds 100 K (p->Le must be NULL). A kind of
 * MEDIUM_GRID with 64^3 majorant cells. */
medium_t *medium_new_nanovdb(const medium_params_t *p, nanovdb_grid_t **density, nanovdb_grid_t **temperature,
                             double temperature_offset, double temperature_scale,
                             const transform_t *medium_to_world, err_t *err);

void medium_destroy(medium_t **self_p);

medium_kind_t medium_kind(const medium_t *self);
double medium_g(const medium_t *self); /* clamped as phase_hg uses it */
int medium_is_emissive(const medium_t *self);

/* The emission varies over the medium (a temperature grid): read it at each point with
 * medium_Le_at, not from medium_coeffs. */
int medium_Le_varies(const medium_t *self);
double medium_Le_at(const medium_t *self, vec3_t p, double lambda);

/* The coefficients at lambda per unit density, scale applied and clamped: sigma_a, sigma_s
 * and the emitted radiance Le (0 without emission). */
typedef struct medium_coeffs {
    double sigma_a, sigma_s, Le;
} medium_coeffs_t;
medium_coeffs_t medium_coeffs(const medium_t *self, double lambda);

/* The density at world point p: 1 for a homogeneous medium; for a grid the trilinear
 * interpolation of its samples at the voxel centres, samples outside the grid reading 0
 * (pbrt-v4 SampledGrid::Lookup), and 0 outside [p0, p1]. */
double medium_density(const medium_t *self, vec3_t p);

/* The majorant segments of the ray org + t dir, t in [0, tmax): consecutive intervals
 * [t0, t1) with a bound dmax on the density inside each; parts of the ray with no density
 * (outside a grid's box) are skipped. A homogeneous medium gives one segment [0, tmax) with
 * dmax 1. Fill an iterator with medium_segments_begin, then call medium_segments_next until it
 * returns 0. */
typedef struct medium_segments {
    const medium_t *m;
    int done;
    double t, t_end;
    /* grid DDA state (voxel, step, next crossing and spacing per axis) */
    int voxel[3], step[3];
    double t_next[3], t_delta[3];
} medium_segments_t;

void medium_segments_begin(const medium_t *self, vec3_t org, vec3_t dir, double tmax,
                           medium_segments_t *it);
int medium_segments_next(medium_segments_t *it, double *t0, double *t1, double *dmax);

#endif
