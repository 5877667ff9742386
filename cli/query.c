#include "query.h"

#include "cli_json.h"
#include "stopping.h"

#include <errno.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const cli_opt_t QUERY_OPTS[] = {
    CLI_OPT_MASTER(.off = offsetof(query_args_t, master)),
    {.name = "timeout", .kind = CLI_DOUBLE, .off = offsetof(query_args_t, timeout_s), .lo = 0.1,
     .hi = 3600, .unit = "seconds", .arg = "S",
     .help = "how long to wait for the master's answer (default 10)"},
    CLI_OPT_GROUP(CLI_SECURITY_OPTS, .off = offsetof(query_args_t, sec)),
    {0},
};

query_args_t query_args_default(void)
{
    return (query_args_t){.master = client_default_master(), .timeout_s = 10,
                          .sec = client_security_default()};
}

int query_parse(const cli_cmd_t *cmd, int argc, char **argv, query_args_t *q, int max_jobs)
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
    q->arg2 = first + 1 < argc ? argv[first + 1] : NULL;
    q->timeout_ms = (int)(q->timeout_s * 1000);
    return CLI_ARGS_GO;
}

int query_parse_job(const char *cmd, const char *s, uint64_t *out)
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

int query_call(const query_args_t *q, const char *cmd, const proto_msg_t *req, proto_msg_t *reply)
{
    err_t err;
    /* The one "no master" rule (client_rpc.h): a master that is not there is an error now. */
    client_rpc_t *rpc =
        client_rpc_probe(q->master, q->timeout_ms / 1000.0, cmd, &err) == 0
            ? client_rpc_new(q->master, NULL, &q->sec, &err)
            : NULL;
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
    json_object_set_new(o, "priority", json_integer((json_int_t)j->priority));
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
    /* Frame sequences (docs/farm.md): a sequence's count of frames; a frame's sequence and
     * number. */
    if (j->frames > 0)
        json_object_set_new(o, "nframes", json_integer(j->frames));
    if (j->parent) {
        json_object_set_new(o, "sequence", json_integer((json_int_t)j->parent));
        json_object_set_new(o, "frame", json_integer(j->frame));
    }
    return o;
}

void query_print_jobs(const proto_job_info_t *jobs, size_t n, int json)
{
    /* A sequence's STATUS lists its frames after it: they go into its "frames" (JSON), or
     * below it, indented, in the table. */
    if (json) {
        json_t *arr = json_array(), *seq = NULL, *frames = NULL;
        for (size_t i = 0; i < n; i++) {
            json_t *o = job_json(&jobs[i]);
            if (seq && jobs[i].parent == jobs[0].id) {
                json_array_append_new(frames, o);
                continue;
            }
            json_array_append_new(arr, o);
            if (i == 0 && jobs[0].frames > 0 && n > 1 && jobs[1].parent == jobs[0].id) {
                seq = o;
                json_object_set_new(seq, "frames", frames = json_array());
            }
        }
        cli_json_print(arr, JSON_INDENT(2));
        return;
    }
    printf("%-6s %-20s %-12s %-10s %5s %9s %8s %9s %9s %10s  %s\n", "ID", "NAME", "OWNER",
           "STATE", "PRIO", "PROGRESS", "SPP", "REL.ERROR", "ELAPSED", "NONFINITE", "ERROR");
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
        else if (j->frames > 0)
            snprintf(note, sizeof note, "(%u frames)", j->frames);
        char name[64];
        if (j->parent)
            snprintf(name, sizeof name, "  #%u %s", j->frame, j->name ? j->name : "");
        else
            snprintf(name, sizeof name, "%s", j->name ? j->name : "");
        printf("%-6llu %-20.20s %-12.12s %-10s %5lld %8.1f%% %8u %9s %8.1fs %10llu  %s\n",
               (unsigned long long)j->id, name,
               j->owner && j->owner[0] ? j->owner : "-", proto_job_state_name(j->state),
               j->priority, p, j->spp, rel, j->elapsed, (unsigned long long)j->nonfinite, note);
    }
}

