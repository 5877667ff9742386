/* stopping: when a progressive render ends before its last pass, and the record of its passes.
 * One rule for the farm's master and for `prismfarm render --direct` (docs/farm.md,
 * "Stopping rules"): at a pass boundary the job ends if its error estimate is <= the target,
 * else if its time limit has passed. The estimate depends only on the image's bytes, so where a
 * target stops a job does not depend on workers or timing. */
#ifndef PRISMFARM_STOPPING_H
#define PRISMFARM_STOPPING_H

#include "error_estimate.h"

#include <stdbool.h>

/* Why a job ended before its last pass. The values are those of the protocol's proto_stop_t. */
typedef enum stopping_why {
    STOPPING_NONE,   /* every pass ran */
    STOPPING_TARGET, /* the error estimate reached the target */
    STOPPING_TIME,   /* the time limit passed */
} stopping_why_t;

/* "none", "target", "time". */
const char *stopping_name(stopping_why_t why);

/* Why, in words for logs and progress lines: "target error reached", "time limit reached",
 * "" for none. */
const char *stopping_reason(stopping_why_t why);

/* The rule of a job: target_error in (0, 1) or 0 for none; time_limit in seconds, 0 for none. */
typedef struct stopping_rule {
    double target_error, time_limit;
} stopping_rule_t;

/* The rule has something to decide (a target or a limit). */
bool stopping_active(const stopping_rule_t *rule);

/* The decision at a pass boundary that is not the last one, for an image with estimate e after
 * elapsed seconds since the job started: the target is checked first (an estimate must exist),
 * then the time. */
stopping_why_t stopping_decide(const stopping_rule_t *rule, const error_estimate_t *e,
                               double elapsed);

/* A pass boundary as it is recorded (journal, EXR history). */
typedef struct pass_record {
    int pass, spp;    /* passes merged (1-based) and samples per pixel they hold */
    double elapsed;   /* seconds since the job started */
    bool valid;       /* an estimate exists (not after the first pass: 1 sample per pixel) */
    double rel_error; /* relative RMSE of the mean luminance, film/error_estimate.h */
} pass_record_t;

/* Records a job may hold: log2(2^31 spp) + 1 = 32 passes at most, with room. */
#define STOPPING_MAX_RECORDS 40

/* The record of the boundary after passes passes holding spp samples per pixel. */
pass_record_t stopping_record(int passes, int spp, double elapsed, const error_estimate_t *e);

#endif
