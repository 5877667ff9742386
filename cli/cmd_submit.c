/* prismfarm submit: bundles a scene with the files it reads, submits it to a master, prints
 * the job id; with --wait follows the job with a progress bar and fetches the result. */
#include "commands.h"

#include "cli_args.h"
#include "client_rpc.h"
#include "film.h"
#include "job_follow.h"
#include "scene_bundle.h"
#include "settings.h"

#include <errno.h>
#include <jansson.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void usage(FILE *out)
{
    fprintf(out,
            "usage: prismfarm submit SCENE.pbrt [--master ENDPOINT] [options]\n"
            "\n"
            "Submits SCENE (and every file it includes) as a job; prints the job id.\n"
            "  --master ENDPOINT   the master's client endpoint (default $PRISMFARM_MASTER or tcp://127.0.0.1:5556)\n"
            "  --name NAME         job name (default: the scene file's name)\n"
            "  --spp N, --res WxH, --seed N, --integrator NAME, --dispersion NAME\n"
            "                      override the scene file, as for prismfarm render\n"
            "  --target-error E    done at the first pass whose relative error estimate is <= E (0 < E < 1)\n"
            "  --time-limit T      done at T seconds (or Ns, Nm, Nh) after the start, with the whole passes so far\n"
            "  --wait              follow the job with a progress bar and fetch the result\n"
            "  -o, --output OUT    with --wait: where the EXR goes (default NAME.exr); the PNG goes beside it\n"
            "  --json              print the job id (and with --wait the final status) as JSON\n"
            CLIENT_SECURITY_HELP);
}

int cmd_submit(int argc, char **argv)
{
    const char *scene = NULL, *master = client_default_master(), *name = NULL, *output = NULL;
    scene_overrides_t ov = {.seed = -1};
    cli_stop_t stop = {0};
    int wait = 0, json = 0, quiet = 0;
    client_security_t sec = client_security_default();
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int s = client_security_arg("submit", argc, argv, &i, &sec);
        if (s < 0)
            return 2;
        if (s)
            continue;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            usage(stdout);
            return 0;
        }
        if (!strcmp(a, "--wait")) {
            wait = 1;
            continue;
        }
        if (!strcmp(a, "--json")) {
            json = 1;
            continue;
        }
        if (!strcmp(a, "--quiet")) {
            quiet = 1;
            continue;
        }
        if (a[0] == '-') {
            if (i + 1 >= argc) {
                fprintf(stderr, "prismfarm submit: %s needs a value\n", a);
                return 2;
            }
            const char *val = argv[++i];
            int handled = cli_parse_override("submit", a, val, &ov);
            if (!handled)
                handled = cli_parse_stop("submit", a, val, &stop);
            if (handled < 0)
                return 2;
            if (handled)
                continue;
            if (!strcmp(a, "--master"))
                master = val;
            else if (!strcmp(a, "--name"))
                name = val;
            else if (!strcmp(a, "-o") || !strcmp(a, "--output"))
                output = val;
            else {
                fprintf(stderr, "prismfarm submit: unknown option '%s' (see prismfarm submit --help)\n", a);
                return 2;
            }
            continue;
        }
        if (scene) {
            fprintf(stderr, "prismfarm submit: more than one scene given ('%s' and '%s')\n", scene, a);
            return 2;
        }
        scene = a;
    }
    if (!scene) {
        usage(stderr);
        return 2;
    }
    if (output && !wait) {
        fprintf(stderr, "prismfarm submit: -o needs --wait (or use prismfarm fetch JOB -o OUT later)\n");
        return 2;
    }
    char namebuf[256];
    if (!name) {
        const char *base = strrchr(scene, '/');
        base = base ? base + 1 : scene;
        size_t n = strlen(base);
        if (n > 5 && !strcmp(base + n - 5, ".pbrt"))
            n -= 5;
        snprintf(namebuf, sizeof namebuf, "%.*s", (int)n, base);
        name = namebuf;
    }

    err_t err;
    scene_bundle_t *b = scene_bundle_new(scene, &err);
    if (!b) {
        fprintf(stderr, "prismfarm submit: %s\n", err.msg);
        return 1;
    }
    client_rpc_t *rpc = client_rpc_new(master, NULL, &sec, &err);
    proto_msg_t req = {.type = PROTO_SUBMIT,
                       .submit = {.name = name, .settings = settings_from_overrides(&ov),
                                  .bundle = *scene_bundle_get(b)}};
    req.submit.settings.target_error = stop.target_error;
    req.submit.settings.time_limit = stop.time_limit;
    proto_msg_t reply;
    int rc = 0;
    if (!rpc || client_rpc_call(rpc, &req, &reply, 60000, &err)) {
        fprintf(stderr, "prismfarm submit: %s\n", err.msg);
        rc = 1;
        goto out;
    }
    if (reply.type != PROTO_SUBMITTED) {
        fprintf(stderr, "prismfarm submit: the master answered %s\n", proto_type_name(reply.type));
        proto_msg_free(&reply);
        rc = 1;
        goto out;
    }
    uint64_t job = reply.submitted.job;
    proto_msg_free(&reply);
    if (!wait) {
        if (json)
            printf("{\"job\": %llu, \"name\": \"%s\"}\n", (unsigned long long)job, name);
        else
            printf("%llu\n", (unsigned long long)job);
        goto out;
    }
    if (!quiet)
        fprintf(stderr, "submit: job %llu (%s, %zu files, %zu bytes) on %s\n", (unsigned long long)job, name,
                scene_bundle_get(b)->nfiles, scene_bundle_bytes(b), master);
    proto_job_info_t last;
    char error[600];
    int state = job_follow_wait(rpc, job, quiet, &last, error, sizeof error);
    if (state != PROTO_JOB_DONE) {
        fprintf(stderr, "prismfarm submit: job %llu %s%s%s\n", (unsigned long long)job,
                state < 0 ? "lost" : proto_job_state_name((proto_job_state_t)state), error[0] ? ": " : "", error);
        rc = 1;
        goto out;
    }
    char exr[4096], png[4200];
    if (output)
        snprintf(exr, sizeof exr, "%s", output);
    else
        snprintf(exr, sizeof exr, "%s.exr", name);
    film_png_path(exr, png, sizeof png);
    if (job_follow_fetch(rpc, job, PROTO_FETCH_EXR, exr, "submit") ||
        job_follow_fetch(rpc, job, PROTO_FETCH_PNG, png, "submit")) {
        rc = 1;
        goto out;
    }
    if (json) {
        json_t *o = json_object();
        json_object_set_new(o, "job", json_integer((json_int_t)job));
        json_object_set_new(o, "state", json_string("done"));
        json_object_set_new(o, "exr", json_string(exr));
        json_object_set_new(o, "png", json_string(png));
        json_object_set_new(o, "elapsed_s", json_real(last.elapsed));
        json_object_set_new(o, "nonfinite", json_integer((json_int_t)last.nonfinite));
        json_object_set_new(o, "spp", json_integer((json_int_t)last.spp));
        json_object_set_new(o, "rel_error", last.has_rel_error ? json_real(last.rel_error) : json_null());
        json_object_set_new(o, "stop", last.stop != PROTO_STOP_NONE ? json_string(proto_stop_name(last.stop))
                                                                    : json_null());
        json_dumpf(o, stdout, JSON_INDENT(2) | JSON_PRESERVE_ORDER);
        fputc('\n', stdout);
        json_decref(o);
    } else {
        printf("job %llu done in %.1f s: wrote %s and %s; %llu non-finite samples discarded\n",
               (unsigned long long)job, last.elapsed, exr, png, (unsigned long long)last.nonfinite);
        if (last.has_rel_error)
            printf("%u spp, relative error estimate %.4f%s\n", last.spp, last.rel_error,
                   last.stop == PROTO_STOP_TARGET ? " (target reached)"
                   : last.stop == PROTO_STOP_TIME ? " (time limit reached)"
                                                  : "");
    }
out:
    client_rpc_destroy(&rpc);
    scene_bundle_destroy(&b);
    return rc;
}
