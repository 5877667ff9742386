#include "worker_daemon.h"

#include "bundle_cache.h"
#include "curve.h"
#include "clock.h"
#include "net.h"
#include "photon.h"
#include "pool.h"
#include "render.h"
#include "scene_cache.h"
#include "store_cache.h"
#include "task_queue.h"

#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include <zmq.h>

/* A master that says nothing while its connection stays up (libzmq's own heartbeats, answered
 * by its I/O thread, keep a live process's link up; a dead host's drops within 3 s) is busy,
 * not gone: its loop may be writing a large EXR or checkpoint. It is waited for this long. */
#define MASTER_BUSY_MAX_S 60.0

typedef struct worker {
    const worker_opts_t *opts;
    bundle_cache_t bundles;
    pthread_mutex_t lock;
    pthread_cond_t wake;
    task_queue_t tasks;
    scene_cache_t scenes;
    store_cache_t stores;
    unsigned generation;
    int quit;
    int wake_fd[2]; /* render threads write a byte here when a result is ready */
} worker_t;

static void logf_(const worker_t *w, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void logf_(const worker_t *w, const char *fmt, ...)
{
    if (!w->opts->verbose)
        return;
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "worker: ");
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
}

/* A task can run once its bundle is on disk and, for a tile that gathers from a photon store,
 * the store is here. Called with the lock held. */
static int task_ready(worker_t *w, const task_t *t)
{
    return bundle_cache_has(&w->bundles, t->hash) && (!t->store[0] || store_cache_find(&w->stores, t->store));
}

/* What arrived (a bundle or a photon store, by hash) and whether it was kept. */
struct arrival {
    worker_t *w;
    const char *hash;
    int kept;
};

/* The parked tasks to take when a bundle arrived: its tasks, unless kept and a tile's photon
 * store is still on its way (it stays parked). */
static bool wants_scene(const task_t *t, void *arg)
{
    const struct arrival *a = arg;
    return !(strcmp(t->hash, a->hash) != 0 || (a->kept && !task_ready(a->w, t)));
}

static bool wants_store(const task_t *t, void *arg)
{
    const struct arrival *a = arg;
    return !(strcmp(t->store, a->hash) != 0 || (a->kept && !task_ready(a->w, t)));
}

/* One of the pool's render threads (base/pool.h sets their floating-point mode). */
static void *render_thread(void *arg)
{
    worker_t *w = arg;
    pthread_mutex_lock(&w->lock);
    for (;;) {
        while (!w->quit && !w->tasks.ready)
            pthread_cond_wait(&w->wake, &w->lock);
        if (w->quit)
            break;
        task_t *t = task_queue_pop(&w->tasks);
        err_t err = {{0}};
        job_scene_t *js = task_queue_is_cancelled(&w->tasks, t->job) ? NULL : scene_cache_acquire(&w->scenes, t->job, t->hash, t->store, &t->settings, &err);
        if (js) {
            pthread_mutex_unlock(&w->lock);
            double t0 = clock_now_s();
            if (t->kind == PROTO_KIND_PHOTON_BATCH) {
                t->ok = photon_batch_run(js->scene, t->photons.first, t->photons.end,
                                         &t->photon_data, &t->photon_size, &t->pstats, &err) == 0;
            } else {
                const proto_tile_t *r = &t->tile;
                t->result = tilebuf_new(r->x0, r->y0, r->w, r->h, js->scene->settings.grid.n, &err);
                if (t->result && render_tile(js->scene, js->photons, r->x0, r->y0, r->w, r->h, r->sample_begin,
                                             r->sample_end, t->result, &t->stats, &err))
                    tilebuf_destroy(&t->result);
                t->ok = t->result != NULL;
            }
            t->elapsed = clock_now_s() - t0;
            pthread_mutex_lock(&w->lock);
            scene_cache_release(&w->scenes, js);
        }
        if (!t->ok)
            snprintf(t->error, sizeof t->error, "%s", err.msg[0] ? err.msg : "job cancelled");
        task_queue_finish(&w->tasks, t);
        /* Wake the network loop at once rather than at its next poll timeout. */
        char one = 1;
        if (write(w->wake_fd[1], &one, 1) < 0) {
            /* A full pipe already holds a wake-up: nothing is lost. */
        }
    }
    pthread_mutex_unlock(&w->lock);
    return NULL;
}

static int send_msg(worker_t *w, proto_net_t *net, const proto_msg_t *m)
{
    err_t err;
    int r = proto_net_send(net, NULL, m, &err);
    if (r)
        logf_(w, "sending %s failed: %s", proto_type_name(m->type), err.msg);
    return r;
}

int worker_run(const worker_opts_t *opts, err_t *err)
{
    worker_t w = {.opts = opts};
    if (!opts->endpoint)
        return err_set(err, "worker: no master endpoint");
    if (proto_curve_require(opts->endpoint, opts->curve.secret_key != NULL, opts->insecure,
                            "--key FILE and --master-key FILE.pub", err) < 0)
        return err_prefix(err, "worker: ");
    if (bundle_cache_open(&w.bundles, opts->cache_dir))
        return err_set(err, "worker: cannot create cache folder %s: %s", w.bundles.dir,
                       strerror(errno));
    int threads = opts->threads > 0 ? opts->threads : pool_cores();
    char name[256];
    if (opts->name)
        snprintf(name, sizeof name, "%s", opts->name);
    else {
        char host[200] = "host";
        gethostname(host, sizeof host - 1);
        snprintf(name, sizeof name, "%s:%ld", host, (long)getpid());
    }
    void *ctx = opts->zmq_ctx ? opts->zmq_ctx : zmq_ctx_new();
    if (!ctx)
        return err_set(err, "worker: zmq_ctx_new failed: %s", zmq_strerror(errno));
    if (pipe(w.wake_fd) != 0 || fcntl(w.wake_fd[0], F_SETFL, O_NONBLOCK) != 0 ||
        fcntl(w.wake_fd[1], F_SETFL, O_NONBLOCK) != 0) {
        if (!opts->zmq_ctx)
            zmq_ctx_term(ctx);
        return err_set(err, "worker: cannot create a pipe: %s", strerror(errno));
    }
    pthread_mutex_init(&w.lock, NULL);
    pthread_cond_init(&w.wake, NULL);
    scene_cache_init(&w.scenes, &w.lock, &w.wake, &w.bundles, &w.stores);
    err_t perr;
    pool_t *pool = pool_start(threads, render_thread, &w, &perr);
    int rc = 0;
    if (!pool) {
        rc = err_set(err, "worker: cannot start render threads: %s", perr.msg);
        goto out;
    }

    int heartbeat_ms = 1000, backoff_ms = 1000;
    int reconnect_max = opts->reconnect_max_ms > 0 ? opts->reconnect_max_ms : 32000;
    while (!*opts->stop && rc == 0) {
        /* One connection: HELLO, then serve until the master goes quiet. */
        /* No linger: when this connection is given up, its unsent HELLO must not reach a
         * master that comes up later, where it would show a second, ghost copy of us. */
        proto_net_options_t nopt = proto_net_options_default();
        nopt.linger_ms = 0;
        nopt.curve = opts->curve;
        proto_net_t *net = proto_net_new(ctx, PROTO_NET_DEALER, &nopt, err);
        if (!net || proto_net_connect(net, opts->endpoint, err)) {
            proto_net_destroy(&net);
            rc = -1;
            break;
        }
        pthread_mutex_lock(&w.lock);
        w.generation++;
        unsigned gen = w.generation;
        pthread_mutex_unlock(&w.lock);
        proto_msg_t hello = {.type = PROTO_HELLO,
                             .hello = {.name = name, .threads = pool_size(pool), .software = "prismfarm 0.1.0"}};
        send_msg(&w, net, &hello);
        logf_(&w, "connecting to %s as '%s' with %d threads", opts->endpoint, name, pool_size(pool));
        double last_heard = clock_now_s(), last_sent = clock_now_s();
        int welcomed = 0, busy_logged = 0;
        while (!*opts->stop) {
            proto_msg_t m;
            proto_peer_t from;
            err_t rerr;
            zmq_pollitem_t items[3] = {{.socket = proto_net_socket(net), .events = ZMQ_POLLIN},
                                       {.fd = w.wake_fd[0], .events = ZMQ_POLLIN},
                                       {.fd = opts->stop_fd, .events = ZMQ_POLLIN}};
            if (zmq_poll(items, opts->stop_fd > 0 ? 3 : 2, 50) > 0 &&
                (items[1].revents & ZMQ_POLLIN)) {
                char drain[64];
                while (read(w.wake_fd[0], drain, sizeof drain) > 0) {
                }
            }
            int r = proto_net_recv(net, &from, &m, 0, &rerr);
            double now = clock_now_s();
            if (r == 0) {
                last_heard = now;
                busy_logged = 0;
                switch (m.type) {
                case PROTO_WELCOME:
                    welcomed = 1;
                    backoff_ms = 1000;
                    if (m.welcome.heartbeat_ms >= 50 && m.welcome.heartbeat_ms <= 60000)
                        heartbeat_ms = (int)m.welcome.heartbeat_ms;
                    logf_(&w, "welcomed as worker %llu", (unsigned long long)m.welcome.worker_id);
                    break;
                case PROTO_TASK: {
                    task_t *t = task_new(&m, gen);
                    if (!t)
                        break;
                    pthread_mutex_lock(&w.lock);
                    /* a re-submitted id is a new job */
                    task_queue_uncancel(&w.tasks, t->job);
                    if (task_ready(&w, t)) {
                        task_queue_push(&w.tasks, t);
                        pthread_cond_broadcast(&w.wake);
                    } else {
                        /* Ask once for whatever is missing: parked tasks already waiting for
                         * the same bundle or store have asked. */
                        bool asked_scene, asked_store;
                        task_queue_park(&w.tasks, t, &asked_scene, &asked_store);
                        if (!asked_scene && !bundle_cache_has(&w.bundles, t->hash)) {
                            proto_msg_t req = {.type = PROTO_SCENE_REQUEST};
                            snprintf(req.scene_request.scene, sizeof req.scene_request.scene, "%s", t->hash);
                            send_msg(&w, net, &req);
                        }
                        if (!asked_store && t->store[0] && !store_cache_find(&w.stores, t->store)) {
                            proto_msg_t req = {.type = PROTO_STORE_REQUEST};
                            snprintf(req.store_request.store, sizeof req.store_request.store, "%s", t->store);
                            send_msg(&w, net, &req);
                        }
                    }
                    pthread_mutex_unlock(&w.lock);
                    break;
                }
                case PROTO_STORE: {
                    /* Keep the store (its hash was checked when the message was decoded), then
                     * start the tiles that waited for it. */
                    pthread_mutex_lock(&w.lock);
                    char dropped[PROTO_HASH_HEX + 1];
                    int kept = store_cache_put(&w.stores, m.store.store, m.store.data, m.store.size,
                                               dropped) == 0;
                    if (kept) {
                        if (dropped[0])
                            logf_(&w, "photon store %.12s dropped for %.12s", dropped, m.store.store);
                        logf_(&w, "photon store %.12s received (%zu bytes)", m.store.store, m.store.size);
                    } else {
                        logf_(&w, "no room for photon store %.12s: its tiles will fail and be re-sent",
                              m.store.store);
                    }
                    char why[sizeof ((task_t *)0)->error];
                    snprintf(why, sizeof why, "no room for photon store %.12s", m.store.store);
                    struct arrival a = {&w, m.store.store, kept};
                    task_queue_unpark(&w.tasks, wants_store, &a, kept ? NULL : why);
                    pthread_cond_broadcast(&w.wake);
                    pthread_mutex_unlock(&w.lock);
                    break;
                }
                case PROTO_SCENE: {
                    err_t serr;
                    int ok = bundle_cache_put(&w.bundles, m.scene.scene, &m.scene.bundle, &serr) == 0;
                    if (!ok)
                        logf_(&w, "scene %s rejected: %s", m.scene.scene, serr.msg);
                    pthread_mutex_lock(&w.lock);
                    char why[sizeof ((task_t *)0)->error];
                    snprintf(why, sizeof why, "scene bundle rejected: %s", ok ? "" : serr.msg);
                    struct arrival a = {&w, m.scene.scene, ok};
                    task_queue_unpark(&w.tasks, wants_scene, &a, ok ? NULL : why);
                    pthread_cond_broadcast(&w.wake);
                    pthread_mutex_unlock(&w.lock);
                    break;
                }
                case PROTO_CANCEL: {
                    pthread_mutex_lock(&w.lock);
                    task_queue_cancel(&w.tasks, m.cancel.job);
                    scene_cache_drop_job(&w.scenes, m.cancel.job);
                    pthread_mutex_unlock(&w.lock);
                    logf_(&w, "job %llu cancelled", (unsigned long long)m.cancel.job);
                    break;
                }
                case PROTO_REFUSE:
                    logf_(&w, "refused by the master: %s", m.refuse.reason);
                    if (strstr(m.refuse.reason, "protocol version")) {
                        rc = err_set(err, "worker: the master refused us: %s", m.refuse.reason);
                    } else {
                        /* Most likely the master restarted and forgot us: say HELLO again. */
                        send_msg(&w, net, &hello);
                    }
                    break;
                default:
                    break;
                }
                proto_msg_free(&m);
                if (rc)
                    break;
            } else if (r == PROTO_ESOCKET) {
                logf_(&w, "socket error: %s", rerr.msg);
                break;
            } else if (r != PROTO_EAGAIN) {
                logf_(&w, "ignored a bad message from the master: %s", rerr.msg);
            }

            /* Send what the render threads finished. */
            pthread_mutex_lock(&w.lock);
            task_t *done = task_queue_take_done(&w.tasks);
            pthread_mutex_unlock(&w.lock);
            while (done) {
                task_t *t = done;
                done = t->next;
                if (t->generation == gen && !task_queue_is_cancelled(&w.tasks, t->job)) {
                    proto_msg_t out;
                    if (t->ok && t->kind == PROTO_KIND_PHOTON_BATCH) {
                        out = (proto_msg_t){.type = PROTO_RESULT};
                        out.result.job = t->job;
                        out.result.task = t->id;
                        out.result.attempt = t->attempt;
                        out.result.kind = PROTO_KIND_PHOTON_BATCH;
                        out.result.photons = (proto_photon_result_t){
                            .range = t->photons, .emitted = t->pstats.emitted, .data = t->photon_data,
                            .size = t->photon_size, .nonfinite = t->pstats.nonfinite};
                        out.result.stats = (proto_task_stats_t){
                            .samples = t->photons.end - t->photons.first, .rays = t->pstats.rays,
                            .elapsed = t->elapsed};
                    } else if (t->ok) {
                        /* The pass's sums rounded by the one rule (tilebuf.h) that --direct
                         * applies too: float32 on the wire unless a value needs a double. */
                        tilebuf_t *b = t->result;
                        int bits = tilebuf_round_sums(b) == 0 ? 32 : 64;
                        out = (proto_msg_t){.type = PROTO_RESULT};
                        out.result.job = t->job;
                        out.result.task = t->id;
                        out.result.attempt = t->attempt;
                        out.result.kind = PROTO_KIND_CAMERA_TILE;
                        out.result.tile = (proto_tile_result_t){
                            .rect = t->tile, .nbuckets = tilebuf_nbuckets(b), .sums_bits = bits,
                            .sums = tilebuf_sums(b),
                            .counts = tilebuf_counts(b), .lum = tilebuf_luminance_sums(b),
                            .lum_sq = tilebuf_luminance_sq_sums(b), .nonfinite = tilebuf_nonfinite(b)};
                        out.result.stats = (proto_task_stats_t){.samples = t->stats.samples, .rays = t->stats.rays,
                                                                .dispersive = t->stats.dispersive,
                                                                .elapsed = t->elapsed};
                    } else {
                        out = (proto_msg_t){.type = PROTO_TASK_FAILED};
                        out.task_failed.job = t->job;
                        out.task_failed.task = t->id;
                        out.task_failed.attempt = t->attempt;
                        out.task_failed.error = t->error;
                    }
                    if (send_msg(&w, net, &out) == 0)
                        last_sent = now;
                }
                t->next = NULL;
                task_list_free(t);
            }

            if (now - last_sent >= heartbeat_ms / 1000.0) {
                proto_msg_t hb = {.type = PROTO_HEARTBEAT};
                send_msg(&w, net, &hb);
                last_sent = now;
            }
            if (now - last_heard > 3.0 * heartbeat_ms / 1000.0) {
                /* Why it never answered, when the handshake says: a refused key, CURVE on one
                 * side only. */
                char why[256];
                proto_net_link_t link = proto_net_link(net, why, sizeof why);
                if (welcomed && link == PROTO_NET_LINK_UP && now - last_heard < MASTER_BUSY_MAX_S) {
                    if (!busy_logged)
                        logf_(&w, "the master is silent but its connection is alive: it is busy, "
                                  "waiting for it (up to %.0f s)",
                              MASTER_BUSY_MAX_S);
                    busy_logged = 1;
                    continue;
                }
                logf_(&w, "the master is silent (%s%s%s); reconnecting in %d ms",
                      welcomed ? "was connected" : "never answered",
                      link == PROTO_NET_LINK_REFUSED ? ": it " : "",
                      link == PROTO_NET_LINK_REFUSED ? why : "", backoff_ms);
                break;
            }
        }
        proto_net_destroy(&net);
        /* Whatever this connection held is the master's to reassign now. */
        pthread_mutex_lock(&w.lock);
        task_queue_abandon(&w.tasks);
        pthread_mutex_unlock(&w.lock);
        if (*opts->stop || rc)
            break;
        for (int waited = 0; waited < backoff_ms && !*opts->stop; waited += 50) {
            /* A readable stop descriptor ends the wait at once; without one (or should it be
             * unusable) the flag is looked at every 50 ms. */
            zmq_pollitem_t stop_item = {.fd = opts->stop_fd, .events = ZMQ_POLLIN};
            if (opts->stop_fd <= 0 || zmq_poll(&stop_item, 1, 50) < 0) {
                struct timespec ts = {0, 50 * 1000000L};
                nanosleep(&ts, NULL);
            }
        }
        backoff_ms = backoff_ms * 2 > reconnect_max ? reconnect_max : backoff_ms * 2;
    }

out:
    pthread_mutex_lock(&w.lock);
    w.quit = 1;
    pthread_cond_broadcast(&w.wake);
    pthread_mutex_unlock(&w.lock);
    pool_join(&pool);
    task_queue_clear(&w.tasks);
    scene_cache_clear(&w.scenes);
    store_cache_clear(&w.stores);
    pthread_cond_destroy(&w.wake);
    pthread_mutex_destroy(&w.lock);
    close(w.wake_fd[0]);
    close(w.wake_fd[1]);
    if (!opts->zmq_ctx)
        zmq_ctx_term(ctx);
    return rc;
}
