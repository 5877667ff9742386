/* prismfarm master: runs the farm's master daemon (master/master.h) until SIGINT or SIGTERM. */
#include "commands.h"

#include "curve.h"
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
            "  --no-journal         keep no journal (SPOOL/journal.db): a restarted master then\n"
            "                       forgets unfinished jobs (docs/reliability.md)\n"
            "  --quiet              no event log on stderr\n"
            "security (docs/security.md): a tcp:// endpoint needs --key and --authorized, or\n"
            "--insecure; inproc:// and ipc:// need neither\n"
            "  --key FILE           the master's key pair, NAME.key from prismfarm keygen\n"
            "  --authorized DIR     the workers' and clients' NAME.pub files: only they get in\n"
            "                       (read again when the folder changes: no restart needed)\n"
            "  --insecure           plain text, anyone who reaches the ports gets in\n"
            "limits (what one client can make the master hold):\n"
            "  --max-jobs N         unfinished jobs held at once, 1..100000 (default 256)\n"
            "  --max-message-mb N   largest message, 1..528 MiB (default 528); a peer sending a\n"
            "                       larger one is disconnected\n"
            "  --max-bundle-mb N    largest scene bundle, 1..512 MiB (default 512, at most the\n"
            "                       message size)\n"
            "  --max-bundle-files N files in a scene bundle, 1..4096 (default 4096)\n");
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
    long message_mb = 0, bundle_mb = 0; /* 0: not given */
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
        if (!strcmp(a, "--insecure")) {
            o.insecure = 1;
            continue;
        }
        if (!strcmp(a, "--no-journal")) {
            o.journal = 0;
            continue;
        }
        if (strcmp(a, "--workers") && strcmp(a, "--clients") && strcmp(a, "--spool") &&
            strcmp(a, "--heartbeat") && strcmp(a, "--task-deadline") && strcmp(a, "--tile") &&
            strcmp(a, "--key") && strcmp(a, "--authorized") && strcmp(a, "--max-jobs") &&
            strcmp(a, "--max-message-mb") && strcmp(a, "--max-bundle-mb") &&
            strcmp(a, "--max-bundle-files")) {
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
        } else if (!strcmp(a, "--key")) {
            o.key_file = val;
        } else if (!strcmp(a, "--authorized")) {
            o.authorized_dir = val;
        } else if (!strcmp(a, "--max-jobs")) {
            if (parse_int(a, val, 1, 100000, &v))
                return 2;
            o.max_jobs = (size_t)v;
        } else if (!strcmp(a, "--max-message-mb")) {
            /* Only lower than the default: workers and clients keep theirs, and a larger
             * message from the master would make them drop the connection. */
            if (parse_int(a, val, 1, (long)(PROTO_MAX_MESSAGE_BYTES >> 20), &v))
                return 2;
            message_mb = v;
        } else if (!strcmp(a, "--max-bundle-mb")) {
            if (parse_int(a, val, 1, (long)(PROTO_MAX_BUNDLE_BYTES >> 20), &v))
                return 2;
            bundle_mb = v;
        } else if (!strcmp(a, "--max-bundle-files")) {
            if (parse_int(a, val, 1, PROTO_MAX_BUNDLE_FILES, &v))
                return 2;
            o.limits.max_bundle_files = (size_t)v;
        } else {
            if (parse_int(a, val, 1, 4096, &v))
                return 2;
            o.sched.tile_size = (int)v;
        }
    }
    o.sched.worker_timeout_s = 3.0 * o.heartbeat_ms / 1000.0;
    if (message_mb)
        o.limits.max_message_bytes = (size_t)message_mb << 20;
    if (bundle_mb)
        o.limits.max_bundle_bytes = (size_t)bundle_mb << 20;
    else if (o.limits.max_bundle_bytes > o.limits.max_message_bytes)
        o.limits.max_bundle_bytes = o.limits.max_message_bytes; /* --max-message-mb alone */
    if (o.limits.max_bundle_bytes > o.limits.max_message_bytes) {
        fprintf(stderr,
                "prismfarm master: --max-bundle-mb %ld exceeds --max-message-mb %ld: a "
                "bundle travels in one message\n",
                bundle_mb, (long)(o.limits.max_message_bytes >> 20));
        return 2;
    }
    /* The security choice and the keys are checked before anything starts: a mistake there is
     * a bad configuration (status 2), which restarting cannot fix. */
    err_t err;
    if (!o.key_file != !o.authorized_dir) {
        fprintf(stderr, "prismfarm master: %s\n",
                o.key_file ? "--key needs --authorized DIR, the public keys let in"
                           : "--authorized needs --key FILE, the master's own key pair");
        return 2;
    }
    const char *how = "--key FILE and --authorized DIR";
    if (proto_curve_require(o.worker_endpoint, o.key_file, o.insecure, how, &err) < 0 ||
        proto_curve_require(o.client_endpoint, o.key_file, o.insecure, how, &err) < 0) {
        fprintf(stderr, "prismfarm master: %s\n", err.msg);
        return 2;
    }
    if (o.key_file) {
        proto_curve_pair_t pair;
        proto_curve_ring_t *ring = NULL;
        int bad = proto_curve_load_pair(o.key_file, &pair, &err) < 0 ||
                  !(ring = proto_curve_ring_new(o.authorized_dir, &err));
        memset(&pair, 0, sizeof pair);
        proto_curve_ring_destroy(&ring);
        if (bad) {
            fprintf(stderr, "prismfarm master: %s\n", err.msg);
            return 2;
        }
    }

    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    if (sigaction(SIGINT, &sa, NULL) < 0 || sigaction(SIGTERM, &sa, NULL) < 0) {
        fprintf(stderr, "prismfarm master: cannot install signal handlers: %s\n", strerror(errno));
        return 1;
    }
    o.stop = &STOP;
    if (master_run(&o, &err) < 0) {
        fprintf(stderr, "prismfarm master: %s\n", err.msg);
        return 1;
    }
    return 0;
}
