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

static void usage(FILE *f)
{
    fprintf(f, "usage: prismfarm refine JOB --photons N [--master ENDPOINT] [--wait [-o OUT.exr]] [--quiet]\n"
               "Adds N photons to a finished job's photon pass (Integrator \"photon\"), then renders\n"
               "its image again from the grown store. With --wait, follows the job and downloads\n"
               "the refined EXR and PNG (default name: refined-JOB.exr).\n"
               CLIENT_SECURITY_HELP);
}

int cmd_refine(int argc, char **argv)
{
    const char *master = client_default_master(), *job_s = NULL, *output = NULL;
    long long photons = 0;
    int wait = 0, quiet = 0;
    client_security_t sec = client_security_default();
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int s = client_security_arg("refine", argc, argv, &i, &sec);
        if (s < 0)
            return 2;
        if (s)
            continue;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            usage(stdout);
            return 0;
        } else if (!strcmp(a, "--photons") && i + 1 < argc) {
            if (cli_parse_int("refine", "--photons", argv[++i], 1, 1LL << 40, &photons))
                return 2;
        } else if (!strcmp(a, "--master") && i + 1 < argc) {
            master = argv[++i];
        } else if ((!strcmp(a, "-o") || !strcmp(a, "--output")) && i + 1 < argc) {
            output = argv[++i];
        } else if (!strcmp(a, "--wait")) {
            wait = 1;
        } else if (!strcmp(a, "--quiet")) {
            quiet = 1;
        } else if (a[0] == '-') {
            fprintf(stderr, "prismfarm refine: unknown option '%s' (see prismfarm refine --help)\n", a);
            return 2;
        } else if (!job_s) {
            job_s = a;
        } else {
            fprintf(stderr, "prismfarm refine: unexpected argument '%s'\n", a);
            return 2;
        }
    }
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
        char exr[4096], png[4200];
        if (output)
            snprintf(exr, sizeof exr, "%s", output);
        else
            snprintf(exr, sizeof exr, "refined-%llu.exr", job);
        film_png_path(exr, png, sizeof png);
        if (job_follow_fetch(rpc, job, PROTO_FETCH_EXR, exr, "refine") ||
            job_follow_fetch(rpc, job, PROTO_FETCH_PNG, png, "refine"))
            rc = 1;
        else
            printf("job %llu refined in %.1f s: wrote %s and %s\n", job, last.elapsed, exr, png);
    }
    client_rpc_destroy(&rpc);
    return rc;
}
