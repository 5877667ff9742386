/* prismfarm refine: more photons for a finished photon job (docs/farm.md, "Photon jobs"). The
 * master traces the new batches on its workers, merges them into the job's store with the same
 * rescaling (by every photon emitted so far; docs/physics.md §5.2) and renders the camera phase
 * again; --wait follows the job and downloads the refined image. */
#include "commands.h"

#include "cli_args.h"
#include "client_rpc.h"
#include "film.h"
#include "frame_pattern.h"
#include "job_follow.h"

#include <errno.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void usage(FILE *out, const cli_opt_t *opts)
{
    fprintf(out,
            "usage: prismfarm refine JOB --photons N [--master ENDPOINT] [--wait [-o OUT.exr]]\n"
            "                        [--quiet]\n"
            "Adds N photons to a finished job's photon pass (Integrator \"photon\"), then renders\n"
            "its image again from the grown store; of a frame sequence, each of its photon\n"
            "frames. With --wait, follows the job and downloads the refined EXR and PNG (default\n"
            "name: refined-JOB.exr; a sequence's frames: -o's pattern, default\n"
            "refined-JOB-%%04d.exr).\n");
    cli_args_help(out, opts);
}

/* The job's STATUS_REPLY (the sequence and its frames for a sequence), into *reply. 0, or 1
 * with the message on stderr. */
static int status_of(client_rpc_t *rpc, unsigned long long job, proto_msg_t *reply)
{
    proto_msg_t req = {.type = PROTO_STATUS, .status = {.job = job}};
    err_t err;
    if (client_rpc_call(rpc, &req, reply, 60000, &err)) {
        fprintf(stderr, "prismfarm refine: %s\n", err.msg);
        return 1;
    }
    if (reply->type == PROTO_ERROR) {
        fprintf(stderr, "prismfarm refine: %s\n", reply->error.message);
        proto_msg_free(reply);
        return 1;
    }
    if (reply->type != PROTO_STATUS_REPLY || reply->status_reply.njobs < 1) {
        fprintf(stderr, "prismfarm refine: the master answered %s\n",
                proto_type_name(reply->type));
        proto_msg_free(reply);
        return 1;
    }
    return 0;
}

/* --wait's outputs, checked before the job is refined: a job's EXR (output, default
 * refined-JOB.exr) and the PNG beside it; a sequence's frames to output's pattern (default
 * refined-JOB-%04d.exr: job_follow_frame_paths), into path. 0, 1 or 2 (a bad output) with the
 * reason on stderr. */
static int check_outputs(client_rpc_t *rpc, unsigned long long job, const char *output,
                         bool *sequence, char *path, size_t size)
{
    proto_msg_t reply;
    if (status_of(rpc, job, &reply))
        return 1;
    const proto_job_info_t *jobs = reply.status_reply.jobs;
    size_t n = reply.status_reply.njobs;
    *sequence = jobs[0].frames > 0;
    if (output)
        snprintf(path, size, "%s", output);
    else
        snprintf(path, size, *sequence ? "refined-%llu-%%04d.exr" : "refined-%llu.exr", job);
    int rc = 0;
    err_t err;
    char exr[4096], png[4200];
    if (!*sequence) {
        film_png_path(path, png, sizeof png);
        rc = job_follow_check_outputs(path, png, "refine");
    } else if (frame_pattern_check(path, &err) < 0) {
        fprintf(stderr, "prismfarm refine: -o for a sequence of frames: %s\n", err.msg);
        rc = 2;
    } else {
        for (size_t i = 1; i < n && !rc; i++) {
            if (job_follow_frame_paths(&jobs[i], path, exr, sizeof exr, png, sizeof png,
                                       &err) < 0) {
                fprintf(stderr, "prismfarm refine: %s\n", err.msg);
                rc = 2;
            } else
                rc = job_follow_check_outputs(exr, png, "refine");
        }
    }
    proto_msg_free(&reply);
    return rc;
}

/* After a refined sequence is done: every frame's outputs (the refined frames' and the others'). */
static int fetch_frames(client_rpc_t *rpc, unsigned long long job, const char *pattern, int quiet)
{
    proto_msg_t reply;
    if (status_of(rpc, job, &reply))
        return 1;
    int rc = job_follow_fetch_frames(rpc, reply.status_reply.jobs, reply.status_reply.njobs,
                                     pattern, quiet, "refine");
    proto_msg_free(&reply);
    return rc;
}

int cmd_refine(int argc, char **argv)
{
    const char *master = client_default_master(), *output = NULL;
    long long photons = 0;
    int wait = 0, quiet = 0;
    client_security_t sec = client_security_default();
    const cli_opt_t opts[] = {
        {.name = "photons", .kind = CLI_LLONG, .dst = &photons, .lo = 1, .hi = 1LL << 40,
         .arg = "N", .help = "photons to add (required)"},
        CLI_OPT_MASTER(.dst = &master),
        {.name = "wait", .kind = CLI_FLAG, .dst = &wait,
         .help = "follow the job and download the refined EXR and PNG"},
        {.name = "output", .letter = 'o', .kind = CLI_STRING, .dst = &output, .arg = "OUT.exr",
         .help = "with --wait: where the EXR goes (default refined-JOB.exr)"},
        CLI_OPT_QUIET(.dst = &quiet, .help = "with --wait: no progress bar"),
        CLI_OPT_GROUP(CLI_SECURITY_OPTS, .dst = &sec),
        CLI_OPT_HELP,
        {0},
    };
    int first;
    const cli_cmd_t cmd = {.name = "refine", .opts = opts, .usage = usage};
    int parsed = cli_args_parse(&cmd, argc, argv, &first);
    if (parsed != CLI_ARGS_GO)
        return parsed;
    if (argc - first > 1) {
        fprintf(stderr, "prismfarm refine: unexpected argument '%s'\n", argv[first + 1]);
        return 2;
    }
    const char *job_s = first < argc ? argv[first] : NULL;
    char *end;
    errno = 0;
    unsigned long long job = job_s ? strtoull(job_s, &end, 10) : 0;
    if (!job_s || errno || end == job_s || *end || job == 0 || job_s[0] == '-') {
        fprintf(stderr, "prismfarm refine: expected a job id (a positive integer), got '%s'\n",
                job_s ? job_s : "");
        return 2;
    }
    if (photons == 0) {
        fprintf(stderr, "prismfarm refine: --photons N is required (photons to add, 1 to 2^40)\n");
        return 2;
    }
    if (output && !wait) {
        fprintf(stderr, "prismfarm refine: -o needs --wait\n");
        return 2;
    }
    err_t err;
    client_rpc_t *rpc =
        client_rpc_probe(master, CLIENT_RPC_LISTEN_WAIT_S, "refine", &err) == 0
            ? client_rpc_new(master, NULL, &sec, &err)
            : NULL;
    if (!rpc) {
        fprintf(stderr, "prismfarm refine: %s\n", err.msg);
        return 1;
    }
    /* With --wait, whether the job is a sequence decides the outputs (an -o pattern, one file per
     * frame): checked before it is refined. */
    char exr[4096], png[4200];
    bool sequence = false;
    if (wait) {
        int rc = check_outputs(rpc, job, output, &sequence, exr, sizeof exr);
        if (rc) {
            client_rpc_destroy(&rpc);
            return rc;
        }
        film_png_path(exr, png, sizeof png);
    }
    proto_msg_t req = {.type = PROTO_REFINE, .refine = {.job = job, .photons = (uint64_t)photons}};
    proto_msg_t reply;
    if (client_rpc_call(rpc, &req, &reply, 10000, &err)) {
        fprintf(stderr, "prismfarm refine: %s\n", err.msg);
        client_rpc_destroy(&rpc);
        return 1;
    }
    int type = reply.type;
    proto_msg_free(&reply);
    if (type != PROTO_SUBMITTED) {
        fprintf(stderr, "prismfarm refine: the master answered %s\n", proto_type_name((proto_type_t)type));
        client_rpc_destroy(&rpc);
        return 1;
    }
    if (!wait) {
        printf("job %llu: refining with %lld more photons\n", job, photons);
        client_rpc_destroy(&rpc);
        return 0;
    }
    proto_job_info_t last;
    char error[600];
    int state = job_follow_wait(rpc, job, quiet, &last, error, sizeof error);
    int rc = 0;
    if (state != JOB_DONE) {
        fprintf(stderr, "prismfarm refine: job %llu %s%s%s\n", job,
                state < 0 ? "lost" : proto_job_state_name((job_state_t)state),
                error[0] ? ": " : "", error);
        rc = 1;
    } else if (sequence) {
        rc = fetch_frames(rpc, job, exr, quiet);
        if (rc == 0)
            printf("job %llu refined in %.1f s\n", job, last.elapsed);
    } else {
        if (job_follow_fetch_outputs(rpc, job, exr, png, "refine"))
            rc = 1;
        else
            printf("job %llu refined in %.1f s: wrote %s and %s\n", job, last.elapsed, exr, png);
    }
    client_rpc_destroy(&rpc);
    return rc;
}
