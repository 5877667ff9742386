/* prismfarm submit: bundles a scene with the files it reads, submits it to a master, prints
 * the job id; with --wait follows the job with a progress bar and fetches the result. Several
 * scene files, or a pattern with --frames, make one job of a frame sequence (docs/farm.md,
 * "Frame sequences"). */
#include "commands.h"

#include "cli_args.h"
#include "cli_json.h"
#include "client_rpc.h"
#include "error_estimate.h"
#include "progress.h"
#include "film.h"
#include "files.h"
#include "frame_list.h"
#include "frame_pattern.h"
#include "job_follow.h"
#include "scene_bundle.h"
#include "settings.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void usage(FILE *out, const cli_opt_t *opts)
{
    fprintf(out, "usage: prismfarm submit SCENE.pbrt [--master ENDPOINT] [options]\n"
                 "       prismfarm submit FRAME.pbrt FRAME.pbrt ... [options]\n"
                 "       prismfarm submit 'frame%%04d.pbrt' --frames FIRST-LAST [options]\n"
                 "\n"
                 "Submits SCENE (and every file it includes) as a job; prints the job id.\n"
                 "Several scene files of one folder (frames/*.pbrt), or a pattern with --frames,\n"
                 "make one job of a frame sequence: one output per frame, the files the frames\n"
                 "share sent once. A listed frame's number is the last number in its file name\n"
                 "(else its place in the list, from 1); with --wait, -o takes a pattern such as\n"
                 "out/f%%04d.exr (default: each frame file's name with .exr).\n");
    cli_args_help(out, opts);
}

/* After a sequence is done: each frame's outputs (job_follow_fetch_frames), then with --json
 * the sequence and its frames' files. */
static int fetch_sequence(client_rpc_t *rpc, uint64_t job, const char *output, int json,
                          const proto_job_info_t *last)
{
    proto_msg_t req = {.type = PROTO_STATUS, .status = {.job = job}}, reply;
    err_t err;
    if (client_rpc_call(rpc, &req, &reply, 60000, &err)) {
        fprintf(stderr, "prismfarm submit: %s\n", err.msg);
        return 1;
    }
    if (reply.type != PROTO_STATUS_REPLY) {
        fprintf(stderr, "prismfarm submit: the master answered %s\n", proto_type_name(reply.type));
        proto_msg_free(&reply);
        return 1;
    }
    const proto_job_info_t *jobs = reply.status_reply.jobs;
    size_t n = reply.status_reply.njobs;
    int rc = job_follow_fetch_frames(rpc, jobs, n, output, json, "submit");
    if (rc == 0 && json) {
        json_t *o = json_object(), *arr = json_array();
        json_object_set_new(o, "job", json_integer((json_int_t)job));
        json_object_set_new(o, "state", json_string("done"));
        json_object_set_new(o, "elapsed_s", json_real(last->elapsed));
        for (size_t i = 1; i < n; i++) {
            char exr[4096], png[4200];
            (void)job_follow_frame_paths(&jobs[i], output, exr, sizeof exr, png, sizeof png, &err);
            json_t *f = json_object();
            json_object_set_new(f, "frame", json_integer(jobs[i].frame));
            json_object_set_new(f, "job", json_integer((json_int_t)jobs[i].id));
            json_object_set_new(f, "exr", cli_json_string(exr));
            json_object_set_new(f, "png", cli_json_string(png));
            json_array_append_new(arr, f);
        }
        json_object_set_new(o, "frames", arr);
        cli_json_print(o, JSON_INDENT(2));
    } else if (rc == 0) {
        printf("job %llu done in %.1f s: %zu frames written\n", (unsigned long long)job,
               last->elapsed, n - 1);
    }
    proto_msg_free(&reply);
    return rc;
}

static int submit_scenes(const frame_list_t *fr, const char *master, const char *name,
                         const char *output, const proto_settings_t *settings, int wait, int json,
                         int quiet, int priority, double timeout_s, client_security_t *secp);

int cmd_submit(int argc, char **argv)
{
    const char *master = client_default_master(), *name = NULL, *output = NULL, *range = NULL;
    proto_settings_t job = PROTO_SETTINGS_FILE;
    int wait = 0, json = 0, quiet = 0, priority = 0;
    double timeout_s = 60;
    client_security_t sec = client_security_default();
    const cli_opt_t opts[] = {
        CLI_OPT_MASTER(.dst = &master),
        {.name = "name",
         .kind = CLI_STRING,
         .dst = &name,
         .arg = "NAME",
         .help = "job name (default: the scene file's name)"},
        CLI_OPT_GROUP(CLI_OVERRIDE_OPTS, .dst = &job),
        CLI_OPT_GROUP(CLI_STOP_OPTS, .dst = &job),
        {.name = "priority",
         .kind = CLI_INT,
         .dst = &priority,
         .lo = -PROTO_MAX_PRIORITY,
         .hi = PROTO_MAX_PRIORITY,
         .arg = "N",
         .help = "higher runs first (default 0; -1000..1000; `prismfarm priority` changes it)"},
        CLI_OPT_FRAMES(.dst = &range),
        {.name = "wait",
         .kind = CLI_FLAG,
         .dst = &wait,
         .help = "follow the job with a progress bar and fetch the result"},
        {.name = "output",
         .letter = 'o',
         .kind = CLI_STRING,
         .dst = &output,
         .arg = "OUT",
         .help = "with --wait: where the EXR goes (default NAME.exr; a sequence: a pattern such "
                 "as out/f%04d.exr, default each frame file's name); the PNG goes beside it"},
        CLI_OPT_JSON(.dst = &json,
                     .help = "print the job id (and with --wait the final status) as JSON"),
        CLI_OPT_QUIET(.dst = &quiet, .help = "with --wait: no progress bar"),
        /* At least 3 s: a master loading the scene says so every 2 s (PROGRESS_S). */
        {.name = "timeout",
         .kind = CLI_DOUBLE,
         .dst = &timeout_s,
         .lo = 3,
         .hi = 3600,
         .unit = "seconds",
         .arg = "S",
         .help = "how long a silent master is waited for (default 60, at least 3); the master "
                 "says every 2 s that it is still loading the scene, which restarts the wait, "
                 "so a long load never runs into it"},
        CLI_OPT_GROUP(CLI_SECURITY_OPTS, .dst = &sec),
        CLI_OPT_HELP,
        {0},
    };
    int first;
    const cli_cmd_t cmd = {.name = "submit", .opts = opts, .usage = usage};
    int parsed = cli_args_parse(&cmd, argc, argv, &first);
    if (parsed != CLI_ARGS_GO)
        return parsed;
    if (first == argc) {
        usage(stderr, opts);
        return 2;
    }
    frame_list_t fr;
    int bad = frame_list_parse(&fr, argv + first, (size_t)(argc - first), range, "submit");
    if (bad) {
        frame_list_free(&fr);
        return bad;
    }
    int rc = submit_scenes(&fr, master, name, output, &job, wait, json, quiet, priority, timeout_s,
                           &sec);
    frame_list_free(&fr);
    return rc;
}

static int submit_scenes(const frame_list_t *fr, const char *master, const char *name,
                         const char *output, const proto_settings_t *settings, int wait, int json,
                         int quiet, int priority, double timeout_s, client_security_t *secp)
{
    bool sequence = fr->sequence;
    if (output && !wait) {
        fprintf(stderr, "prismfarm submit: -o needs --wait (or use prismfarm fetch JOB -o OUT later)\n");
        return 2;
    }
    char namebuf[420];
    if (!name) {
        frame_list_name(fr, namebuf, sizeof namebuf);
        name = namebuf;
    }

    err_t err;
    char exr[4096], png[4200];
    if (sequence) {
        if (wait && output && frame_pattern_check(output, &err) < 0) {
            fprintf(stderr, "prismfarm submit: -o for a sequence of frames: %s\n", err.msg);
            return 2;
        }
        for (size_t k = 0; wait && k < fr->n; k++) {
            proto_job_info_t f = {.name = fr->paths[k], .frame = fr->numbers[k]};
            if (job_follow_frame_paths(&f, output, exr, sizeof exr, png, sizeof png, &err) < 0) {
                fprintf(stderr, "prismfarm submit: %s\n", err.msg);
                return 2;
            }
            int bad_output = job_follow_check_outputs(exr, png, "submit");
            if (bad_output)
                return bad_output;
        }
    } else {
        if (output)
            snprintf(exr, sizeof exr, "%s", output);
        else
            snprintf(exr, sizeof exr, "%s.exr", name);
        film_png_path(exr, png, sizeof png);
        int bad_output = wait ? job_follow_check_outputs(exr, png, "submit") : 0;
        if (bad_output)
            return bad_output;
    }

    scene_bundle_t *b = scene_bundle_new_frames((const char *const *)fr->paths, fr->n, &err);
    if (!b) {
        fprintf(stderr, "prismfarm submit: %s\n", err.msg);
        return 1;
    }
    proto_frame_t *frames = sequence ? calloc(fr->n, sizeof *frames) : NULL;
    for (size_t k = 0; frames && k < fr->n; k++)
        frames[k] = (proto_frame_t){.main = scene_bundle_frame_main(b, k), .number = fr->numbers[k]};
    if (sequence && !frames) {
        fprintf(stderr, "prismfarm submit: out of memory\n");
        scene_bundle_destroy(&b);
        return 1;
    }
    client_security_t sec = *secp;
    client_rpc_t *rpc = client_rpc_probe(master, timeout_s, quiet || json ? NULL : "submit", &err) == 0
                            ? client_rpc_new(master, NULL, &sec, &err)
                            : NULL;
    if (rpc && !quiet && !json)
        client_rpc_on_progress(rpc, progress_print_master, "submit");
    proto_msg_t req = {
        .type = PROTO_SUBMIT,
        .submit = {.name = name, .settings = *settings, .bundle = *scene_bundle_get(b)}};
    req.submit.priority = priority;
    req.submit.frames = frames;
    req.submit.nframes = sequence ? fr->n : 0;
    proto_msg_t reply;
    int rc = 0;
    if (!rpc || client_rpc_call(rpc, &req, &reply, (int)(timeout_s * 1000), &err)) {
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
        if (json) {
            json_t *o = json_object();
            json_object_set_new(o, "job", json_integer((json_int_t)job));
            json_object_set_new(o, "name", cli_json_string(name));
            if (sequence)
                json_object_set_new(o, "nframes", json_integer((json_int_t)fr->n));
            cli_json_print(o, 0);
        } else {
            printf("%llu\n", (unsigned long long)job);
        }
        goto out;
    }
    if (!quiet && sequence)
        fprintf(stderr, "submit: job %llu (%s, %zu frames, %zu file%s, %zu bytes) on %s\n",
                (unsigned long long)job, name, fr->n, scene_bundle_get(b)->nfiles,
                scene_bundle_get(b)->nfiles == 1 ? "" : "s", scene_bundle_bytes(b), master);
    else if (!quiet)
        fprintf(stderr, "submit: job %llu (%s, %zu file%s, %zu bytes) on %s\n",
                (unsigned long long)job, name, scene_bundle_get(b)->nfiles,
                scene_bundle_get(b)->nfiles == 1 ? "" : "s", scene_bundle_bytes(b), master);
    proto_job_info_t last;
    char error[600];
    char prediction[256] = "";
    int state = job_follow_wait_error(rpc, job, quiet, settings->target_error, 0, &last, error,
                                      sizeof error, prediction, sizeof prediction);
    if (state != JOB_DONE) {
        fprintf(stderr, "prismfarm submit: job %llu %s%s%s\n", (unsigned long long)job,
                state < 0 ? "lost" : proto_job_state_name((job_state_t)state), error[0] ? ": " : "", error);
        rc = 1;
        goto out;
    }
    if (sequence) {
        rc = fetch_sequence(rpc, job, output, json, &last);
        goto out;
    }
    if (job_follow_fetch_outputs(rpc, job, exr, png, "submit")) {
        rc = 1;
        goto out;
    }
    if (json) {
        json_t *o = json_object();
        json_object_set_new(o, "job", json_integer((json_int_t)job));
        json_object_set_new(o, "state", json_string("done"));
        json_object_set_new(o, "exr", cli_json_string(exr));
        json_object_set_new(o, "png", cli_json_string(png));
        json_object_set_new(o, "elapsed_s", json_real(last.elapsed));
        json_object_set_new(o, "nonfinite", json_integer((json_int_t)last.nonfinite));
        json_object_set_new(o, "spp", json_integer((json_int_t)last.spp));
        json_object_set_new(o, "rel_error", last.has_rel_error ? json_real(last.rel_error) : json_null());
        json_object_set_new(o, "stop", last.stop != PROTO_STOP_NONE ? json_string(proto_stop_name(last.stop))
                                                                    : json_null());
        cli_json_print(o, JSON_INDENT(2));
    } else {
        printf("job %llu done in %.1f s: wrote %s and %s; %llu non-finite samples discarded\n",
               (unsigned long long)job, last.elapsed, exr, png, (unsigned long long)last.nonfinite);
        if (last.has_rel_error)
            printf("%u spp, relative error estimate %.4f%s%s\n", last.spp, last.rel_error,
                   error_estimate_note(last.rel_error),
                   last.stop == PROTO_STOP_TARGET ? " (target reached)"
                   : last.stop == PROTO_STOP_TIME ? " (time limit reached)"
                                                  : "");
        if (prediction[0])
            printf("%s\n", prediction);
    }
out:
    client_rpc_destroy(&rpc);
    scene_bundle_destroy(&b);
    free(frames);
    return rc;
}
