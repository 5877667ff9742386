#include "cli_args.h"

#include "proto.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int cli_parse_int(const char *cmd, const char *flag, const char *s, long long lo, long long hi,
                  long long *out)
{
    char *end;
    errno = 0;
    long long v = strtoll(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi) {
        fprintf(stderr, "prismfarm %s: %s expects an integer in %lld..%lld, got '%s'\n", cmd, flag, lo, hi, s);
        return -1;
    }
    *out = v;
    return 0;
}

int cli_parse_override(const char *cmd, const char *flag, const char *val, scene_overrides_t *ov)
{
    long long v;
    if (!strcmp(flag, "--spp")) {
        if (cli_parse_int(cmd, flag, val, 1, 1 << 24, &v))
            return -1;
        ov->spp = (int)v;
    } else if (!strcmp(flag, "--seed")) {
        if (cli_parse_int(cmd, flag, val, 0, 4294967295LL, &v))
            return -1;
        ov->seed = v;
    } else if (!strcmp(flag, "--res")) {
        int w, h;
        char extra;
        if (sscanf(val, "%dx%d%c", &w, &h, &extra) != 2 || w < 1 || h < 1 || w > 32768 || h > 32768) {
            fprintf(stderr, "prismfarm %s: --res expects WxH with 1..32768 each, got '%s'\n", cmd, val);
            return -1;
        }
        ov->xres = w;
        ov->yres = h;
    } else if (!strcmp(flag, "--integrator")) {
        const integrator_name_t *named = integrators_find(val);
        if (!named || !named->overridable) {
            char names[INTEGRATORS_LIST_MAX];
            integrators_list(true, names, sizeof names);
            fprintf(stderr, "prismfarm %s: --integrator expects %s, got '%s'\n", cmd, names, val);
            return -1;
        }
        ov->integrator = val;
    } else if (!strcmp(flag, "--dispersion")) {
        if (strcmp(val, "hero") && strcmp(val, "fanout")) {
            fprintf(stderr, "prismfarm %s: --dispersion expects hero or fanout, got '%s'\n", cmd, val);
            return -1;
        }
        ov->dispersion = val;
    } else {
        return 0;
    }
    return 1;
}

int cli_parse_stop(const char *cmd, const char *flag, const char *val, cli_stop_t *stop)
{
    char *end;
    errno = 0;
    if (!strcmp(flag, "--target-error")) {
        double e = strtod(val, &end);
        if (errno || end == val || *end || !(e > 0 && e < 1)) {
            fprintf(stderr,
                    "prismfarm %s: --target-error expects a relative error in (0, 1), e.g. 0.02, "
                    "got '%s'\n",
                    cmd, val);
            return -1;
        }
        stop->target_error = e;
        return 1;
    }
    if (!strcmp(flag, "--time-limit")) {
        double t = strtod(val, &end);
        double unit = !strcmp(end, "h")                  ? 3600
                      : !strcmp(end, "m")                ? 60
                      : !*end || !strcmp(end, "s")       ? 1
                                                         : 0; /* 0: not a unit */
        if (errno || end == val || unit == 0 || !(t > 0) || !(t * unit <= PROTO_MAX_TIME_LIMIT)) {
            fprintf(stderr,
                    "prismfarm %s: --time-limit expects seconds in (0, %.0f], optionally with s, "
                    "m or h, got '%s'\n",
                    cmd, PROTO_MAX_TIME_LIMIT, val);
            return -1;
        }
        stop->time_limit = t * unit;
        return 1;
    }
    return 0;
}
