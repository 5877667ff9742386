/* prismfarm status / jobs / workers / cancel / fetch: questions to a running master, answered
 * as human-readable tables or, with --json, as JSON for scripts. */
#include "commands.h"

#include "cli_args.h"
#include "cli_json.h"
#include "client_rpc.h"
#include "film.h"
#include "frame_pattern.h"
#include "job_follow.h"
#include "query.h"
#include "stopping.h"

#include <errno.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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
    int r = query_parse(&cmd, argc, argv, &q, 1);
    if (r != CLI_ARGS_GO)
        return r;
    proto_msg_t req = {.type = PROTO_STATUS, .status = {.all = q.job == NULL}};
    if (q.job && query_parse_job("status", q.job, &req.status.job))
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
    if (query_call(&q, "status", &req, &reply))
        return 1;
    query_print_jobs(reply.status_reply.jobs, reply.status_reply.njobs, q.json);
    proto_msg_free(&reply);
    return over < 0 || over == JOB_DONE ? 0 : 1;
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
    int r = query_parse(&cmd, argc, argv, &q, 0);
    if (r != CLI_ARGS_GO)
        return r;
    proto_msg_t req = {.type = PROTO_JOBS}, reply;
    if (query_call(&q, "jobs", &req, &reply))
        return 1;
    query_print_jobs(reply.jobs_reply.jobs, reply.jobs_reply.njobs, q.json);
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
    int r = query_parse(&cmd, argc, argv, &q, 0);
    if (r != CLI_ARGS_GO)
        return r;
    proto_msg_t req = {.type = PROTO_WORKERS}, reply;
    if (query_call(&q, "workers", &req, &reply))
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
            json_object_set_new(o, "tasks_failed", json_integer((json_int_t)w[i].tasks_failed));
            json_object_set_new(o, "failures_in_a_row", json_integer(w[i].fail_streak));
            json_object_set_new(o, "blocked_jobs", json_integer(w[i].blocked_jobs));
            json_object_set_new(o, "samples_per_s", json_real(w[i].samples_per_s));
            json_array_append_new(arr, o);
        }
        cli_json_print(arr, JSON_INDENT(2));
    } else {
        /* FAILED: tasks failed (in a row); BLOCKED FROM: jobs it failed too often (the whole farm
         * shows as the state "blocked"); `prismfarm unblock` lifts both. */
        printf("%-6s %-24s %7s %-7s %10s %12s %12s %10s %10s\n", "ID", "NAME", "THREADS", "STATE",
               "TASKS", "FAILED", "MSAMPLES/S", "BLOCKED", "LAST SEEN");
        for (size_t i = 0; i < n; i++) {
            char failed[48], blocked[24] = "-";
            snprintf(failed, sizeof failed, "%llu (%u)", (unsigned long long)w[i].tasks_failed,
                     w[i].fail_streak);
            if (w[i].state == PROTO_WORKER_BLOCKED)
                snprintf(blocked, sizeof blocked, "all jobs");
            else if (w[i].blocked_jobs > 0)
                snprintf(blocked, sizeof blocked, "%u job%s", w[i].blocked_jobs,
                         w[i].blocked_jobs == 1 ? "" : "s");
            /* Msamples/s as the progress lines print them: one format for every figure. */
            printf("%-6llu %-24.24s %7d %-7s %10llu %12s %12.3f %10s %9.1fs\n",
                   (unsigned long long)w[i].id, w[i].name ? w[i].name : "", w[i].threads,
                   proto_worker_state_name(w[i].state), (unsigned long long)w[i].tasks_done,
                   failed, w[i].samples_per_s / 1e6, blocked, w[i].last_seen);
        }
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
    int r = query_parse(&cmd, argc, argv, &q, 1);
    if (r != CLI_ARGS_GO)
        return r;
    proto_msg_t req = {.type = PROTO_CANCEL}, reply;
    if (query_parse_job("cancel", q.job, &req.cancel.job))
        return 2;
    if (query_call(&q, "cancel", &req, &reply))
        return 1;
    if (reply.type == PROTO_STATUS_REPLY)
        query_print_jobs(reply.status_reply.jobs, reply.status_reply.njobs, q.json);
    proto_msg_free(&reply);
    return 0;
}

static void fetch_usage(FILE *out, const cli_opt_t *opts)
{
    fprintf(out,
            "usage: prismfarm fetch JOB -o OUT.exr [--master ENDPOINT] [--timeout S]\n"
            "Downloads a finished job's spectral EXR to OUT.exr and its preview to OUT.png.\n"
            "A frame sequence's frames go to -o's pattern with each frame's number\n"
            "(out/f%%04d.exr), or without -o to each frame file's name with .exr.\n");
    cli_args_help(out, opts);
}

int cmd_fetch(int argc, char **argv)
{
    query_args_t q = query_args_default();
    const cli_opt_t opts[] = {
        {.name = "output", .letter = 'o', .kind = CLI_STRING, .dst = &q.output, .arg = "OUT.exr",
         .help = "where the EXR goes (required but for a sequence: a pattern such as "
                 "out/f%04d.exr); the PNG goes beside it"},
        CLI_OPT_GROUP(QUERY_OPTS, .dst = &q),
        /* Taken, as by the other questions, for scripts that pass it to all of them; fetch
         * prints no JSON. */
        CLI_OPT_JSON(.dst = &q.json),
        CLI_OPT_HELP,
        {0},
    };
    const cli_cmd_t cmd = {.name = "fetch", .opts = opts, .usage = fetch_usage};
    int r = query_parse(&cmd, argc, argv, &q, 1);
    if (r != CLI_ARGS_GO)
        return r;
    uint64_t job;
    if (query_parse_job("fetch", q.job, &job))
        return 2;
    /* A single job's outputs are checked before the master is asked (a pattern is a
     * sequence's, checked once its frames are known). */
    char png[4200];
    bool pattern = q.output && frame_pattern_has(q.output);
    if (q.output && !pattern) {
        film_png_path(q.output, png, sizeof png);
        int bad_output = job_follow_check_outputs(q.output, png, "fetch");
        if (bad_output)
            return bad_output;
    }
    err_t err;
    client_rpc_t *rpc =
        client_rpc_probe(q.master, q.timeout_ms / 1000.0, "fetch", &err) == 0
            ? client_rpc_new(q.master, NULL, &q.sec, &err)
            : NULL;
    if (!rpc) {
        fprintf(stderr, "prismfarm fetch: %s\n", err.msg);
        return 1;
    }
    /* A frame sequence is fetched frame by frame: its STATUS lists them. */
    proto_msg_t sreq = {.type = PROTO_STATUS, .status = {.job = job}}, sreply;
    if (client_rpc_call(rpc, &sreq, &sreply, q.timeout_ms, &err) == 0 &&
        sreply.type == PROTO_STATUS_REPLY && sreply.status_reply.njobs > 0 &&
        sreply.status_reply.jobs[0].frames > 0) {
        int rc = job_follow_fetch_frames(rpc, sreply.status_reply.jobs, sreply.status_reply.njobs,
                                         q.output, 0, "fetch");
        proto_msg_free(&sreply);
        client_rpc_destroy(&rpc);
        return rc;
    }
    proto_msg_free(&sreply);
    if (!q.output || pattern) {
        client_rpc_destroy(&rpc);
        fprintf(stderr, "prismfarm fetch: %s\n",
                q.output ? "-o with a frame number pattern is for a frame sequence; this job is "
                           "a single scene"
                         : "-o OUT.exr is required");
        return 2;
    }
    int failed = job_follow_fetch_outputs(rpc, job, q.output, png, "fetch");
    client_rpc_destroy(&rpc);
    if (failed)
        return 1;
    printf("wrote %s and %s\n", q.output, png);
    return 0;
}
