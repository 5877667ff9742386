/* prismfarm priority / pause / resume / requeue / unblock / logs / metrics: operating a running
 * farm (docs/farm.md, "Operating a farm"). The actions are ACT requests that only the job's
 * owner or an admin may make (an unblock: an admin); logs and metrics are printed as the
 * master sends them. */
#include "commands.h"

#include "query.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct op {
    void (*usage)(FILE *out, const cli_opt_t *opts); /* prints op_usage of this op */
    const char *name;
    proto_act_t act;
    const char *operands; /* for the usage line */
    const char *what;
    int noperands;
} op_t;

static void op_usage(FILE *out, const cli_opt_t *opts, const op_t *op)
{
    fprintf(out, "usage: prismfarm %s %s [--master ENDPOINT] [--json] [--timeout S]\n%s\n",
            op->name, op->operands, op->what);
    cli_args_help(out, opts);
}

/* A whole number in lo..hi, or 2 with a message. */
static int parse_number(const char *cmd, const char *what, const char *s, long long lo,
                        long long hi, long long *out)
{
    char *end;
    errno = 0;
    long long v = s ? strtoll(s, &end, 10) : 0;
    if (!s || errno || end == s || *end || v < lo || v > hi) {
        fprintf(stderr, "prismfarm %s: expected %s (a whole number in %lld..%lld), got '%s'\n",
                cmd, what, lo, hi, s ? s : "");
        return 2;
    }
    *out = v;
    return 0;
}

/* A task as `prismfarm logs` shows it: 12 (a camera task) or p3 (photon batch 3). */
static int parse_task(const char *cmd, const char *s, uint32_t *task)
{
    if (proto_task_parse(s, task) == 0)
        return 0;
    fprintf(stderr, "prismfarm %s: expected a task as `prismfarm logs` shows it (a number, or p and "
                    "a number for a photon batch), got '%s'\n",
            cmd, s ? s : "");
    return 2;
}

static int run_act(const op_t *op, int argc, char **argv)
{
    query_args_t q = query_args_default();
    const cli_opt_t opts[] = {
        CLI_OPT_GROUP(QUERY_OPTS, .dst = &q),
        CLI_OPT_JSON(.dst = &q.json, .help = "print the job (or the workers) as JSON"),
        CLI_OPT_HELP,
        {0},
    };
    const cli_cmd_t cmd = {.name = op->name, .opts = opts, .usage = op->usage};
    int r = query_parse(&cmd, argc, argv, &q, op->noperands);
    if (r != CLI_ARGS_GO)
        return r;
    if (!q.job || (op->noperands == 2 && !q.arg2)) {
        op_usage(stderr, opts, op);
        return 2;
    }
    proto_msg_t req = {.type = PROTO_ACT, .act = {.act = op->act}};
    long long v;
    if (op->act == PROTO_ACT_UNBLOCK) {
        req.act.worker = q.job;
    } else if (query_parse_job(op->name, q.job, &req.act.job)) {
        return 2;
    }
    if (op->act == PROTO_ACT_PRIORITY) {
        if (parse_number(op->name, "a priority", q.arg2, -PROTO_MAX_PRIORITY, PROTO_MAX_PRIORITY,
                         &v))
            return 2;
        req.act.priority = v;
    } else if (op->act == PROTO_ACT_REQUEUE) {
        if (parse_task(op->name, q.arg2, &req.act.task))
            return 2;
    }
    proto_msg_t reply;
    if (query_call(&q, op->name, &req, &reply))
        return 1;
    if (reply.type == PROTO_STATUS_REPLY)
        query_print_jobs(reply.status_reply.jobs, reply.status_reply.njobs, q.json);
    else if (reply.type == PROTO_WORKERS_REPLY && !q.json)
        printf("worker '%s' unblocked\n", q.job);
    else if (reply.type == PROTO_WORKERS_REPLY)
        printf("{\"unblocked\": true}\n");
    proto_msg_free(&reply);
    return 0;
}

static void priority_usage(FILE *out, const cli_opt_t *opts);
static const op_t OP_PRIORITY = {priority_usage, "priority", PROTO_ACT_PRIORITY, "JOB N",
                            "Sets a job's priority (-1000..1000, default 0): higher-priority jobs "
                            "get workers first;\nequal ones share them between owners.",
                            2};
static void priority_usage(FILE *out, const cli_opt_t *opts)
{
    op_usage(out, opts, &OP_PRIORITY);
}

int cmd_priority(int argc, char **argv)
{
    return run_act(&OP_PRIORITY, argc, argv);
}

static void pause_usage(FILE *out, const cli_opt_t *opts);
static const op_t OP_PAUSE = {pause_usage, "pause", PROTO_ACT_PAUSE, "JOB",
                            "Pauses a job: workers finish the tasks of it they hold and get no "
                            "more until\n`prismfarm resume JOB`. A paused job stays paused "
                            "through a restart of the master.",
                            1};
static void pause_usage(FILE *out, const cli_opt_t *opts)
{
    op_usage(out, opts, &OP_PAUSE);
}

int cmd_pause(int argc, char **argv)
{
    return run_act(&OP_PAUSE, argc, argv);
}

static void resume_usage(FILE *out, const cli_opt_t *opts);
static const op_t OP_RESUME = {resume_usage, "resume", PROTO_ACT_RESUME, "JOB", "Resumes a paused job.", 1};
static void resume_usage(FILE *out, const cli_opt_t *opts)
{
    op_usage(out, opts, &OP_RESUME);
}

int cmd_resume(int argc, char **argv)
{
    return run_act(&OP_RESUME, argc, argv);
}

static void requeue_usage(FILE *out, const cli_opt_t *opts);
static const op_t OP_REQUEUE = {requeue_usage, "requeue", PROTO_ACT_REQUEUE, "JOB TASK",
                            "Puts a running task (stuck on its worker) back in the queue: another "
                            "worker renders it,\nits retries start afresh. TASK is the number "
                            "`prismfarm logs JOB` shows.",
                            2};
static void requeue_usage(FILE *out, const cli_opt_t *opts)
{
    op_usage(out, opts, &OP_REQUEUE);
}

int cmd_requeue(int argc, char **argv)
{
    return run_act(&OP_REQUEUE, argc, argv);
}

static void unblock_usage(FILE *out, const cli_opt_t *opts);
static const op_t OP_UNBLOCK = {unblock_usage, "unblock", PROTO_ACT_UNBLOCK, "WORKER",
                            "Lets a blocked worker (by name or id, as `prismfarm workers` shows "
                            "it) take tasks again,\nof every job. An admin's action.",
                            1};
static void unblock_usage(FILE *out, const cli_opt_t *opts)
{
    op_usage(out, opts, &OP_UNBLOCK);
}

int cmd_unblock(int argc, char **argv)
{
    return run_act(&OP_UNBLOCK, argc, argv);
}

/* A FILE reply's bytes to stdout. */
static int print_file(const proto_msg_t *reply, const char *cmd)
{
    if (reply->type != PROTO_FILE) {
        fprintf(stderr, "prismfarm %s: the master answered %s\n", cmd,
                proto_type_name(reply->type));
        return 1;
    }
    if (reply->file.size && fwrite(reply->file.data, 1, reply->file.size, stdout) != reply->file.size)
        return 1;
    return fflush(stdout) == 0 ? 0 : 1;
}

static void logs_usage(FILE *out, const cli_opt_t *opts)
{
    fprintf(out,
            "usage: prismfarm logs JOB [TASK] [--master ENDPOINT] [--timeout S]\n"
            "Prints a job's task log, oldest first: which attempt of each task went to which "
            "worker\nand when, its result or failure with the worker's message, re-issues, "
            "blocks and\nevery action on the job with the key that asked. With TASK, that "
            "task's lines only.\n");
    cli_args_help(out, opts);
}

int cmd_logs(int argc, char **argv)
{
    query_args_t q = query_args_default();
    const cli_opt_t opts[] = {
        CLI_OPT_GROUP(QUERY_OPTS, .dst = &q),
        CLI_OPT_HELP,
        {0},
    };
    const cli_cmd_t cmd = {.name = "logs", .opts = opts, .usage = logs_usage};
    int r = query_parse(&cmd, argc, argv, &q, 2);
    if (r != CLI_ARGS_GO)
        return r;
    proto_msg_t req = {.type = PROTO_LOGS};
    if (query_parse_job("logs", q.job, &req.logs.job))
        return 2;
    if (q.arg2) {
        if (parse_task("logs", q.arg2, &req.logs.task))
            return 2;
        req.logs.has_task = true;
    }
    proto_msg_t reply;
    if (query_call(&q, "logs", &req, &reply))
        return 1;
    int rc = print_file(&reply, "logs");
    proto_msg_free(&reply);
    return rc;
}

static void metrics_usage(FILE *out, const cli_opt_t *opts)
{
    fprintf(out, "usage: prismfarm metrics [--master ENDPOINT] [--timeout S]\n"
                 "Prints the master's metrics in Prometheus' text format (what the dashboard "
                 "serves at /metrics).\n");
    cli_args_help(out, opts);
}

int cmd_metrics(int argc, char **argv)
{
    query_args_t q = query_args_default();
    const cli_opt_t opts[] = {
        CLI_OPT_GROUP(QUERY_OPTS, .dst = &q),
        CLI_OPT_HELP,
        {0},
    };
    const cli_cmd_t cmd = {.name = "metrics", .opts = opts, .usage = metrics_usage};
    int r = query_parse(&cmd, argc, argv, &q, 0);
    if (r != CLI_ARGS_GO)
        return r;
    proto_msg_t req = {.type = PROTO_METRICS}, reply;
    if (query_call(&q, "metrics", &req, &reply))
        return 1;
    int rc = print_file(&reply, "metrics");
    proto_msg_free(&reply);
    return rc;
}
