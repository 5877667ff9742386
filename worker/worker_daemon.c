#include "worker_daemon.h"

#include "bundle.h"
#include "curve.h"
#include "local_render.h"
#include "net.h"
#include "photon.h"
#include "render.h"
#include "scene_load.h"

#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>
#include <zmq.h>
#if defined(__SSE__)
#include <pmmintrin.h>
#include <xmmintrin.h>
#endif

#define MAX_SCENES 4 /* loaded scenes kept (one per job); the oldest unused one goes first */
/* A master that says nothing while its connection stays up (libzmq's own heartbeats, answered
 * by its I/O thread, keep a live process's link up; a dead host's drops within 3 s) is busy,
 * not gone: its loop may be writing a large EXR or checkpoint. It is waited for this long. */
#define MASTER_BUSY_MAX_S 60.0
#define MAX_STORES 4 /* photon stores kept (their wire form), by hash; the oldest unused goes */

typedef struct job_scene {
    uint64_t job;
    char hash[PROTO_HASH_HEX + 1];
    /* The photon store installed in the scene for its camera tasks, "" for none yet: a
     * refined job's new store needs a scene of its own, as a store is installed once. */
    char store[PROTO_HASH_HEX + 1];
    scene_t *scene;
    char error[512];
    int loading, users;
    unsigned long stamp;
} job_scene_t;

/* A photon store's wire form as the master sent it (STORE), until no task needs it. */
typedef struct store_bytes {
    char hash[PROTO_HASH_HEX + 1]; /* "" for an empty slot */
    uint8_t *data;
    size_t size;
    int users; /* render threads installing it right now */
    unsigned long stamp;
} store_bytes_t;

typedef struct task {
    struct task *next;
    uint64_t job, id;
    uint32_t attempt;
    unsigned generation; /* connection generation that received it */
    char hash[PROTO_HASH_HEX + 1];
    proto_settings_t settings;
    char strings[2][16];
    proto_kind_t kind;
    proto_tile_t tile;             /* camera tiles */
    char store[PROTO_HASH_HEX + 1]; /* camera tiles of a photon job: the store to gather from */
    proto_photon_batch_t photons;  /* photon batches */
    /* filled by the render thread */
    tilebuf_t *result;
    uint8_t *photon_data; /* a batch's partial store, wire form */
    size_t photon_size;
    int ok;
    photon_stats_t pstats;
    render_stats_t stats;
    double elapsed;
    char error[640];
} task_t;

typedef struct worker {
    const worker_opts_t *opts;
    char cache[512];
    pthread_mutex_t lock;
    pthread_cond_t wake;
    task_t *queue, *queue_tail; /* ready to render */
    task_t *parked;             /* waiting for their scene */
    task_t *running;            /* being rendered */
    task_t *done;               /* rendered, to send */
    job_scene_t scenes[MAX_SCENES];
    store_bytes_t stores[MAX_STORES];
    unsigned long clock;
    unsigned generation;
    int quit;
    uint64_t cancelled[64]; /* recently cancelled jobs */
    int ncancelled;
    int wake_fd[2]; /* render threads write a byte here when a result is ready */
} worker_t;

static double now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

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

static void copy_settings(task_t *t, const proto_settings_t *s)
{
    t->settings = *s;
    snprintf(t->strings[0], sizeof t->strings[0], "%s", s->integrator ? s->integrator : "");
    snprintf(t->strings[1], sizeof t->strings[1], "%s", s->dispersion ? s->dispersion : "");
    t->settings.integrator = s->integrator ? t->strings[0] : NULL;
    t->settings.dispersion = s->dispersion ? t->strings[1] : NULL;
}

static int is_cancelled(const worker_t *w, uint64_t job)
{
    for (int i = 0; i < w->ncancelled; i++)
        if (w->cancelled[i] == job)
            return 1;
    return 0;
}

/* How many tasks of job the worker holds: queued, parked, being rendered, rendered and not yet
 * sent, or in `also` (the list the network loop is sending). Called with the lock held. */
static int job_tasks_held(const worker_t *w, uint64_t job, const task_t *also)
{
    const task_t *lists[] = {w->queue, w->parked, w->running, w->done, also};
    int n = 0;
    for (size_t i = 0; i < sizeof lists / sizeof *lists; i++)
        for (const task_t *t = lists[i]; t; t = t->next)
            n += t->job == job;
    return n;
}

static int bundle_ready(const worker_t *w, const char *hash)
{
    char path[700];
    snprintf(path, sizeof path, "%s/%s/.complete", w->cache, hash);
    return access(path, F_OK) == 0;
}

static store_bytes_t *find_store(worker_t *w, const char *hash)
{
    for (int i = 0; i < MAX_STORES; i++)
        if (w->stores[i].hash[0] && !strcmp(w->stores[i].hash, hash))
            return &w->stores[i];
    return NULL;
}

/* A task can run once its bundle is on disk and, for a tile that gathers from a photon store,
 * the store is here. Called with the lock held. */
static int task_ready(worker_t *w, const task_t *t)
{
    return bundle_ready(w, t->hash) && (!t->store[0] || find_store(w, t->store));
}

/* Installs the task's photon store into a freshly loaded scene (its derived-data slot is still
 * empty). Called with the lock held; released while the store is decoded and built. */
static int install_store(worker_t *w, job_scene_t *js, const task_t *t, err_t *err)
{
    store_bytes_t *sb = find_store(w, t->store);
    if (!sb)
        return err_set(err, "photon store %.12s is no longer held: the master will send it again",
                       t->store);
    sb->users++;
    pthread_mutex_unlock(&w->lock);
    int r = photon_pass_install_bytes(js->scene, sb->data, sb->size, err);
    pthread_mutex_lock(&w->lock);
    sb->users--;
    sb->stamp = ++w->clock;
    if (!r)
        snprintf(js->store, sizeof js->store, "%s", t->store);
    return r;
}

/* Finds or loads the scene of a task's job. Called by render threads with the lock held; the
 * lock is released while loading so that other threads keep rendering. */
static job_scene_t *acquire_scene(worker_t *w, const task_t *t, err_t *err)
{
    for (;;) {
        job_scene_t *hit = NULL, *victim = NULL;
        for (int i = 0; i < MAX_SCENES; i++) {
            job_scene_t *s = &w->scenes[i];
            /* Photon batches take any scene of their job (they leave its store slot alone);
             * a tile needs its store installed, or a scene with none yet to install it in. */
            if ((s->scene || s->loading || s->error[0]) && s->job == t->job &&
                (s->error[0] || !t->store[0] || !s->store[0] || !strcmp(s->store, t->store))) {
                hit = s;
                break;
            }
            if (!s->loading && s->users == 0 && (!victim || s->stamp < victim->stamp))
                victim = s;
        }
        if (hit && hit->loading) {
            pthread_cond_wait(&w->wake, &w->lock);
            continue;
        }
        if (hit) {
            if (hit->error[0]) {
                err_set(err, "%s", hit->error);
                return NULL;
            }
            if (t->store[0] && !hit->store[0]) {
                /* Wait for the scene's own users to leave? No: batches do not touch the store
                 * slot, and tiles of this job all want this store. */
                hit->loading = 1;
                int r = install_store(w, hit, t, err);
                hit->loading = 0;
                pthread_cond_broadcast(&w->wake);
                if (r)
                    return NULL;
            }
            hit->users++;
            hit->stamp = ++w->clock;
            return hit;
        }
        if (!victim) {
            pthread_cond_wait(&w->wake, &w->lock);
            continue;
        }
        scene_destroy(&victim->scene);
        memset(victim, 0, sizeof *victim);
        victim->job = t->job;
        victim->loading = 1;
        snprintf(victim->hash, sizeof victim->hash, "%s", t->hash);
        char main_path[PROTO_MAX_STRING + 800], dir[700], mainname[PROTO_MAX_STRING + 1];
        snprintf(dir, sizeof dir, "%s/%s", w->cache, t->hash);
        /* The bundle's main file name was written next to it at extraction. */
        char namefile[760];
        snprintf(namefile, sizeof namefile, "%s/.main", dir);
        pthread_mutex_unlock(&w->lock);
        err_t lerr = {{0}};
        scene_t *sc = NULL;
        FILE *f = fopen(namefile, "r");
        if (!f || !fgets(mainname, sizeof mainname, f)) {
            err_set(&lerr, "scene %s: its bundle in %s is incomplete", t->hash, dir);
        } else {
            mainname[strcspn(mainname, "\n")] = 0;
            snprintf(main_path, sizeof main_path, "%s/%s", dir, mainname);
            scene_overrides_t ov = proto_settings_to_overrides(&t->settings);
            sc = scene_load_file_confined(main_path, dir, &ov, &lerr);
        }
        if (f)
            fclose(f);
        pthread_mutex_lock(&w->lock);
        victim->scene = sc;
        victim->stamp = ++w->clock;
        if (!sc)
            snprintf(victim->error, sizeof victim->error, "%s", lerr.msg);
        else if (t->store[0] && install_store(w, victim, t, &lerr)) {
            /* The scene is fine for batches; this tile fails (and is tried again). */
            victim->loading = 0;
            pthread_cond_broadcast(&w->wake);
            err_set(err, "%s", lerr.msg);
            return NULL;
        }
        victim->loading = 0;
        pthread_cond_broadcast(&w->wake);
    }
}

static void *render_thread(void *arg)
{
    worker_t *w = arg;
#if defined(__SSE__)
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
#endif
    pthread_mutex_lock(&w->lock);
    for (;;) {
        while (!w->quit && !w->queue)
            pthread_cond_wait(&w->wake, &w->lock);
        if (w->quit)
            break;
        task_t *t = w->queue;
        w->queue = t->next;
        if (!w->queue)
            w->queue_tail = NULL;
        t->next = w->running;
        w->running = t;
        err_t err = {{0}};
        job_scene_t *js = is_cancelled(w, t->job) ? NULL : acquire_scene(w, t, &err);
        if (js) {
            pthread_mutex_unlock(&w->lock);
            double t0 = now_s();
            if (t->kind == PROTO_KIND_PHOTON_BATCH) {
                t->ok = photon_batch_run(js->scene, t->photons.first, t->photons.end,
                                         &t->photon_data, &t->photon_size, &t->pstats, &err) == 0;
            } else {
                const proto_tile_t *r = &t->tile;
                t->result = tilebuf_new(r->x0, r->y0, r->w, r->h, js->scene->settings.grid.n, &err);
                if (t->result && render_tile(js->scene, r->x0, r->y0, r->w, r->h, r->sample_begin,
                                             r->sample_end, t->result, &t->stats, &err))
                    tilebuf_destroy(&t->result);
                t->ok = t->result != NULL;
            }
            t->elapsed = now_s() - t0;
            pthread_mutex_lock(&w->lock);
            js->users--;
            pthread_cond_broadcast(&w->wake);
        }
        if (!t->ok)
            snprintf(t->error, sizeof t->error, "%s", err.msg[0] ? err.msg : "job cancelled");
        for (task_t **pp = &w->running; *pp; pp = &(*pp)->next)
            if (*pp == t) {
                *pp = t->next;
                break;
            }
        t->next = w->done;
        w->done = t;
        /* Wake the network loop at once rather than at its next poll timeout. */
        char one = 1;
        if (write(w->wake_fd[1], &one, 1) < 0) {
            /* A full pipe already holds a wake-up: nothing is lost. */
        }
    }
    pthread_mutex_unlock(&w->lock);
    return NULL;
}

static void free_list(task_t *t)
{
    while (t) {
        task_t *n = t->next;
        tilebuf_destroy(&t->result);
        free(t->photon_data);
        free(t);
        t = n;
    }
}

static int send_msg(worker_t *w, proto_net_t *net, const proto_msg_t *m)
{
    err_t err;
    int r = proto_net_send(net, NULL, m, &err);
    if (r)
        logf_(w, "sending %s failed: %s", proto_type_name(m->type), err.msg);
    return r;
}

/* Writes a received bundle into the cache: into a fresh folder first, then renamed into place,
 * so a half-written bundle never looks complete. */
static int store_bundle(worker_t *w, const char *hash, const proto_bundle_t *b, err_t *err)
{
    char have[PROTO_HASH_HEX + 1];
    if (proto_bundle_hash(b, have, err))
        return -1;
    if (strcmp(have, hash) != 0)
        return err_set(err, "scene bundle hashes to %s, not %s", have, hash);
    if (bundle_ready(w, hash))
        return 0;
    char tmp[700], final[700], path[800];
    snprintf(tmp, sizeof tmp, "%s/tmp-%s-%ld", w->cache, hash, (long)getpid());
    snprintf(final, sizeof final, "%s/%s", w->cache, hash);
    if (proto_bundle_extract(b, tmp, err))
        return -1;
    snprintf(path, sizeof path, "%s/.main", tmp);
    FILE *f = fopen(path, "w");
    if (!f || fprintf(f, "%s\n", b->main) < 0 || fclose(f) != 0)
        return err_set(err, "cannot write %s: %s", path, strerror(errno));
    snprintf(path, sizeof path, "%s/.complete", tmp);
    f = fopen(path, "w");
    if (!f || fclose(f) != 0)
        return err_set(err, "cannot write %s: %s", path, strerror(errno));
    if (rename(tmp, final) != 0 && !bundle_ready(w, hash))
        return err_set(err, "cannot move %s to %s: %s", tmp, final, strerror(errno));
    return 0;
}

static int make_dirs(const char *path)
{
    char buf[512];
    snprintf(buf, sizeof buf, "%s", path);
    for (char *p = buf + 1;; p++) {
        if (*p == '/' || !*p) {
            char c = *p;
            *p = 0;
            if (mkdir(buf, 0700) && errno != EEXIST)
                return -1;
            if (!c)
                return 0;
            *p = c;
        }
    }
}

int worker_run(const worker_opts_t *opts, err_t *err)
{
    worker_t w = {.opts = opts};
    if (!opts->endpoint)
        return err_set(err, "worker: no master endpoint");
    if (proto_curve_require(opts->endpoint, opts->curve.secret_key != NULL, opts->insecure,
                            "--key FILE and --master-key FILE.pub", err) < 0)
        return err_prefix(err, "worker: ");
    if (opts->cache_dir)
        snprintf(w.cache, sizeof w.cache, "%s", opts->cache_dir);
    else
        snprintf(w.cache, sizeof w.cache, "%s/prismfarm-worker-%ld",
                 getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp", (long)getuid());
    if (make_dirs(w.cache))
        return err_set(err, "worker: cannot create cache folder %s: %s", w.cache, strerror(errno));
    int threads = opts->threads > 0 ? opts->threads : local_render_cores();
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
    pthread_t *th = calloc((size_t)threads, sizeof *th);
    int started = 0;
    while (th && started < threads && pthread_create(&th[started], NULL, render_thread, &w) == 0)
        started++;
    int rc = 0;
    if (started == 0) {
        rc = err_set(err, "worker: cannot start render threads");
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
                             .hello = {.name = name, .threads = started, .software = "prismfarm 0.1.0"}};
        send_msg(&w, net, &hello);
        logf_(&w, "connecting to %s as '%s' with %d threads", opts->endpoint, name, started);
        double last_heard = now_s(), last_sent = now_s();
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
            double now = now_s();
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
                    task_t *t = calloc(1, sizeof *t);
                    if (!t)
                        break;
                    t->job = m.task.job;
                    t->id = m.task.task;
                    t->attempt = m.task.attempt;
                    t->generation = gen;
                    snprintf(t->hash, sizeof t->hash, "%s", m.task.scene);
                    copy_settings(t, &m.task.settings);
                    t->kind = m.task.kind;
                    t->tile = m.task.tile;
                    t->photons = m.task.photons;
                    snprintf(t->store, sizeof t->store, "%s", m.task.store);
                    pthread_mutex_lock(&w.lock);
                    for (int i = 0; i < w.ncancelled; i++)
                        if (w.cancelled[i] == t->job) /* a re-submitted id is a new job */
                            w.cancelled[i] = w.cancelled[--w.ncancelled];
                    if (task_ready(&w, t)) {
                        if (w.queue_tail)
                            w.queue_tail->next = t;
                        else
                            w.queue = t;
                        w.queue_tail = t;
                        pthread_cond_broadcast(&w.wake);
                    } else {
                        /* Ask once for whatever is missing: parked tasks already waiting for
                         * the same bundle or store have asked. */
                        int asked_scene = 0, asked_store = 0;
                        for (task_t *p = w.parked; p; p = p->next) {
                            asked_scene |= !strcmp(p->hash, t->hash);
                            asked_store |= t->store[0] && !strcmp(p->store, t->store);
                        }
                        t->next = w.parked;
                        w.parked = t;
                        if (!asked_scene && !bundle_ready(&w, t->hash)) {
                            proto_msg_t req = {.type = PROTO_SCENE_REQUEST};
                            snprintf(req.scene_request.scene, sizeof req.scene_request.scene, "%s", t->hash);
                            send_msg(&w, net, &req);
                        }
                        if (!asked_store && t->store[0] && !find_store(&w, t->store)) {
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
                    store_bytes_t *slot = find_store(&w, m.store.store);
                    for (int i = 0; i < MAX_STORES && !slot; i++)
                        if (!w.stores[i].hash[0])
                            slot = &w.stores[i];
                    for (int i = 0; i < MAX_STORES && !slot; i++) {
                        store_bytes_t *c = &w.stores[i];
                        if (!c->users && (!slot || c->stamp < slot->stamp))
                            slot = c;
                    }
                    uint8_t *copy = slot ? malloc(m.store.size ? m.store.size : 1) : NULL;
                    if (copy) {
                        if (slot->hash[0] && strcmp(slot->hash, m.store.store) != 0)
                            logf_(&w, "photon store %.12s dropped for %.12s", slot->hash, m.store.store);
                        free(slot->data);
                        memcpy(copy, m.store.data, m.store.size);
                        slot->data = copy;
                        slot->size = m.store.size;
                        slot->stamp = ++w.clock;
                        snprintf(slot->hash, sizeof slot->hash, "%s", m.store.store);
                        logf_(&w, "photon store %.12s received (%zu bytes)", m.store.store, m.store.size);
                    } else {
                        logf_(&w, "no room for photon store %.12s: its tiles will fail and be re-sent",
                              m.store.store);
                    }
                    task_t **pp = &w.parked;
                    while (*pp) {
                        task_t *t = *pp;
                        if (strcmp(t->store, m.store.store) != 0 || (copy && !task_ready(&w, t))) {
                            pp = &t->next;
                            continue;
                        }
                        *pp = t->next;
                        t->next = NULL;
                        if (copy) {
                            if (w.queue_tail)
                                w.queue_tail->next = t;
                            else
                                w.queue = t;
                            w.queue_tail = t;
                        } else {
                            snprintf(t->error, sizeof t->error, "no room for photon store %.12s", m.store.store);
                            t->next = w.done;
                            w.done = t;
                        }
                    }
                    pthread_cond_broadcast(&w.wake);
                    pthread_mutex_unlock(&w.lock);
                    break;
                }
                case PROTO_SCENE: {
                    err_t serr;
                    int ok = store_bundle(&w, m.scene.scene, &m.scene.bundle, &serr) == 0;
                    if (!ok)
                        logf_(&w, "scene %s rejected: %s", m.scene.scene, serr.msg);
                    pthread_mutex_lock(&w.lock);
                    task_t **pp = &w.parked;
                    while (*pp) {
                        task_t *t = *pp;
                        /* A tile whose photon store is still on its way stays parked. */
                        if (strcmp(t->hash, m.scene.scene) != 0 || (ok && !task_ready(&w, t))) {
                            pp = &t->next;
                            continue;
                        }
                        *pp = t->next;
                        t->next = NULL;
                        if (ok) {
                            if (w.queue_tail)
                                w.queue_tail->next = t;
                            else
                                w.queue = t;
                            w.queue_tail = t;
                        } else {
                            snprintf(t->error, sizeof t->error, "scene bundle rejected: %s", serr.msg);
                            t->next = w.done;
                            w.done = t;
                        }
                    }
                    pthread_cond_broadcast(&w.wake);
                    pthread_mutex_unlock(&w.lock);
                    break;
                }
                case PROTO_CANCEL: {
                    pthread_mutex_lock(&w.lock);
                    if (w.ncancelled == 64)
                        memmove(w.cancelled, w.cancelled + 1, 63 * sizeof *w.cancelled), w.ncancelled--;
                    w.cancelled[w.ncancelled++] = m.cancel.job;
                    /* Queued tasks of the job go, and those waiting for its scene; the master
                     * reclaims their slots itself. Tasks being rendered finish, unsent. */
                    int dropped = 0;
                    task_t **pp = &w.queue;
                    w.queue_tail = NULL;
                    while (*pp) {
                        task_t *t = *pp;
                        if (t->job == m.cancel.job) {
                            *pp = t->next;
                            free(t);
                            dropped++;
                        } else {
                            w.queue_tail = t;
                            pp = &t->next;
                        }
                    }
                    for (pp = &w.parked; *pp;) {
                        task_t *t = *pp;
                        if (t->job == m.cancel.job) {
                            *pp = t->next;
                            free(t);
                            dropped++;
                        } else {
                            pp = &t->next;
                        }
                    }
                    for (int i = 0; i < MAX_SCENES; i++)
                        if (w.scenes[i].job == m.cancel.job && !w.scenes[i].users && !w.scenes[i].loading) {
                            scene_destroy(&w.scenes[i].scene);
                            memset(&w.scenes[i], 0, sizeof w.scenes[i]);
                        }
                    int held = job_tasks_held(&w, m.cancel.job, NULL);
                    pthread_mutex_unlock(&w.lock);
                    logf_(&w, "job %llu cancelled (%d task%s dropped, %d in flight)",
                          (unsigned long long)m.cancel.job, dropped, dropped == 1 ? "" : "s", held);
                    /* Said once the worker holds none of the job's tasks: nothing of it runs. */
                    if (held == 0)
                        logf_(&w, "job %llu: all its tasks stopped",
                              (unsigned long long)m.cancel.job);
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
            task_t *done = w.done;
            w.done = NULL;
            pthread_mutex_unlock(&w.lock);
            while (done) {
                task_t *t = done;
                done = t->next;
                int cancelled = is_cancelled(&w, t->job);
                if (t->generation == gen && !cancelled) {
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
                uint64_t job = t->job;
                t->next = NULL;
                free_list(t);
                if (cancelled) {
                    pthread_mutex_lock(&w.lock);
                    int held = job_tasks_held(&w, job, done);
                    pthread_mutex_unlock(&w.lock);
                    if (held == 0)
                        logf_(&w, "job %llu: all its tasks stopped", (unsigned long long)job);
                }
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
        free_list(w.queue);
        w.queue = w.queue_tail = NULL;
        free_list(w.parked);
        w.parked = NULL;
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
    for (int i = 0; i < started; i++)
        pthread_join(th[i], NULL);
    free(th);
    free_list(w.queue);
    free_list(w.parked);
    free_list(w.done);
    for (int i = 0; i < MAX_SCENES; i++)
        scene_destroy(&w.scenes[i].scene);
    for (int i = 0; i < MAX_STORES; i++)
        free(w.stores[i].data);
    pthread_cond_destroy(&w.wake);
    pthread_mutex_destroy(&w.lock);
    close(w.wake_fd[0]);
    close(w.wake_fd[1]);
    if (!opts->zmq_ctx)
        zmq_ctx_term(ctx);
    return rc;
}
