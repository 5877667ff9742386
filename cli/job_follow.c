#include "job_follow.h"

#include "clock.h"
#include "error_estimate.h"
#include "files.h"
#include "film.h"
#include "frame_pattern.h"
#include "progress.h"
#include "stopping.h"

#include <errno.h>
#include <inttypes.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

/* How long a master may be unreachable while a job is followed before the wait gives up. */
#define JOB_FOLLOW_RECONNECT_S 120

int job_follow_wait(client_rpc_t *rpc, uint64_t job, int quiet, proto_job_info_t *last, char *error,
                    size_t esize)
{
    return job_follow_wait_error(rpc, job, quiet, 0.0, 0, last, error, esize, NULL, 0);
}

int job_follow_wait_error(client_rpc_t *rpc, uint64_t job, int quiet, double target, int spp_cap,
                          proto_job_info_t *last, char *error, size_t esize, char *prediction,
                          size_t psize)
{
    if (prediction && psize)
        prediction[0] = 0;
    progress_t prog = progress_make("job", quiet);
    if (target > 0.0)
        progress_follow_error(&prog, target, spp_cap);
    /* A photon pass has its own line (photons merged of the pass, their rate, ETA) from the
     * first poll that finds it running; the samples' line, its rate and ETA start when it ends. */
    progress_t phot = progress_make("photons", quiet);
    phot.unit = "photons";
    bool phot_shown = false, phot_closed = false;
    uint64_t phot_base = 0; /* photons merged when the line began: a refinement's earlier ones */
    double phot_t0 = 0;
    double t0 = clock_now_s();
    /* Why a running job waits (outputs to a full spool), said once each time it begins. */
    char waiting[sizeof(((err_t *)0)->msg)] = "";
    /* A long poll (docs/protocol.md, STATUS `wait`): the master answers as soon as the job is
     * over, so its end is learnt at once, and otherwise after the wait, which paces the
     * progress line; with no progress to show, few questions are asked. */
    const uint32_t wait_ms = quiet ? 5000 : 200;
    double lost_since = 0; /* when the master stopped answering; 0: it answers */
    for (;;) {
        proto_msg_t req = {.type = PROTO_STATUS, .status = {.job = job, .wait_ms = wait_ms}}, reply;
        err_t err;
        double asked = clock_now_s();
        int rc = client_rpc_call(rpc, &req, &reply, (int)wait_ms + 10000, &err);
        /* A master that went away (restarted, or a network cut) is asked again on a fresh
         * connection for a while: a restarted master resumes the job from its journal
         * (docs/reliability.md), so the wait goes on where it was. */
        if (rc == CLIENT_RPC_UNREACHABLE) {
            if (lost_since == 0) {
                lost_since = asked;
                if (!quiet)
                    fprintf(stderr, "\nprismfarm: %s; asking again for up to %d s\n", err.msg,
                            JOB_FOLLOW_RECONNECT_S);
            }
            err_t rerr;
            if (clock_now_s() - lost_since < JOB_FOLLOW_RECONNECT_S) {
                clock_sleep_s(1.0);
                if (client_rpc_reconnect(rpc, &rerr) == 0)
                    continue;
                snprintf(err.msg, sizeof err.msg, "%s", rerr.msg);
            }
        }
        if (rc) {
            snprintf(error, esize, "%s", err.msg);
            return -1;
        }
        lost_since = 0;
        if (reply.type != PROTO_STATUS_REPLY || reply.status_reply.njobs < 1) {
            snprintf(error, esize, "the master answered %s without the job",
                     proto_type_name(reply.type));
            proto_msg_free(&reply);
            return -1;
        }
        proto_job_info_t j = reply.status_reply.jobs[0];
        int state = (int)j.state;
        snprintf(error, esize, "%s", j.error ? j.error : "");
        *last = j;
        last->name = NULL;
        last->error = NULL;
        /* The accuracy so far, after the rate: whole passes merged and the error estimate. */
        char extra[160] = "";
        if (j.spp > 0 && j.has_rel_error)
            snprintf(extra, sizeof extra, "%u spp, rel. error %.4f%s", j.spp, j.rel_error,
                     error_estimate_note(j.rel_error));
        else if (j.spp > 0)
            snprintf(extra, sizeof extra, "%u spp", j.spp);
        prog.extra = extra;
        /* A remote job's cap, unknown to this client: samples_total / pixels, with pixels at
         * most samples_done / spp (tiles of the next pass may be merged already), so each
         * poll's figure is a lower bound that meets the cap at a pass boundary; the largest
         * seen is kept. (Adaptive sampling leaves pixels with fewer samples, so there it may
         * overshoot: the prediction is then capped later, by the job's own end.) */
        if (target > 0.0 && spp_cap <= 0 && j.spp > 0 && j.samples_done > 0) {
            double cap = (double)j.samples_total * j.spp / (double)j.samples_done;
            if (cap > prog.spp_cap && cap < 1e9)
                prog.spp_cap = (int)(cap + 0.5);
        }
        double now = clock_now_s();
        bool photons_running = j.photons_total > 0 && j.photons_done < j.photons_total &&
                               (state == JOB_RUNNING || state == JOB_QUEUED);
        if (photons_running && !phot_shown) {
            phot_shown = true;
            phot_base = j.photons_done;
            phot_t0 = now;
        }
        if (phot_shown && !phot_closed && j.photons_total > phot_base) {
            char pextra[96];
            snprintf(pextra, sizeof pextra, "%" PRIu64 " of %" PRIu64 " photons", j.photons_done,
                     j.photons_total);
            phot.extra = pextra;
            progress_update(&phot, j.photons_done - phot_base, j.photons_total - phot_base,
                            now - phot_t0);
            phot.extra = NULL;
            if (!photons_running) { /* the line is closed: the camera phase's clock starts */
                phot_closed = true;
                t0 = now;
            }
        }
        if (state != JOB_FAILED && j.error && *j.error) {
            if (!*waiting && !quiet) {
                if (prog.open_line)
                    fputc('\n', stderr);
                prog.open_line = 0;
                fprintf(stderr, "prismfarm: job %" PRIu64 ": %s\n", j.id, j.error);
            }
            snprintf(waiting, sizeof waiting, "%s", j.error);
        } else {
            waiting[0] = 0;
        }
        if (j.spp > 0 && j.has_rel_error) /* on this client's clock, as the line's elapsed */
            progress_note_error(&prog, (int)j.spp, now - t0, j.rel_error);
        if (j.samples_total && !photons_running)
            progress_update(&prog, j.samples_done, j.samples_total, now - t0);
        if (state == JOB_DONE && j.stop != PROTO_STOP_NONE)
            progress_end(&prog, j.samples_done, j.samples_total, clock_now_s() - t0,
                         stopping_reason((stopping_why_t)j.stop));
        if (state == JOB_DONE && prediction && psize)
            progress_prediction_line(
                &prog, j.stop == PROTO_STOP_TARGET || (j.has_rel_error && j.rel_error <= target),
                (int)j.spp, clock_now_s() - t0, prediction, psize);
        prog.extra = NULL;
        proto_msg_free(&reply);
        if (state == JOB_DONE || state == JOB_FAILED || state == JOB_CANCELLED)
            return state;
        /* A master that answered early with the job still running (one that holds too many
         * long polls, or ignores `wait`) is asked again only after the wait. */
        double left = wait_ms / 1000.0 - (clock_now_s() - asked);
        if (left > 0) {
            struct timespec ts = {(time_t)left, (long)((left - (double)(time_t)left) * 1e9)};
            nanosleep(&ts, NULL);
        }
    }
}

int job_follow_check_outputs(const char *exr, const char *png, const char *cmd)
{
    err_t err;
    if ((exr && files_check_output(exr, &err) < 0) || (png && files_check_output(png, &err) < 0)) {
        fprintf(stderr, "prismfarm %s: %s\n", cmd, err.msg);
        return 2;
    }
    return 0;
}

int job_follow_fetch_outputs(client_rpc_t *rpc, uint64_t job, const char *exr, const char *png,
                             const char *cmd)
{
    if (job_follow_fetch(rpc, job, PROTO_FETCH_EXR, exr, cmd) ||
        job_follow_fetch(rpc, job, PROTO_FETCH_PNG, png, cmd))
        return 1;
    err_t err;
    if (film_stokes_previews_from_exr(exr, png, &err)) {
        fprintf(stderr, "prismfarm %s: %s\n", cmd, err.msg);
        return 1;
    }
    return 0;
}

int job_follow_fetch(client_rpc_t *rpc, uint64_t job, proto_fetch_what_t what, const char *path,
                     const char *cmd)
{
    proto_msg_t req = {.type = PROTO_FETCH, .fetch = {.job = job, .what = what}}, reply;
    err_t err;
    if (client_rpc_call(rpc, &req, &reply, 60000, &err)) {
        fprintf(stderr, "prismfarm %s: %s\n", cmd, err.msg);
        return 1;
    }
    if (reply.type != PROTO_FILE) {
        fprintf(stderr, "prismfarm %s: the master answered %s, not FILE\n", cmd,
                proto_type_name(reply.type));
        proto_msg_free(&reply);
        return 1;
    }
    int ok = files_write_atomic(path, reply.file.data, reply.file.size, true, &err) == 0;
    if (!ok)
        fprintf(stderr, "prismfarm %s: cannot write %s: %s\n", cmd, path, err.msg);
    proto_msg_free(&reply);
    return ok ? 0 : 1;
}

int job_follow_frame_paths(const proto_job_info_t *f, const char *pattern, char *exr,
                           size_t exr_size, char *png, size_t png_size, err_t *err)
{
    if (pattern) {
        if (frame_pattern_format(pattern, f->frame, exr, exr_size, err) < 0)
            return -1;
    } else {
        const char *name = f->name ? f->name : "frame";
        const char *base = strrchr(name, '/');
        base = base ? base + 1 : name;
        size_t n = strlen(base);
        if (n > 5 && !strcmp(base + n - 5, ".pbrt"))
            n -= 5;
        if ((size_t)snprintf(exr, exr_size, "%.*s.exr", (int)n, base) >= exr_size)
            return err_set(err, "frame %u: its output name is too long", f->frame);
    }
    film_png_path(exr, png, png_size);
    return 0;
}

int job_follow_fetch_frames(client_rpc_t *rpc, const proto_job_info_t *jobs, size_t n,
                            const char *pattern, int quiet, const char *cmd)
{
    err_t err;
    if (pattern && frame_pattern_check(pattern, &err) < 0) {
        fprintf(stderr, "prismfarm %s: -o for a sequence of frames: %s\n", cmd, err.msg);
        return 2;
    }
    if (n < 1 || jobs[0].frames == 0) {
        fprintf(stderr, "prismfarm %s: job %llu is not a frame sequence\n", cmd,
                n ? (unsigned long long)jobs[0].id : 0ULL);
        return 1;
    }
    if (n - 1 != jobs[0].frames) {
        fprintf(stderr, "prismfarm %s: job %llu has %u frames, the master listed %zu\n", cmd,
                (unsigned long long)jobs[0].id, jobs[0].frames, n - 1);
        return 1;
    }
    char exr[4096], png[4200];
    for (size_t i = 1; i < n; i++) {
        if (job_follow_frame_paths(&jobs[i], pattern, exr, sizeof exr, png, sizeof png, &err) < 0) {
            fprintf(stderr, "prismfarm %s: %s\n", cmd, err.msg);
            return 2;
        }
        int bad = job_follow_check_outputs(exr, png, cmd);
        if (bad)
            return bad;
        if (jobs[i].state != JOB_DONE) {
            fprintf(stderr, "prismfarm %s: frame %u (job %llu) is %s%s%s: nothing fetched\n", cmd,
                    jobs[i].frame, (unsigned long long)jobs[i].id,
                    proto_job_state_name(jobs[i].state), jobs[i].error ? ": " : "",
                    jobs[i].error ? jobs[i].error : "");
            return 1;
        }
    }
    for (size_t i = 1; i < n; i++) {
        (void)job_follow_frame_paths(&jobs[i], pattern, exr, sizeof exr, png, sizeof png, &err);
        if (job_follow_fetch_outputs(rpc, jobs[i].id, exr, png, cmd))
            return 1;
        if (!quiet)
            printf("frame %u: wrote %s and %s\n", jobs[i].frame, exr, png);
    }
    return 0;
}
