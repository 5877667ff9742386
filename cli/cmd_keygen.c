/* prismfarm keygen: writes a CURVE key pair, NAME.key (secret, mode 0600) and NAME.pub, for a
 * master, a worker or a client (docs/security.md). */
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
            "to its workers and clients (--master-key). See docs/security.md.\n");
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
    char key_path[PATH_MAX], pub_path[PATH_MAX];
    int rc =
        curve_generate(&pair, &err) < 0 ||
        curve_write(&pair, dir, name, force, key_path, pub_path, sizeof key_path, &err) < 0;
    memset(&pair, 0, sizeof pair);
    if (rc) {
        fprintf(stderr, "prismfarm keygen: %s\n", err.msg);
        return 1;
    }
    printf("wrote %s (secret: keep it on this host) and %s (public: hand it out)\n", key_path,
           pub_path);
    return 0;
}
