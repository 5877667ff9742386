/* loop: the master's loop (master.h): master_open, master_turn (its comment lists a turn's
 * duties), master_close, and master_run, which is the three in a row until *opts->stop. */
#include "master.h"

#include "clock.h"
#include "curve.h"
#include "dash_view.h"
#include "dispatch.h"
#include "files.h"
#include "jobs.h"
#include "logbook.h"
#include "master_state.h"
#include "on_client.h"
#include "on_worker.h"
#include "submit.h"
#include "ops.h"
#include "peers.h"
#include "persist.h"
#include "resume.h"
#include "zap.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <zmq.h>

#define RECV_BURST 1000 /* messages taken from one socket per loop turn */

master_opts_t master_opts_default(void)
{
    master_opts_t o = {
        .worker_endpoint = "tcp://*:5555",
        .client_endpoint = "tcp://*:5556",
        .spool_dir = "prismfarm-spool",
        .heartbeat_ms = 1000,
        .sched = sched_config_default(),
        .limits = proto_limits_default(),
        .task_prefetch = -1,
        .preview_interval_s = 1.0,
        .max_jobs = 256,
        .wait_for_space = 1,
        .max_conns_per_host = 512,
        .budget = scene_budget_default(),
        .journal = 1,
        .verbose = 1,
    };
    /* farm.md: a worker silent for 10 s (at least 3 heartbeat intervals, zguide's liveness 3)
     * is dead; a loaded host's worker can be silent for seconds without being gone. */
    o.sched.worker_timeout_s = 10.0;
    return o;
}

/* Takes what one socket holds (at most RECV_BURST messages). Returns -1 with err when the
 * socket is unusable. */
static int drain(master_t *m, bool workers, err_t *err)
{
    net_t *net = workers ? m->wnet : m->cnet;
    for (int k = 0; k < RECV_BURST; k++) {
        proto_peer_t from;
        proto_msg_t msg;
        err_t rerr;
        int rc = net_recv(net, &from, &msg, 0, &rerr);
        if (rc == PROTO_EAGAIN)
            return 0;
        if (rc == PROTO_ESOCKET)
            return err_set(err, "%s socket: %s", workers ? "workers" : "clients", rerr.msg);
        if (rc == PROTO_EVERSION) {
            err_t text;
            char who[PROTO_PEER_STR];
            proto_msg_t refuse = proto_refuse_version(msg.version, "master", &text);
            master_log(m, "%s %s speaks protocol version %d: refused",
                       workers ? "worker" : "client", proto_peer_str(&from, who), msg.version);
            if (from.len > 0 && net_send(net, &from, &refuse, &rerr) < 0)
                master_log(m, "cannot send REFUSE: %s", rerr.msg);
            continue;
        }
        if (rc < 0) {
            char reason[600];
            master_log(m, "malformed message on the %s endpoint %s",
                       workers ? "workers" : "clients", rerr.msg);
            snprintf(reason, sizeof reason, "malformed message: %s", rerr.msg);
            master_refuse(m, net, &from, reason);
            continue;
        }
        double now = clock_now_s();
        if (workers)
            on_worker_message(m, &from, &msg, now);
        else
            on_client_message(m, &from, &msg, now);
        proto_msg_free(&msg);
    }
    return 0;
}

/* Dead workers, missed deadlines and heartbeats: the clock-driven part of a loop turn. busy is
 * how long this turn's messages took to handle. */
static void housekeeping(master_t *m, double now, double busy)
{
    peers_check_silence(m, now, busy);
    int requeued = sched_tick(m->sched, now);
    if (requeued > 0)
        master_log(m, "%d task%s past the %.0f s deadline issued again", requeued,
                   requeued == 1 ? "" : "s", m->opts->sched.task_deadline_s);
    peers_agree_with_sched(m);
    jobs_enforce_time_limits(m, now);
    jobs_retry_outputs(m, now);
    persist_checkpoints_collect(m, now);
    peers_heartbeat(m, now);
    ops_turn(m);
}

/* Clients send one request at a time: a few queued per connection is plenty, and the bound
 * keeps what one connection can make the master buffer to this many messages (each at most
 * limits.max_message_bytes). */
#define CLIENT_RCVHWM 4

static void guard_log(void *user, const char *line)
{
    master_log(user, "%s", line);
}

/* A bound ROUTER, watched by a connection guard (*guard) from before it binds; with secret_key
 * a CURVE server whose ZAP domain names the endpoint. */
static net_t *open_router(master_t *m, void *ctx, const char *what, const char *endpoint,
                          const char *secret_key, char *bound, size_t size, conn_guard_t **guard,
                          err_t *err)
{
    net_options_t no = net_options_default();
    no.limits = m->limits;
    no.curve.secret_key = secret_key;
    no.curve.zap_domain = secret_key ? what : NULL;
    if (!strcmp(what, "clients"))
        no.rcvhwm = CLIENT_RCVHWM;
    net_t *net = net_new(ctx, NET_ROUTER, &no, err);
    if (!net) {
        err_prefix(err, "%s endpoint: ", what);
        return NULL;
    }
    conn_guard_config_t gc = {.max_per_host = m->opts->max_conns_per_host,
                              .max_total = m->max_conns,
                              .handshake_bytes = secret_key ? CONN_GUARD_CURVE_HANDSHAKE
                                                            : CONN_GUARD_NULL_HANDSHAKE};
    if (!(*guard = conn_guard_new(ctx, net_socket(net), what, &gc, guard_log, m, err)) ||
        net_bind(net, endpoint, err) < 0 || net_endpoint(net, bound, size, err) < 0) {
        err_prefix(err, "%s endpoint: ", what);
        conn_guard_destroy(guard);
        net_destroy(&net);
        return NULL;
    }
    return net;
}

/* Descriptors kept for the spool, the journal, outputs and libzmq's own when the connections
 * are bounded by the file limit. */
#define FD_RESERVE 256

/* Raises the soft file limit to the hard one (Debian's default soft limit of 1024 is what a
 * flood of idle connections exhausted) and returns the connections each endpoint may hold:
 * half of what is left after the reserve. */
static int file_limit_raise(master_t *m)
{
    struct rlimit rl;
    if (getrlimit(RLIMIT_NOFILE, &rl) != 0)
        return 512;
    if (rl.rlim_cur < rl.rlim_max) {
        struct rlimit want = {.rlim_cur = rl.rlim_max, .rlim_max = rl.rlim_max};
        if (rl.rlim_max == RLIM_INFINITY || rl.rlim_max > 1048576)
            want.rlim_cur = 1048576;
        if (setrlimit(RLIMIT_NOFILE, &want) == 0)
            rl.rlim_cur = want.rlim_cur;
    }
    rlim_t n = rl.rlim_cur == RLIM_INFINITY ? 1048576 : rl.rlim_cur;
    int per = n > 2 * FD_RESERVE ? (int)((n - FD_RESERVE) / 2) : 64;
    master_log(m, "file limit %llu: at most %d connections per endpoint, %d from one host",
               (unsigned long long)n, per, m->opts->max_conns_per_host);
    return per;
}

int master_check_opts(const master_opts_t *o, err_t *err)
{
    if (!o || !o->worker_endpoint || !o->client_endpoint || !o->spool_dir || !o->stop)
        return err_set(
            err, "master: worker and client endpoints, spool folder and stop flag are required");
    if (o->heartbeat_ms < 1 || o->heartbeat_ms > 3600000)
        return err_set(err, "master: heartbeat %d ms is outside 1..3600000", o->heartbeat_ms);
    if (o->max_jobs < 1)
        return err_set(err, "master: max_jobs is 0: no job could ever be submitted");
    /* A worker silent between two heartbeats is not gone (farm.md, "Workers"). */
    double interval_s = o->heartbeat_ms / 1000.0;
    if (o->sched.worker_timeout_s < 2.0 * interval_s)
        return err_set(err,
                       "master: --worker-timeout %g s is shorter than 2 heartbeat intervals (%g "
                       "s): every worker would be lost between two heartbeats",
                       o->sched.worker_timeout_s, 2.0 * interval_s);
    if (o->limits.max_bundle_bytes > o->limits.max_message_bytes)
        return err_set(err,
                       "master: --max-bundle-mb %zu exceeds --max-message-mb %zu: a bundle "
                       "travels in one message",
                       o->limits.max_bundle_bytes >> 20, o->limits.max_message_bytes >> 20);
    bool roles = o->authorized_workers_dir || o->authorized_clients_dir || o->authorized_admins_dir;
    if (roles && o->authorized_dir)
        return err_set(err, "master: --authorized DIR lets keys in on both endpoints; give it or "
                            "the role folders (--authorized-workers, --authorized-clients), not "
                            "both");
    if (roles && (!o->authorized_workers_dir || !o->authorized_clients_dir))
        return err_set(err, "master: the role folders need both --authorized-workers DIR and "
                            "--authorized-clients DIR");
    if (!o->key_file != !(o->authorized_dir || roles))
        return err_set(err, "master: %s",
                       o->key_file ? "--key needs --authorized DIR, the public keys let in: "
                                     "without it any peer that knows our public key would be let in"
                                   : "--authorized needs --key FILE, the master's own key pair");
    const char *how = "the master --key FILE and --authorized DIR";
    if (curve_require(o->worker_endpoint, o->key_file, o->insecure, how, err) < 0 ||
        curve_require(o->client_endpoint, o->key_file, o->insecure, how, err) < 0 ||
        dash_view_check(o, err) < 0)
        return err_prefix(err, "master: ");
    /* The keys are read here too, so that a wrong file is a bad configuration, told before
     * anything starts, not a failure of a running master. */
    if (o->key_file) {
        curve_pair_t pair;
        curve_ring_t *ring = NULL;
        const char *dirs[] = {o->authorized_dir, o->authorized_workers_dir,
                              o->authorized_clients_dir, o->authorized_admins_dir};
        int bad = curve_load_pair(o->key_file, &pair, err) < 0;
        for (size_t i = 0; !bad && i < sizeof dirs / sizeof *dirs; i++) {
            bad = dirs[i] && !(ring = curve_ring_new(dirs[i], err));
            curve_ring_destroy(&ring);
        }
        memset(&pair, 0, sizeof pair);
        if (bad)
            return err_prefix(err, "master: ");
    }
    return 0;
}

static void zap_log(void *user, const char *line)
{
    const master_t *m = user;
    if (m->opts->verbose)
        fprintf(stderr, "master: %s\n", line);
}

/* master_open: everything the loop turns over, in the order it needs it -- the options checked,
 * the ZAP handler (before any CURVE server, which would otherwise let every client in), the
 * spool, the task logs, the scheduler, the journal with its jobs resumed, the loader thread, the
 * two ROUTERs with their connection guards, the dashboard -- and the bound endpoints written to
 * <spool>/endpoints and handed to opts->ready. NULL with err; what was opened is closed. */
master_t *master_open(const master_opts_t *opts, err_t *err)
{
    if (master_check_opts(opts, err) < 0)
        return NULL;
    master_t *m = calloc(1, sizeof *m);
    if (!m) {
        err_set(err, "master: out of memory");
        return NULL;
    }
    m->opts = opts;
    m->limits = opts->limits;
    m->heartbeat_s = opts->heartbeat_ms / 1000.0;
    m->ctx = opts->zmq_ctx ? opts->zmq_ctx : zmq_ctx_new();
    char wbound[512] = "", cbound[512] = "";
    curve_pair_t keys = {0};
    if (!m->ctx) {
        err_set(err, "master: zmq_ctx_new: %s", zmq_strerror(zmq_errno()));
        goto fail;
    }
    /* The handler first: a CURVE server bound without one would let in every client. */
    if (opts->key_file &&
        (curve_load_pair(opts->key_file, &keys, err) < 0 ||
         !(m->zap = zap_new(m->ctx,
                            &(zap_folders_t){.any = opts->authorized_dir,
                                             .workers = opts->authorized_workers_dir,
                                             .clients = opts->authorized_clients_dir,
                                             .admins = opts->authorized_admins_dir},
                            zap_log, m, err)))) {
        err_prefix(err, "master: ");
        goto fail;
    }
    if (!(m->spool = spool_new(opts->spool_dir, err))) {
        err_prefix(err, "master: spool: ");
        goto fail;
    }
    m->last_job = spool_last_job_id(m->spool);
    if (!(m->tasklog = tasklog_new(spool_path(m->spool), TASKLOG_MAX_BYTES, err))) {
        err_prefix(err, "master: ");
        goto fail;
    }
    if (!(m->sched = sched_new(&opts->sched, err))) {
        err_prefix(err, "master: ");
        goto fail;
    }
    if (opts->journal) {
        if (!(m->journal = journal_open(spool_path(m->spool), err)) || ops_load_blocked(m, err) < 0 ||
            resume_jobs(m, err) < 0) {
            err_prefix(err, "master: ");
            goto fail;
        }
    }
    if (!(m->loader = loader_new(err))) {
        err_prefix(err, "master: ");
        goto fail;
    }
    const char *secret = opts->key_file ? keys.secret_key : NULL;
    m->max_conns = opts->max_conns > 0 ? opts->max_conns : file_limit_raise(m);
    if (!(m->wnet = open_router(m, m->ctx, "workers", opts->worker_endpoint, secret, wbound,
                                sizeof wbound, &m->wguard, err)) ||
        !(m->cnet = open_router(m, m->ctx, "clients", opts->client_endpoint, secret, cbound,
                                sizeof cbound, &m->cguard, err)))
        goto fail;
    if (m->zap && opts->authorized_dir)
        master_log(m, "CURVE: public key %s; %zu keys authorised in %s", keys.public_key,
                   zap_stats(m->zap).keys, opts->authorized_dir);
    else if (m->zap)
        master_log(m, "CURVE: public key %s; %zu keys authorised: workers in %s, clients in %s%s%s",
                   keys.public_key, zap_stats(m->zap).keys, opts->authorized_workers_dir,
                   opts->authorized_clients_dir,
                   opts->authorized_admins_dir ? ", admins in " : "",
                   opts->authorized_admins_dir ? opts->authorized_admins_dir : "");
    else if (opts->insecure)
        master_log(m, "plain text (--insecure): anyone who reaches the endpoints can connect");
    memset(&keys, 0, sizeof keys); /* the servers hold their copy */
    char hbound[128] = "";
    if (opts->http && (!(m->logbook = logbook_new()) ||
                       !(m->dash = dash_view_open(m, hbound, sizeof hbound, err)))) {
        if (!m->logbook)
            err_set(err, "out of memory for the dashboard's log");
        err_prefix(err, "master: ");
        goto fail;
    }
    char text[1400], path[PATH_MAX];
    snprintf(text, sizeof text, "workers %s\nclients %s\n", wbound, cbound);
    if (m->dash)
        snprintf(text + strlen(text), sizeof text - strlen(text), "http %s\n", hbound);
    snprintf(path, sizeof path, "%s/endpoints", spool_path(m->spool));
    if (files_write_atomic(path, text, strlen(text), true, err) < 0) {
        err_prefix(err, "master: ");
        goto fail;
    }
    master_log(m, "workers on %s, clients on %s, spool %s, next job %llu", wbound, cbound,
               spool_path(m->spool), (unsigned long long)m->last_job + 1);
    if (m->dash)
        master_log(m, "dashboard on %s", hbound);
    if (opts->ready)
        opts->ready(opts->user, wbound, cbound);
    m->last_heartbeat = clock_now_s();
    m->until_waiter = POLL_MS;
    return m;

fail:
    memset(&keys, 0, sizeof keys);
    master_close(&m);
    return NULL;
}

/* master_turn: one turn of the master's loop (Redis's aeProcessEvents and serverCron in one).
 * Each turn, in this order:
 *  - waits at most POLL_MS (less when a heartbeat, a long poll's deadline or the dashboard is
 *    due) on the two sockets, the stop descriptor and the dashboard's descriptor;
 *  - opens the journal's turn: the turn's results go into one transaction;
 *  - drains each socket (at most RECV_BURST messages) into on_worker / on_client;
 *  - answers the dashboard's requests;
 *  - pumps the connection guards (the endpoints' per-host and total bounds);
 *  - finishes the submissions the loader thread has loaded, and tells the others' clients
 *    that their scene is still loading;
 *  - housekeeping: silent workers lost, deadlines passed (tasks issued again), the worker
 *    table and the scheduler agreed, time limits, outputs retried, checkpoints collected,
 *    heartbeats, the operators' task-log lines;
 *  - dispatches tasks into every live worker's free slots;
 *  - forgets the lost workers beyond the table's bound;
 *  - answers the long polls that are due;
 *  - commits the journal's turn.
 * Returns 0, or -1 with err when a socket or the dashboard is unusable (the loop ends). */
int master_turn(master_t *m, err_t *err)
{
    const master_opts_t *opts = m->opts;
    /* The stop descriptor, when given, ends the wait as soon as *stop is set; the
     * dashboard's epoll descriptor, when it is on, as soon as a request comes. */
    zmq_pollitem_t items[4] = {{.socket = net_socket(m->wnet), .events = ZMQ_POLLIN},
                               {.socket = net_socket(m->cnet), .events = ZMQ_POLLIN}};
    int nitems = 2;
    if (opts->stop_fd > 0)
        items[nitems++] = (zmq_pollitem_t){.fd = opts->stop_fd, .events = ZMQ_POLLIN};
    if (m->dash)
        items[nitems++] = (zmq_pollitem_t){.fd = dash_view_fd(m->dash), .events = ZMQ_POLLIN};
    double until_hb = m->last_heartbeat + m->heartbeat_s - clock_now_s();
    int timeout = until_hb < POLL_MS / 1000.0 ? (int)(until_hb * 1000) : POLL_MS;
    if (m->until_waiter < timeout)
        timeout = m->until_waiter;
    if (m->dash)
        timeout = dash_view_timeout_ms(m->dash, timeout);
    int n = zmq_poll(items, nitems, timeout > 0 ? timeout : 0);
    double polled = clock_now_s();
    if (m->journal)
        journal_turn_begin(m->journal);
    if (n < 0 && zmq_errno() != EINTR)
        return err_set(err, "master: zmq_poll: %s", zmq_strerror(zmq_errno()));
    if (n > 0 && (((items[0].revents & ZMQ_POLLIN) && drain(m, true, err) < 0) ||
                  ((items[1].revents & ZMQ_POLLIN) && drain(m, false, err) < 0)))
        return err_prefix(err, "master: ");
    /* The dashboard's requests, answered on this thread (its handlers are quick: they
     * read the state, or act as a client's message would). */
    if (m->dash && dash_view_run(m->dash, err) < 0)
        return err_prefix(err, "master: ");
    conn_guard_pump(m->wguard);
    conn_guard_pump(m->cguard);
    double now = clock_now_s();
    submit_loads(m, now);
    housekeeping(m, now, now - polled);
    dispatch_tasks(m, now);
    peers_prune_lost(m);
    m->until_waiter = on_client_answer_waiters(m, now);
    err_t jerr;
    if (m->journal && journal_turn_end(m->journal, &jerr) < 0)
        master_log(m, "journal: the results of a loop turn were not journaled (they are "
                      "rendered again after a restart): %s", jerr.msg);
    return 0;
}

/* master_close: everything master_open opened, closed in the order the ZAP handler needs (the
 * guards before the sockets they watch, the sockets before the handler, the context last), then
 * the loader waited for (a submission not finished is dropped), the checkpoints being written
 * collected or dropped, and the state freed. NULL is fine. */
void master_close(master_t **self_p)
{
    master_t *m = self_p ? *self_p : NULL;
    if (!m)
        return;
    dash_view_close(&m->dash);
    logbook_destroy(&m->logbook);
    conn_guard_destroy(&m->wguard); /* before the sockets they watch */
    conn_guard_destroy(&m->cguard);
    net_destroy(&m->wnet);
    net_destroy(&m->cnet);
    zap_destroy(&m->zap); /* after the servers it guards */
    if (m->ctx && !m->opts->zmq_ctx)
        (void)zmq_ctx_term(m->ctx);
    /* Waits for a scene still loading, and drops the submissions not finished. */
    loader_destroy(&m->loader, submit_drop);
    /* A checkpoint written meanwhile is journaled; one still being written is waited for and
     * dropped (the journal names the previous one). */
    if (m->journal)
        persist_checkpoints_collect(m, clock_now_s());
    for (size_t i = 0; i < m->njobs; i++)
        persist_checkpoint_drop(m, m->jobs[i]);
    free(m->loading);
    sched_destroy(&m->sched);
    tasklog_destroy(&m->tasklog);
    ops_free(m);
    journal_close(&m->journal);
    spool_destroy(&m->spool);
    for (size_t i = 0; i < m->nworkers; i++)
        peers_free(m->workers[i]);
    free(m->workers);
    for (size_t i = 0; i < m->njobs; i++)
        job_destroy(&m->jobs[i]);
    free(m->jobs);
    free(m->winfo);
    free(m);
    *self_p = NULL;
}

int master_run(const master_opts_t *opts, err_t *err)
{
    master_t *m = master_open(opts, err);
    if (!m)
        return -1;
    int rc = 0;
    while (rc == 0 && !*opts->stop)
        rc = master_turn(m, err);
    if (rc == 0)
        master_log(m, "stopping");
    master_close(&m);
    return rc;
}
