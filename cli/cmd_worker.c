/* prismfarm worker: runs a render worker that serves a master until interrupted. */
#include "commands.h"

#include "cli_args.h"
#include "client_rpc.h"
#include "worker_daemon.h"

#include <signal.h>
#include <stdio.h>
#include <string.h>

static volatile sig_atomic_t stop_flag;

static void on_signal(int sig)
{
    (void)sig;
    stop_flag = 1;
}

static void usage(FILE *out, const cli_opt_t *opts)
{
    fprintf(out, "usage: prismfarm worker --connect tcp://HOST:5555 --key FILE --master-key FILE [options]\n"
                 "\n"
                 "Renders tasks for the master until interrupted (Ctrl-C or SIGTERM).\n");
    cli_args_help(out, opts);
}

int cmd_worker(int argc, char **argv)
{
    worker_opts_t o = {.verbose = 1, .stop = &stop_flag};
    client_security_t sec = client_security_default();
    int quiet = 0;
    const cli_opt_t opts[] = {
        {.name = "connect", .kind = CLI_STRING, .dst = &o.endpoint, .arg = "ENDPOINT",
         .help = "the master's worker endpoint (required)"},
        {.name = "threads", .kind = CLI_INT, .dst = &o.threads, .lo = 1, .hi = 1024, .arg = "N",
         .help = "render threads, and tasks held at once (default: all cores)"},
        {.name = "name", .kind = CLI_STRING, .dst = &o.name, .arg = "NAME",
         .help = "shown by `prismfarm workers` (default: host:pid)"},
        {.name = "cache", .kind = CLI_STRING, .dst = &o.cache_dir, .arg = "DIR",
         .help = "where scene bundles are kept (default: $TMPDIR/prismfarm-worker-UID)"},
        CLI_OPT_QUIET(.dst = &quiet, .help = "log nothing"),
        {.kind = CLI_TEXT,
         .help = "A tcp:// master needs keys (docs/security.md) or --insecure:\n"},
        CLI_OPT_GROUP(CLI_SECURITY_OPTS, .dst = &sec),
        CLI_OPT_HELP,
        {0},
    };
    int first;
    const cli_cmd_t cmd = {.name = "worker", .opts = opts, .usage = usage};
    int parsed = cli_args_parse(&cmd, argc, argv, &first);
    if (parsed != CLI_ARGS_GO)
        return parsed;
    if (first < argc) {
        fprintf(stderr,
                "prismfarm worker: unexpected argument '%s' (see prismfarm worker --help)\n",
                argv[first]);
        return 2;
    }
    if (quiet)
        o.verbose = 0;
    if (!o.endpoint) {
        fprintf(stderr, "prismfarm worker: --connect ENDPOINT is required\n");
        return 2;
    }
    /* A missing or unreadable key is a configuration error that no restart fixes: status 2. */
    curve_pair_t pair;
    char master_public[CURVE_Z85 + 1];
    int curve;
    err_t err;
    if (client_security_load(&sec, o.endpoint, &pair, master_public, &curve, &err) < 0) {
        fprintf(stderr, "prismfarm worker: %s\n", err.msg);
        return 2;
    }
    if (curve)
        o.curve = (net_curve_t){.server_public = master_public,
                                      .public_key = pair.public_key,
                                      .secret_key = pair.secret_key};
    o.insecure = sec.insecure;
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    int rc = worker_run(&o, &err);
    memset(&pair, 0, sizeof pair);
    if (rc) {
        fprintf(stderr, "prismfarm worker: %s\n", err.msg);
        return 1;
    }
    return 0;
}
