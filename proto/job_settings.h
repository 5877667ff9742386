/* job_settings: a job's settings, each declared once (issue 26), as the X-macro list
 * JOB_SETTINGS(X): X(FIELD, KIND, KEEP, KEY, WIRE, LOAD, GROUP, CLI) once per setting. From it
 * come the struct proto_settings_t and its "nothing given" value PROTO_SETTINGS_FILE
 * (proto/proto.h), the SETTINGS map's keys, checks and the deep copy (proto/proto.c), the
 * command-line options and their help (cli/cli_args.c), what the scene loader takes and the key
 * a loaded scene is shared under (settings/settings.c), and the journal's column per setting
 * with its bind and read code and the column an older spool is given (master/store/). Adding a
 * setting is one line here, JOURNAL_VERSION + 1 (master/store/journal_db.h: opening an older
 * spool adds the column, filled with KEEP, the value that means "as before") and the code that
 * uses it.
 *
 *   FIELD  the struct field, the journal's column and, with LOADER, the scene_overrides_t field
 *   KIND   INT (int), LLONG (long long), DOUBLE (double) or NAME (const char *, at most
 *          PROTO_SETTING_NAME_MAX bytes; NULL: not given): the C type, the wire and SQL types,
 *          and how a value is bound, read, copied and written into a scene key
 *   KEEP   the value before any is given: the scene file's, or no rule
 *   KEY    its key in the SETTINGS map of a TASK and a SUBMIT (wire bytes: never change one)
 *   WIRE   (field_t initializers, proto.c): the decoder's check, and UNLESS_ZERO presence for
 *          a setting left out while it is KEEP
 *   LOAD   LOADER: the scene loader takes it as it is (settings_to_overrides, the scene key);
 *          MASTER: only the master reads it (a stopping rule)
 *   GROUP  its command-line table: OVERRIDE (CLI_OVERRIDE_OPTS: render, submit, plan), STOP
 *          (CLI_STOP_OPTS: render, submit), or NONE (another setting's option sets it)
 *   CLI    (cli_opt_t initializers, cli_args.c): the flag, how its value is read and checked
 *          (the bounds a user may give, inside the wire's), its metavar and help
 *
 * The settings in order (the struct's, the SETTINGS map's and the journal's columns'):
 *   spp          samples per pixel of the whole job; 0: the file's
 *   xres, yres   the image size; 0: the file's; --res WxH sets both
 *   seed         -1: the Sampler's
 *   integrator   NULL: the file's (scenefile/integrators.h names them)
 *   dispersion   NULL: the file's ("hero", "fanout")
 *   target_error 0: no target; else 0 < E < 1: done at the first pass whose estimate is <= E
 *   time_limit   0: no limit; else 0 < T <= PROTO_MAX_TIME_LIMIT seconds after the start
 *   adaptive     1: under a target error tiles stop one by one (film/adaptive.h); 0: every
 *                tile runs every pass
 *   polarized    polarised transport as the plan decided it once, before the job started
 *                (render/polar_pilot.h polar_pilot_decide, issue 28): 0 not decided (the
 *                scene file's own, as before: a worker never decides), 1 off, 2 on; the
 *                master and `render` decide, workers obey, the journal keeps it; a user may
 *                force it with --polarized on|off (auto: 0), and then nothing decides
 * A stopping rule's 0 is never written to the wire; anything else there must be a usable rule. */
#ifndef PRISMFARM_JOB_SETTINGS_H
#define PRISMFARM_JOB_SETTINGS_H

/* clang-format off */
#define JOB_SETTINGS(X)                                                                            \
    X(spp, INT, 0, "spp", (RANGE(0, INT_MAX)), LOADER, OVERRIDE,                                   \
      (.name = "spp", .kind = CLI_INT, .lo = 1, .hi = 1 << 24, .arg = "N",                         \
       .help = "samples per pixel"))                                                               \
    X(xres, INT, 0, "xres", (RANGE(0, PROTO_MAX_IMAGE_SIDE)), LOADER, OVERRIDE,                    \
      (.name = "res", .kind = CLI_CUSTOM, .parse = parse_res, .arg = "WxH",                        \
       .help = "image resolution"))                                                                \
    X(yres, INT, 0, "yres", (RANGE(0, PROTO_MAX_IMAGE_SIDE)), LOADER, NONE, ())                    \
    X(seed, LLONG, -1, "seed", (RANGE(-1, LLONG_MAX)), LOADER, OVERRIDE,                           \
      (.name = "seed", .kind = CLI_LLONG, .lo = 0, .hi = 4294967295.0, .arg = "N",                 \
       .help = "random seed (default: the Sampler's seed)"))                                       \
    X(integrator, NAME, NULL, "integ", (.presence = UNLESS_ZERO, NAME(PROTO_SETTING_NAME_MAX)),    \
      LOADER, OVERRIDE,                                                                            \
      (.name = "integrator", .kind = CLI_CUSTOM, .parse = parse_integrator, .arg = "NAME",         \
       .help = "any name Integrator takes: auto, path,\nphoton, volpath, bdpt, ... "               \
               "(docs/rendering.md)"))                                                             \
    X(dispersion, NAME, NULL, "disp", (.presence = UNLESS_ZERO, NAME(PROTO_SETTING_NAME_MAX)),     \
      LOADER, OVERRIDE,                                                                            \
      (.name = "dispersion", .kind = CLI_CUSTOM, .parse = parse_dispersion, .arg = "NAME",         \
       .help = "hero | fanout"))                                                                   \
    X(target_error, DOUBLE, 0, "tgt",                                                              \
      (.presence = UNLESS_ZERO, .absent = "no target", .check = ck_target_error), MASTER, STOP,    \
      (.name = "target-error", .kind = CLI_DOUBLE, .lo = 0, .hi = 1, .open = 1,                    \
       .unit = "a relative error", .example = "e.g. 0.02", .arg = "E",                             \
       .help = "stop at the first pass whose relative error estimate is <= E\n"                    \
               "(0 < E < 1; RMSE of the mean luminance over its mean)"))                           \
    X(time_limit, DOUBLE, 0, "tlim",                                                               \
      (.presence = UNLESS_ZERO, .absent = "no time limit", .check = ck_time_limit), MASTER, STOP,  \
      (.name = "time-limit", .kind = CLI_SECONDS, .hi = PROTO_MAX_TIME_LIMIT, .arg = "T",          \
       .help = "stop at T seconds (or Ns, Nm, Nh) with the whole passes so far"))                  \
    X(adaptive, INT, 0, "adapt",                                                                   \
      (.presence = UNLESS_ZERO, .absent = "no adaptive sampling", RANGE(0, 1)), MASTER, STOP,      \
      (.name = "adaptive", .kind = CLI_CUSTOM, .parse = parse_adaptive, .arg = "on|off",           \
       .help = "with --target-error: each tile stops once it reaches its share\n"                  \
               "of the target (on), or every tile runs every pass (off, the default)"))          \
    X(polarized, INT, 0, "polar", (.presence = UNLESS_ZERO, .absent = "the file's", RANGE(0, 2)), \
      LOADER, OVERRIDE,                                                                            \
      (.name = "polarized", .kind = CLI_CUSTOM, .parse = parse_polarized, .arg = "on|off|auto",    \
       .help = "polarised transport forced on or off, or auto (the default):\n"                   \
               "the plan decides (its pilot where nothing asks for it)"))
/* clang-format on */

/* Helpers for the expansions: a parenthesised list without its parentheses, and each KIND's C
 * type. */
#define JOB_SETTING_UNPAREN(...) __VA_ARGS__
#define JOB_SETTING_CTYPE_INT int
#define JOB_SETTING_CTYPE_LLONG long long
#define JOB_SETTING_CTYPE_DOUBLE double
#define JOB_SETTING_CTYPE_NAME const char *

#endif
