#include "on_worker.h"

#include "jobs.h"
#include "merge.h"
#include "ops.h"
#include "peers.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void on_hello(master_t *m, const proto_peer_t *from, mworker_t *w, const proto_msg_t *msg,
                     double now)
{
    bool again = w != NULL;
    char who[PROTO_PEER_STR];
    if (!w && !(w = peers_add(m, from)))
        return;
    char *name = master_strdup(msg->hello.name);
    if (name) {
        free(w->name);
        w->name = name;
    } else if (!w->name) {
        w->name = master_strdup("?");
    }
    w->threads = msg->hello.threads;
    snprintf(w->key, sizeof w->key, "%s", from->user);
    /* Slots beyond the threads: a thread that finishes a tile starts on a queued one while its
     * result travels and the next TASK comes back (docs/performance.md). */
    int prefetch = m->opts->task_prefetch < 0 ? w->threads : m->opts->task_prefetch;
    err_t err;
    if (sched_worker_join(m->sched, w->id, w->threads + prefetch, now, &err) < 0 ||
        sched_worker_set_threads(m->sched, w->id, w->threads, &err) < 0) {
        master_log(m, "worker %s refused: %s", proto_peer_str(from, who), err.msg);
        w->alive = false;
        master_refuse(m, m->wnet, from, err.msg);
        return;
    }
    w->alive = true;
    w->last_seen = now;
    w->has_unsent = false;
    /* The same key and name on a new connection is the same worker (finding 1 of issue 26: a
     * peer that said HELLO again and again, holding each connection's tasks, stalled every
     * job): the old connection's tasks go back to the queue now, and its standing -- credit,
     * probation, strikes, a block -- is the new one's. */
    mworker_t *prev = again ? NULL : peers_find_same(m, w);
    if (prev) {
        int held = sched_worker_take_over(m->sched, w->id, prev->id);
        bool was_alive = prev->alive;
        prev->alive = false;
        prev->has_unsent = false;
        if (was_alive || held > 0)
            master_log(m, "worker %llu '%s' said HELLO again as worker %llu: the old connection "
                          "is dropped, %d task%s back in the queue%s",
                       (unsigned long long)prev->id, w->name, (unsigned long long)w->id, held,
                       held == 1 ? "" : "s",
                       held > 0 ? " (counted as expired: on probation, one strike)" : "");
    }
    ops_worker_joined(m, w);
    proto_msg_t welcome = {
        .type = PROTO_WELCOME,
        .welcome = {.worker_id = w->id, .heartbeat_ms = (uint32_t)m->opts->heartbeat_ms}};
    if (peers_send(m, w, &welcome) == 0)
        master_log(m, "worker %llu '%s' %s from %s with %d thread%s (%s)",
                   (unsigned long long)w->id, w->name, again ? "joined again" : "joined",
                   proto_peer_str(from, who), w->threads, w->threads == 1 ? "" : "s",
                   msg->hello.software);
}

static void on_result(master_t *m, mworker_t *w, const proto_msg_t *msg, double now)
{
    uint64_t job = msg->result.job, task = msg->result.task;
    uint32_t attempt = msg->result.attempt;
    job_t *j = jobs_find(m, job);
    if (!j) {
        master_log(m, "worker %llu sent a result for job %llu, which does not exist",
                   (unsigned long long)w->id, (unsigned long long)job);
        return;
    }
    if (!j->sched.known || task >> 32 != j->sched.round)
        return; /* finished already, or of an earlier round: a late copy of a re-issued task */
    uint32_t t32 = (uint32_t)(task & UINT32_MAX);
    merge_source_t src = {.id = w->id,
                          .name = w->name,
                          .key = w->key,
                          .elapsed = msg->result.stats.elapsed,
                          .samples = msg->result.stats.samples,
                          .wire = msg->wire,
                          .wire_size = msg->wire_size};
    peers_count_samples(w, msg->result.stats.samples, now);
    merge_result(m, j, &src, t32, attempt, msg, now);
    job_refresh(m, j, now);
}

static void on_task_failed(master_t *m, mworker_t *w, const proto_msg_t *msg, double now)
{
    job_t *j = jobs_find(m, msg->task_failed.job);
    if (!j || !j->sched.known || msg->task_failed.task >> 32 != j->sched.round)
        return;
    char label[PROTO_TASK_LABEL_MAX];
    proto_task_label((uint32_t)(msg->task_failed.task & UINT32_MAX), label);
    master_log(m, "job %llu task %s failed on worker %llu '%s': %s", (unsigned long long)j->id,
               label, (unsigned long long)w->id, w->name, msg->task_failed.error);
    tasklog_add(m->tasklog, j->id, "task %s attempt %u failed on worker %llu '%s': %s", label,
                msg->task_failed.attempt, (unsigned long long)w->id, w->name,
                msg->task_failed.error);
    sched_task_failed(m->sched, w->id, j->id, (uint32_t)(msg->task_failed.task & UINT32_MAX),
                      msg->task_failed.attempt, msg->task_failed.error);
    job_refresh(m, j, now);
}

static void on_scene_request(master_t *m, mworker_t *w, const proto_msg_t *msg)
{
    proto_msg_t scene;
    err_t err;
    if (spool_scene_read(m->spool, msg->scene_request.scene, &m->limits, &scene, &err) < 0) {
        master_log(m, "worker %llu asked for scene %.12s: %s", (unsigned long long)w->id,
                   msg->scene_request.scene, err.msg);
        return;
    }
    if (peers_send(m, w, &scene) == 0)
        master_log(m, "scene %.12s sent to worker %llu '%s'", msg->scene_request.scene,
                   (unsigned long long)w->id, w->name);
    proto_msg_free(&scene);
}

/* A worker asks for a job's merged photon store by its hash. */
static void on_store_request(master_t *m, mworker_t *w, const proto_msg_t *msg)
{
    for (size_t i = 0; i < m->njobs; i++) {
        job_t *j = m->jobs[i];
        if (!j->photons.phase || !j->photons.store_ready ||
            strcmp(j->photons.store, msg->store_request.store) != 0)
            continue;
        const uint8_t *data;
        size_t size;
        const char *hash;
        err_t err;
        if (photon_phase_store(j->photons.phase, &data, &size, &hash, &err) < 0) {
            master_log(m, "worker %llu asked for photon store %.12s: %s", (unsigned long long)w->id,
                       msg->store_request.store, err.msg);
            return;
        }
        proto_msg_t out = {.type = PROTO_STORE, .store = {.data = data, .size = size}};
        memcpy(out.store.store, hash, sizeof out.store.store);
        if (peers_send(m, w, &out) == 0)
            master_log(m, "photon store %.12s (%.1f MB) sent to worker %llu '%s'", hash, size / 1e6,
                       (unsigned long long)w->id, w->name);
        return;
    }
    master_log(m, "worker %llu asked for photon store %.12s, which no job has",
               (unsigned long long)w->id, msg->store_request.store);
}

void on_worker_message(master_t *m, const proto_peer_t *from, const proto_msg_t *msg, double now)
{
    mworker_t *w = peers_find(m, from);
    if (msg->type == PROTO_HELLO) {
        on_hello(m, from, w, msg, now);
        return;
    }
    char who[PROTO_PEER_STR];
    if (!w || !w->alive) {
        /* A worker the master forgot (restarted) or gave up on (silent too long): its work is
         * still good, but its slots were handed out again, so it must start afresh. */
        if (w && msg->type == PROTO_RESULT)
            on_result(m, w, msg, now);
        master_log(m, "%s from %s, %s: refused", proto_type_name(msg->type),
                   proto_peer_str(from, who),
                   w ? "a worker given up as lost, which must say HELLO again"
                     : "which has not said HELLO");
        master_refuse(m, m->wnet, from, "unknown worker: send HELLO");
        return;
    }
    w->last_seen = now;
    sched_worker_seen(m->sched, w->id, now);
    switch (msg->type) {
    case PROTO_HEARTBEAT:
        break;
    case PROTO_RESULT:
        on_result(m, w, msg, now);
        break;
    case PROTO_TASK_FAILED:
        on_task_failed(m, w, msg, now);
        break;
    case PROTO_SCENE_REQUEST:
        on_scene_request(m, w, msg);
        break;
    case PROTO_STORE_REQUEST:
        on_store_request(m, w, msg);
        break;
    default: {
        char reason[128];
        snprintf(reason, sizeof reason, "%s is not a message for the master's worker endpoint",
                 proto_type_name(msg->type));
        master_log(m, "%s from worker %s: refused", proto_type_name(msg->type),
                   proto_peer_str(from, who));
        master_refuse(m, m->wnet, from, reason);
    }
    }
}
