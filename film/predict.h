/* predict: what a target error costs, from the passes rendered so far -- one rule for `prismfarm
 * plan --target-error` (from a short pilot render) and for `render --target-error` (from its own
 * first passes, so the summary can say how close the prediction was).
 *
 * The relative error of a Monte-Carlo pixel mean falls as 1/sqrt(spp) (docs/accuracy.md checks
 * it per scene), so the samples per pixel that reach a target E from an estimate e after n spp
 * are n (e / E)^2; the time is fitted to the passes' elapsed times as a fixed part (the load,
 * a photon pass) plus a cost per sample per pixel. A prediction, not a promise: the estimate of
 * a few passes is itself noisy (fireflies not yet found raise it later), and adaptive sampling
 * (film/adaptive.h) usually needs fewer samples than the whole image at the same error. */
#ifndef PRISMFARM_PREDICT_H
#define PRISMFARM_PREDICT_H

#include "stopping.h"

#include <stdbool.h>

typedef struct predict {
    bool valid;        /* two records with estimates, or one with an estimate and its time */
    double spp;        /* samples per pixel that reach the target (not rounded to passes) */
    double seconds;    /* elapsed seconds from the job's start when it is reached */
    double per_spp;    /* seconds per sample per pixel of the fit */
    double fixed;      /* seconds before the first sample (load, photon pass) of the fit */
    int from_spp;      /* the record it was made from */
    double from_error; /* that record's estimate */
} predict_t;

/* The prediction for target (0 < target < 1) from the first n records of history (in pass
 * order); valid = false when no record has an estimate or the target is not in (0, 1). */
predict_t predict_target(const pass_record_t *history, int n, double target);

/* The passes' cut rounds a job up to whole passes: the spp the job actually renders to reach
 * the prediction, that is the first pass boundary at or past p.spp, capped at max_spp. */
int predict_pass_spp(const predict_t *p, int max_spp);

/* The seconds from the job's start to the end of that pass: the fit's fixed part plus its cost
 * per spp times predict_pass_spp. */
double predict_pass_seconds(const predict_t *p, int max_spp);

#endif
