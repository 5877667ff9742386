/* prismfarm local: the whole farm in one process -- a master, N workers and a client talking
 * over inproc:// sockets -- so that a scene renders through exactly the code a farm runs:
 * bundling, scheduling, progressive passes, merging and outputs. */
#include "commands.h"

#include "client_rpc.h"
#include "film.h"
#include "job_follow.h"
#include "local_render.h"
#include "master.h"
#include "scene_bundle.h"
#include "worker_daemon.h"

#include <errno.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zmq.h>

#define MAX_LOCAL_WORKERS 64

static void usage(FILE *out)
{
    fprintf(out,
            "usage: prismfarm local SCENE.pbrt [options]\n"
            "\n"
            "Runs a master and workers in this process and renders SCENE through them, exactly as\n"
            "a farm would; writes the spectral EXR and the PNG preview.\n"
            "  -o, --output OUT.exr   output (default: SCENE's name .exr in the current folder)\n"
            "  --workers N            worker count (default 2)\n"
            "  --threads N            render threads per worker (default: cores / workers, at least 1)\n"
            "  --spool DIR            the master's spool folder (default: a fresh temporary folder)\n"
            "  --spp N, --res WxH, --seed N, --integrator NAME, --dispersion NAME, --tile N\n"
            "                         as for prismfarm render; --tile sets the tile size (default 32)\n"
            "  --quiet                no progress output\n");
}

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

static int parse_int(const char *flag, const char *s, long long lo, long long hi, long long *out)
{
    char *end;
    errno = 0;
    long long v = strtoll(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi) {
        fprintf(stderr, "prismfarm local: %s expects an integer in %lld..%lld, got '%s'\n", flag, lo, hi, s);
        return -1;
    }
    *out = v;
    return 0;
}

int cmd_local(int argc, char **argv)
{
    const char *scene = NULL, *output = NULL, *spool = NULL;
    scene_overrides_t ov = {.seed = -1};
    long long nworkers = 2, threads = 0, tile = 0, v;
    int quiet = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            usage(stdout);
            return 0;
        }
        if (!strcmp(a, "--quiet")) {
            quiet = 1;
            continue;
        }
        if (a[0] == '-') {
            if (i + 1 >= argc) {
                fprintf(stderr, "prismfarm local: %s needs a value\n", a);
                return 2;
            }
            const char *val = argv[++i];
            if (!strcmp(a, "-o") || !strcmp(a, "--output"))
                output = val;
            else if (!strcmp(a, "--spool"))
                spool = val;
            else if (!strcmp(a, "--workers")) {
                if (parse_int(a, val, 1, MAX_LOCAL_WORKERS, &nworkers))
                    return 2;
            } else if (!strcmp(a, "--threads")) {
                if (parse_int(a, val, 1, 1024, &threads))
                    return 2;
            } else if (!strcmp(a, "--tile")) {
                if (parse_int(a, val, 1, 4096, &tile))
                    return 2;
            } else if (!strcmp(a, "--spp")) {
                if (parse_int(a, val, 1, 1 << 24, &v))
                    return 2;
                ov.spp = (int)v;
            } else if (!strcmp(a, "--seed")) {
                if (parse_int(a, val, 0, 4294967295LL, &v))
                    return 2;
                ov.seed = v;
            } else if (!strcmp(a, "--res")) {
                int w, h;
                char extra;
                if (sscanf(val, "%dx%d%c", &w, &h, &extra) != 2 || w < 1 || h < 1 || w > 32768 || h > 32768) {
                    fprintf(stderr, "prismfarm local: --res expects WxH with 1..32768 each, got '%s'\n", val);
                    return 2;
                }
                ov.xres = w;
                ov.yres = h;
            } else if (!strcmp(a, "--integrator")) {
                if (strcmp(val, "path") && strcmp(val, "simplepath") && strcmp(val, "whitted")) {
                    fprintf(stderr, "prismfarm local: --integrator expects path, simplepath or whitted, got '%s'\n", val);
                    return 2;
                }
                ov.integrator = val;
            } else if (!strcmp(a, "--dispersion")) {
                if (strcmp(val, "hero") && strcmp(val, "fanout")) {
                    fprintf(stderr, "prismfarm local: --dispersion expects hero or fanout, got '%s'\n", val);
                    return 2;
                }
                ov.dispersion = val;
            } else {
                fprintf(stderr, "prismfarm local: unknown option '%s' (see prismfarm local --help)\n", a);
                return 2;
            }
            continue;
        }
        if (scene) {
            fprintf(stderr, "prismfarm local: more than one scene given ('%s' and '%s')\n", scene, a);
            return 2;
        }
        scene = a;
    }
    if (!scene) {
        usage(stderr);
        return 2;
    }
    if (threads == 0)
        threads = local_render_cores() / nworkers > 0 ? local_render_cores() / nworkers : 1;

    char name[256], exr[4096], png[4200], spool_buf[512];
    const char *base = strrchr(scene, '/');
    base = base ? base + 1 : scene;
    size_t n = strlen(base);
    if (n > 5 && !strcmp(base + n - 5, ".pbrt"))
        n -= 5;
    snprintf(name, sizeof name, "%.*s", (int)n, base);
    if (output)
        snprintf(exr, sizeof exr, "%s", output);
    else
        snprintf(exr, sizeof exr, "%s.exr", name);
    film_png_path(exr, png, sizeof png);

    err_t err;
    scene_bundle_t *bundle = scene_bundle_new(scene, &err);
    if (!bundle) {
        fprintf(stderr, "prismfarm local: %s\n", err.msg);
        return 1;
    }
    int made_spool = 0;
    if (!spool) {
        snprintf(spool_buf, sizeof spool_buf, "%s/prismfarm-local-XXXXXX", getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp");
        if (!mkdtemp(spool_buf)) {
            fprintf(stderr, "prismfarm local: cannot create a spool folder: %s\n", strerror(errno));
            scene_bundle_destroy(&bundle);
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
    local_master_t m = {.opts = master_opts_default()};
    m.opts.worker_endpoint = wep;
    m.opts.client_endpoint = cep;
    m.opts.spool_dir = spool;
    m.opts.zmq_ctx = ctx;
    m.opts.stop = &stop_master;
    m.opts.verbose = 0;
    if (tile)
        m.opts.sched.tile_size = (int)tile;
    local_worker_t *workers = calloc((size_t)nworkers, sizeof *workers);
    int rc = 0, master_started = 0, nstarted = 0;
    client_rpc_t *rpc = NULL;
    if (!ctx || !workers) {
        fprintf(stderr, "prismfarm local: cannot set up ZeroMQ\n");
        rc = 1;
        goto out;
    }
    if (pthread_create(&m.thread, NULL, run_master, &m) != 0) {
        fprintf(stderr, "prismfarm local: cannot start the master thread\n");
        rc = 1;
        goto out;
    }
    master_started = 1;
    for (; nstarted < nworkers; nstarted++) {
        local_worker_t *w = &workers[nstarted];
        snprintf(w->name, sizeof w->name, "local-%d", nstarted + 1);
        snprintf(w->cache, sizeof w->cache, "%s/worker-cache-%d", spool, nstarted + 1);
        w->opts = (worker_opts_t){.endpoint = wep, .zmq_ctx = ctx, .threads = (int)threads, .name = w->name,
                                  .cache_dir = w->cache, .stop = &stop_workers, .reconnect_max_ms = 1000};
        if (pthread_create(&w->thread, NULL, run_worker, w) != 0)
            break;
    }
    if (!quiet)
        fprintf(stderr, "local: master and %d workers x %lld threads in this process, spool %s\n", nstarted,
                threads, spool);
    rpc = client_rpc_new(cep, ctx, &err);
    proto_msg_t req = {.type = PROTO_SUBMIT,
                       .submit = {.name = name, .settings = proto_settings_from_overrides(&ov),
                                  .bundle = *scene_bundle_get(bundle)}};
    proto_msg_t reply;
    if (!rpc || client_rpc_call(rpc, &req, &reply, 60000, &err)) {
        fprintf(stderr, "prismfarm local: %s\n", err.msg);
        rc = 1;
        goto out;
    }
    uint64_t job = reply.type == PROTO_SUBMITTED ? reply.submitted.job : 0;
    proto_msg_free(&reply);
    proto_job_info_t last;
    char error[600];
    int state = job_follow_wait(rpc, job, quiet, &last, error, sizeof error);
    if (state != PROTO_JOB_DONE) {
        fprintf(stderr, "prismfarm local: job %s%s%s\n",
                state < 0 ? "lost" : proto_job_state_name((proto_job_state_t)state), error[0] ? ": " : "", error);
        rc = 1;
        goto out;
    }
    if (job_follow_fetch(rpc, job, PROTO_FETCH_EXR, exr, "local") ||
        job_follow_fetch(rpc, job, PROTO_FETCH_PNG, png, "local")) {
        rc = 1;
        goto out;
    }
    printf("wrote %s (spectral) and %s in %.1f s with %d workers; %llu non-finite samples discarded\n", exr, png,
           last.elapsed, nstarted, (unsigned long long)last.nonfinite);
out:
    client_rpc_destroy(&rpc);
    /* Workers first, so that none is left talking to a master that has gone. */
    stop_workers = 1;
    for (int i = 0; i < nstarted; i++) {
        pthread_join(workers[i].thread, NULL);
        if (workers[i].rc && !rc)
            fprintf(stderr, "prismfarm local: worker %d: %s\n", i + 1, workers[i].err.msg);
    }
    stop_master = 1;
    if (master_started) {
        pthread_join(m.thread, NULL);
        if (m.rc) {
            fprintf(stderr, "prismfarm local: master: %s\n", m.err.msg);
            rc = 1;
        }
    }
    free(workers);
    if (ctx)
        zmq_ctx_term(ctx);
    if (made_spool) {
        /* Outputs were copied out; the temporary spool goes. */
        char cmd[700];
        snprintf(cmd, sizeof cmd, "rm -rf '%s'", spool);
        if (system(cmd) != 0)
            fprintf(stderr, "prismfarm local: could not remove %s\n", spool);
    }
    scene_bundle_destroy(&bundle);
    return rc;
}
