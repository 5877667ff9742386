/* cli_args: the one option parser of the prismfarm commands, on getopt_long. A command lists
 * its options in a table -- long name, short letter, what the value is and where it goes, help
 * text -- from which both the parsing and the option lines of its --help come, so an option and
 * its help are written once. The options several commands share (the scene overrides, the
 * stopping rules, the keys of a client) are tables here, included by the commands that take
 * them; --master, --json, --quiet and --help are entries made by the macros below. */
#ifndef PRISMFARM_CLI_ARGS_H
#define PRISMFARM_CLI_ARGS_H

#include "client_rpc.h"
#include "scene_load.h"

#include <stddef.h>
#include <stdio.h>

typedef enum cli_kind {
    CLI_END = 0, /* ends a table */
    CLI_FLAG,    /* no value: *(int *)dst = 1 */
    CLI_HELP,    /* no value: the command's usage on stdout, exit 0 */
    CLI_STRING,  /* *(const char **)dst = the value; with .need, an empty one is refused */
    CLI_INT,     /* *(int *)dst = a whole decimal number in lo..hi */
    CLI_LLONG,   /* *(long long *)dst = a whole decimal number in lo..hi */
    CLI_DOUBLE,  /* *(double *)dst = a number in lo..hi, or in (lo, hi) with .open */
    CLI_SECONDS, /* *(double *)dst = seconds in (0, hi], the number optionally followed by s, m
                  * or h (a duration: --time-limit 90, 90s, 1.5m) */
    CLI_CUSTOM,  /* .parse checks the value and stores it */
    CLI_GROUP,   /* .group's options, their destinations offsets from this entry's */
    CLI_TEXT,    /* no option: .help is printed as it is among the option lines */
} cli_kind_t;

/* Checks val, the value of flag (as the user spelled it), and stores it at dst: 0, or -1 after
 * printing "prismfarm CMD: FLAG expects ..., got 'VAL'". */
typedef int (*cli_parse_fn)(const char *cmd, const char *flag, const char *val, void *dst);

typedef struct cli_opt {
    const char *name; /* the long name, without its dashes */
    char letter;      /* the short name (-o), or 0 */
    cli_kind_t kind;
    /* Where the value goes: dst + off. A group's table has no dst: its offsets count from the
     * destination of the CLI_GROUP entry that includes it. */
    void *dst;
    size_t off;
    double lo, hi;       /* CLI_INT, CLI_LLONG, CLI_DOUBLE: the bounds; CLI_SECONDS: hi */
    int open;            /* CLI_DOUBLE: lo and hi themselves are refused */
    const char *unit;    /* CLI_DOUBLE, in errors: "stops" -> "expects stops in -30..30" */
    const char *example; /* CLI_DOUBLE, in errors after the range: "e.g. 0.02" */
    const char *need;    /* a missing (or empty) value: "FLAG needs NEED"; default "a value" */
    int last;            /* the options end after this one: the rest is operands (glass) */
    cli_parse_fn parse;  /* CLI_CUSTOM */
    const struct cli_opt *group; /* CLI_GROUP */
    const char *arg;     /* the value's name in the help: "N", "WxH" */
    const char *help;    /* the help text (wrapped to 90 columns; a '\n' breaks the line);
                          * NULL: accepted, not listed */
} cli_opt_t;

typedef struct cli_cmd {
    const char *name;      /* "render": errors start "prismfarm render: " */
    const cli_opt_t *opts;
    /* Prints the command's --help text (cli_args_help prints the option lines of opts). */
    void (*usage)(FILE *out, const cli_opt_t *opts);
    int stop_at_operand;   /* the first operand ends the options (glass NAME NM ...) */
    const char *unknown;   /* an unknown option in errors: "unknown UNKNOWN '--x'"; default
                            * "option" (master: "argument") */
} cli_cmd_t;

#define CLI_ARGS_GO (-1)

/* Parses argv[1..argc) (argv[0] is the command) with getopt_long, in the order given, options
 * and operands mixed as the user likes; "--" ends the options. Long options are taken only
 * spelled out (no abbreviations: a later option would make them ambiguous), with their value
 * as the next argument or after '='; short ones as -o VALUE or -oVALUE. Each value is checked
 * and stored as its entry says. Like GNU getopt it reorders argv: the operands, in their order,
 * end up in argv[*first..argc). Returns CLI_ARGS_GO, or the command's exit status: 0 after
 * printing the usage to stdout at -h or --help; 2 after printing the error ("prismfarm CMD:
 * unknown option '--x' (see prismfarm CMD --help)", "prismfarm CMD: --spp needs a value",
 * "prismfarm CMD: --spp expects an integer in 1..16777216, got 'x'"). Resets getopt's state
 * first (optind = 0), so that commands can be called one after another in one process. */
int cli_args_parse(const cli_cmd_t *cmd, int argc, char **argv, int *first);

/* The option lines of a --help text: each option with its value's name, its help aligned in
 * one column and wrapped; CLI_TEXT lines as they are. */
void cli_args_help(FILE *out, const cli_opt_t *opts);

/* A job's settings are parsed into the proto_settings_t a SUBMIT carries (start it with
 * PROTO_SETTINGS_FILE), whether the job goes to a master, to the in-process farm or to --direct
 * (settings_to_overrides gives the loader its part): one struct from the flag to the wire. */

/* The options of the settings (proto/job_settings.h, each declared there once) that override
 * a scene file: --spp, --res, --seed, --integrator, --dispersion. */
extern const cli_opt_t CLI_OVERRIDE_OPTS[];

/* The stopping rules of a progressive render (docs/farm.md, "Accuracy"): --target-error E
 * (0 < E < 1), --time-limit T (seconds, or with a suffix s, m or h; at most a year) and
 * --adaptive on|off. */
extern const cli_opt_t CLI_STOP_OPTS[];

/* The entry of the setting whose flag is name ("target-error") in CLI_OVERRIDE_OPTS or
 * CLI_STOP_OPTS, or NULL: for a command that takes one setting with its own help (plan's
 * --target-error), copied and given .dst (its .off is the setting's place in proto_settings_t),
 * so that the bounds and their messages stay the declaration's. */
const cli_opt_t *cli_args_setting(const char *name);

/* How a client or a worker secures its link (docs/security.md): --key FILE, --master-key FILE,
 * --insecure, into a client_security_t (start it with client_security_default()). */
extern const cli_opt_t CLI_SECURITY_OPTS[];

/* Entries every command spells the same; the arguments add the destination (.dst = &x, or
 * .off = offsetof(...) in a group's table) and, for --json and --quiet, the help. A group's
 * options go to the struct at its destination: CLI_OPT_GROUP(CLI_STOP_OPTS, .dst = &stop). */
#define CLI_OPT_HELP {.name = "help", .letter = 'h', .kind = CLI_HELP, .help = "this text"}
#define CLI_OPT_MASTER(...)                                                                        \
    {.name = "master", .kind = CLI_STRING, .arg = "ENDPOINT",                                      \
     .help = "the master's client endpoint (default $PRISMFARM_MASTER or tcp://127.0.0.1:5556)",  \
     __VA_ARGS__}
#define CLI_OPT_JSON(...) {.name = "json", .kind = CLI_FLAG, __VA_ARGS__}
#define CLI_OPT_QUIET(...) {.name = "quiet", .kind = CLI_FLAG, __VA_ARGS__}
/* A frame sequence's range (render, submit and plan word it alike). */
#define CLI_OPT_FRAMES(...)                                                                        \
    {.name = "frames", .kind = CLI_STRING, .arg = "FIRST-LAST",                                    \
     .help = "a frame sequence: SCENE is a pattern such as frame%04d.pbrt, formatted with each "  \
             "number FIRST..LAST",                                                                \
     __VA_ARGS__}
#define CLI_OPT_GROUP(table, ...) {.kind = CLI_GROUP, .group = (table), __VA_ARGS__}

#endif
