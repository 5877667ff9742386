/* query: what the commands that ask a running master share (status, jobs, workers, cancel,
 * fetch, and the operations: priority, pause, resume, requeue, unblock, logs, metrics): the
 * options --master, --timeout and the keys, operands, one request and its reply, and the job
 * table (or JSON) they print. */
#ifndef PRISMFARM_QUERY_H
#define PRISMFARM_QUERY_H

#include "cli_args.h"
#include "client_rpc.h"
#include "proto.h"

#include <stddef.h>
#include <stdint.h>

typedef struct query_args {
    const char *master;
    int json;
    const char *job;  /* the operand, if any */
    const char *arg2; /* a second operand (requeue JOB TASK, priority JOB N, logs JOB TASK) */
    const char *output;
    double timeout_s; /* how long to wait for the master's answer */
    int timeout_ms;
    int wait, quiet; /* status: follow the job until it is over */
    client_security_t sec;
} query_args_t;

/* --master, --timeout and the keys: CLI_OPT_GROUP(QUERY_OPTS, .dst = &q). */
extern const cli_opt_t QUERY_OPTS[];

query_args_t query_args_default(void);
/* Parses the command line of cmd into *q: its options, then at most max_jobs operands (q->job,
 * q->arg2). Returns CLI_ARGS_GO or the exit status. */
int query_parse(const cli_cmd_t *cmd, int argc, char **argv, query_args_t *q, int max_jobs);
/* A job id operand (a positive integer); 2 with a message naming cmd when it is not one. */
int query_parse_job(const char *cmd, const char *s, uint64_t *out);
/* Sends req and waits for the reply; 1 with the error printed (prefixed by cmd). */
int query_call(const query_args_t *q, const char *cmd, const proto_msg_t *req, proto_msg_t *reply);
/* The jobs as a table, or JSON with json. */
void query_print_jobs(const proto_job_info_t *jobs, size_t n, int json);

#endif
