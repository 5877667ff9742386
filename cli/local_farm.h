/* local_farm: the farm in one process -- a master, N workers and a client over inproc://
 * sockets on one ZeroMQ context -- so `prismfarm render` runs exactly the code a farm runs:
 * bundling, scheduling, progressive passes, merging and outputs. The scene is loaded once in
 * the process: the client's copy is put on a scene shelf (scene_shelf.h) that the master and
 * the workers take it from under its bundle hash and settings, instead of loading it again. */
#ifndef PRISMFARM_LOCAL_FARM_H
#define PRISMFARM_LOCAL_FARM_H

#include "proto.h"
#include "scene_load.h"
#include "scene_shelf.h"

typedef struct local_farm_opts {
    const char *scene;    /* the scene file */
    const char *name;     /* job name */
    const char *exr_path; /* where the fetched EXR goes */
    const char *png_path; /* where the master's PNG preview goes; NULL: not fetched */
    proto_settings_t settings; /* the job's, as a SUBMIT carries them */
    int workers;       /* >= 1 */
    int threads;       /* render threads per worker, >= 1 */
    int tile;          /* tile size; 0: the scheduler's default */
    const char *spool; /* NULL: a temporary folder, removed afterwards */
    int quiet;
    /* The scene as the client loaded it (scene_load_file with overrides), shared with the
     * master and workers; NULL: they load it. */
    scene_t *loaded;
    /* A frame sequence (docs/farm.md, "Frame sequences"): nframes > 0 scene files of one
     * folder with their numbers, submitted as one job in one bundle, the master loading each
     * frame (scene and loaded are then unused); its outputs go to job_follow_frame_paths's
     * names with frame_pattern (NULL: each frame file's name), exr_path and png_path unused. */
    const char *const *frames;
    const uint32_t *numbers;
    size_t nframes;
    const char *frame_pattern;
    /* Out: with a target error, how close the progress line's first prediction came
     * (progress_prediction_line), or ""; NULL: not wanted. */
    char *prediction;
    size_t prediction_size;
} local_farm_opts_t;

/* Renders the scene and writes the EXR (and the master's PNG when png_path is set; a sequence:
 * each frame's EXR and PNG, and unless quiet a line per frame on stdout). Returns 0 with the
 * finished job's counters and accuracy in *info (name and error cleared), or 1 with a message on
 * stderr. Unless quiet, ends with "render: the scene was loaded N time(s) in this process and
 * shared M time(s) by its master and workers" (the shelf's counts, scene_shelf_stats_t), also given
 * in *loads when not NULL. */
int local_farm_run(const local_farm_opts_t *opts, proto_job_info_t *info,
                   scene_shelf_stats_t *loads);

#endif
