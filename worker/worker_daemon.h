/* worker_daemon: a render worker of the farm. Connects to the master, says HELLO, takes camera
 * tasks, renders them on its threads with render_tile and sends the results back; heartbeats
 * both ways, and reconnects with back-off when the master goes quiet (zguide's Paranoid
 * Pirate). Scenes arrive as bundles, are checked against their hash, extracted only inside the
 * worker's cache folder, and loaded once per bundle, scene file and settings, whatever the number of jobs
 * and photon stores that use it at once (scene_shelf.h). */
#ifndef PRISMFARM_WORKER_DAEMON_H
#define PRISMFARM_WORKER_DAEMON_H

#include "err.h"
#include "net.h"
#include "scene_shelf.h"

#include <signal.h>

typedef struct worker_opts {
    const char *endpoint;   /* the master's worker endpoint, e.g. tcp://host:5555 */
    void *zmq_ctx;          /* NULL: the worker makes its own (inproc:// needs a shared one) */
    int threads;            /* render threads, told to the master in HELLO (it sends up to twice
                             * as many tasks, so that a thread never waits for the next); 0: all cores */
    const char *name;       /* shown by `prismfarm workers`; NULL: host name and pid */
    const char *cache_dir;  /* where bundles are extracted; NULL: $TMPDIR/prismfarm-worker-<uid> */
    volatile sig_atomic_t *stop; /* checked at least every 100 ms; non-zero ends worker_run */
    int stop_fd;            /* > 0: a descriptor (a pipe's read end) made readable when *stop
                             * is set, so that the loop ends at once; 0: none */
    int reconnect_max_ms;   /* back-off ceiling (default 32000) */
    int verbose;            /* log events to stderr */
    /* Security (docs/security.md): the three keys of a CURVE client (server_public: the
     * master's), or plain text, which a network endpoint allows only with insecure. */
    net_curve_t curve;
    int insecure;
    /* Scenes shared with the rest of this process (`prismfarm render`'s local farm: its client
     * and master loaded the scene already); NULL: the worker keeps a shelf of its own. */
    scene_shelf_t *shelf;
} worker_opts_t;

/* Runs until *stop is set (returns 0) or a fatal error (returns -1: the master refused this
 * worker's protocol version, the endpoint is invalid, or a network endpoint has neither keys
 * nor insecure). A master that refuses our key is logged and tried again with back-off: its
 * operator may authorise the key meanwhile. */
int worker_run(const worker_opts_t *opts, err_t *err);

#endif
