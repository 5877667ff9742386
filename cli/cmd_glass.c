/* prismfarm glass: lists the glass catalogue and prints refractive indices of a catalogue
 * glass or of a Sellmeier/Cauchy model given on the command line. */
#include "commands.h"

#include "cli_args.h"
#include "dispersion.h"
#include "err.h"
#include "glass.h"
#include "named_spectra.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Wavelengths the command accepts: beyond these no catalogue fit is meaningful. */
#define GLASS_CMD_MIN_NM 100.0
#define GLASS_CMD_MAX_NM 10000.0
#define GLASS_CMD_MAX_NUMBERS (1 + 2 * IOR_SELLMEIER_MAX_TERMS)
#define GLASS_STR(x) #x
#define GLASS_XSTR(x) GLASS_STR(x) /* a macro's value as a string literal */

static void print_usage(FILE *out, const cli_opt_t *opts)
{
    fprintf(out,
            "usage: prismfarm glass --list\n"
            "       prismfarm glass NAME [NM ...]\n"
            "       prismfarm glass --sellmeier [A0,]B1,C1[,B2,C2 ...] [NM ...]\n"
            "       prismfarm glass --cauchy A,B [NM ...]\n"
            "\n"
            "Prints the refractive index of a catalogue glass (NAME or an alias, any case) at\n"
            "the given wavelengths in nanometres (%g to %g), or by default n_F (%.4f nm),\n"
            "n_d (%.4f nm), n_C (%.4f nm) and the Abbe number v_d = (n_d - 1) / (n_F - n_C).\n"
            "\n",
            GLASS_CMD_MIN_NM, GLASS_CMD_MAX_NM, IOR_LAMBDA_F_NM, IOR_LAMBDA_D_NM, IOR_LAMBDA_C_NM);
    cli_args_help(out, opts);
    fprintf(out,
            "\n"
            "exit status: 0 success, 1 unknown glass or unphysical model, 2 bad command line\n");
}

static int print_list(void)
{
    printf("%-14s %-8s %-6s %-21s %s\n", "name", "n_d", "v_d", "source", "aliases");
    for (int i = 0; i < glass_count(); i++) {
        const glass_t *g = glass_get(i);
        double vd;
        char vd_text[16];
        if (ior_abbe_number(&g->ior, &vd))
            snprintf(vd_text, sizeof vd_text, "%.2f", vd);
        else
            snprintf(vd_text, sizeof vd_text, "inf");
        printf("%-14s %.5f  %-6s %-21s ", g->name, ior_eval(&g->ior, IOR_LAMBDA_D_NM), vd_text,
               g->source);
        if (!g->aliases[0])
            printf("-");
        for (int k = 0; k < GLASS_MAX_ALIASES && g->aliases[k]; k++)
            printf("%s%s", k ? ", " : "", g->aliases[k]);
        printf("\n");
    }
    /* pbrt-v4's glass-* names mean its tabulated tables in "spectrum eta" (docs/scene-format.md). */
    printf("\npbrt-v4's tabulated glasses (\"spectrum eta\" \"NAME\"; as \"string glass\" the aliases "
           "above):\n");
    for (int i = 0; i < named_spectra_count(); i++) {
        const named_spectrum_t *e = named_spectra_get(i);
        if (e->kind != NAMED_SPECTRUM_GLASS_ETA)
            continue;
        ior_model_t m;
        if (ior_tabulated(&m, e->lambda, e->value, e->count, NULL) == 0)
            printf("%-14s %.5f  %.0f-%.0f nm, pbrt-v4 spectrum.cpp\n", e->name, ior_eval(&m, IOR_LAMBDA_D_NM),
                   e->lambda[0], e->lambda[e->count - 1]);
    }
    return 0;
}

/* A wavelength argument: a number, optionally followed by "nm". */
static int parse_wavelength(const char *arg, double *lambda_nm)
{
    char *end;
    double v = strtod(arg, &end);
    if (end == arg || (*end && strcmp(end, "nm") != 0) || !isfinite(v) || v < GLASS_CMD_MIN_NM ||
        v > GLASS_CMD_MAX_NM) {
        fprintf(stderr,
                "prismfarm glass: bad wavelength '%s': expected a number of nanometres from %g "
                "to %g\n",
                arg, GLASS_CMD_MIN_NM, GLASS_CMD_MAX_NM);
        return -1;
    }
    *lambda_nm = v;
    return 0;
}

/* Comma-separated finite numbers; returns how many, or -1 (message printed). */
static int parse_numbers(const char *option, const char *arg, double *values, int max)
{
    int count = 0;
    const char *p = arg;
    for (;;) {
        char *end;
        double v = strtod(p, &end);
        if (end == p || !isfinite(v) || (*end != ',' && *end != '\0') || count == max) {
            fprintf(stderr,
                    "prismfarm glass: bad %s list '%s': expected up to %d comma-separated "
                    "numbers\n",
                    option, arg, max);
            return -1;
        }
        values[count++] = v;
        if (*end == '\0')
            return count;
        p = end + 1;
    }
}

static int model_from_options(const char *option, const char *arg, ior_model_t *model)
{
    double v[GLASS_CMD_MAX_NUMBERS];
    if (!strcmp(option, "--cauchy")) {
        int count = parse_numbers(option, arg, v, 2);
        if (count < 0)
            return -1;
        if (count != 2) {
            fprintf(stderr, "prismfarm glass: bad --cauchy list '%s': expected A,B\n", arg);
            return -1;
        }
        *model = ior_cauchy(v[0], v[1]);
        return 0;
    }
    int count = parse_numbers(option, arg, v, GLASS_CMD_MAX_NUMBERS);
    if (count < 0)
        return -1;
    int first = count % 2; /* an odd count starts with A0 */
    double a0 = first ? v[0] : 0.0;
    double b[IOR_SELLMEIER_MAX_TERMS], c[IOR_SELLMEIER_MAX_TERMS];
    int terms = (count - first) / 2;
    for (int i = 0; i < terms; i++) {
        b[i] = v[first + 2 * i];
        c[i] = v[first + 2 * i + 1];
    }
    err_t err;
    if (ior_sellmeier(model, a0, b, c, terms, &err) != 0) {
        fprintf(stderr, "prismfarm glass: bad --sellmeier list '%s': %s\n", arg, err.msg);
        return -1;
    }
    return 0;
}

static int print_indices(const char *name, const ior_model_t *model, const char *heading,
                         char **wavelengths, int count)
{
    double lambda[64];
    if (count > (int)(sizeof lambda / sizeof lambda[0])) {
        fprintf(stderr, "prismfarm glass: at most %d wavelengths at a time\n",
                (int)(sizeof lambda / sizeof lambda[0]));
        return 2;
    }
    for (int i = 0; i < count; i++)
        if (parse_wavelength(wavelengths[i], &lambda[i]) != 0)
            return 2;

    double lo = IOR_LAMBDA_F_NM, hi = IOR_LAMBDA_C_NM;
    if (count > 0) {
        lo = hi = lambda[0];
        for (int i = 1; i < count; i++) {
            lo = fmin(lo, lambda[i]);
            hi = fmax(hi, lambda[i]);
        }
    }
    err_t err;
    if (ior_validate(model, name, lo, hi, &err) != 0) {
        fprintf(stderr, "prismfarm glass: %s\n", err.msg);
        return 1;
    }

    printf("%s\n", heading);
    if (count > 0) {
        for (int i = 0; i < count; i++)
            printf("n(%g nm) = %.5f\n", lambda[i], ior_eval(model, lambda[i]));
        return 0;
    }
    printf("n_F = %.5f  (%.4f nm)\n", ior_eval(model, IOR_LAMBDA_F_NM), IOR_LAMBDA_F_NM);
    printf("n_d = %.5f  (%.4f nm)\n", ior_eval(model, IOR_LAMBDA_D_NM), IOR_LAMBDA_D_NM);
    printf("n_C = %.5f  (%.4f nm)\n", ior_eval(model, IOR_LAMBDA_C_NM), IOR_LAMBDA_C_NM);
    double vd;
    if (ior_abbe_number(model, &vd))
        printf("v_d = %.2f\n", vd);
    else
        printf("v_d = inf  (not dispersive)\n");
    return 0;
}

int cmd_glass(int argc, char **argv)
{
    /* The first argument chooses: --list, a model (the rest its wavelengths) or a NAME (the
     * rest its wavelengths, which may look like options: "-5" is a bad wavelength). */
    int list = 0;
    const char *sellmeier = NULL, *cauchy = NULL;
    const cli_opt_t opts[] = {
        {.name = "list", .kind = CLI_FLAG, .dst = &list, .last = 1,
         .help = "print the catalogue: name, n_d, v_d, source, aliases"},
        {.name = "sellmeier", .kind = CLI_STRING, .dst = &sellmeier, .last = 1,
         .need = "a comma-separated list of numbers", .arg = "LIST",
         .help = "a custom model n^2 = 1 + A0 + sum B_i L^2 / (L^2 - C_i), L in um, C_i in um^2, "
                 "up to " GLASS_XSTR(IOR_SELLMEIER_MAX_TERMS) " terms; an odd count of numbers "
                 "starts with A0"},
        {.name = "cauchy", .kind = CLI_STRING, .dst = &cauchy, .last = 1,
         .need = "a comma-separated list of numbers", .arg = "A,B",
         .help = "a custom model n = A + B / L^2, L in um, B in um^2"},
        CLI_OPT_HELP,
        {0},
    };
    int at;
    const cli_cmd_t cmd = {
        .name = "glass", .opts = opts, .usage = print_usage, .stop_at_operand = 1};
    int parsed = cli_args_parse(&cmd, argc, argv, &at);
    if (parsed != CLI_ARGS_GO)
        return parsed;
    char **rest = argv + at;
    int nrest = argc - at;
    if (list) {
        if (nrest > 0) {
            fprintf(stderr, "prismfarm glass: --list takes no arguments (got '%s')\n", rest[0]);
            return 2;
        }
        return print_list();
    }
    if (sellmeier || cauchy) {
        const char *option = sellmeier ? "--sellmeier" : "--cauchy";
        const char *numbers = sellmeier ? sellmeier : cauchy;
        ior_model_t model;
        if (model_from_options(option, numbers, &model) != 0)
            return 2;
        char heading[256];
        snprintf(heading, sizeof heading, "custom %s model %s", ior_kind_name(model.kind), numbers);
        return print_indices("custom", &model, heading, rest, nrest);
    }
    if (nrest == 0) {
        print_usage(stderr, opts);
        return 2;
    }
    err_t err;
    const glass_t *g = glass_lookup(rest[0], &err);
    if (!g) {
        fprintf(stderr, "prismfarm glass: %s (see prismfarm glass --list)\n", err.msg);
        return 1;
    }
    char heading[256];
    snprintf(heading, sizeof heading, "%s: %s; %s, %s", g->name, g->description,
             ior_kind_name(g->ior.kind), g->source);
    return print_indices(g->name, &g->ior, heading, rest + 1, nrest - 1);
}
