/* local_farm: the farm in one process -- a master, N workers and a client over inproc://
 * sockets on one ZeroMQ context -- so `prismfarm render` runs exactly the code a farm runs:
 * bundling, scheduling, progressive passes, merging and outputs. */
#ifndef PRISMFARM_LOCAL_FARM_H
#define PRISMFARM_LOCAL_FARM_H

#include "proto.h"
#include "scene_load.h"

typedef struct local_farm_opts {
    const char *scene;    /* the scene file */
    const char *name;     /* job name */
    const char *exr_path; /* where the fetched EXR goes */
    const char *png_path; /* where the master's PNG preview goes; NULL: not fetched */
    scene_overrides_t overrides;
    int workers;          /* >= 1 */
    int threads;          /* render threads per worker, >= 1 */
    int tile;             /* tile size; 0: the scheduler's default */
    const char *spool;    /* NULL: a temporary folder, removed afterwards */
    int quiet;
    double target_error;  /* the job's stopping rules (proto_settings_t); 0: none */
    double time_limit;
} local_farm_opts_t;

/* Renders the scene and writes the EXR (and the master's PNG when png_path is set). Returns 0 with the finished job's counters and accuracy
 * in *info (name and error cleared), or 1 with a message on stderr. */
int local_farm_run(const local_farm_opts_t *opts, proto_job_info_t *info);

#endif
