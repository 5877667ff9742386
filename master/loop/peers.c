#include "peers.h"

#include "bisect.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_LOST_WORKERS 256 /* lost workers still listed by WORKERS */

mworker_t *peers_find(const master_t *m, const proto_peer_t *p)
{
    for (size_t i = 0; i < m->nworkers; i++)
        if (m->workers[i]->peer.len == p->len && !memcmp(m->workers[i]->peer.id, p->id, p->len))
            return m->workers[i];
    return NULL;
}

mworker_t *peers_add(master_t *m, const proto_peer_t *from)
{
    char who[PROTO_PEER_STR];
    if (m->nworkers == m->cap_workers) {
        size_t cap = m->cap_workers ? 2 * m->cap_workers : 16;
        mworker_t **p = realloc(m->workers, cap * sizeof *p);
        if (!p) {
            master_log(m, "out of memory for worker %s", proto_peer_str(from, who));
            return NULL;
        }
        m->workers = p;
        m->cap_workers = cap;
    }
    mworker_t *w = calloc(1, sizeof *w);
    if (!w) {
        master_log(m, "out of memory for worker %s", proto_peer_str(from, who));
        return NULL;
    }
    w->id = ++m->last_worker;
    w->peer = *from;
    m->workers[m->nworkers++] = w;
    return w;
}

void peers_free(mworker_t *w)
{
    if (w) {
        free(w->name);
        free(w);
    }
}

static int by_sched_id(const void *a, const void *b)
{
    uint64_t x = ((const sched_worker_info_t *)a)->id, y = ((const sched_worker_info_t *)b)->id;
    return (x > y) - (x < y);
}

/* Sorted by id, so that each lookup is a binary search: the listings (WORKERS, the dashboard,
 * /metrics) and every loop turn's peers_agree_with_sched look up each worker in the table, and
 * a linear search made them quadratic in the workers. The scheduler lists them in the order they
 * joined, already sorted when ids are handed out in order: then checking costs one pass. */
size_t peers_sched_table(master_t *m)
{
    size_t n = sched_workers(m->sched, m->winfo, m->cap_winfo);
    if (n > m->cap_winfo) {
        sched_worker_info_t *p = realloc(m->winfo, n * sizeof *p);
        if (!p)
            return m->cap_winfo;
        m->winfo = p;
        m->cap_winfo = n;
        n = sched_workers(m->sched, m->winfo, m->cap_winfo);
    }
    for (size_t i = 1; i < n; i++)
        if (m->winfo[i - 1].id > m->winfo[i].id) {
            qsort(m->winfo, n, sizeof *m->winfo, by_sched_id);
            break;
        }
    return n;
}

static uint64_t winfo_key(const void *winfo, size_t i)
{
    return ((const sched_worker_info_t *)winfo)[i].id;
}

const sched_worker_info_t *peers_sched_info(master_t *m, size_t n, uint64_t id)
{
    size_t i = bisect_lower(m->winfo, n, winfo_key, id);
    return i < n && m->winfo[i].id == id ? &m->winfo[i] : NULL;
}

/* m->workers is in id order: peers_add appends the next id and peers_prune_lost keeps the
 * order. */
static uint64_t worker_key(const void *workers, size_t i)
{
    return ((mworker_t *const *)workers)[i]->id;
}

mworker_t *peers_by_id(const master_t *m, uint64_t id)
{
    size_t i = bisect_lower(m->workers, m->nworkers, worker_key, id);
    return i < m->nworkers && m->workers[i]->id == id ? m->workers[i] : NULL;
}

mworker_t *peers_find_same(const master_t *m, const mworker_t *w)
{
    mworker_t *best = NULL;
    for (size_t i = 0; i < m->nworkers; i++) {
        mworker_t *o = m->workers[i];
        if (o == w || !o->name || !w->name || strcmp(o->name, w->name) != 0 ||
            strcmp(o->key, w->key) != 0)
            continue;
        if (!best || (o->alive && !best->alive) ||
            (o->alive == best->alive && o->last_seen > best->last_seen))
            best = o;
    }
    return best;
}

/* Forgets the lost worker seen longest ago once more than MAX_LOST_WORKERS are listed, so that
 * workers that come and go do not grow the table for ever. Called between loops over the
 * table only, never inside one. */
void peers_prune_lost(master_t *m)
{
    size_t lost = 0, oldest = SIZE_MAX;
    for (size_t i = 0; i < m->nworkers; i++)
        if (!m->workers[i]->alive) {
            lost++;
            if (oldest == SIZE_MAX || m->workers[i]->last_seen < m->workers[oldest]->last_seen)
                oldest = i;
        }
    if (lost <= MAX_LOST_WORKERS)
        return;
    peers_free(m->workers[oldest]);
    memmove(&m->workers[oldest], &m->workers[oldest + 1],
            (m->nworkers - oldest - 1) * sizeof *m->workers);
    m->nworkers--;
}

void peers_lost(master_t *m, mworker_t *w, const char *why)
{
    if (!w->alive)
        return;
    size_t n = peers_sched_table(m);
    const sched_worker_info_t *si = peers_sched_info(m, n, w->id);
    int busy = si ? si->busy : 0;
    /* A dropped connection is the worker's failure (killed, crashed): the tasks it held count
     * as expired (sched_worker_dropped). Silence is not: a loaded machine can be slow to answer. */
    bool dropped = !strcmp(why, PEERS_DISCONNECTED);
    if (dropped)
        sched_worker_dropped(m->sched, w->id);
    else
        sched_worker_leave(m->sched, w->id);
    w->alive = false;
    w->has_unsent = false;
    master_log(m, "worker %llu '%s' lost (%s); %d task%s back in the queue%s",
               (unsigned long long)w->id, w->name, why, busy, busy == 1 ? "" : "s",
               dropped && busy > 0 ? " (counted as expired: on probation, one strike)" : "");
}

int peers_send(master_t *m, mworker_t *w, const proto_msg_t *msg)
{
    err_t err;
    int rc = net_send(m->wnet, &w->peer, msg, &err);
    if (rc == PROTO_EUNREACHABLE)
        peers_lost(m, w, PEERS_DISCONNECTED);
    else if (rc < 0 && rc != PROTO_EAGAIN)
        master_log(m, "cannot send to worker %llu: %s", (unsigned long long)w->id, err.msg);
    return rc;
}

void peers_cancel_job(master_t *m, uint64_t job)
{
    proto_msg_t c = {.type = PROTO_CANCEL, .cancel = {.job = job}};
    for (size_t i = 0; i < m->nworkers; i++) {
        mworker_t *w = m->workers[i];
        if (w->alive && w->has_unsent && w->unsent.job == job)
            w->has_unsent = false;
        if (w->alive)
            (void)peers_send(m, w, &c);
    }
}

void peers_check_silence(master_t *m, double now, double busy)
{
    /* A turn that took long (a big scene loaded, an EXR written) was time the master did not
     * listen: the workers' silence during it says nothing about them. */
    if (busy > 0.5 * m->opts->sched.worker_timeout_s)
        for (size_t i = 0; i < m->nworkers; i++)
            if (m->workers[i]->alive) {
                m->workers[i]->last_seen = now;
                sched_worker_seen(m->sched, m->workers[i]->id, now);
            }
    for (size_t i = 0; i < m->nworkers; i++) {
        mworker_t *w = m->workers[i];
        if (w->alive && now - w->last_seen > m->opts->sched.worker_timeout_s) {
            char why[64];
            snprintf(why, sizeof why, "silent for %.1f s", now - w->last_seen);
            peers_lost(m, w, why);
        }
    }
}

void peers_agree_with_sched(master_t *m)
{
    /* The scheduler's and the master's idea of who is alive must agree. */
    size_t ns = peers_sched_table(m);
    for (size_t i = 0; i < m->nworkers; i++) {
        const sched_worker_info_t *si = peers_sched_info(m, ns, m->workers[i]->id);
        if (m->workers[i]->alive && (!si || !si->alive))
            peers_lost(m, m->workers[i], "timed out");
    }
}

void peers_heartbeat(master_t *m, double now)
{
    if (now - m->last_heartbeat >= m->heartbeat_s) {
        proto_msg_t hb = {.type = PROTO_HEARTBEAT};
        for (size_t i = 0; i < m->nworkers; i++)
            if (m->workers[i]->alive)
                (void)peers_send(m, m->workers[i], &hb);
        m->last_heartbeat = now;
    }
}

/* A window of at least PEERS_RATE_WINDOW_S: the rate is that of the last full window, so it
 * does not jump with each result (a tile's samples arrive at once). */
void peers_count_samples(mworker_t *w, uint64_t samples, double now)
{
    if (w->rate.window_start <= 0)
        w->rate.window_start = now;
    w->rate.window_samples += samples;
    double span = now - w->rate.window_start;
    if (span >= PEERS_RATE_WINDOW_S) {
        w->rate.samples_per_s = (double)w->rate.window_samples / span;
        w->rate.window_start = now;
        w->rate.window_samples = 0;
    }
}

double peers_samples_per_s(const mworker_t *w, double now)
{
    double span = now - w->rate.window_start;
    if (!w->alive || w->rate.window_start <= 0 || span > 2 * PEERS_RATE_WINDOW_S)
        return 0;
    if (w->rate.samples_per_s > 0 && span < PEERS_RATE_WINDOW_S)
        return w->rate.samples_per_s; /* the last full window's */
    /* No full window yet (a worker that just joined, a short job): the current one's, over at
     * least a second so that one early result does not read as a huge rate. */
    return (double)w->rate.window_samples / (span > 1.0 ? span : 1.0);
}

proto_worker_state_t peers_wire_state(const mworker_t *w, const sched_worker_info_t *si)
{
    if (!w->alive)
        return PROTO_WORKER_LOST;
    if (si && si->blocked)
        return PROTO_WORKER_BLOCKED;
    return si && si->busy > 0 ? PROTO_WORKER_BUSY : PROTO_WORKER_IDLE;
}
