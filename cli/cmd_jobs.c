/* prismfarm status / jobs / workers / cancel / fetch: questions to a running master, answered
 * as human-readable tables or, with --json, as JSON for scripts. */
#include "commands.h"

#include "cli_args.h"
#include "cli_json.h"
#include "client_rpc.h"
#include "film.h"
#include "job_follow.h"
#include "stopping.h"

#include <errno.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct query_args {
    const char *master;
    int json;
    const char *job; /* the operand, if any */
    const char *output;
    double timeout_s; /* how long to wait for the master's answer */
    int timeout_ms;
    int wait, quiet; /* status: follow the job until it is over */
    client_security_t sec;
} query_args_t;

/* The options of every question: --master, --timeout and the keys. */
static const cli_opt_t QUERY_OPTS[] = {
    CLI_OPT_MASTER(.off = offsetof(query_args_t, master)),
    {.name = "timeout", .kind = CLI_DOUBLE, .off = offsetof(query_args_t, timeout_s), .lo = 0.1,
     .hi = 3600, .unit = "seconds", .arg = "S",
     .help = "how long to wait for the master's answer (default 10)"},
    CLI_OPT_GROUP(CLI_SECURITY_OPTS, .off = offsetof(query_args_t, sec)),
    {0},
};

static query_args_t query_args_default(void)
{
    return (query_args_t){.master = client_default_master(), .timeout_s = 10,
                          .sec = client_security_default()};
}

/* Parses the command line of cmd into *q: its options, then at most max_jobs operands (the
 * job id). */
static int parse_args(const cli_cmd_t *cmd, int argc, char **argv, query_args_t *q, int max_jobs)
{
    int first;
    int parsed = cli_args_parse(cmd, argc, argv, &first);
    if (parsed != CLI_ARGS_GO)
        return parsed;
    if (argc - first > max_jobs) {
        fprintf(stderr, "prismfarm %s: unexpected argument '%s'\n", cmd->name,
                argv[first + max_jobs]);
        return 2;
    }
    q->job = first < argc ? argv[first] : NULL;
    q->timeout_ms = (int)(q->timeout_s * 1000);
    return CLI_ARGS_GO;
}

static int parse_job(const char *cmd, const char *s, uint64_t *out)
{
    char *end;
    errno = 0;
    unsigned long long v = s ? strtoull(s, &end, 10) : 0;
    if (!s || errno || end == s || *end || v == 0 || s[0] == '-') {
        fprintf(stderr, "prismfarm %s: expected a job id (a positive integer), got '%s'\n", cmd, s ? s : "");
        return 2;
    }
    *out = v;
    return 0;
}

static int call(const query_args_t *q, const char *cmd, const proto_msg_t *req, proto_msg_t *reply)
{
    err_t err;
    client_rpc_t *rpc = client_rpc_new(q->master, NULL, &q->sec, &err);
    int r = rpc ? client_rpc_call(rpc, req, reply, q->timeout_ms, &err) : -1;
    client_rpc_destroy(&rpc);
    if (r)
        fprintf(stderr, "prismfarm %s: %s\n", cmd, err.msg);
    return r ? 1 : 0;
}

static json_t *job_json(const proto_job_info_t *j)
{
    json_t *o = json_object();
    json_object_set_new(o, "id", json_integer((json_int_t)j->id));
    json_object_set_new(o, "name", cli_json_string(j->name));
    json_object_set_new(o, "state", json_string(proto_job_state_name(j->state)));
    /* The submitting key's name (docs/security.md, "Rights"); null without keys. */
    json_object_set_new(o, "owner", j->owner && j->owner[0] ? cli_json_string(j->owner) : json_null());
    json_object_set_new(o, "samples_done", json_integer((json_int_t)j->samples_done));
    json_object_set_new(o, "samples_total", json_integer((json_int_t)j->samples_total));
    json_object_set_new(o, "progress", json_real(j->samples_total ? (double)j->samples_done / (double)j->samples_total : 0.0));
    json_object_set_new(o, "elapsed_s", json_real(j->elapsed));
    json_object_set_new(o, "nonfinite", json_integer((json_int_t)j->nonfinite));
    json_object_set_new(o, "error", j->error ? cli_json_string(j->error) : json_null());
    /* Accuracy (docs/farm.md): spp of the whole passes merged, the relative error estimate
     * after the last one (null before the second pass), why a done job stopped early. */
    json_object_set_new(o, "spp", json_integer((json_int_t)j->spp));
    json_object_set_new(o, "rel_error", j->has_rel_error ? json_real(j->rel_error) : json_null());
    json_object_set_new(o, "stop",
                        j->stop != PROTO_STOP_NONE ? json_string(proto_stop_name(j->stop)) : json_null());
    return o;
}

static void print_jobs(const proto_job_info_t *jobs, size_t n, int json)
{
    if (json) {
        json_t *arr = json_array();
        for (size_t i = 0; i < n; i++)
            json_array_append_new(arr, job_json(&jobs[i]));
        cli_json_print(arr, JSON_INDENT(2));
        return;
    }
    printf("%-6s %-20s %-12s %-10s %9s %8s %9s %9s %10s  %s\n", "ID", "NAME", "OWNER", "STATE",
           "PROGRESS", "SPP", "REL.ERROR", "ELAPSED", "NONFINITE", "ERROR");
    for (size_t i = 0; i < n; i++) {
        const proto_job_info_t *j = &jobs[i];
        double p = j->samples_total ? 100.0 * (double)j->samples_done / (double)j->samples_total : 0;
        char rel[32] = "-";
        if (j->has_rel_error)
            snprintf(rel, sizeof rel, "%.4f", j->rel_error);
        char note[PROTO_MAX_STRING + 32] = "";
        if (j->error)
            snprintf(note, sizeof note, "%s", j->error);
        else if (j->stop != PROTO_STOP_NONE)
            snprintf(note, sizeof note, "(stopped: %s)", stopping_reason((stopping_why_t)j->stop));
        printf("%-6llu %-20.20s %-12.12s %-10s %8.1f%% %8u %9s %8.1fs %10llu  %s\n",
               (unsigned long long)j->id, j->name ? j->name : "",
               j->owner && j->owner[0] ? j->owner : "-", proto_job_state_name(j->state), p, j->spp,
               rel, j->elapsed,
               (unsigned long long)j->nonfinite, note);
    }
}

static void status_usage(FILE *out, const cli_opt_t *opts)
{
    fprintf(out,
            "usage: prismfarm status [JOB] [--master ENDPOINT] [--json] [--timeout S]\n"
            "                        [--wait [--quiet]]\n"
            "Shows one job, or every job, of the master. With --wait, follows JOB (a progress\n"
            "line unless --quiet) until it is over, through a restart of the master, then\n"
            "shows it; exits 0 when it is done, 1 when it failed or was cancelled.\n");
    cli_args_help(out, opts);
}

int cmd_status(int argc, char **argv)
{
    query_args_t q = query_args_default();
    const cli_opt_t opts[] = {
        CLI_OPT_GROUP(QUERY_OPTS, .dst = &q),
        CLI_OPT_JSON(.dst = &q.json, .help = "print the job or jobs as JSON"),
        {.name = "wait", .kind = CLI_FLAG, .dst = &q.wait,
         .help = "follow JOB until it is over, then show it"},
        CLI_OPT_QUIET(.dst = &q.quiet, .help = "with --wait: no progress line"),
        CLI_OPT_HELP,
        {0},
    };
    const cli_cmd_t cmd = {.name = "status", .opts = opts, .usage = status_usage};
    int r = parse_args(&cmd, argc, argv, &q, 1);
    if (r != CLI_ARGS_GO)
        return r;
    proto_msg_t req = {.type = PROTO_STATUS, .status = {.all = q.job == NULL}};
    if (q.job && parse_job("status", q.job, &req.status.job))
        return 2;
    if (q.wait && !q.job) {
        fprintf(stderr, "prismfarm status: --wait needs a job id\n");
        return 2;
    }
    int over = -1;
    if (q.wait) {
        err_t err;
        client_rpc_t *rpc = client_rpc_new(q.master, NULL, &q.sec, &err);
        proto_job_info_t last;
        char error[600] = "";
        if (!rpc)
            snprintf(error, sizeof error, "%s", err.msg);
        else
            over = job_follow_wait(rpc, req.status.job, q.quiet, &last, error, sizeof error);
        client_rpc_destroy(&rpc);
        if (over < 0) {
            fprintf(stderr, "prismfarm status: %s\n", error);
            return 1;
        }
    }
    proto_msg_t reply;
    if (call(&q, "status", &req, &reply))
        return 1;
    print_jobs(reply.status_reply.jobs, reply.status_reply.njobs, q.json);
    proto_msg_free(&reply);
    return over < 0 || over == PROTO_JOB_DONE ? 0 : 1;
}

static void jobs_usage(FILE *out, const cli_opt_t *opts)
{
    fprintf(out, "usage: prismfarm jobs [--master ENDPOINT] [--json] [--timeout S]\n"
                 "Lists the master's jobs.\n");
    cli_args_help(out, opts);
}

int cmd_jobs(int argc, char **argv)
{
    query_args_t q = query_args_default();
    const cli_opt_t opts[] = {
        CLI_OPT_GROUP(QUERY_OPTS, .dst = &q),
        CLI_OPT_JSON(.dst = &q.json, .help = "print the jobs as JSON"),
        CLI_OPT_HELP,
        {0},
    };
    const cli_cmd_t cmd = {.name = "jobs", .opts = opts, .usage = jobs_usage};
    int r = parse_args(&cmd, argc, argv, &q, 0);
    if (r != CLI_ARGS_GO)
        return r;
    proto_msg_t req = {.type = PROTO_JOBS}, reply;
    if (call(&q, "jobs", &req, &reply))
        return 1;
    print_jobs(reply.jobs_reply.jobs, reply.jobs_reply.njobs, q.json);
    proto_msg_free(&reply);
    return 0;
}

static void workers_usage(FILE *out, const cli_opt_t *opts)
{
    fprintf(out, "usage: prismfarm workers [--master ENDPOINT] [--json] [--timeout S]\n"
                 "Lists the workers the master knows.\n");
    cli_args_help(out, opts);
}

int cmd_workers(int argc, char **argv)
{
    query_args_t q = query_args_default();
    const cli_opt_t opts[] = {
        CLI_OPT_GROUP(QUERY_OPTS, .dst = &q),
        CLI_OPT_JSON(.dst = &q.json, .help = "print the workers as JSON"),
        CLI_OPT_HELP,
        {0},
    };
    const cli_cmd_t cmd = {.name = "workers", .opts = opts, .usage = workers_usage};
    int r = parse_args(&cmd, argc, argv, &q, 0);
    if (r != CLI_ARGS_GO)
        return r;
    proto_msg_t req = {.type = PROTO_WORKERS}, reply;
    if (call(&q, "workers", &req, &reply))
        return 1;
    const proto_worker_info_t *w = reply.workers_reply.workers;
    size_t n = reply.workers_reply.nworkers;
    if (q.json) {
        json_t *arr = json_array();
        for (size_t i = 0; i < n; i++) {
            json_t *o = json_object();
            json_object_set_new(o, "id", json_integer((json_int_t)w[i].id));
            json_object_set_new(o, "name", cli_json_string(w[i].name));
            json_object_set_new(o, "threads", json_integer(w[i].threads));
            json_object_set_new(o, "state", json_string(proto_worker_state_name(w[i].state)));
            json_object_set_new(o, "tasks_done", json_integer((json_int_t)w[i].tasks_done));
            json_object_set_new(o, "last_seen_s", json_real(w[i].last_seen));
            json_array_append_new(arr, o);
        }
        cli_json_print(arr, JSON_INDENT(2));
    } else {
        printf("%-6s %-24s %7s %-6s %10s %10s\n", "ID", "NAME", "THREADS", "STATE", "TASKS", "LAST SEEN");
        for (size_t i = 0; i < n; i++)
            printf("%-6llu %-24.24s %7d %-6s %10llu %9.1fs\n", (unsigned long long)w[i].id,
                   w[i].name ? w[i].name : "", w[i].threads, proto_worker_state_name(w[i].state),
                   (unsigned long long)w[i].tasks_done, w[i].last_seen);
    }
    proto_msg_free(&reply);
    return 0;
}

static void cancel_usage(FILE *out, const cli_opt_t *opts)
{
    fprintf(out, "usage: prismfarm cancel JOB [--master ENDPOINT] [--json] [--timeout S]\n"
                 "Cancels a job.\n");
    cli_args_help(out, opts);
}

int cmd_cancel(int argc, char **argv)
{
    query_args_t q = query_args_default();
    const cli_opt_t opts[] = {
        CLI_OPT_GROUP(QUERY_OPTS, .dst = &q),
        CLI_OPT_JSON(.dst = &q.json, .help = "print the cancelled job as JSON"),
        CLI_OPT_HELP,
        {0},
    };
    const cli_cmd_t cmd = {.name = "cancel", .opts = opts, .usage = cancel_usage};
    int r = parse_args(&cmd, argc, argv, &q, 1);
    if (r != CLI_ARGS_GO)
        return r;
    proto_msg_t req = {.type = PROTO_CANCEL}, reply;
    if (parse_job("cancel", q.job, &req.cancel.job))
        return 2;
    if (call(&q, "cancel", &req, &reply))
        return 1;
    if (reply.type == PROTO_STATUS_REPLY)
        print_jobs(reply.status_reply.jobs, reply.status_reply.njobs, q.json);
    proto_msg_free(&reply);
    return 0;
}

static void fetch_usage(FILE *out, const cli_opt_t *opts)
{
    fprintf(out,
            "usage: prismfarm fetch JOB -o OUT.exr [--master ENDPOINT] [--timeout S]\n"
            "Downloads a finished job's spectral EXR to OUT.exr and its preview to OUT.png.\n");
    cli_args_help(out, opts);
}

int cmd_fetch(int argc, char **argv)
{
    query_args_t q = query_args_default();
    const cli_opt_t opts[] = {
        {.name = "output", .letter = 'o', .kind = CLI_STRING, .dst = &q.output, .arg = "OUT.exr",
         .help = "where the EXR goes (required); the PNG goes beside it"},
        CLI_OPT_GROUP(QUERY_OPTS, .dst = &q),
        /* Taken, as by the other questions, for scripts that pass it to all of them; fetch
         * prints no JSON. */
        CLI_OPT_JSON(.dst = &q.json),
        CLI_OPT_HELP,
        {0},
    };
    const cli_cmd_t cmd = {.name = "fetch", .opts = opts, .usage = fetch_usage};
    int r = parse_args(&cmd, argc, argv, &q, 1);
    if (r != CLI_ARGS_GO)
        return r;
    uint64_t job;
    if (parse_job("fetch", q.job, &job))
        return 2;
    if (!q.output) {
        fprintf(stderr, "prismfarm fetch: -o OUT.exr is required\n");
        return 2;
    }
    char png[4200];
    film_png_path(q.output, png, sizeof png);
    int bad_output = job_follow_check_outputs(q.output, png, "fetch");
    if (bad_output)
        return bad_output;
    err_t err;
    client_rpc_t *rpc =
        client_rpc_probe(q.master, &err) == 0 ? client_rpc_new(q.master, NULL, &q.sec, &err) : NULL;
    if (!rpc) {
        fprintf(stderr, "prismfarm fetch: %s\n", err.msg);
        return 1;
    }
    int failed = job_follow_fetch(rpc, job, PROTO_FETCH_EXR, q.output, "fetch") ||
                 job_follow_fetch(rpc, job, PROTO_FETCH_PNG, png, "fetch");
    client_rpc_destroy(&rpc);
    if (failed)
        return 1;
    printf("wrote %s and %s\n", q.output, png);
    return 0;
}
