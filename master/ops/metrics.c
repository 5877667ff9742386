#include "metrics.h"

#include "jobs.h"
#include "master_state.h"
#include "peers.h"

#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct text {
    char *p;
    size_t len, cap;
    bool failed; /* out of memory: the rest is dropped, the render fails */
} text_t;

__attribute__((format(printf, 2, 3))) static void put(text_t *t, const char *fmt, ...)
{
    if (t->failed)
        return;
    for (;;) {
        va_list ap;
        va_start(ap, fmt);
        int n = vsnprintf(t->p ? t->p + t->len : NULL, t->p ? t->cap - t->len : 0, fmt, ap);
        va_end(ap);
        if (n < 0) {
            t->failed = true;
            return;
        }
        if (t->p && t->len + (size_t)n < t->cap) {
            t->len += (size_t)n;
            return;
        }
        size_t cap = (t->cap ? 2 * t->cap : 4096) + (size_t)n;
        char *q = realloc(t->p, cap);
        if (!q) {
            t->failed = true;
            return;
        }
        t->p = q;
        t->cap = cap;
    }
}

/* A label value as the format wants it: \\, \" and \n escaped. */
static void put_label(text_t *t, const char *v)
{
    put(t, "\"");
    for (const char *c = v ? v : ""; *c; c++) {
        if (*c == '\\')
            put(t, "\\\\");
        else if (*c == '"')
            put(t, "\\\"");
        else if (*c == '\n')
            put(t, "\\n");
        else
            put(t, "%c", *c);
    }
    put(t, "\"");
}

static void family(text_t *t, const char *name, const char *type, const char *help)
{
    put(t, "# HELP %s %s\n# TYPE %s %s\n", name, help, name, type);
}

/* A value: integers as integers, others in %.17g (round-trips a double); never NaN or Inf. */
static void put_value(text_t *t, double v)
{
    if (!isfinite(v))
        v = 0;
    if (v == floor(v) && fabs(v) < 9007199254740992.0)
        put(t, " %.0f\n", v);
    else
        put(t, " %.17g\n", v);
}

static void put_u64(text_t *t, uint64_t v)
{
    put(t, " %llu\n", (unsigned long long)v);
}

static void worker_family(text_t *t, const metrics_snapshot_t *s, const char *name,
                          const char *type, const char *help, int which)
{
    family(t, name, type, help);
    for (size_t i = 0; i < s->nworkers; i++) {
        const metrics_worker_t *w = &s->workers[i];
        if (which == 0 && w->state == PROTO_WORKER_LOST)
            continue; /* a lost worker has no rate */
        put(t, "%s{worker=", name);
        put_label(t, w->name);
        put(t, ",id=\"%llu\"}", (unsigned long long)w->id);
        if (which == 0)
            put_value(t, w->samples_per_s);
        else
            put_u64(t, which == 1 ? w->tasks_done : w->tasks_failed);
    }
}

int metrics_render(const metrics_snapshot_t *s, char **text, size_t *len, err_t *err)
{
    text_t t = {0};
    family(&t, "prismfarm_jobs", "gauge", "Jobs the master holds, by state.");
    for (int st = 0; st < JOB_STATE_COUNT; st++) {
        put(&t, "prismfarm_jobs{state=\"%s\"}", proto_job_state_name((job_state_t)st));
        put_u64(&t, s->jobs[st]);
    }
    family(&t, "prismfarm_tasks_in_flight", "gauge",
           "Tasks handed to workers and not returned yet.");
    put(&t, "prismfarm_tasks_in_flight");
    put_u64(&t, s->tasks_in_flight);
    family(&t, "prismfarm_queue_depth", "gauge",
           "Tasks of unfinished jobs waiting to be handed out (paused jobs' included).");
    put(&t, "prismfarm_queue_depth");
    put_u64(&t, s->queue_depth);
    family(&t, "prismfarm_workers", "gauge", "Workers the master knows, by state.");
    for (int st = 0; st < PROTO_WORKER_STATE_COUNT; st++) {
        uint64_t n = 0;
        for (size_t i = 0; i < s->nworkers; i++)
            n += (int)s->workers[i].state == st;
        put(&t, "prismfarm_workers{state=\"%s\"}",
            proto_worker_state_name((proto_worker_state_t)st));
        put_u64(&t, n);
    }
    worker_family(&t, s, "prismfarm_worker_samples_per_second", "gauge",
                  "Samples per second of each live worker over its last seconds.", 0);
    worker_family(&t, s, "prismfarm_worker_tasks_done_total", "counter",
                  "Tasks each worker returned.", 1);
    worker_family(&t, s, "prismfarm_worker_tasks_failed_total", "counter",
                  "Tasks each worker failed.", 2);
    family(&t, "prismfarm_received_messages_total", "counter",
           "Messages the master received, by endpoint.");
    put(&t, "prismfarm_received_messages_total{endpoint=\"workers\"}");
    put_u64(&t, s->messages_workers);
    put(&t, "prismfarm_received_messages_total{endpoint=\"clients\"}");
    put_u64(&t, s->messages_clients);
    family(&t, "prismfarm_received_bytes_total", "counter",
           "Bytes of the messages the master received, by endpoint.");
    put(&t, "prismfarm_received_bytes_total{endpoint=\"workers\"}");
    put_u64(&t, s->bytes_workers);
    put(&t, "prismfarm_received_bytes_total{endpoint=\"clients\"}");
    put_u64(&t, s->bytes_clients);
    family(&t, "prismfarm_journal_writes_total", "counter",
           "Journal transactions and results written.");
    put(&t, "prismfarm_journal_writes_total");
    put_u64(&t, s->journal_writes);
    family(&t, "prismfarm_journal_write_seconds_total", "counter",
           "Seconds the journal's writes took.");
    put(&t, "prismfarm_journal_write_seconds_total");
    put_value(&t, s->journal_write_seconds);
    if (t.failed || !t.p) {
        free(t.p);
        return err_set(err, "metrics: out of memory");
    }
    *text = t.p;
    *len = t.len;
    return 0;
}

int master_metrics_text(master_t *m, double now, char **text, size_t *len, err_t *err)
{
    metrics_snapshot_t s = {0};
    for (size_t i = 0; i < m->njobs; i++) {
        const job_t *j = m->jobs[i];
        if (j->seq.nframes > 0)
            continue; /* its frames are counted, each a job of its own */
        s.jobs[jobs_wire_state(j)]++;
        sched_job_info_t info;
        if (j->sched.known && !job_over(j) && sched_job_info(m->sched, j->id, &info) == 0) {
            s.tasks_in_flight += info.tasks_running;
            s.queue_depth += info.tasks_total - info.tasks_done - info.tasks_running;
        }
    }
    size_t ns = peers_sched_table(m);
    metrics_worker_t *ws = m->nworkers ? calloc(m->nworkers, sizeof *ws) : NULL;
    if (m->nworkers && !ws)
        return err_set(err, "metrics: out of memory");
    for (size_t i = 0; i < m->nworkers; i++) {
        const mworker_t *w = m->workers[i];
        const sched_worker_info_t *si = peers_sched_info(m, ns, w->id);
        ws[i] = (metrics_worker_t){
            .name = w->name,
            .id = w->id,
            .state = peers_wire_state(w, si),
            .samples_per_s = peers_samples_per_s(w, now),
            .tasks_done = si ? si->tasks_done : 0,
            .tasks_failed = si ? si->tasks_failed : 0,
        };
    }
    s.workers = ws;
    s.nworkers = m->nworkers;
    if (m->wnet) {
        net_stats_t st = net_stats(m->wnet);
        s.messages_workers = st.messages_received;
        s.bytes_workers = st.bytes_received;
    }
    if (m->cnet) {
        net_stats_t st = net_stats(m->cnet);
        s.messages_clients = st.messages_received;
        s.bytes_clients = st.bytes_received;
    }
    if (m->journal) {
        journal_stats_t js = journal_stats(m->journal);
        s.journal_writes = js.writes;
        s.journal_write_seconds = js.seconds;
    }
    int rc = metrics_render(&s, text, len, err);
    free(ws);
    return rc;
}
