/* filter: pbrt-v4's pixel reconstruction filters (box, gaussian, mitchell, sinc, triangle) and
 * their importance sampling: a camera sample's offset from its pixel's centre is drawn from
 * the filter and the sample keeps a weight, so each sample still lands in its own pixel (no
 * splatting: tiles stay independent, the farm's merge and its bytes stay as they are). The
 * weights are normalised so that their mean is 1: a pixel's mean of weighted samples then
 * converges to the filter-weighted average that pbrt-v4's sum(w L) / sum(w) estimates. */
#ifndef PRISMFARM_FILTER_H
#define PRISMFARM_FILTER_H

#include "err.h"

typedef enum filter_kind {
    FILTER_BOX,
    FILTER_GAUSSIAN,
    FILTER_MITCHELL,
    FILTER_SINC,
    FILTER_TRIANGLE,
} filter_kind_t;

typedef struct filter_params {
    filter_kind_t kind;
    double xradius, yradius; /* the filter's support is [-xradius, xradius] x [-yradius, yradius] */
    double sigma;            /* gaussian */
    double b, c;             /* mitchell */
    double tau;              /* sinc: Lanczos window, in lobes */
} filter_params_t;

/* pbrt-v4's defaults (filters.cpp): box radius 0.5; gaussian radius 1.5, sigma 0.5; mitchell
 * radius 2, B = C = 1/3; sinc radius 4, tau 3; triangle radius 2. */
filter_params_t filter_params_default(filter_kind_t kind);

/* The kind named name ("box", "gaussian", ...); -1 when there is none. */
int filter_kind_find(const char *name);
const char *filter_kind_name(filter_kind_t kind);

/* pbrt-v4's Filter::Evaluate at offset (x, y) from the pixel centre. */
double filter_eval(const filter_params_t *f, double x, double y);

typedef struct filter_sample {
    double dx, dy; /* offset from the pixel centre, in pixels */
    double weight; /* f / pdf divided by the mean of f / pdf: 1 for a non-negative filter,
                    * +-(integral of |f|) / (integral of f) where mitchell and sinc are negative */
} filter_sample_t;

typedef struct filter_sampler filter_sampler_t;

/* Box and triangle sample analytically (weight 1, as pbrt-v4); the others by pbrt-v4's
 * FilterSampler: |f| tabulated at 32 cells per unit of radius, a piecewise-constant 2D
 * distribution (marginal over rows, then the column in the row), so that a stratified (u1, u2)
 * stays stratified through the inversion. Radii must lie in (0, 64]. */
filter_sampler_t *filter_sampler_new(const filter_params_t *params, err_t *err);
void filter_sampler_destroy(filter_sampler_t **self_p);

/* (u1, u2) in [0, 1)^2 to an offset and its weight. Deterministic. */
filter_sample_t filter_sampler_sample(const filter_sampler_t *self, double u1, double u2);

const filter_params_t *filter_sampler_params(const filter_sampler_t *self);

#endif
