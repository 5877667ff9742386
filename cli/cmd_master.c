/* prismfarm master: runs the farm's master daemon (master/master.h) until SIGINT or SIGTERM. */
#include "commands.h"

#include "cli_args.h"
#include "curve.h"
#include "master.h"

#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <sys/resource.h>

static volatile sig_atomic_t STOP; /* set by the signal handler: the only state it may touch */

static void on_signal(int sig)
{
    (void)sig;
    STOP = 1;
}

static void usage(FILE *out, const cli_opt_t *opts)
{
    fprintf(out,
            "usage: prismfarm master [options]\n"
            "\n"
            "Runs the farm's master: takes jobs from clients (prismfarm submit), cuts them into\n"
            "tiles, hands them to workers (prismfarm worker) and writes each job's progressive\n"
            "preview and final spectral EXR and PNG into SPOOL/jobs/<id>/. Stops on Ctrl-C.\n");
    cli_args_help(out, opts);
}

int cmd_master(int argc, char **argv)
{
    master_opts_t o = master_opts_default();
    int quiet = 0, no_journal = 0;
    int heartbeat_ms = 0, deadline_s = 0, tile = 0, max_jobs = 0, message_mb = 0, bundle_mb = 0,
        bundle_files = 0, conns_per_host = -1, conns = 0; /* 0, -1: not given */
    long long max_shapes = -1, max_triangles = -1, max_texels = -1, max_vertices = -1;
    double max_text_mb = -1, max_ply_mb = -1, max_load_s = -1;
    double max_image_mb = -1;
    double worker_timeout = 0; /* 0: not given */
    /* -1: not given (0 is a value: never block a worker for failures in a row) */
    int task_retries = 0, job_failures = 0, row_failures = -1;
    const cli_opt_t opts[] = {
        {.name = "workers",
         .kind = CLI_STRING,
         .dst = &o.worker_endpoint,
         .arg = "ENDPOINT",
         .help = "where workers connect (default tcp://*:5555)"},
        {.name = "clients",
         .kind = CLI_STRING,
         .dst = &o.client_endpoint,
         .arg = "ENDPOINT",
         .help = "where clients connect (default tcp://*:5556)\n"
                 "a port '*' lets the system choose: see SPOOL/endpoints"},
        {.name = "spool",
         .kind = CLI_STRING,
         .dst = &o.spool_dir,
         .need = "a folder name",
         .arg = "DIR",
         .help = "scenes and outputs (default ./prismfarm-spool)"},
        /* 50 ms is the shortest interval workers accept from WELCOME. */
        {.name = "heartbeat",
         .kind = CLI_INT,
         .dst = &heartbeat_ms,
         .lo = 50,
         .hi = 60000,
         .arg = "MS",
         .help = "heartbeat interval, 50..60000 (default 1000)"},
        {.name = "worker-timeout",
         .kind = CLI_SECONDS,
         .dst = &worker_timeout,
         .hi = 3600,
         .arg = "T",
         .help = "a worker silent for T is lost and its tasks re-issued (default 10 s, and at "
                 "least 3 heartbeat intervals; at least 2 when given)"},
        {.name = "task-deadline",
         .kind = CLI_INT,
         .dst = &deadline_s,
         .lo = 1,
         .hi = 86400,
         .arg = "S",
         .help = "a task not back after S seconds is issued again (1..86400, default 120)"},
        {.name = "tile",
         .kind = CLI_INT,
         .dst = &tile,
         .lo = 1,
         .hi = 4096,
         .arg = "N",
         .help = "tile side in pixels, 1..4096 (default 32)"},
        {.name = "task-retries",
         .kind = CLI_INT,
         .dst = &task_retries,
         .lo = 1,
         .hi = 1000,
         .arg = "N",
         .help = "a task that fails N times fails its job with the task's last error "
                 "(default 4)"},
        {.name = "job-failures",
         .kind = CLI_INT,
         .dst = &job_failures,
         .lo = 1,
         .hi = 1000,
         .arg = "N",
         .help = "a worker failing N tasks of a job gets no more of that job (default 2)"},
        {.name = "worker-failures",
         .kind = CLI_INT,
         .dst = &row_failures,
         .lo = 0,
         .hi = 1000,
         .arg = "N",
         .help = "a worker failing N tasks in a row, of any jobs, is blocked from every job "
                 "until `prismfarm unblock` (default 5; 0: never)"},
        {.name = "no-journal",
         .kind = CLI_FLAG,
         .dst = &no_journal,
         .help = "keep no journal (SPOOL/journal.db): a restarted master then forgets unfinished "
                 "jobs (docs/reliability.md)"},
        CLI_OPT_QUIET(.dst = &quiet, .help = "no event log on stderr"),
        {.kind = CLI_TEXT,
         .help = "security (docs/security.md): a tcp:// endpoint needs --key and --authorized, or\n"
                 "--insecure; inproc:// and ipc:// need neither\n"},
        {.name = "key",
         .kind = CLI_STRING,
         .dst = &o.key_file,
         .arg = "FILE",
         .help = "the master's key pair, NAME.key from prismfarm keygen"},
        {.name = "authorized",
         .kind = CLI_STRING,
         .dst = &o.authorized_dir,
         .arg = "DIR",
         .help = "the workers' and clients' NAME.pub files: only they get in (read again when "
                 "the folder changes: no restart needed)"},
        {.name = "authorized-workers",
         .kind = CLI_STRING,
         .dst = &o.authorized_workers_dir,
         .arg = "DIR",
         .help = "roles, instead of --authorized: the workers' NAME.pub files, let in on the "
                 "workers endpoint only"},
        {.name = "authorized-clients",
         .kind = CLI_STRING,
         .dst = &o.authorized_clients_dir,
         .arg = "DIR",
         .help = "the clients' NAME.pub files, let in on the clients endpoint only"},
        {.name = "authorized-admins",
         .kind = CLI_STRING,
         .dst = &o.authorized_admins_dir,
         .arg = "DIR",
         .help = "optional: the admins' NAME.pub files (clients endpoint)"},
        {.name = "insecure",
         .kind = CLI_FLAG,
         .dst = &o.insecure,
         .help = "plain text, anyone who reaches the ports gets in"},
        {.kind = CLI_TEXT, .help = "the web dashboard (docs/dashboard.md):\n"},
        {.name = "http",
         .kind = CLI_STRING,
         .dst = &o.http,
         .arg = "ADDR:PORT",
         .help = "serve the dashboard on this port (PORT alone: 127.0.0.1; 0: the system "
                 "chooses, see SPOOL/endpoints); off without it"},
        {.name = "http-public",
         .kind = CLI_FLAG,
         .dst = &o.http_public,
         .help = "let --http bind an address other hosts reach (plain HTTP: pages and tokens "
                 "readable on the network)"},
        {.name = "http-token-file",
         .kind = CLI_STRING,
         .dst = &o.http_token_file,
         .arg = "FILE",
         .help = "NAME.token (prismfarm keygen): its holder acts on the dashboard as an "
                 "administrator; without keys, the only way to act"},
        {.name = "dashboard-public",
         .kind = CLI_FLAG,
         .dst = &o.dashboard_public,
         .help = "for a trusted network only: whoever reaches --http reads every job's "
                 "preview, log and tasks without a token (actions still need one)"},
        {.name = "metrics-token-file",
         .kind = CLI_STRING,
         .dst = &o.metrics_token_file,
         .arg = "FILE",
         .help = "NAME.token (prismfarm keygen) a Prometheus scraper sends to read /metrics "
                 "(and nothing else); a key's token reads it too"},
        {.kind = CLI_TEXT, .help = "limits (what one client can make the master hold):\n"},
        {.name = "max-jobs",
         .kind = CLI_INT,
         .dst = &max_jobs,
         .lo = 1,
         .hi = 100000,
         .arg = "N",
         .help = "unfinished jobs held at once, 1..100000 (default 256)"},
        /* Only lower than the default: workers and clients keep theirs, and a larger message
         * from the master would make them drop the connection. */
        {.name = "max-message-mb",
         .kind = CLI_INT,
         .dst = &message_mb,
         .lo = 1,
         .hi = (double)(PROTO_MAX_MESSAGE_BYTES >> 20),
         .arg = "N",
         .help = "largest message, 1..528 MiB (default 528); a peer sending a larger one is "
                 "disconnected"},
        {.name = "max-bundle-mb",
         .kind = CLI_INT,
         .dst = &bundle_mb,
         .lo = 1,
         .hi = (double)(PROTO_MAX_BUNDLE_BYTES >> 20),
         .arg = "N",
         .help = "largest scene bundle, 1..512 MiB (default 512, at most the message size)"},
        {.name = "max-bundle-files",
         .kind = CLI_INT,
         .dst = &bundle_files,
         .lo = 1,
         .hi = PROTO_MAX_BUNDLE_FILES,
         .arg = "N",
         .help = "files in a scene bundle, 1..4096 (default 4096)"},
        {.kind = CLI_TEXT,
         .help = "budgets (what one job's scene may make the master build; "
                 "0: no bound):\n"},
        {.name = "max-shapes",
         .kind = CLI_LLONG,
         .dst = &max_shapes,
         .lo = 0,
         .hi = 1e12,
         .arg = "N",
         .help = "shapes and object instances (default 1000000)"},
        {.name = "max-triangles",
         .kind = CLI_LLONG,
         .dst = &max_triangles,
         .lo = 0,
         .hi = 1e13,
         .arg = "N",
         .help = "triangles after subdivision and tessellation (default 100000000)"},
        {.name = "max-texels",
         .kind = CLI_LLONG,
         .dst = &max_texels,
         .lo = 0,
         .hi = 1e13,
         .arg = "N",
         .help = "image texture and environment pixels (default 268435456)"},
        {.name = "max-vertices",
         .kind = CLI_LLONG,
         .dst = &max_vertices,
         .lo = 0,
         .hi = 1e13,
         .arg = "N",
         .help = "PLY vertices, from each file's header (default 33554432)"},
        {.name = "max-text-mb",
         .kind = CLI_DOUBLE,
         .dst = &max_text_mb,
         .lo = 0,
         .hi = 1e9,
         .arg = "N",
         .help = "scene text read, each Include counted each time (default 256)"},
        {.name = "max-ply-mb",
         .kind = CLI_DOUBLE,
         .dst = &max_ply_mb,
         .lo = 0,
         .hi = 1e9,
         .arg = "N",
         .help = "PLY bodies as their headers declare them (default 1024)"},
        {.name = "max-load-seconds",
         .kind = CLI_DOUBLE,
         .dst = &max_load_s,
         .lo = 0,
         .hi = 1e9,
         .arg = "S",
         .help = "the longest a scene's parse may take (default 60; decoding images and building "
                 "the BVH after it are bounded by the size budgets, not by time)"},
        {.name = "max-image-mb",
         .kind = CLI_DOUBLE,
         .dst = &max_image_mb,
         .lo = 0,
         .hi = 1e9,
         .arg = "N",
         .help = "the merged image, xres*yres*(buckets+4)*8 bytes (default 4096 MiB)"},
        {.name = "load-threads",
         .kind = CLI_INT,
         .dst = &o.load_threads,
         .lo = 0,
         .hi = 1024,
         .arg = "N",
         .help = "frames of a sequence loaded at once at submission (default 0: as many as "
                 "cores; 1: one after another)"},
        {.kind = CLI_TEXT, .help = "connections:\n"},
        {.name = "max-connections-per-host",
         .kind = CLI_INT,
         .dst = &conns_per_host,
         .lo = 0,
         .hi = 1048576,
         .arg = "N",
         .help = "open connections from one IP address per endpoint (default 512; 0: no "
                 "bound); more are shut down at once"},
        {.name = "max-connections",
         .kind = CLI_INT,
         .dst = &conns,
         .lo = 1,
         .hi = 1048576,
         .arg = "N",
         .help = "open connections per endpoint (default: from the file limit, which the "
                 "master raises to its hard maximum)"},
        CLI_OPT_HELP,
        {0},
    };
    int first;
    const cli_cmd_t cmd = {
        .name = "master", .opts = opts, .usage = usage, .unknown = "argument"};
    int parsed = cli_args_parse(&cmd, argc,
                                argv, &first);
    if (parsed != CLI_ARGS_GO)
        return parsed;
    if (first < argc) {
        fprintf(stderr, "prismfarm master: unknown argument '%s' (see prismfarm master --help)\n",
                argv[first]);
        return 2;
    }
    if (quiet)
        o.verbose = 0;
    if (no_journal)
        o.journal = 0;
    if (heartbeat_ms)
        o.heartbeat_ms = heartbeat_ms;
    if (deadline_s)
        o.sched.task_deadline_s = deadline_s;
    if (tile)
        o.sched.tile_size = tile;
    if (task_retries)
        o.sched.max_task_failures = task_retries;
    if (job_failures)
        o.sched.max_worker_job_failures = job_failures;
    if (row_failures >= 0)
        o.sched.max_worker_failures_in_row = row_failures;
    if (max_jobs)
        o.max_jobs = (size_t)max_jobs;
    if (max_shapes >= 0)
        o.budget.shapes = (uint64_t)max_shapes;
    if (max_triangles >= 0)
        o.budget.triangles = (uint64_t)max_triangles;
    if (max_texels >= 0)
        o.budget.texels = (uint64_t)max_texels;
    if (max_vertices >= 0)
        o.budget.vertices = (uint64_t)max_vertices;
    if (max_text_mb >= 0)
        o.budget.text_bytes = (uint64_t)(max_text_mb * 1048576.0);
    if (max_ply_mb >= 0)
        o.budget.ply_bytes = (uint64_t)(max_ply_mb * 1048576.0);
    if (max_load_s >= 0)
        o.budget.load_seconds = max_load_s;
    if (max_image_mb >= 0)
        o.budget.image_bytes = (uint64_t)(max_image_mb * 1048576.0);
    if (conns_per_host >= 0)
        o.max_conns_per_host = conns_per_host;
    if (conns)
        o.max_conns = conns;
    if (bundle_files)
        o.limits.max_bundle_files = (size_t)bundle_files;
    /* A worker on a loaded host (a big scene being decoded, other jobs on its cores) can be
     * silent for seconds and is not gone: losing it re-issues its tasks and, since its tasks
     * then count as abandoned, strikes its key (farm.md, "Workers"). So the default is not
     * zguide's 3 intervals alone but at least 10 s. */
    double interval_s = o.heartbeat_ms / 1000.0;
    o.sched.worker_timeout_s =
        worker_timeout > 0 ? worker_timeout : (3.0 * interval_s > 10.0 ? 3.0 * interval_s : 10.0);
    if (message_mb)
        o.limits.max_message_bytes = (size_t)message_mb << 20;
    if (bundle_mb)
        o.limits.max_bundle_bytes = (size_t)bundle_mb << 20;
    else if (o.limits.max_bundle_bytes > o.limits.max_message_bytes)
        o.limits.max_bundle_bytes = o.limits.max_message_bytes; /* --max-message-mb alone */
    o.stop = &STOP;
    /* Every option is checked before anything starts (master_check_opts, the master's one
     * place for them): a mistake there is a bad configuration (status 2), which restarting
     * cannot fix. */
    err_t err;
    if (master_check_opts(&o, &err) < 0) {
        fprintf(stderr, "prismfarm master: %s\n",
                !strncmp(err.msg, "master: ", 8) ? err.msg + 8 : err.msg);
        return 2;
    }

    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    if (sigaction(SIGINT, &sa, NULL) < 0 || sigaction(SIGTERM, &sa, NULL) < 0) {
        fprintf(stderr, "prismfarm master: cannot install signal handlers: %s\n", strerror(errno));
        return 1;
    }
    if (master_run(&o, &err) < 0) {
        /* The master's errors name it already ("master: spool: ..."), as they must where the
         * master runs inside another command (render's in-process farm): one prefix. */
        const char *msg = !strncmp(err.msg, "master: ", 8) ? err.msg + 8 : err.msg;
        fprintf(stderr, "prismfarm master: %s\n", msg);
        return 1;
    }
    return 0;
}
