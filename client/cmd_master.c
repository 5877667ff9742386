/* prismfarm master: runs the farm's master daemon (master/master.h) until SIGINT or SIGTERM. */
#include "commands.h"

#include "master.h"

#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static volatile sig_atomic_t STOP; /* set by the signal handler: the only state it may touch */

static void on_signal(int sig)
{
    (void)sig;
    STOP = 1;
}

static void usage(FILE *out)
{
    fprintf(out,
            "usage: prismfarm master [options]\n"
            "\n"
            "Runs the farm's master: takes jobs from clients (prismfarm submit), cuts them into\n"
            "tiles, hands them to workers (prismfarm worker) and writes each job's progressive\n"
            "preview and final spectral EXR and PNG into SPOOL/jobs/<id>/. Stops on Ctrl-C.\n"
            "  --workers ENDPOINT   where workers connect (default tcp://*:5555)\n"
            "  --clients ENDPOINT   where clients connect (default tcp://*:5556)\n"
            "                       a port '*' lets the system choose: see SPOOL/endpoints\n"
            "  --spool DIR          scenes and outputs (default ./prismfarm-spool)\n"
            "  --heartbeat MS       heartbeat interval, 50..60000 (default 1000); a worker\n"
            "                       silent for 3 intervals is lost and its tasks re-issued\n"
            "  --task-deadline S    a task not back after S seconds is issued again\n"
            "                       (1..86400, default 120)\n"
            "  --tile N             tile side in pixels, 1..4096 (default 32)\n"
            "  --quiet              no event log on stderr\n");
}

static int parse_int(const char *flag, const char *s, long lo, long hi, long *out)
{
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi) {
        fprintf(stderr, "prismfarm master: %s expects an integer in %ld..%ld, got '%s'\n", flag, lo,
                hi, s);
        return -1;
    }
    *out = v;
    return 0;
}

int cmd_master(int argc, char **argv)
{
    master_opts_t o = master_opts_default();
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        long v;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            usage(stdout);
            return 0;
        }
        if (!strcmp(a, "--quiet")) {
            o.verbose = 0;
            continue;
        }
        if (strcmp(a, "--workers") && strcmp(a, "--clients") && strcmp(a, "--spool") &&
            strcmp(a, "--heartbeat") && strcmp(a, "--task-deadline") && strcmp(a, "--tile")) {
            fprintf(stderr,
                    "prismfarm master: unknown argument '%s' (see prismfarm master --help)\n", a);
            return 2;
        }
        if (i + 1 >= argc) {
            fprintf(stderr, "prismfarm master: %s needs a value\n", a);
            return 2;
        }
        const char *val = argv[++i];
        if (!strcmp(a, "--workers")) {
            o.worker_endpoint = val;
        } else if (!strcmp(a, "--clients")) {
            o.client_endpoint = val;
        } else if (!strcmp(a, "--spool")) {
            if (!*val) {
                fprintf(stderr, "prismfarm master: --spool needs a folder name\n");
                return 2;
            }
            o.spool_dir = val;
        } else if (!strcmp(a, "--heartbeat")) {
            /* 50 ms is the shortest interval workers accept from WELCOME. */
            if (parse_int(a, val, 50, 60000, &v))
                return 2;
            o.heartbeat_ms = (int)v;
        } else if (!strcmp(a, "--task-deadline")) {
            if (parse_int(a, val, 1, 86400, &v))
                return 2;
            o.sched.task_deadline_s = (double)v;
        } else {
            if (parse_int(a, val, 1, 4096, &v))
                return 2;
            o.sched.tile_size = (int)v;
        }
    }
    o.sched.worker_timeout_s = 3.0 * o.heartbeat_ms / 1000.0;

    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    if (sigaction(SIGINT, &sa, NULL) < 0 || sigaction(SIGTERM, &sa, NULL) < 0) {
        fprintf(stderr, "prismfarm master: cannot install signal handlers: %s\n", strerror(errno));
        return 1;
    }
    o.stop = &STOP;
    err_t err;
    if (master_run(&o, &err) < 0) {
        fprintf(stderr, "prismfarm master: %s\n", err.msg);
        return 1;
    }
    return 0;
}
