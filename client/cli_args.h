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

/* Usage lines describing the overrides, for --help texts. */
#define CLI_OVERRIDES_HELP                                                                        \
    "  --spp N                  samples per pixel\n"                                             \
    "  --res WxH                image resolution\n"                                              \
    "  --seed N                 random seed (default: the Sampler's seed)\n"                     \
    "  --integrator NAME        path | simplepath | whitted\n"                                   \
    "  --dispersion NAME        hero | fanout\n"

#endif
