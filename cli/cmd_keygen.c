/* prismfarm keygen: writes a CURVE key pair, NAME.key (secret, mode 0600) and NAME.pub, for a
 * master, a worker or a client (docs/security.md), and NAME.token, the key's dashboard token
 * (docs/dashboard.md), whose hash NAME.pub carries. */
#include "commands.h"

#include "cli_args.h"
#include "curve.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

static void usage(FILE *out, const cli_opt_t *opts)
{
    fprintf(out,
            "usage: prismfarm keygen NAME [--dir DIR] [--force]\n"
            "\n"
            "Writes a CURVE key pair: DIR/NAME.key (the secret key, mode 0600: it never leaves\n"
            "this host) and DIR/NAME.pub (the public key, to hand out). Copy a worker's or a\n"
            "client's NAME.pub into the master's --authorized folder; give the master's NAME.pub\n"
            "to its workers and clients (--master-key). See docs/security.md.\n"
            "Also writes DIR/NAME.token (mode 0600), the token that lets NAME act on the\n"
            "master's dashboard ('Authorization: Bearer TOKEN'); NAME.pub carries only its\n"
            "SHA-256, so the master holds no secret of it. See docs/dashboard.md.\n");
    cli_args_help(out, opts);
}

int cmd_keygen(int argc, char **argv)
{
    const char *dir = ".";
    int force = 0;
    const cli_opt_t opts[] = {
        {.name = "dir", .kind = CLI_STRING, .dst = &dir, .need = "a folder", .arg = "DIR",
         .help = "where the files go (default: the current folder; created, mode 0700, if "
                 "missing)"},
        {.name = "force", .kind = CLI_FLAG, .dst = &force,
         .help = "replace an existing pair (hosts that trusted the old one must be given the new "
                 "NAME.pub)"},
        CLI_OPT_HELP,
        {0},
    };
    int first;
    const cli_cmd_t cmd = {.name = "keygen", .opts = opts, .usage = usage};
    int parsed = cli_args_parse(&cmd, argc, argv, &first);
    if (parsed != CLI_ARGS_GO)
        return parsed;
    if (argc - first > 1) {
        fprintf(stderr, "prismfarm keygen: one NAME only ('%s' and '%s' given)\n", argv[first],
                argv[first + 1]);
        return 2;
    }
    const char *name = first < argc ? argv[first] : NULL;
    err_t err;
    if (!name) {
        usage(stderr, opts);
        return 2;
    }
    if (curve_name_check(name, &err) < 0) {
        fprintf(stderr, "prismfarm keygen: %s\n", err.msg);
        return 2;
    }
    if (mkdir(dir, 0700) != 0 && errno != EEXIST) {
        fprintf(stderr, "prismfarm keygen: cannot create %s: %s\n", dir, strerror(errno));
        return 1;
    }
    curve_pair_t pair;
    char token[CURVE_TOKEN_CHARS + 1];
    curve_paths_t paths;
    int rc = curve_generate(&pair, &err) < 0 || curve_token_generate(token) < 0 ||
             curve_write(&pair, token, dir, name, force, &paths, &err) < 0;
    memset(&pair, 0, sizeof pair);
    memset(token, 0, sizeof token);
    if (rc) {
        fprintf(stderr, "prismfarm keygen: %s\n", err.msg);
        return 1;
    }
    printf("wrote %s (secret: keep it on this host), %s (the dashboard token: secret too) and %s "
           "(public: hand it out)\n",
           paths.key, paths.token, paths.pub);
    return 0;
}
