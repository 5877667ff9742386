/* cli_args: command-line value parsing shared by the prismfarm commands: bounded integers and
 * the options that override a scene file (--spp, --res, --seed, --integrator, --dispersion). */
#ifndef PRISMFARM_CLI_ARGS_H
#define PRISMFARM_CLI_ARGS_H

#include "scene_load.h"

/* A whole decimal integer in [lo, hi] into *out; otherwise prints
 * "prismfarm CMD: FLAG expects an integer in LO..HI, got 'S'" and returns -1. */
int cli_parse_int(const char *cmd, const char *flag, const char *s, long long lo, long long hi,
                  long long *out);

/* Handles flag with its value if it is one of the scene overrides: returns 1 when handled,
 * 0 when flag is not an override, -1 after printing an error for a bad value. */
int cli_parse_override(const char *cmd, const char *flag, const char *val, scene_overrides_t *ov);

/* The stopping rules of a progressive render (docs/farm.md, "Accuracy"); 0: no rule. */
typedef struct cli_stop {
    double target_error; /* --target-error E: done at the first pass whose estimate is <= E */
    double time_limit;   /* --time-limit T: done at T seconds with the whole passes so far */
} cli_stop_t;

/* Handles --target-error E (0 < E < 1) and --time-limit T (seconds, or with a suffix s, m or
 * h; at most a year) like cli_parse_override: 1 handled, 0 not one of them, -1 after printing
 * an error. */
int cli_parse_stop(const char *cmd, const char *flag, const char *val, cli_stop_t *stop);

/* Usage lines describing the overrides, for --help texts. */
#define CLI_OVERRIDES_HELP                                                                        \
    "  --spp N                  samples per pixel\n"                                             \
    "  --res WxH                image resolution\n"                                              \
    "  --seed N                 random seed (default: the Sampler's seed)\n"                     \
    "  --integrator NAME        path | simplepath | whitted\n"                                   \
    "  --dispersion NAME        hero | fanout\n"

#define CLI_STOP_HELP                                                                             \
    "  --target-error E         stop at the first pass whose relative error estimate is <= E\n"   \
    "                           (0 < E < 1; RMSE of the mean luminance over its mean)\n"         \
    "  --time-limit T           stop at T seconds (or Ns, Nm, Nh) with the whole passes so far\n"

#endif
