#include "ops.h"

#include "access.h"
#include "clock.h"
#include "jobs.h"
#include "peers.h"
#include "persist.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* How a key shows in logs. */
static const char *who_name(const master_actor_t *who)
{
    return who && who->name && who->name[0] ? who->name : "(no key)";
}

master_actor_t ops_actor_of_peer(const master_t *m, const proto_peer_t *peer)
{
    return (master_actor_t){.name = peer->user,
                            .admin = access_peer_is_admin(peer) || !m->opts->key_file};
}

bool ops_may_act(const master_t *m, const job_t *j, const master_actor_t *who, err_t *err)
{
    (void)m;
    if (access_allowed(j->owner, who->name ? who->name : "", who->admin))
        return true;
    err_set(err,
            "job %llu belongs to %s%s%s: only its owner or an admin (--authorized-admins) may "
            "change it",
            (unsigned long long)j->id, j->owner[0] ? "'" : "",
            j->owner[0] ? j->owner : "nobody (it was submitted without keys)",
            j->owner[0] ? "'" : "");
    return false;
}

_Static_assert(SCHED_PHOTON_TASK == PROTO_PHOTON_TASK, "one numbering of photon tasks");

/* "task 17 (pass 0, tile 17)", "task p2 (photon batch 2)". */
static const char *task_str(const job_t *j, uint32_t task, char *buf, size_t size)
{
    char label[PROTO_TASK_LABEL_MAX];
    if (task & SCHED_PHOTON_TASK)
        snprintf(buf, size, "task %s (photon batch %u)", proto_task_label(task, label),
                 task & ~SCHED_PHOTON_TASK);
    else if (j && j->sched.ntiles > 0)
        snprintf(buf, size, "task %u (pass %u, tile %u)", task, task / (uint32_t)j->sched.ntiles,
                 task % (uint32_t)j->sched.ntiles);
    else
        snprintf(buf, size, "task %u", task);
    return buf;
}

/* The job, if it exists, who may act on it and it is still in the scheduler. */
static job_t *job_to_act_on(master_t *m, uint64_t id, const master_actor_t *who,
                             const char *what, err_t *err)
{
    job_t *j = jobs_find(m, id);
    if (!j) {
        err_set(err, "no job %llu", (unsigned long long)id);
        return NULL;
    }
    if (!ops_may_act(m, j, who, err)) {
        master_log(m, "%s of job %llu by %s refused: %s", what, (unsigned long long)id,
                   who_name(who), err->msg);
        return NULL;
    }
    if (job_over(j) || !j->sched.known) {
        err_set(err, "job %llu is %s: only a queued or running job can be changed",
                (unsigned long long)id, proto_job_state_name(j->state));
        return NULL;
    }
    return j;
}

static void journal_control(master_t *m, job_t *j)
{
    err_t err;
    if (m->journal &&
        journal_set_control(m->journal, j->id, j->ops.priority, j->ops.paused, &err) < 0)
        persist_failed(m, j, &err);
}

/* What master_job_set_priority, _pause and _resume do to a frame sequence (docs/farm.md,
 * "Frame sequences"): the same to each of its frames that is not over, a frame already paused
 * or resumed passed over; the first other failure is the answer. */
typedef enum seq_act { SEQ_PRIORITY, SEQ_PAUSE, SEQ_RESUME } seq_act_t;
static int act_on_frames(master_t *m, job_t *seq, seq_act_t act, int priority,
                         const master_actor_t *who, err_t *err)
{
    if (!ops_may_act(m, seq, who, err))
        return -1;
    int acted = 0;
    for (uint32_t k = 0; k < seq->seq.nframes; k++) {
        job_t *f = jobs_frame(m, seq, k);
        if (!f || job_over(f) || !f->sched.known)
            continue;
        int r = act == SEQ_PRIORITY ? master_job_set_priority(m, f->id, priority, who, err)
                : act == SEQ_PAUSE  ? (f->ops.paused ? 0 : master_job_pause(m, f->id, who, err))
                                    : (!f->ops.paused ? 0 : master_job_resume(m, f->id, who, err));
        if (r < 0)
            return err_prefix(err, "frame %u: ", f->seq.frame);
        acted++;
    }
    if (acted == 0)
        return err_set(err, "job %llu is %s: only a queued or running job can be changed",
                       (unsigned long long)seq->id, proto_job_state_name(seq->state));
    if (act == SEQ_PRIORITY)
        seq->ops.priority = priority;
    jobs_sequence_refresh(m, seq, clock_now_s()); /* its pause follows its frames' */
    journal_control(m, seq);
    return 0;
}

static job_t *sequence_of(const master_t *m, uint64_t id)
{
    job_t *j = jobs_find(m, id);
    return j && j->seq.nframes > 0 ? j : NULL;
}

int master_job_set_priority(master_t *m, uint64_t id, int priority, const master_actor_t *who,
                            err_t *err)
{
    job_t *seq = sequence_of(m, id);
    if (seq)
        return act_on_frames(m, seq, SEQ_PRIORITY, priority, who, err);
    job_t *j = job_to_act_on(m, id, who, "a priority change", err);
    if (!j || sched_set_job_priority(m->sched, id, priority, err) < 0)
        return -1;
    int old = j->ops.priority;
    j->ops.priority = priority;
    journal_control(m, j);
    master_log(m, "job %llu priority %d -> %d by %s", (unsigned long long)id, old, priority,
               who_name(who));
    tasklog_add(m->tasklog, id, "job priority %d -> %d by %s", old, priority, who_name(who));
    return 0;
}

static int set_paused(master_t *m, uint64_t id, bool paused, const master_actor_t *who,
                      err_t *err)
{
    job_t *j = job_to_act_on(m, id, who, paused ? "a pause" : "a resume", err);
    if (!j)
        return -1;
    if (j->ops.paused == paused)
        return err_set(err, "job %llu is %s already", (unsigned long long)id,
                       paused ? "paused" : "not paused");
    if (sched_pause_job(m->sched, id, paused, clock_now_s(), err) < 0)
        return -1;
    j->ops.paused = paused;
    journal_control(m, j);
    sched_job_info_t info;
    uint32_t running = sched_job_info(m->sched, id, &info) == 0 ? info.tasks_running : 0;
    if (paused) {
        master_log(m, "job %llu paused by %s (%u tasks running finish first)",
                   (unsigned long long)id, who_name(who), running);
        tasklog_add(m->tasklog, id, "job paused by %s: %u running tasks finish, no more start",
                    who_name(who), running);
    } else {
        master_log(m, "job %llu resumed by %s", (unsigned long long)id, who_name(who));
        tasklog_add(m->tasklog, id, "job resumed by %s", who_name(who));
    }
    return 0;
}

int master_job_pause(master_t *m, uint64_t id, const master_actor_t *who, err_t *err)
{
    job_t *seq = sequence_of(m, id);
    return seq ? act_on_frames(m, seq, SEQ_PAUSE, 0, who, err) : set_paused(m, id, true, who, err);
}

int master_job_resume(master_t *m, uint64_t id, const master_actor_t *who, err_t *err)
{
    job_t *seq = sequence_of(m, id);
    return seq ? act_on_frames(m, seq, SEQ_RESUME, 0, who, err)
               : set_paused(m, id, false, who, err);
}

int master_task_requeue(master_t *m, uint64_t id, uint32_t task, const master_actor_t *who,
                        err_t *err)
{
    job_t *j = job_to_act_on(m, id, who, "a requeue", err);
    if (!j || sched_requeue_task(m->sched, id, task, err) < 0)
        return -1;
    char t[80];
    master_log(m, "job %llu %s requeued by %s", (unsigned long long)id,
               task_str(j, task, t, sizeof t), who_name(who));
    tasklog_add(m->tasklog, id, "%s requeued by %s", task_str(j, task, t, sizeof t),
                who_name(who));
    return 0;
}

/* ---------------------------------------------------------------- the blocklist */

static size_t blocked_index(const master_t *m, const char *name)
{
    for (size_t i = 0; i < m->blocked.n; i++)
        if (!strcmp(m->blocked.names[i], name))
            return i;
    return SIZE_MAX;
}

/* Whether a blocklist entry names the worker: its name, or "key:NAME" for its key. */
static bool entry_names(const char *entry, const mworker_t *w)
{
    if (!strncmp(entry, OPS_KEY_PREFIX, strlen(OPS_KEY_PREFIX)))
        return w->key[0] && !strcmp(entry + strlen(OPS_KEY_PREFIX), w->key);
    return w->name && !strcmp(entry, w->name);
}

bool ops_worker_blocked(const master_t *m, const mworker_t *w)
{
    for (size_t i = 0; i < m->blocked.n; i++)
        if (entry_names(m->blocked.names[i], w))
            return true;
    return false;
}

void ops_block_entry(const mworker_t *w, char *buf, size_t size)
{
    if (w->key[0])
        snprintf(buf, size, "%s%s", OPS_KEY_PREFIX, w->key);
    else
        snprintf(buf, size, "%s", w->name ? w->name : "?");
}

static int block_name(master_t *m, const char *name)
{
    if (blocked_index(m, name) != SIZE_MAX)
        return 0;
    if (m->blocked.n == m->blocked.cap) {
        size_t cap = m->blocked.cap ? 2 * m->blocked.cap : 8;
        char **p = realloc(m->blocked.names, cap * sizeof *p);
        if (!p)
            return -1;
        m->blocked.names = p;
        m->blocked.cap = cap;
    }
    char *copy = master_strdup(name);
    if (!copy)
        return -1;
    m->blocked.names[m->blocked.n++] = copy;
    return 0;
}

static void load_one(void *user, const char *name, const char *reason)
{
    master_t *m = user;
    if (block_name(m, name) == 0)
        master_log(m, "worker '%s' is blocked (%s): `prismfarm unblock %s` lifts it", name,
                   reason, name);
}

int ops_load_blocked(master_t *m, err_t *err)
{
    return m->journal ? journal_blocked(m->journal, load_one, m, err) : 0;
}

void ops_free(master_t *m)
{
    for (size_t i = 0; i < m->blocked.n; i++)
        free(m->blocked.names[i]);
    free(m->blocked.names);
    m->blocked.names = NULL;
    m->blocked.n = m->blocked.cap = 0;
}

void ops_worker_joined(master_t *m, mworker_t *w)
{
    err_t err;
    /* The hint names the entry as `unblock` takes it: "key:NAME" for a key's block. */
    const char *entry = NULL;
    for (size_t i = 0; i < m->blocked.n && !entry; i++)
        if (entry_names(m->blocked.names[i], w))
            entry = m->blocked.names[i];
    if (entry && sched_worker_block(m->sched, w->id, true, &err) == 0)
        master_log(m,
                   "worker %llu '%s' is on the blocklist: it gets no task until "
                   "`prismfarm unblock %s`",
                   (unsigned long long)w->id, w->name, entry);
}

/* A worker's name from its name or the id `prismfarm workers` shows. */
static const char *worker_name_of(const master_t *m, const char *worker)
{
    char *end;
    errno = 0;
    unsigned long long id = strtoull(worker, &end, 10);
    if (!errno && end != worker && !*end && worker[0] != '-') {
        const mworker_t *w = peers_by_id(m, id);
        if (w && w->name)
            return w->name;
    }
    return worker;
}

int master_worker_block(master_t *m, const char *worker, const master_actor_t *who, err_t *err)
{
    if (!who->admin) {
        master_log(m, "block of worker '%s' by %s refused: not an admin", worker, who_name(who));
        return err_set(err, "only an admin may block a worker (it serves every owner's jobs)");
    }
    const char *name = worker_name_of(m, worker);
    bool known = false;
    for (size_t i = 0; i < m->nworkers; i++)
        known = known || (m->workers[i]->name && !strcmp(m->workers[i]->name, name));
    if (!known)
        return err_set(err, "no worker '%s'", worker);
    if (block_name(m, name) < 0)
        return err_set(err, "the master is out of memory");
    for (size_t i = 0; i < m->nworkers; i++)
        if (m->workers[i]->name && !strcmp(m->workers[i]->name, name)) {
            err_t ignore;
            (void)sched_worker_block(m->sched, m->workers[i]->id, true, &ignore);
        }
    char reason[160];
    snprintf(reason, sizeof reason, "blocked by %s", who_name(who));
    err_t jerr;
    if (m->journal && journal_set_blocked(m->journal, name, reason, &jerr) < 0)
        master_log(m, "journal: %s (a restarted master would not block '%s')", jerr.msg, name);
    master_log(m, "worker '%s' blocked from every job by %s", name, who_name(who));
    return 0;
}

int master_worker_unblock(master_t *m, const char *worker, const master_actor_t *who, err_t *err)
{
    if (!who->admin) {
        master_log(m, "unblock of worker '%s' by %s refused: not an admin", worker,
                   who_name(who));
        return err_set(err, "only an admin may unblock a worker (it serves every owner's jobs)");
    }
    const char *name = worker_name_of(m, worker);
    size_t k = blocked_index(m, name);
    /* A worker blocked through its key ("key:NAME", from its strikes) stays blocked until that
     * entry goes: lifting its name would last until its next HELLO, so the answer names the
     * entry as this command takes it. */
    for (size_t i = 0; i < m->nworkers && k == SIZE_MAX; i++) {
        const mworker_t *w = m->workers[i];
        if (!w->name || strcmp(w->name, name) || !w->key[0])
            continue;
        for (size_t b = 0; b < m->blocked.n; b++)
            if (!strncmp(m->blocked.names[b], OPS_KEY_PREFIX, strlen(OPS_KEY_PREFIX)) &&
                entry_names(m->blocked.names[b], w))
                return err_set(err, "worker '%s' is blocked with its key: `prismfarm unblock %s`",
                               worker, m->blocked.names[b]);
    }
    bool any = k != SIZE_MAX;
    size_t ns = peers_sched_table(m);
    for (size_t i = 0; i < m->nworkers; i++) {
        mworker_t *w = m->workers[i];
        if (!entry_names(name, w))
            continue;
        const sched_worker_info_t *si = peers_sched_info(m, ns, w->id);
        any = any || (si && (si->blocked || si->blocked_jobs > 0));
        err_t ignore;
        (void)sched_worker_block(m->sched, w->id, false, &ignore);
    }
    if (!any)
        return err_set(err, "worker '%s' is not blocked (from any job)", worker);
    if (k != SIZE_MAX) {
        free(m->blocked.names[k]);
        m->blocked.names[k] = m->blocked.names[--m->blocked.n];
        err_t jerr;
        if (m->journal && journal_set_blocked(m->journal, name, NULL, &jerr) < 0)
            master_log(m, "journal: %s (a restarted master would block '%s' again)", jerr.msg,
                       name);
    }
    master_log(m, "worker '%s' unblocked by %s", name, who_name(who));
    return 0;
}

/* ---------------------------------------------------------------- jobs and events */

void ops_job_init(job_t *j, int priority)
{
    j->ops.priority = priority;
    j->ops.paused = false;
}

static void log_event(master_t *m, const sched_event_t *ev)
{
    job_t *j = jobs_find(m, ev->job);
    const mworker_t *w = peers_by_id(m, ev->worker);
    const char *wname = w && w->name ? w->name : "?";
    unsigned long long wid = (unsigned long long)ev->worker;
    char t[80];
    task_str(j, ev->task, t, sizeof t);
    switch (ev->kind) {
    case SCHED_EV_REQUEUED_DEADLINE:
        tasklog_add(m->tasklog, ev->job,
                    "%s attempt %u missed its deadline on worker %llu '%s': issued again", t,
                    ev->attempt, wid, wname);
        break;
    case SCHED_EV_REQUEUED_LOST:
        tasklog_add(m->tasklog, ev->job,
                    "%s attempt %u: worker %llu '%s' was lost holding it: issued again", t,
                    ev->attempt, wid, wname);
        break;
    case SCHED_EV_REQUEUED_BY_HAND:
        tasklog_add(m->tasklog, ev->job, "%s attempt %u taken back from worker %llu '%s'", t,
                    ev->attempt, wid, wname);
        break;
    case SCHED_EV_WORKER_BLOCKED_JOB:
        master_log(m, "worker %llu '%s' blocked from job %llu after %d failures of its tasks",
                   wid, wname, (unsigned long long)ev->job, m->opts->sched.max_worker_job_failures);
        tasklog_add(m->tasklog, ev->job,
                    "%s attempt %u: worker %llu '%s' blocked from this job after %d failures", t,
                    ev->attempt, wid, wname, m->opts->sched.max_worker_job_failures);
        break;
    case SCHED_EV_WORKER_BLOCKED: {
        /* Blocked by its key when it has one (a key is a host's: docs/security.md), so that a
         * new name does not make a new worker; else by its name. */
        char reason[256], entry[96];
        const int strikes = m->opts->sched.max_worker_failures_in_row;
        if (ev->job)
            snprintf(reason, sizeof reason,
                     "%d strike%s in a row (failed, expired or abandoned tasks, refused results), "
                     "the last job %llu %s",
                     strikes, strikes == 1 ? "" : "s", (unsigned long long)ev->job, t);
        else
            snprintf(reason, sizeof reason,
                     "%d strike%s in a row (failed, expired or abandoned tasks, refused results)",
                     strikes, strikes == 1 ? "" : "s");
        snprintf(entry, sizeof entry, "?");
        if (w)
            ops_block_entry(w, entry, sizeof entry);
        err_t err;
        if (w && block_name(m, entry) == 0 && m->journal &&
            journal_set_blocked(m->journal, entry, reason, &err) < 0)
            master_log(m, "journal: %s (a restarted master would not block '%s')", err.msg, entry);
        if (w) /* the other connections of its key are blocked too */
            for (size_t i = 0; i < m->nworkers; i++)
                if (m->workers[i] != w && m->workers[i]->alive && entry_names(entry, m->workers[i])) {
                    err_t ignore;
                    (void)sched_worker_block(m->sched, m->workers[i]->id, true, &ignore);
                }
        master_log(m, "worker %llu '%s' blocked from every job: %s (`prismfarm unblock %s`)",
                   wid, wname, reason, entry);
        if (ev->job)
            tasklog_add(m->tasklog, ev->job,
                        "%s attempt %u: worker %llu '%s' blocked from every job (%d strikes in a "
                        "row)",
                        t, ev->attempt, wid, wname, m->opts->sched.max_worker_failures_in_row);
        break;
    }
    case SCHED_EV_JOB_FAILED:
        tasklog_add(m->tasklog, ev->job, "%s failed %d times: the job fails", t,
                    m->opts->sched.max_task_failures);
        break;
    }
}

void ops_turn(master_t *m)
{
    sched_event_t ev[256];
    size_t n;
    uint64_t dropped = 0, d;
    while ((n = sched_events_take(m->sched, ev, 256, &d)) > 0) {
        dropped += d;
        for (size_t i = 0; i < n; i++)
            log_event(m, &ev[i]);
    }
    dropped += d;
    if (dropped > 0)
        master_log(m, "%llu scheduler events were not logged (more than 4096 in one turn)",
                   (unsigned long long)dropped);
    err_t err;
    if (tasklog_flush(m->tasklog, &err) < 0)
        master_log(m, "%s", err.msg);
}
