#include "worker_daemon.h"

#include "clock.h"
#include "curve.h"
#include "net.h"
#include "pool.h"
#include "render_threads.h"
#include "worker_handlers.h"
#include "worker_state.h"

#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>
#include <zmq.h>

/* A master that says nothing while its connection stays up (libzmq's own heartbeats, answered
 * by its I/O thread, keep a live process's link up; a dead host's drops within 3 s) is busy,
 * not gone: its loop may be writing a large EXR or checkpoint. It is waited for this long. */
#define MASTER_BUSY_MAX_S 60.0

/* Opens a connection to the master and says HELLO. */
static int conn_open(worker_t *w, void *ctx, err_t *err)
{
    /* No linger: when this connection is given up, its unsent HELLO must not reach a master
     * that comes up later, where it would show a second, ghost copy of us. */
    net_options_t nopt = net_options_default();
    nopt.linger_ms = 0;
    nopt.curve = w->opts->curve;
    w->conn = (worker_conn_t){0};
    w->conn.net = net_new(ctx, NET_DEALER, &nopt, err);
    if (!w->conn.net || net_connect(w->conn.net, w->opts->endpoint, err)) {
        net_destroy(&w->conn.net);
        return -1;
    }
    pthread_mutex_lock(&w->lock);
    w->generation++;
    w->conn.generation = w->generation;
    pthread_mutex_unlock(&w->lock);
    worker_send_hello(w);
    worker_log(w, "connecting to %s as '%s' with %d thread%s", w->opts->endpoint, w->name,
               w->threads, w->threads == 1 ? "" : "s");
    w->conn.last_heard = clock_now_s();
    w->conn.last_sent = clock_now_s();
    return 0;
}

/* Waits up to 50 ms for a message, a result from a render thread or the stop descriptor. */
static void conn_wait(worker_t *w)
{
    zmq_pollitem_t items[3] = {{.socket = net_socket(w->conn.net), .events = ZMQ_POLLIN},
                               {.fd = w->wake_fd[0], .events = ZMQ_POLLIN},
                               {.fd = w->opts->stop_fd, .events = ZMQ_POLLIN}};
    if (zmq_poll(items, w->opts->stop_fd > 0 ? 3 : 2, 50) > 0 && (items[1].revents & ZMQ_POLLIN)) {
        char drain[64];
        while (read(w->wake_fd[0], drain, sizeof drain) > 0) {
        }
    }
}

/* The clock's work at the end of a turn: a HEARTBEAT when nothing was sent for an interval, and
 * the master's silence. Returns 1 when the connection is to be given up. */
static int conn_cron(worker_t *w, double now)
{
    worker_conn_t *c = &w->conn;
    if (now - c->last_sent >= w->heartbeat_ms / 1000.0) {
        proto_msg_t hb = {.type = PROTO_HEARTBEAT};
        worker_send(w, &hb);
        c->last_sent = now;
    }
    if (now - c->last_heard <= 3.0 * w->heartbeat_ms / 1000.0)
        return 0;
    /* Why it never answered, when the handshake says: a refused key, CURVE on one side only. */
    char why[256];
    net_link_t link = net_link(c->net, why, sizeof why);
    if (c->welcomed && link == NET_LINK_UP && now - c->last_heard < MASTER_BUSY_MAX_S) {
        if (!c->busy_logged)
            worker_log(w,
                       "the master is silent but its connection is alive: it is busy, "
                       "waiting for it (up to %.0f s)",
                       MASTER_BUSY_MAX_S);
        c->busy_logged = 1;
        return 0;
    }
    worker_log(w, "the master is silent (%s%s%s); reconnecting in %d ms",
               c->welcomed ? "was connected" : "never answered",
               link == NET_LINK_REFUSED ? ": it " : "",
               link == NET_LINK_REFUSED ? why : "", w->backoff_ms);
    return 1;
}

/* Serves one connection, a turn at a time: wait, handle what arrived, send what the render
 * threads finished, then the clock's work. Returns 0 when *stop is set, the socket failed or
 * the master went quiet; -1 with err when the worker must end. */
static int conn_serve(worker_t *w, err_t *err)
{
    while (!*w->opts->stop) {
        conn_wait(w);
        proto_msg_t m;
        proto_peer_t from;
        err_t rerr;
        int r = net_recv(w->conn.net, &from, &m, 0, &rerr);
        double now = clock_now_s();
        if (r == 0) {
            /* Any message is a sign of life. */
            w->conn.last_heard = now;
            w->conn.busy_logged = 0;
            int rc = worker_on_message(w, &m, err);
            proto_msg_free(&m);
            if (rc)
                return rc;
        } else if (r == PROTO_ESOCKET) {
            worker_log(w, "socket error: %s", rerr.msg);
            return 0;
        } else if (r != PROTO_EAGAIN) {
            worker_log(w, "ignored a bad message from the master: %s", rerr.msg);
        }
        worker_send_results(w, now);
        if (conn_cron(w, now))
            return 0;
    }
    return 0;
}

static void conn_close(worker_t *w)
{
    net_destroy(&w->conn.net);
    /* Whatever this connection held is the master's to reassign now. */
    pthread_mutex_lock(&w->lock);
    task_queue_abandon(&w->tasks);
    pthread_mutex_unlock(&w->lock);
}

/* Waits the back-off (or until *stop), then doubles it up to the ceiling. */
static void backoff_wait(worker_t *w)
{
    const worker_opts_t *opts = w->opts;
    for (int waited = 0; waited < w->backoff_ms && !*opts->stop; waited += 50) {
        /* A readable stop descriptor ends the wait at once; without one (or should it be
         * unusable) the flag is looked at every 50 ms. */
        zmq_pollitem_t stop_item = {.fd = opts->stop_fd, .events = ZMQ_POLLIN};
        if (opts->stop_fd <= 0 || zmq_poll(&stop_item, 1, 50) < 0)
            clock_sleep_s(0.050);
    }
    w->backoff_ms =
        w->backoff_ms * 2 > w->reconnect_max_ms ? w->reconnect_max_ms : w->backoff_ms * 2;
}

int worker_run(const worker_opts_t *opts, err_t *err)
{
    worker_t w = {.opts = opts, .verbose = opts->verbose};
    if (!opts->endpoint)
        return err_set(err, "worker: no master endpoint");
    if (curve_require(opts->endpoint, opts->curve.secret_key != NULL, opts->insecure,
                            "--key FILE and --master-key FILE.pub", err) < 0)
        return err_prefix(err, "worker: ");
    if (bundle_cache_open(&w.bundles, opts->cache_dir))
        return err_set(err, "worker: cannot create cache folder %s: %s", w.bundles.dir,
                       strerror(errno));
    int threads = opts->threads > 0 ? opts->threads : pool_cores();
    if (opts->name)
        snprintf(w.name, sizeof w.name, "%s", opts->name);
    else {
        char host[200] = "host";
        gethostname(host, sizeof host - 1);
        snprintf(w.name, sizeof w.name, "%s:%ld", host, (long)getpid());
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
    scene_shelf_t *own_shelf = opts->shelf ? NULL : scene_shelf_new(err);
    scene_cache_init(&w.scenes, &w.lock, &w.wake, &w.bundles, &w.stores,
                     opts->shelf ? opts->shelf : own_shelf);
    err_t perr;
    pool_t *pool = NULL;
    int rc = 0;
    if (!opts->shelf && !own_shelf) {
        rc = err_prefix(err, "worker: ");
        goto out;
    }
    if (!(pool = pool_start(threads, render_thread_main, &w, &perr))) {
        rc = err_set(err, "worker: cannot start render threads: %s", perr.msg);
        goto out;
    }
    w.threads = pool_size(pool);

    w.heartbeat_ms = 1000;
    w.backoff_ms = 1000;
    w.reconnect_max_ms = opts->reconnect_max_ms > 0 ? opts->reconnect_max_ms : 32000;
    /* One connection at a time: HELLO, then serve until the master goes quiet. */
    while (!*opts->stop && rc == 0) {
        if (conn_open(&w, ctx, err)) {
            rc = -1;
            break;
        }
        rc = conn_serve(&w, err);
        conn_close(&w);
        if (*opts->stop || rc)
            break;
        backoff_wait(&w);
    }

out:
    pthread_mutex_lock(&w.lock);
    w.quit = 1;
    pthread_cond_broadcast(&w.wake);
    pthread_mutex_unlock(&w.lock);
    pool_join(&pool);
    task_queue_clear(&w.tasks);
    scene_cache_clear(&w.scenes);
    scene_shelf_destroy(&own_shelf);
    store_cache_clear(&w.stores);
    pthread_cond_destroy(&w.wake);
    pthread_mutex_destroy(&w.lock);
    close(w.wake_fd[0]);
    close(w.wake_fd[1]);
    if (!opts->zmq_ctx)
        zmq_ctx_term(ctx);
    return rc;
}
