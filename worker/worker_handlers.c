#include "worker_handlers.h"

#include <stdbool.h>
#include <stdio.h>
#include <string.h>

int worker_send_hello(worker_t *w)
{
    proto_msg_t hello = {
        .type = PROTO_HELLO,
        .hello = {.name = w->name, .threads = w->threads, .software = "prismfarm 0.1.0"}};
    return worker_send(w, &hello);
}

/* A task can run once its bundle is on disk and, for a tile that gathers from a photon store,
 * the store is here. Called with the lock held. */
static bool task_ready(worker_t *w, const task_t *t)
{
    return bundle_cache_has(&w->bundles, t->hash) &&
           (!t->store[0] || store_cache_find(&w->stores, t->store));
}

/* What arrived (a bundle or a photon store, by hash) and whether it was kept: the parked tasks
 * that waited for it leave, to the queue if it was kept and they have all they need now (a tile
 * whose photon store is still on its way stays parked), else to fail. */
typedef struct arrival {
    worker_t *w;
    const char *hash;
    bool kept;
} arrival_t;

static bool waited_for_scene(const task_t *t, void *arg)
{
    const arrival_t *a = arg;
    return !strcmp(t->hash, a->hash) && (!a->kept || task_ready(a->w, t));
}

static bool waited_for_store(const task_t *t, void *arg)
{
    const arrival_t *a = arg;
    return !strcmp(t->store, a->hash) && (!a->kept || task_ready(a->w, t));
}

static void on_welcome(worker_t *w, const proto_msg_t *m)
{
    w->conn.welcomed = 1;
    w->backoff_ms = 1000;
    if (m->welcome.heartbeat_ms >= 50 && m->welcome.heartbeat_ms <= 60000)
        w->heartbeat_ms = (int)m->welcome.heartbeat_ms;
    worker_log(w, "welcomed as worker %llu", (unsigned long long)m->welcome.worker_id);
}

static void on_task(worker_t *w, const proto_msg_t *m)
{
    task_t *t = task_new(m, w->conn.generation);
    if (!t)
        return;
    pthread_mutex_lock(&w->lock);
    /* a re-submitted id is a new job */
    task_queue_uncancel(&w->tasks, t->job);
    if (task_ready(w, t)) {
        task_queue_push(&w->tasks, t);
        pthread_cond_broadcast(&w->wake);
    } else {
        /* Ask once for whatever is missing: parked tasks already waiting for the same bundle or
         * store have asked. */
        bool asked_scene, asked_store;
        task_queue_park(&w->tasks, t, &asked_scene, &asked_store);
        if (!asked_scene && !bundle_cache_has(&w->bundles, t->hash)) {
            proto_msg_t req = {.type = PROTO_SCENE_REQUEST};
            snprintf(req.scene_request.scene, sizeof req.scene_request.scene, "%s", t->hash);
            worker_send(w, &req);
        }
        if (!asked_store && t->store[0] && !store_cache_find(&w->stores, t->store)) {
            proto_msg_t req = {.type = PROTO_STORE_REQUEST};
            snprintf(req.store_request.store, sizeof req.store_request.store, "%s", t->store);
            worker_send(w, &req);
        }
    }
    pthread_mutex_unlock(&w->lock);
}

/* Keeps the store (its hash was checked when the message was decoded), then starts the tiles
 * that waited for it. */
static void on_store(worker_t *w, const proto_msg_t *m)
{
    pthread_mutex_lock(&w->lock);
    char dropped[PROTO_HASH_HEX + 1];
    bool kept =
        store_cache_put(&w->stores, m->store.store, m->store.data, m->store.size, dropped) == 0;
    if (kept) {
        if (dropped[0])
            worker_log(w, "photon store %.12s dropped for %.12s", dropped, m->store.store);
        worker_log(w, "photon store %.12s received (%zu bytes)", m->store.store, m->store.size);
    } else {
        worker_log(w, "no room for photon store %.12s: its tiles will fail and be re-sent",
                   m->store.store);
    }
    char why[sizeof((task_t *)0)->error];
    snprintf(why, sizeof why, "no room for photon store %.12s", m->store.store);
    arrival_t a = {w, m->store.store, kept};
    task_queue_unpark(&w->tasks, waited_for_store, &a, kept ? NULL : why);
    pthread_cond_broadcast(&w->wake);
    pthread_mutex_unlock(&w->lock);
}

/* Writes the bundle into the cache, then starts the tasks that waited for it. */
static void on_scene(worker_t *w, const proto_msg_t *m)
{
    err_t serr;
    bool ok = bundle_cache_put(&w->bundles, m->scene.scene, &m->scene.bundle, &serr) == 0;
    char why[sizeof((task_t *)0)->error] = "";
    if (!ok) {
        worker_log(w, "scene %s rejected: %s", m->scene.scene, serr.msg);
        snprintf(why, sizeof why, "scene bundle rejected: %s", serr.msg);
    }
    pthread_mutex_lock(&w->lock);
    arrival_t a = {w, m->scene.scene, ok};
    task_queue_unpark(&w->tasks, waited_for_scene, &a, ok ? NULL : why);
    pthread_cond_broadcast(&w->wake);
    pthread_mutex_unlock(&w->lock);
}

static void on_cancel(worker_t *w, const proto_msg_t *m)
{
    uint64_t job = m->cancel.job;
    pthread_mutex_lock(&w->lock);
    int dropped = task_queue_cancel(&w->tasks, job);
    scene_cache_drop_job(&w->scenes, job);
    int held = task_queue_held(&w->tasks, job, NULL);
    pthread_mutex_unlock(&w->lock);
    worker_log(w, "job %llu cancelled (%d task%s dropped, %d in flight)", (unsigned long long)job,
               dropped, dropped == 1 ? "" : "s", held);
    /* Said once the worker holds none of the job's tasks: nothing of it runs. */
    if (held == 0)
        worker_log(w, "job %llu: all its tasks stopped", (unsigned long long)job);
}

static int on_refuse(worker_t *w, const proto_msg_t *m, err_t *err)
{
    worker_log(w, "refused by the master: %s", m->refuse.reason);
    if (strstr(m->refuse.reason, "protocol version"))
        return err_set(err, "worker: the master refused us: %s", m->refuse.reason);
    /* Most likely the master restarted and forgot us: say HELLO again. */
    worker_send_hello(w);
    return 0;
}

int worker_on_message(worker_t *w, const proto_msg_t *m, err_t *err)
{
    switch (m->type) {
    case PROTO_WELCOME:
        on_welcome(w, m);
        break;
    case PROTO_TASK:
        on_task(w, m);
        break;
    case PROTO_STORE:
        on_store(w, m);
        break;
    case PROTO_SCENE:
        on_scene(w, m);
        break;
    case PROTO_CANCEL:
        on_cancel(w, m);
        break;
    case PROTO_REFUSE:
        return on_refuse(w, m, err);
    case PROTO_HEARTBEAT: /* a sign of life, which the loop took from every message */
    default:
        break;
    }
    return 0;
}

/* The RESULT or TASK_FAILED of a finished task. */
static proto_msg_t result_message(task_t *t)
{
    proto_msg_t out;
    if (t->ok && t->kind == PROTO_KIND_PHOTON_BATCH) {
        out = (proto_msg_t){.type = PROTO_RESULT};
        out.result.job = t->job;
        out.result.task = t->id;
        out.result.attempt = t->attempt;
        out.result.kind = PROTO_KIND_PHOTON_BATCH;
        out.result.photons = (proto_photon_result_t){.range = t->photons,
                                                     .emitted = t->pstats.emitted,
                                                     .data = t->photon_data,
                                                     .size = t->photon_size,
                                                     .nonfinite = t->pstats.nonfinite};
        out.result.stats = (proto_task_stats_t){.samples = t->photons.end - t->photons.first,
                                                .rays = t->pstats.rays,
                                                .elapsed = t->elapsed};
    } else if (t->ok) {
        /* The pass's sums rounded by the one rule (tilebuf.h) that --direct applies too:
         * float32 on the wire unless a value needs a double. */
        tilebuf_t *b = t->result;
        int bits = tilebuf_round_sums(b) == 0 ? 32 : 64;
        out = (proto_msg_t){.type = PROTO_RESULT};
        out.result.job = t->job;
        out.result.task = t->id;
        out.result.attempt = t->attempt;
        out.result.kind = PROTO_KIND_CAMERA_TILE;
        out.result.tile = (proto_tile_result_t){.rect = t->tile,
                                                .nbuckets = tilebuf_nbuckets(b),
                                                .sums_bits = bits,
                                                .sums = tilebuf_sums(b),
                                                .xyz = tilebuf_xyz_sums(b),
                                                .counts = tilebuf_counts(b),
                                                .lum = tilebuf_luminance_sums(b),
                                                .lum_sq = tilebuf_luminance_sq_sums(b),
                                                .nonfinite = tilebuf_nonfinite(b)};
        out.result.stats = (proto_task_stats_t){.samples = t->stats.samples,
                                                .rays = t->stats.rays,
                                                .dispersive = t->stats.dispersive,
                                                .elapsed = t->elapsed};
    } else {
        out = (proto_msg_t){.type = PROTO_TASK_FAILED};
        out.task_failed.job = t->job;
        out.task_failed.task = t->id;
        out.task_failed.attempt = t->attempt;
        out.task_failed.error = t->error;
    }
    return out;
}

void worker_send_results(worker_t *w, double now)
{
    pthread_mutex_lock(&w->lock);
    task_t *done = task_queue_take_done(&w->tasks);
    pthread_mutex_unlock(&w->lock);
    while (done) {
        task_t *t = done;
        done = t->next;
        /* The cancelled jobs are read without the lock: this thread is their only writer. */
        bool cancelled = task_queue_is_cancelled(&w->tasks, t->job);
        if (t->generation == w->conn.generation && !cancelled) {
            proto_msg_t out = result_message(t);
            if (worker_send(w, &out) == 0)
                w->conn.last_sent = now;
        }
        uint64_t job = t->job;
        t->next = NULL;
        task_list_free(t);
        if (cancelled) {
            pthread_mutex_lock(&w->lock);
            int held = task_queue_held(&w->tasks, job, done);
            pthread_mutex_unlock(&w->lock);
            if (held == 0)
                worker_log(w, "job %llu: all its tasks stopped", (unsigned long long)job);
        }
    }
}
