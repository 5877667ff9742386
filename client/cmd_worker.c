/* prismfarm worker: runs a render worker that serves a master until interrupted. */
#include "commands.h"

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
    fprintf(out, "usage: prismfarm worker --connect tcp://HOST:5555 [options]\n"
                 "\n"
                 "Renders tasks for the master until interrupted (Ctrl-C or SIGTERM).\n"
                 "  --connect ENDPOINT   the master's worker endpoint (required)\n"
                 "  --threads N          render threads, and tasks held at once (default: all cores)\n"
                 "  --name NAME          shown by `prismfarm workers` (default: host:pid)\n"
                 "  --cache DIR          where scene bundles are kept (default: $TMPDIR/prismfarm-worker-UID)\n"
                 "  --quiet              log nothing\n");
}

int cmd_worker(int argc, char **argv)
{
    worker_opts_t o = {.verbose = 1, .stop = &stop_flag};
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
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
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    err_t err;
    if (worker_run(&o, &err)) {
        fprintf(stderr, "prismfarm worker: %s\n", err.msg);
        return 1;
    }
    return 0;
}
