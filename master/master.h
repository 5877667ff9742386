/* master: the farm's master daemon. Binds a ROUTER for workers and one for clients, stores
 * submitted scenes in its spool folder, cuts jobs into tasks with sched, hands them to workers,
 * merges their results and writes each job's progressive preview and final spectral EXR and PNG
 * (docs/farm.md). One thread, one loop: it never blocks longer than 100 ms on the network, and
 * every malformed message is logged with its peer, refused, and survived. A STATUS with a
 * `wait` is answered when its job ends or the wait runs out (a long poll). */
#ifndef PRISMFARM_MASTER_H
#define PRISMFARM_MASTER_H

#include "budget.h"
#include "err.h"
#include "proto.h"
#include "scene_shelf.h"
#include "sched.h"

#include <signal.h>

/* Called once both endpoints are bound, with the endpoints as bound: a tcp endpoint whose port
 * is '*' comes back with the port the system chose ("tcp://127.0.0.1:40123"). */
typedef void (*master_ready_fn)(void *user, const char *worker_endpoint,
                                const char *client_endpoint);

typedef struct master_opts {
    const char *worker_endpoint; /* ROUTER for workers: "tcp://HOST:5555", "inproc://w", ... */
    const char *client_endpoint; /* ROUTER for clients */
    const char *spool_dir;       /* scenes and outputs (created if missing) */
    void *zmq_ctx;               /* NULL: the master makes its own (inproc:// needs a shared one) */
    volatile sig_atomic_t *stop; /* checked at least every 100 ms; non-zero ends master_run */
    int stop_fd;                 /* > 0: a descriptor (a pipe's read end) made readable when
                                  * *stop is set, so that the loop ends at once; 0: none */
    int heartbeat_ms;            /* HEARTBEAT to workers this often; told to them in WELCOME */
    sched_config_t sched;        /* tile size, deadlines; worker_timeout_s is the silence that
                                  * makes a worker lost (default 3 heartbeats) */
    proto_limits_t limits;       /* message and bundle sizes accepted */
    size_t max_jobs;             /* unfinished (queued or running) jobs held at once; a SUBMIT
                                  * beyond them is refused */
    /* Open TCP connections per endpoint (net/conn_guard.h): from one IP address, and in all
     * (0: the file limit, raised to its hard maximum at start, less a reserve for the spool's
     * files). A connection beyond either is shut down at once and logged (rate-limited). */
    int max_conns_per_host, max_conns;
    /* What one job's scene may make the master build (scenefile/budget.h), checked while it
     * loads: shapes, triangles, texels, the merged image's bytes. */
    scene_budget_t budget;
    /* How many frames of a sequence the master loads at once at submission (on the pool, each
     * load on its share of the cores; docs/performance.md): 0 all cores, 1 one after another. */
    int load_threads;
    /* Security (docs/security.md): with key_file both endpoints are CURVE servers that let in
     * only the public keys of authorized_dir's *.pub files; without it a tcp:// endpoint
     * needs insecure (plain text), and inproc:// and ipc:// need neither. */
    const char *key_file;        /* the master's NAME.key (prismfarm keygen) */
    const char *authorized_dir;  /* NAME.pub files let in on both endpoints (before roles) */
    /* Roles (docs/security.md): the workers' keys, let in on the workers endpoint only; the
     * clients', and the admins', on the clients endpoint only. Instead of authorized_dir. */
    const char *authorized_workers_dir, *authorized_clients_dir, *authorized_admins_dir;
    int insecure;                /* plain text on network endpoints, by explicit choice */
    int task_prefetch;           /* tasks a worker holds beyond its threads, so that a thread
                                  * that finishes finds its next task queued instead of waiting
                                  * for the round trip: -1 as many as it has threads, 0 none */
    int journal;                 /* keep <spool>/journal.db (master/journal.h): a master
                                  * restarted on the spool resumes every unfinished job with
                                  * the pixels of an uninterrupted run; 0 for a master that
                                  * lives and dies with its only client (`prismfarm render`) */
    /* A done job whose outputs cannot be written (a full disk) keeps its image and tries again
     * every JOB_OUTPUT_RETRY_S (1, the daemon's default); 0 fails it at once with the reason,
     * for `prismfarm render`, whose user is waiting for the command to end. */
    int wait_for_space;
    double preview_interval_s;   /* a progressive preview is written after a pass at most this
                                  * often (0: after every pass); the final outputs always */
    /* The web dashboard (docs/dashboard.md): an HTTP port served from this loop. */
    const char *http;            /* "ADDR:PORT" or "PORT" (127.0.0.1); NULL: no dashboard */
    int http_public;             /* let http bind an address other than 127.x (plain HTTP) */
    const char *http_token_file; /* a NAME.token whose holder is an administrator of the
                                  * dashboard's actions (the only way to act without keys) */
    int dashboard_public;        /* every dashboard read open to whoever reaches the port (a
                                  * trusted network); otherwise reads follow the owner rule */
    const char *metrics_token_file; /* a NAME.token whose holder reads /metrics only */
    int verbose;                 /* one line per event on stderr */
    /* Scenes shared with the rest of this process (scene_shelf.h): `prismfarm render`'s local
     * farm, whose client loaded the user's scene already. A submission whose scene is on the
     * shelf under its bundle hash and settings takes it from there, neither loaded again nor
     * checked against budget (the user's own scene, which has none); NULL: none. */
    scene_shelf_t *shelf;
    master_ready_fn ready;       /* may be NULL */
    void *user;
} master_opts_t;

/* Workers on port 5555 and clients on port 5556 of every interface, spool "prismfarm-spool",
 * heartbeat 1000 ms, worker timeout 3 s, sched_config_default() otherwise, proto_limits_default(),
 * 256 unfinished jobs, a worker holding twice its threads in tasks, a preview at most every
 * second, a journal, verbose; no keys and not insecure (so tcp:// endpoints need keys or insecure). */
master_opts_t master_opts_default(void);

/* Every check of a master's options, in one place, without opening anything: what is required
 * (endpoints, spool, stop flag), the heartbeat against the worker timeout, the bundle limit
 * against the message limit, the security choice (keys and authorised folders, or insecure, for
 * each network endpoint; the key files read), the dashboard's options (an address other hosts
 * reach needs http_public; its token and public options need http). -1 with err ("master: "
 * and the option's name). master_open checks them; a command line checks them first, so that a
 * bad configuration exits with status 2 before anything starts. */
int master_check_opts(const master_opts_t *opts, err_t *err);

/* Runs the master until *opts->stop becomes non-zero (returns 0) or a fatal error (returns -1
 * with err: a network endpoint without keys or insecure, an unreadable key or authorised folder,
 * an endpoint that cannot be bound, the spool folder unusable, the ZeroMQ context terminated). The bound endpoints are also written to <spool>/endpoints, one
 * "workers ENDPOINT" and one "clients ENDPOINT" line, for scripts and tests, and with http an
 * "http http://ADDR:PORT/" line (the port as bound). */
int master_run(const master_opts_t *opts, err_t *err);

/* master_run in three steps, for a caller that turns the loop itself (master_run is
 * master_open, master_turn until *opts->stop, master_close). master_open opens everything the
 * loop needs (NULL with err); master_turn is one turn (loop/loop.c lists its duties), -1 with
 * err when the loop cannot go on; master_close closes and frees it all and sets *self_p to
 * NULL. opts must outlive the master. */
typedef struct master master_t;
master_t *master_open(const master_opts_t *opts, err_t *err);
int master_turn(master_t *self, err_t *err);
void master_close(master_t **self_p);

#endif
