#define _XOPEN_SOURCE 700 /* nftw */
#include "local_farm.h"

#include "bundle.h"
#include "client_rpc.h"
#include "progress.h"
#include "job_follow.h"
#include "master.h"
#include "scene_bundle.h"
#include "settings.h"
#include "worker_daemon.h"

#include <errno.h>
#include <ftw.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <zmq.h>

typedef struct local_worker {
    pthread_t thread;
    worker_opts_t opts;
    char name[32], cache[600];
    int rc;
    err_t err;
} local_worker_t;

typedef struct local_master {
    pthread_t thread;
    master_opts_t opts;
    int rc;
    err_t err;
} local_master_t;

static void *run_master(void *arg)
{
    local_master_t *m = arg;
    m->rc = master_run(&m->opts, &m->err);
    return NULL;
}

static void *run_worker(void *arg)
{
    local_worker_t *w = arg;
    w->rc = worker_run(&w->opts, &w->err);
    return NULL;
}

static int remove_entry(const char *path, const struct stat *st, int type, struct FTW *ftw)
{
    (void)st;
    (void)ftw;
    int rc = type == FTW_DP ? rmdir(path) : unlink(path);
    if (rc != 0)
        fprintf(stderr, "prismfarm render: cannot remove %s: %s\n", path, strerror(errno));
    return 0; /* remove what can be removed */
}

/* Removes a folder and everything in it, without following symbolic links (FTW_PHYS) and
 * without leaving its file system (FTW_MOUNT); children before their folder (FTW_DEPTH). */
static int remove_tree(const char *dir)
{
    return nftw(dir, remove_entry, 16, FTW_DEPTH | FTW_PHYS | FTW_MOUNT);
}

/* Each frame of a finished sequence to its outputs (job_follow_fetch_frames). */
static int fetch_frames(client_rpc_t *rpc, uint64_t job, const char *pattern, int quiet)
{
    proto_msg_t req = {.type = PROTO_STATUS, .status = {.job = job}}, reply;
    err_t err;
    if (client_rpc_call(rpc, &req, &reply, 60000, &err)) {
        fprintf(stderr, "prismfarm render: %s\n", err.msg);
        return 1;
    }
    int rc = reply.type == PROTO_STATUS_REPLY
                 ? job_follow_fetch_frames(rpc, reply.status_reply.jobs, reply.status_reply.njobs,
                                           pattern, quiet, "render")
                 : 1;
    if (reply.type != PROTO_STATUS_REPLY)
        fprintf(stderr, "prismfarm render: the master answered %s\n", proto_type_name(reply.type));
    proto_msg_free(&reply);
    return rc;
}

int local_farm_run(const local_farm_opts_t *o, proto_job_info_t *info, scene_shelf_stats_t *loads)
{
    const char *scene = o->scene, *spool = o->spool, *name = o->name;
    const long long nworkers = o->workers, threads = o->threads, tile = o->tile;
    const int quiet = o->quiet;
    char spool_buf[512];
    err_t err;
    scene_bundle_t *bundle = o->nframes ? scene_bundle_new_frames(o->frames, o->nframes, &err)
                                        : scene_bundle_new(scene, &err);
    proto_frame_t *frames = bundle && o->nframes ? calloc(o->nframes, sizeof *frames) : NULL;
    for (size_t k = 0; frames && k < o->nframes; k++)
        frames[k] = (proto_frame_t){.main = scene_bundle_frame_main(bundle, k), .number = o->numbers[k]};
    if (bundle && o->nframes && !frames) {
        err_set(&err, "out of memory");
        scene_bundle_destroy(&bundle);
    }
    if (!bundle) {
        fprintf(stderr, "prismfarm render: %s\n", err.msg);
        return 1;
    }
    const proto_settings_t settings = o->settings;
    /* The client's scene on the shelf under the key the master and workers will ask for: the
     * bundle's hash and main file (what they load it from) and the settings the SUBMIT
     * carries. */
    char hash[PROTO_HASH_HEX + 1], key[SETTINGS_KEY_SIZE];
    scene_shelf_t *shelf = scene_shelf_new(&err);
    int shared = shelf && proto_bundle_hash(scene_bundle_get(bundle), hash, &err) == 0;
    if (shared) {
        settings_scene_key(hash, scene_bundle_get(bundle)->main, &settings, key);
        shared = !o->loaded || o->nframes || scene_shelf_put(shelf, key, o->loaded, &err) == 0;
    }
    if (!shared) {
        fprintf(stderr, "prismfarm render: %s\n", err.msg);
        scene_shelf_destroy(&shelf);
        scene_bundle_destroy(&bundle);
        free(frames);
        return 1;
    }
    int made_spool = 0;
    if (!spool) {
        snprintf(spool_buf, sizeof spool_buf, "%s/prismfarm-local-XXXXXX", getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp");
        if (!mkdtemp(spool_buf)) {
            fprintf(stderr, "prismfarm render: cannot create a spool folder: %s\n", strerror(errno));
            scene_bundle_destroy(&bundle);
            scene_shelf_destroy(&shelf);
            free(frames);
            return 1;
        }
        spool = spool_buf;
        made_spool = 1;
    }

    /* inproc endpoints are private to this context; the pid keeps them unique in logs. */
    char wep[64], cep[64];
    snprintf(wep, sizeof wep, "inproc://local-workers-%ld", (long)getpid());
    snprintf(cep, sizeof cep, "inproc://local-clients-%ld", (long)getpid());
    void *ctx = zmq_ctx_new();
    volatile sig_atomic_t stop_master = 0, stop_workers = 0;
    /* Written to when the farm stops: the master's and workers' loops poll its read end, so
     * they end at once instead of at their next poll timeout. */
    int stop_pipe[2] = {-1, -1};
    if (pipe(stop_pipe) != 0) {
        fprintf(stderr, "prismfarm render: cannot create a pipe: %s\n", strerror(errno));
        stop_pipe[0] = stop_pipe[1] = -1;
    }
    local_master_t m = {.opts = master_opts_default()};
    m.opts.worker_endpoint = wep;
    m.opts.client_endpoint = cep;
    m.opts.spool_dir = spool;
    m.opts.zmq_ctx = ctx;
    m.opts.stop = &stop_master;
    m.opts.stop_fd = stop_pipe[0] > 0 ? stop_pipe[0] : 0;
    m.opts.verbose = 0;
    m.opts.journal = 0; /* the spool is a temporary folder that dies with this process */
    m.opts.wait_for_space = 0; /* the user waits for this command: a failed write ends it */
    /* The user's own scene on the user's own machine: no budget (security.md, "Limits"). */
    m.opts.budget = (scene_budget_t){0};
    m.opts.shelf = shelf;
    if (tile)
        m.opts.sched.tile_size = (int)tile;
    local_worker_t *workers = calloc((size_t)nworkers, sizeof *workers);
    int rc = 0, master_started = 0, nstarted = 0;
    client_rpc_t *rpc = NULL;
    if (!ctx || !workers) {
        fprintf(stderr, "prismfarm render: cannot set up ZeroMQ\n");
        rc = 1;
        goto out;
    }
    if (pthread_create(&m.thread, NULL, run_master, &m) != 0) {
        fprintf(stderr, "prismfarm render: cannot start the master thread\n");
        rc = 1;
        goto out;
    }
    master_started = 1;
    for (; nstarted < nworkers; nstarted++) {
        local_worker_t *w = &workers[nstarted];
        snprintf(w->name, sizeof w->name, "local-%d", nstarted + 1);
        snprintf(w->cache, sizeof w->cache, "%s/worker-cache-%d", spool, nstarted + 1);
        w->opts = (worker_opts_t){.endpoint = wep, .zmq_ctx = ctx, .threads = (int)threads, .name = w->name,
                                  .cache_dir = w->cache, .stop = &stop_workers,
                                  .stop_fd = stop_pipe[0] > 0 ? stop_pipe[0] : 0,
                                  .reconnect_max_ms = 1000, .shelf = shelf};
        if (pthread_create(&w->thread, NULL, run_worker, w) != 0)
            break;
    }
    if (!quiet)
        fprintf(stderr, "render: a master and %d worker%s x %lld thread%s in this process\n",
                nstarted, nstarted == 1 ? "" : "s", threads, threads == 1 ? "" : "s");
    rpc = client_rpc_new(cep, ctx, NULL, &err);
    if (rpc && !quiet)
        client_rpc_on_progress(rpc, progress_print_master, "render");
    proto_msg_t req = {.type = PROTO_SUBMIT,
                       .submit = {.name = name, .settings = settings,
                                  .bundle = *scene_bundle_get(bundle),
                                  .frames = frames, .nframes = o->nframes}};
    proto_msg_t reply;
    if (!rpc || client_rpc_call(rpc, &req, &reply, 60000, &err)) {
        fprintf(stderr, "prismfarm render: %s\n", err.msg);
        rc = 1;
        goto out;
    }
    uint64_t job = reply.type == PROTO_SUBMITTED ? reply.submitted.job : 0;
    proto_msg_free(&reply);
    char error[600];
    int state = job_follow_wait_error(rpc, job, quiet, o->settings.target_error,
                                      o->loaded ? o->loaded->settings.spp : 0, info, error,
                                      sizeof error, o->prediction, o->prediction_size);
    if (state != JOB_DONE) {
        fprintf(stderr, "prismfarm render: job %s%s%s\n",
                state < 0 ? "lost" : proto_job_state_name((job_state_t)state), error[0] ? ": " : "", error);
        rc = 1;
        goto out;
    }
    if (o->nframes) {
        /* The lines naming each frame's files are the command's result, not progress. */
        rc = fetch_frames(rpc, job, o->frame_pattern, 0);
        goto out;
    }
    if (job_follow_fetch(rpc, job, PROTO_FETCH_EXR, o->exr_path, "render") ||
        (o->png_path && job_follow_fetch(rpc, job, PROTO_FETCH_PNG, o->png_path, "render"))) {
        rc = 1;
        goto out;
    }
out:
    client_rpc_destroy(&rpc);
    /* Master and workers stop together: nothing is left to render or to answer, and a
     * worker's last messages to a master that has gone are simply dropped with its socket. */
    stop_workers = 1;
    stop_master = 1;
    if (stop_pipe[1] >= 0 && write(stop_pipe[1], "", 1) != 1)
        fprintf(stderr, "prismfarm render: cannot wake the farm's threads: %s\n", strerror(errno));
    for (int i = 0; i < nstarted; i++) {
        pthread_join(workers[i].thread, NULL);
        if (workers[i].rc && !rc)
            fprintf(stderr, "prismfarm render: worker %d: %s\n", i + 1, workers[i].err.msg);
    }
    if (master_started) {
        pthread_join(m.thread, NULL);
        if (m.rc) {
            fprintf(stderr, "prismfarm render: master: %s\n", m.err.msg);
            rc = 1;
        }
    }
    free(workers);
    if (ctx && zmq_ctx_term(ctx) != 0)
        fprintf(stderr, "prismfarm render: zmq_ctx_term: %s\n", zmq_strerror(zmq_errno()));
    for (int i = 0; i < 2; i++)
        if (stop_pipe[i] >= 0)
            close(stop_pipe[i]);
    /* Outputs were copied out; the temporary spool goes. */
    if (made_spool && remove_tree(spool) != 0)
        fprintf(stderr, "prismfarm render: could not remove %s: %s\n", spool, strerror(errno));
    scene_bundle_destroy(&bundle);
    free(frames);
    /* Every party is gone: the counts are final. */
    scene_shelf_stats_t st = scene_shelf_stats(shelf);
    scene_shelf_destroy(&shelf);
    if (loads)
        *loads = st;
    if (!quiet)
        fprintf(stderr, "render: the scene was loaded %llu time%s in this process and shared %llu "
                        "time%s by its master and workers\n",
                (unsigned long long)st.loads, st.loads == 1 ? "" : "s",
                (unsigned long long)st.shares, st.shares == 1 ? "" : "s");
    return rc;
}
