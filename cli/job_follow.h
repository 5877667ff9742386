/* job_follow: what `submit --wait` and `local` do after submitting: follow a job's progress
 * until it ends, and download its outputs. */
#ifndef PRISMFARM_JOB_FOLLOW_H
#define PRISMFARM_JOB_FOLLOW_H

#include "client_rpc.h"

/* Follows the job's status with STATUS long polls (answered the moment the job ends), showing
 * progress on stderr unless quiet (with the spp merged and the error estimate), until it is
 * done, failed or cancelled. A master that stops answering (a restart) is asked again on a
 * fresh connection for up to 2 minutes. Returns the job's final job_state_t, or -1 when
 * the master did not come back or the job is gone; *last gets the final counters and accuracy (name and error cleared), error the
 * job's or the lost master's message. */
int job_follow_wait(client_rpc_t *rpc, uint64_t job, int quiet, proto_job_info_t *last,
                    char *error, size_t esize);

/* job_follow_wait for a job with a target error: the progress line follows the error
 * (progress_follow_error) from its first estimate on. spp_cap is the job's spp, or 0 when the
 * caller does not know it (a remote master's job: then it is read off the job's own counters,
 * samples_total x spp / samples_done at a pass boundary). When the job is done and prediction
 * is not NULL, it gets progress_prediction_line's text, or "" when no prediction was made. */
int job_follow_wait_error(client_rpc_t *rpc, uint64_t job, int quiet, double target, int spp_cap,
                          proto_job_info_t *last, char *error, size_t esize, char *prediction,
                          size_t psize);

/* Checks, before anything is submitted, rendered or fetched, that the outputs exr and png (NULL:
 * none) can be written (files_check_output: a regular file or nothing there yet, in a folder
 * that exists and is writable). Returns 0, or 2 (a bad command line) with the reason on stderr
 * prefixed by "prismfarm CMD: ". */
int job_follow_check_outputs(const char *exr, const char *png, const char *cmd);

/* Downloads one output of a job into path (written beside it and renamed). Returns 0, or 1
 * with a message on stderr prefixed by "prismfarm CMD: ". */
int job_follow_fetch(client_rpc_t *rpc, uint64_t job, proto_fetch_what_t what, const char *path,
                     const char *cmd);

/* Where frame f of a sequence goes: pattern (frame_pattern.h) with its number, else the frame
 * file's name without ".pbrt" and with ".exr" (in the current folder); the PNG beside it. 0, or
 * -1 with err. */
int job_follow_frame_paths(const proto_job_info_t *f, const char *pattern, char *exr,
                           size_t exr_size, char *png, size_t png_size, err_t *err);

/* Downloads a job's EXR and PNG (job_follow_fetch) and writes, for a Stokes output, the
 * polarisation previews beside the PNG from the EXR (film_stokes_previews_from_exr), as
 * --direct writes them. Returns 0, or 1 with a message on stderr prefixed by "prismfarm CMD: ". */
int job_follow_fetch_outputs(client_rpc_t *rpc, uint64_t job, const char *exr, const char *png,
                             const char *cmd);

/* Downloads every frame of a sequence (jobs[0], its frames after it: a STATUS_REPLY of the
 * sequence) to job_follow_frame_paths's names, after checking that every one can be written;
 * a line per frame on stdout unless quiet. Returns 0, 1 (a frame not done, a failed download)
 * or 2 (a bad pattern or output), with a message on stderr prefixed by "prismfarm CMD: ". */
int job_follow_fetch_frames(client_rpc_t *rpc, const proto_job_info_t *jobs, size_t n,
                            const char *pattern, int quiet, const char *cmd);

#endif
