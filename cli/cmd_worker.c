/* prismfarm worker: runs a render worker that serves a master until interrupted. */
#include "commands.h"

#include "client_rpc.h"
#include "worker_daemon.h"

#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static volatile sig_atomic_t stop_flag;

static void on_signal(int sig)
{
    (void)sig;
    stop_flag = 1;
}

static void usage(FILE *out)
{
    fprintf(out, "usage: prismfarm worker --connect tcp://HOST:5555 --key FILE --master-key FILE [options]\n"
                 "\n"
                 "Renders tasks for the master until interrupted (Ctrl-C or SIGTERM).\n"
                 "  --connect ENDPOINT   the master's worker endpoint (required)\n"
                 "  --threads N          render threads, and tasks held at once (default: all cores)\n"
                 "  --name NAME          shown by `prismfarm workers` (default: host:pid)\n"
                 "  --cache DIR          where scene bundles are kept (default: $TMPDIR/prismfarm-worker-UID)\n"
                 "  --quiet              log nothing\n"
                 "A tcp:// master needs keys (docs/security.md) or --insecure:\n"
                 CLIENT_SECURITY_HELP);
}

int cmd_worker(int argc, char **argv)
{
    worker_opts_t o = {.verbose = 1, .stop = &stop_flag};
    client_security_t sec = client_security_default();
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int s = client_security_arg("worker", argc, argv, &i, &sec);
        if (s < 0)
            return 2;
        if (s)
            continue;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            usage(stdout);
            return 0;
        }
        if (!strcmp(a, "--quiet")) {
            o.verbose = 0;
            continue;
        }
        if (i + 1 >= argc || strncmp(a, "--", 2) != 0) {
            fprintf(stderr, "prismfarm worker: unexpected argument '%s' (see prismfarm worker --help)\n", a);
            return 2;
        }
        const char *v = argv[++i];
        if (!strcmp(a, "--connect"))
            o.endpoint = v;
        else if (!strcmp(a, "--name"))
            o.name = v;
        else if (!strcmp(a, "--cache"))
            o.cache_dir = v;
        else if (!strcmp(a, "--threads")) {
            char *end;
            long n = strtol(v, &end, 10);
            if (end == v || *end || n < 1 || n > 1024) {
                fprintf(stderr, "prismfarm worker: --threads expects an integer in 1..1024, got '%s'\n", v);
                return 2;
            }
            o.threads = (int)n;
        } else {
            fprintf(stderr, "prismfarm worker: unknown option '%s' (see prismfarm worker --help)\n", a);
            return 2;
        }
    }
    if (!o.endpoint) {
        fprintf(stderr, "prismfarm worker: --connect ENDPOINT is required\n");
        return 2;
    }
    /* A missing or unreadable key is a configuration error that no restart fixes: status 2. */
    proto_curve_pair_t pair;
    char master_public[PROTO_CURVE_Z85 + 1];
    int curve;
    err_t err;
    if (client_security_load(&sec, o.endpoint, &pair, master_public, &curve, &err) < 0) {
        fprintf(stderr, "prismfarm worker: %s\n", err.msg);
        return 2;
    }
    if (curve)
        o.curve = (proto_net_curve_t){.server_public = master_public,
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
