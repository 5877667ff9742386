#include "cli_args.h"

#include "integrators.h"
#include "overrides.h"
#include "proto.h"
#include "suggest.h"

#include <errno.h>
#include <getopt.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#define CLI_OPTS_MAX 64   /* options of one command, its groups' included */
#define CLI_HELP_WIDTH 90 /* the help is wrapped to this column, as its prose */
#define CLI_VAL_BASE 256  /* getopt_long's code of the flat option i: CLI_VAL_BASE + i */

/* ---- the shared tables -------------------------------------------------------------------- */

/* --res sets xres and yres: dst is xres's place in the settings. */
static int parse_res(const char *cmd, const char *flag, const char *val, void *dst)
{
    proto_settings_t *ov = (proto_settings_t *)((char *)dst - offsetof(proto_settings_t, xres));
    int w, h;
    char extra;
    if (sscanf(val, "%dx%d%c", &w, &h, &extra) != 2 || w < 1 || h < 1 || w > 32768 || h > 32768) {
        fprintf(stderr, "prismfarm %s: %s expects WxH with 1..32768 each, got '%s'\n", cmd, flag,
                val);
        return -1;
    }
    ov->xres = w;
    ov->yres = h;
    return 0;
}

static int parse_integrator(const char *cmd, const char *flag, const char *val, void *dst)
{
    const integrator_name_t *named = integrators_find(val);
    if (named && named->refused) {
        fprintf(stderr, "prismfarm %s: %s %s is not supported: %s\n", cmd, flag, val, named->refused);
        return -1;
    }
    if (!named) {
        char names[INTEGRATORS_LIST_MAX];
        integrators_list(false, names, sizeof names);
        const char *best = integrators_suggest(val);
        if (best)
            fprintf(stderr, "prismfarm %s: %s expects %s, got '%s' (did you mean '%s'?)\n", cmd,
                    flag, names, val, best);
        else
            fprintf(stderr, "prismfarm %s: %s expects %s, got '%s'\n", cmd, flag, names, val);
        return -1;
    }
    *(const char **)dst = val;
    return 0;
}

static int parse_dispersion(const char *cmd, const char *flag, const char *val, void *dst)
{
    dispersion_kind_t kind;
    if (!integrators_dispersion_find(val, &kind)) {
        fprintf(stderr, "prismfarm %s: %s expects hero or fanout, got '%s'\n", cmd, flag, val);
        return -1;
    }
    *(const char **)dst = val;
    return 0;
}

static int parse_adaptive(const char *cmd, const char *flag, const char *val, void *dst)
{
    if (strcmp(val, "on") && strcmp(val, "off")) {
        fprintf(stderr, "prismfarm %s: %s expects on or off, got '%s'\n", cmd, flag, val);
        return -1;
    }
    *(int *)dst = !strcmp(val, "on");
    return 0;
}

/* --polarized: the job setting's values (scene/overrides.h): auto leaves the decision to the
 * plan (SCENE_POLARIZED_FILE), on and off force it. */
static int parse_polarized(const char *cmd, const char *flag, const char *val, void *dst)
{
    const struct {
        const char *name;
        int setting;
    } values[] = {
        {"auto", SCENE_POLARIZED_FILE}, {"off", SCENE_POLARIZED_OFF}, {"on", SCENE_POLARIZED_ON}};
    for (size_t i = 0; i < sizeof values / sizeof values[0]; i++)
        if (!strcmp(val, values[i].name)) {
            *(int *)dst = values[i].setting;
            return 0;
        }
    fprintf(stderr, "prismfarm %s: %s expects on, off or auto, got '%s'\n", cmd, flag, val);
    return -1;
}

/* The settings' options (job_settings.h), each in its group's table. */
#define IN_OVERRIDE_OVERRIDE(x) x
#define IN_OVERRIDE_STOP(x)
#define IN_OVERRIDE_NONE(x)
#define IN_STOP_OVERRIDE(x)
#define IN_STOP_STOP(x) x
#define IN_STOP_NONE(x)
#define SETTING_OPT(field, cli) {.off = offsetof(proto_settings_t, field), JOB_SETTING_UNPAREN cli},
#define OVERRIDE_OPT(field, kind, keep, key, wire, load, group, cli)                               \
    IN_OVERRIDE_##group(SETTING_OPT(field, cli))
#define STOP_OPT(field, kind, keep, key, wire, load, group, cli)                                   \
    IN_STOP_##group(SETTING_OPT(field, cli))
const cli_opt_t CLI_OVERRIDE_OPTS[] = {JOB_SETTINGS(OVERRIDE_OPT){0}};
const cli_opt_t CLI_STOP_OPTS[] = {JOB_SETTINGS(STOP_OPT){0}};

static const cli_opt_t *find_in(const cli_opt_t *table, const char *name)
{
    for (const cli_opt_t *o = table; o->kind != CLI_END; o++)
        if (!strcmp(o->name, name))
            return o;
    return NULL;
}

const cli_opt_t *cli_args_setting(const char *name)
{
    const cli_opt_t *o = find_in(CLI_OVERRIDE_OPTS, name);
    return o ? o : find_in(CLI_STOP_OPTS, name);
}

/* --key and --master-key also note that the keys came from flags, not only from the
 * environment (client_security_load). */
static int parse_key(const char *cmd, const char *flag, const char *val, void *dst)
{
    (void)cmd;
    client_security_t *sec = dst;
    if (!strcmp(flag, "--key"))
        sec->key_file = val;
    else
        sec->master_key_file = val;
    sec->keys_from_flags = 1;
    return 0;
}

const cli_opt_t CLI_SECURITY_OPTS[] = {
    {.name = "key", .kind = CLI_CUSTOM, .parse = parse_key, .arg = "FILE",
     .help = "our key pair, NAME.key from prismfarm keygen (default $PRISMFARM_KEY)"},
    {.name = "master-key", .kind = CLI_CUSTOM, .parse = parse_key, .arg = "FILE",
     .help = "the master's public key, its NAME.pub (default $PRISMFARM_MASTER_KEY)"},
    {.name = "insecure", .kind = CLI_FLAG, .off = offsetof(client_security_t, insecure),
     .help = "plain text over tcp:// instead of CURVE (a network you trust)"},
    {0},
};

/* ---- values ------------------------------------------------------------------------------- */

static int parse_int(const char *cmd, const char *flag, const char *s, long long lo, long long hi,
                     long long *out)
{
    char *end;
    errno = 0;
    long long v = strtoll(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi) {
        fprintf(stderr, "prismfarm %s: %s expects an integer in %lld..%lld, got '%s'\n", cmd, flag,
                lo, hi, s);
        return -1;
    }
    *out = v;
    return 0;
}

static int parse_double(const char *cmd, const char *flag, const cli_opt_t *o, const char *s,
                        double *out)
{
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    int in = o->open ? v > o->lo && v < o->hi : v >= o->lo && v <= o->hi; /* false for NaN */
    if (errno || end == s || *end || !in) {
        const char *unit = o->unit ? o->unit : "a number";
        fprintf(stderr, "prismfarm %s: %s expects %s in ", cmd, flag, unit);
        fprintf(stderr, o->open ? "(%g, %g)" : "%g..%g", o->lo, o->hi);
        if (o->example)
            fprintf(stderr, ", %s", o->example);
        fprintf(stderr, ", got '%s'\n", s);
        return -1;
    }
    *out = v;
    return 0;
}

static int parse_seconds(const char *cmd, const char *flag, const cli_opt_t *o, const char *s,
                         double *out)
{
    char *end;
    errno = 0;
    double t = strtod(s, &end);
    double unit = !strcmp(end, "h")            ? 3600
                  : !strcmp(end, "m")          ? 60
                  : !*end || !strcmp(end, "s") ? 1
                                               : 0; /* 0: not a unit */
    if (errno || end == s || unit == 0 || !(t > 0) || !(t * unit <= o->hi)) {
        fprintf(stderr,
                "prismfarm %s: %s expects seconds in (0, %.0f], optionally with s, m or h, got "
                "'%s'\n",
                cmd, flag, o->hi, s);
        return -1;
    }
    *out = t * unit;
    return 0;
}

/* Stores the value of o (spelled flag) at dst: 0, or -1 after printing why not. */
static int take(const char *cmd, const cli_opt_t *o, void *dst, const char *flag, const char *val)
{
    long long v;
    switch (o->kind) {
    case CLI_FLAG:
        *(int *)dst = 1;
        return 0;
    case CLI_STRING:
        if (o->need && !*val) {
            fprintf(stderr, "prismfarm %s: %s needs %s\n", cmd, flag, o->need);
            return -1;
        }
        *(const char **)dst = val;
        return 0;
    case CLI_INT:
        if (parse_int(cmd, flag, val, (long long)o->lo, (long long)o->hi, &v))
            return -1;
        *(int *)dst = (int)v;
        return 0;
    case CLI_LLONG:
        return parse_int(cmd, flag, val, (long long)o->lo, (long long)o->hi, dst);
    case CLI_DOUBLE:
        return parse_double(cmd, flag, o, val, dst);
    case CLI_SECONDS:
        return parse_seconds(cmd, flag, o, val, dst);
    case CLI_CUSTOM:
        return o->parse(cmd, flag, val, dst);
    default:
        return -1; /* CLI_HELP, CLI_GROUP, CLI_TEXT and CLI_END never get here */
    }
}

/* ---- the parser --------------------------------------------------------------------------- */

static int takes_value(cli_kind_t k)
{
    return k != CLI_FLAG && k != CLI_HELP;
}

/* An option of the command with its groups opened: the entry and where its value goes. */
typedef struct flat {
    const cli_opt_t *opt;
    void *dst;
} flat_t;

/* Appends the options of table (its destinations counted from base) to flat. */
static int flatten(const cli_opt_t *table, char *base, flat_t *flat, int *n)
{
    for (const cli_opt_t *o = table; o->kind != CLI_END; o++) {
        char *at = o->dst ? (char *)o->dst : base, *dst = at ? at + o->off : NULL;
        if (o->kind == CLI_GROUP) {
            if (flatten(o->group, dst, flat, n))
                return -1;
        } else if (o->kind != CLI_TEXT) {
            if (*n == CLI_OPTS_MAX)
                return -1;
            flat[(*n)++] = (flat_t){o, dst};
        }
    }
    return 0;
}

/* Words other renderers and habits use for an option, too far from its name for an edit's
 * "did you mean" (--samples is 5 edits from --spp): suggested when the command has the option. */
static const struct {
    const char *word, *option;
} SYNONYMS[] = {
    {"samples", "spp"},           {"sample", "spp"},     {"pixelsamples", "spp"},
    {"samples-per-pixel", "spp"}, {"out", "output"},     {"outfile", "output"},
    {"nthreads", "threads"},      {"resolution", "res"}, {"size", "res"},
};

/* The option argv[i] ("--name" or "--name=value") names exactly, or -1. */
static int find_long(const flat_t *flat, int n, const char *arg)
{
    size_t len = strcspn(arg + 2, "=");
    for (int i = 0; i < n; i++)
        if (strlen(flat[i].opt->name) == len && !strncmp(flat[i].opt->name, arg + 2, len))
            return i;
    return -1;
}

static int find_letter(const flat_t *flat, int n, int c)
{
    for (int i = 0; i < n; i++)
        if (flat[i].opt->letter && flat[i].opt->letter == c)
            return i;
    return -1;
}

/* argv[from - nops, from) are the operands so far; argv[from, to) what getopt_long has just
 * read (an option and its value): moved before the operands, so the operands stay last. */
static void move_before(char **argv, int from, int to, int nops)
{
    for (int i = from; i < to; i++) {
        char *a = argv[i];
        memmove(argv + i - nops + 1, argv + i - nops, (size_t)nops * sizeof *argv);
        argv[i - nops] = a;
    }
}

int cli_args_parse(const cli_cmd_t *cmd, int argc, char **argv, int *first)
{
    flat_t flat[CLI_OPTS_MAX];
    int n = 0;
    if (flatten(cmd->opts, NULL, flat, &n)) {
        fprintf(stderr, "prismfarm %s: more than %d options\n", cmd->name, CLI_OPTS_MAX);
        return 2;
    }
    struct option longs[CLI_OPTS_MAX + 1];
    /* '-': operands come back in order as code 1, whatever POSIXLY_CORRECT says; ':': a
     * missing value is ':', not '?'; getopt_long prints nothing. */
    char shorts[3 + 2 * CLI_OPTS_MAX] = "-:";
    size_t ns = 2;
    for (int i = 0; i < n; i++) {
        const cli_opt_t *o = flat[i].opt;
        int has = takes_value(o->kind);
        longs[i] =
            (struct option){o->name, has ? required_argument : no_argument, NULL, CLI_VAL_BASE + i};
        if (o->letter) {
            shorts[ns++] = o->letter;
            if (has)
                shorts[ns++] = ':';
        }
    }
    longs[n] = (struct option){0};
    shorts[ns] = 0;

    const char *unknown = cmd->unknown ? cmd->unknown : "option";
    int nops = 0, mid = 0; /* mid: inside a cluster of short options (-ab) */
    optind = 0;            /* a fresh scan: glibc forgets any earlier one */
    for (;;) {
        int at = optind ? optind : 1;
        /* getopt_long would take a unique abbreviation (--sp for --spp): only whole names. */
        if (!mid && at < argc && !strncmp(argv[at], "--", 2) && argv[at][2] &&
            find_long(flat, n, argv[at]) < 0) {
            /* The nearest option's name, for "did you mean": compared without the dashes and
             * without an "=value". */
            char word[SUGGEST_MAX_LEN + 1];
            snprintf(word, sizeof word, "%.*s", (int)strcspn(argv[at] + 2, "="), argv[at] + 2);
            suggest_t near = suggest_begin(word);
            for (int k = 0; k < n; k++)
                suggest_consider(&near, flat[k].opt->name);
            const char *best = suggest_result(&near);
            for (size_t k = 0; !best && k < sizeof SYNONYMS / sizeof SYNONYMS[0]; k++)
                if (!strcasecmp(word, SYNONYMS[k].word))
                    for (int o = 0; o < n && !best; o++)
                        if (!strcmp(flat[o].opt->name, SYNONYMS[k].option))
                            best = flat[o].opt->name;
            if (best)
                fprintf(stderr, "prismfarm %s: unknown %s '%s' (did you mean '--%s'? see prismfarm %s --help)\n",
                        cmd->name, unknown, argv[at], best, cmd->name);
            else
                fprintf(stderr, "prismfarm %s: unknown %s '%s' (see prismfarm %s --help)\n", cmd->name,
                        unknown, argv[at], cmd->name);
            return 2;
        }
        int c = getopt_long(argc, argv, shorts, longs, NULL);
        if (c == 1) { /* an operand: it joins those before it */
            nops++;
            if (cmd->stop_at_operand)
                break;
            continue;
        }
        int i;
        char flag[80];
        if (c == '?' || c == ':') { /* optopt: the code of the option at fault */
            int is_long = optopt >= CLI_VAL_BASE;
            i = is_long ? optopt - CLI_VAL_BASE : find_letter(flat, n, optopt);
            if (is_long)
                snprintf(flag, sizeof flag, "--%s", flat[i].opt->name);
            else
                snprintf(flag, sizeof flag, "-%c", optopt);
            if (c == ':')
                fprintf(stderr, "prismfarm %s: %s needs %s\n", cmd->name, flag,
                        i >= 0 && flat[i].opt->need ? flat[i].opt->need : "a value");
            else if (is_long) /* --flag=value for a flag without one */
                fprintf(stderr, "prismfarm %s: %s takes no value, got '%s'\n", cmd->name, flag,
                        argv[optind - 1]);
            else
                fprintf(stderr, "prismfarm %s: unknown %s '%s' (see prismfarm %s --help)\n",
                        cmd->name, unknown, flag, cmd->name);
            return 2;
        }
        move_before(argv, at, optind, nops);
        if (c == -1)
            break;
        if (c >= CLI_VAL_BASE) {
            i = c - CLI_VAL_BASE;
            snprintf(flag, sizeof flag, "--%s", flat[i].opt->name);
            mid = 0;
        } else {
            i = find_letter(flat, n, c);
            snprintf(flag, sizeof flag, "-%c", c);
            mid = optind == at;
        }
        const cli_opt_t *o = flat[i].opt;
        if (o->kind == CLI_HELP) {
            cmd->usage(stdout, cmd->opts);
            return 0;
        }
        if (take(cmd->name, o, flat[i].dst, flag, optarg))
            return 2;
        if (o->last)
            break;
    }
    /* After a stop (an operand with stop_at_operand, an option marked last, "--"), the rest
     * are operands too, already after those before. */
    *first = optind - nops;
    return CLI_ARGS_GO;
}

/* ---- the help ----------------------------------------------------------------------------- */

/* "  -o, --output OUT.exr" into buf; its length. */
static int spec(const cli_opt_t *o, char *buf, size_t size)
{
    char letter[8] = "";
    if (o->letter)
        snprintf(letter, sizeof letter, "-%c, ", o->letter);
    return snprintf(buf, size, "  %s--%s%s%s", letter, o->name, o->arg ? " " : "",
                    o->arg ? o->arg : "");
}

static int spec_width(const cli_opt_t *table)
{
    int w = 0;
    char buf[128];
    for (const cli_opt_t *o = table; o->kind != CLI_END; o++) {
        int k = o->kind == CLI_GROUP              ? spec_width(o->group)
                : o->kind == CLI_TEXT || !o->help ? 0
                                                  : spec(o, buf, sizeof buf);
        if (k > w)
            w = k;
    }
    return w;
}

/* text from column col to CLI_HELP_WIDTH, broken between words and at '\n'; the lines after
 * the first indented to col. */
static void print_wrapped(FILE *out, const char *text, int col)
{
    int at = col;
    for (const char *p = text; *p;) {
        if (*p == '\n') {
            fprintf(out, "\n%*s", col, "");
            at = col;
            p++;
            continue;
        }
        size_t word = strcspn(p, " \n");
        if (at > col && at + 1 + (int)word > CLI_HELP_WIDTH) {
            fprintf(out, "\n%*s", col, "");
            at = col;
        } else if (at > col) {
            fputc(' ', out);
            at++;
        }
        fprintf(out, "%.*s", (int)word, p);
        at += (int)word;
        p += word;
        while (*p == ' ')
            p++;
    }
    fputc('\n', out);
}

static void help_lines(FILE *out, const cli_opt_t *table, int col)
{
    char buf[128];
    for (const cli_opt_t *o = table; o->kind != CLI_END; o++) {
        if (o->kind == CLI_GROUP) {
            help_lines(out, o->group, col);
        } else if (o->kind == CLI_TEXT) {
            fputs(o->help, out);
        } else if (o->help) {
            int k = spec(o, buf, sizeof buf);
            fprintf(out, "%s%*s", buf, col - k, "");
            print_wrapped(out, o->help, col);
        }
    }
}

void cli_args_help(FILE *out, const cli_opt_t *opts)
{
    help_lines(out, opts, spec_width(opts) + 2);
}
