/* worker_state: what a running worker owns (internal to worker/; cli/ and tests use only
 * worker_daemon.h). The loop's thread alone has the connection and its timers; what the render
 * threads share with it -- the task queue and the caches -- is under lock. Also the two things
 * every part of the loop does with the state: log and send. */
#ifndef PRISMFARM_WORKER_STATE_H
#define PRISMFARM_WORKER_STATE_H

#include "bundle_cache.h"
#include "net.h"
#include "proto.h"
#include "scene_cache.h"
#include "store_cache.h"
#include "task_queue.h"

#include <pthread.h>
#include <stdbool.h>

/* worker_daemon.h's options: the loop reads them; the parts below it see only what they need
 * (verbose), so that no module under the daemon includes the daemon's header. */
struct worker_opts;

/* One connection to the master, from HELLO until it is given up. */
typedef struct worker_conn {
    net_t *net;
    unsigned generation; /* its tasks carry this; results of older connections are dropped */
    double last_heard;   /* clock_now_s of the master's last message */
    double last_sent;    /* ... of our last message */
    int welcomed;        /* WELCOME came */
    int busy_logged;     /* "the master is ... busy" said once for this silence */
} worker_conn_t;

typedef struct worker {
    const struct worker_opts *opts;
    bool verbose; /* the options' verbose, for worker_log */
    char name[256]; /* told in HELLO */
    int threads;    /* render threads running, told in HELLO */
    /* Set up before the render threads start and not changed after; its files are its state. */
    bundle_cache_t bundles;

    /* The loop's thread alone. */
    worker_conn_t conn;
    int heartbeat_ms;     /* how often to send HEARTBEAT: the master's WELCOME says (1000) */
    int backoff_ms;       /* the next reconnection's wait: 1000, doubled up to reconnect_max_ms */
    int reconnect_max_ms; /* back-off ceiling */

    /* Shared with the render threads, under lock. */
    pthread_mutex_t lock;
    pthread_cond_t wake; /* a task is ready, a scene slot changed, or quit */
    task_queue_t tasks;
    scene_cache_t scenes;
    store_cache_t stores;
    unsigned generation; /* connections opened */
    int quit;            /* the render threads end */
    int wake_fd[2];      /* render threads write a byte here when a result is ready */
} worker_t;

/* Writes "worker: <message>" to stderr when the options ask for verbose. */
void worker_log(const worker_t *w, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* Sends m to the master on the current connection; a failure is logged and returned. */
int worker_send(worker_t *w, const proto_msg_t *m);

#endif
