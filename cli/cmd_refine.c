/* prismfarm refine: more photons for a finished photon job (docs/farm.md, "Photon jobs"). The
 * master traces the new batches on its workers, merges them into the job's store with the same
 * rescaling (by every photon emitted so far; docs/physics.md §5.2) and renders the camera phase
 * again; --wait follows the job and downloads the refined image. */
#include "commands.h"

#include "cli_args.h"
#include "client_rpc.h"
#include "film.h"
#include "job_follow.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void usage(FILE *out, const cli_opt_t *opts)
{
    fprintf(out,
            "usage: prismfarm refine JOB --photons N [--master ENDPOINT] [--wait [-o OUT.exr]]\n"
            "                        [--quiet]\n"
            "Adds N photons to a finished job's photon pass (Integrator \"photon\"), then renders\n"
            "its image again from the grown store. With --wait, follows the job and downloads\n"
            "the refined EXR and PNG (default name: refined-JOB.exr).\n");
    cli_args_help(out, opts);
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
    char exr[4096], png[4200];
    if (output)
        snprintf(exr, sizeof exr, "%s", output);
    else
        snprintf(exr, sizeof exr, "refined-%llu.exr", job);
    film_png_path(exr, png, sizeof png);
    int bad_output = wait ? job_follow_check_outputs(exr, png, "refine") : 0;
    if (bad_output)
        return bad_output;
    err_t err;
    client_rpc_t *rpc = client_rpc_new(master, NULL, &sec, &err);
    proto_msg_t req = {.type = PROTO_REFINE, .refine = {.job = job, .photons = (uint64_t)photons}};
    proto_msg_t reply;
    if (!rpc || client_rpc_call(rpc, &req, &reply, 10000, &err)) {
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
    if (state != PROTO_JOB_DONE) {
        fprintf(stderr, "prismfarm refine: job %llu %s%s%s\n", job,
                state < 0 ? "lost" : proto_job_state_name((proto_job_state_t)state),
                error[0] ? ": " : "", error);
        rc = 1;
    } else {
        if (job_follow_fetch(rpc, job, PROTO_FETCH_EXR, exr, "refine") ||
            job_follow_fetch(rpc, job, PROTO_FETCH_PNG, png, "refine"))
            rc = 1;
        else
            printf("job %llu refined in %.1f s: wrote %s and %s\n", job, last.elapsed, exr, png);
    }
    client_rpc_destroy(&rpc);
    return rc;
}
