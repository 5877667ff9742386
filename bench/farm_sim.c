/* farm_sim: hundreds of simulated workers against one master, on loopback, so that what is
 * measured is the master (docs/performance.md, "The master at scale"). One process, one thread:
 * N DEALER connections made with net/ (the worker's own socket set-up), each speaking the
 * worker protocol as worker/ does -- HELLO, HEARTBEAT when it has sent nothing for an interval,
 * RESULT for each TASK, HELLO again after a REFUSE, CANCEL dropping the job's tasks -- but
 * answering every task with a prepared tile buffer instead of rendering it. A simulated worker
 * has `threads` render slots and holds each task `hold` milliseconds (0: answers at once), so the
 * offered rate is N * threads / hold.
 *
 * It submits the job itself (a one-file bundle), follows it with STATUS, and at the end fetches
 * its EXR and checks it: the result of pass [sb, se) carries the value sb + 1 for every sample
 * in every bucket, so a pixel's mean is sum_p n_p (sb_p + 1) / spp only when each of its passes
 * was merged exactly once -- a task merged twice or never (the job would not end) shows. Every
 * pixel must therefore hold the same spectrum, and the job's sample count must be the image's.
 * A chosen fraction of the workers (10 % by default) disconnects at seeded points of the job's
 * progress: half close their connection abruptly (the tasks they held are lost with it) and
 * come back as new connections a second later, half go silent past the master's timeout and
 * then send their held results late (copies the master must not merge twice) before saying
 * HELLO again.
 *
 * It reads the master's CPU time (main thread and whole process) and peak memory from /proc
 * when given its pid, and prints one line of key=value figures; exit status 0 when the job is
 * done and checks out, 1 when it fails, times out or does not check out, 2 for a bad command
 * line.
 *
 * usage: farm_sim --workers EP --clients EP --scene FILE --res WxH --spp N --buckets NB
 *                 --tile T [--n 100] [--threads 1] [--hold-ms 0] [--disconnect 0.1]
 *                 [--seed 1] [--master-pid PID] [--timeout 600] [--quiet] */
#include "err.h"
#include "files.h"
#include "image_exr.h"
#include "net.h"
#include "proto.h"
#include "rng.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>
#include <unistd.h>
#include <zmq.h>

#define STATUS_INTERVAL_S 0.25 /* how often the job's STATUS is asked */
#define REJOIN_S 1.0           /* a dropped worker connects again after this long */
#define STALL_S 4.5            /* a stalled worker is silent this long: past the master's 3 s */

typedef struct opts {
    const char *workers, *clients, *scene;
    int xres, yres, spp, buckets, tile;
    int n, threads;
    double hold_s, disconnect;
    uint64_t seed;
    long master_pid;
    double timeout_s;
    bool quiet;
} opts_t;

typedef struct held {
    uint64_t job, task;
    uint32_t attempt;
    proto_tile_t rect;
    double received;
    double finish; /* < 0: not started */
} held_t;

typedef enum { W_UP, W_DOWN, W_STALLED } wstate_t;

/* A result sent and not yet followed by a TASK, and when its task had come. */
typedef struct sent {
    double sent, received;
} sent_t;

/* A growing array of latencies, in seconds, each with when its result was sent. */
typedef struct lat {
    double *v, *at;
    size_t n, cap;
} lat_t;

typedef struct sworker {
    int idx;
    net_t *net;
    wstate_t state;
    double until;      /* W_DOWN: when to connect again; W_STALLED: when to speak again */
    double *slot_free; /* per render slot, when its last task finished (or will) */
    double last_sent;
    held_t *held;
    size_t nheld, cap;
    /* the results not yet followed by a TASK, oldest first: the master's turnaround */
    sent_t *sent_at;
    size_t nsent, sent_head, sent_cap;
    /* its disconnection: at the global result count trigger (0: never), by dropping or stalling */
    uint64_t trigger;
    bool drop;
} sworker_t;

/* The prepared results: one per tile shape and pass. */
typedef struct prepared {
    int w, h;
    uint32_t sb, se;
    double *sums, *xyz, *lum, *lum2;
    uint64_t *counts;
} prepared_t;

typedef struct sim {
    opts_t o;
    void *ctx;
    sworker_t *w;
    net_t *client;
    proto_limits_t lim;
    prepared_t *prep;
    size_t nprep;
    uint8_t *answers; /* per task id (lower 32 bits): results sent */
    uint8_t *received;
    size_t ntask_ids;
    uint64_t results_sent, tasks_received, reissued, refused, disconnects;
    uint64_t distinct, ntasks; /* tasks answered at least once, of the job's */
    double t5, t95;            /* when 5 % and 95 % of them had been answered */
    lat_t turnaround;          /* a result sent to the next TASK received by its worker */
    lat_t cycle; /* a TASK received to the next TASK that its result freed a slot for */
    uint64_t job;
} sim_t;

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + ts.tv_nsec * 1e-9;
}

static void die(const char *fmt, ...) __attribute__((format(printf, 1, 2), noreturn));
static void die(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fputs("farm_sim: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    exit(1);
}

static void say(const sim_t *s, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void say(const sim_t *s, const char *fmt, ...)
{
    if (s->o.quiet)
        return;
    va_list ap;
    va_start(ap, fmt);
    fputs("farm_sim: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
}

/* CPU seconds (user + system) of /proc/PID/stat or /proc/PID/task/TID/stat; -1 if unreadable. */
static double proc_cpu_s(long pid, long tid)
{
    char path[96], buf[2048];
    if (tid > 0)
        snprintf(path, sizeof path, "/proc/%ld/task/%ld/stat", pid, tid);
    else
        snprintf(path, sizeof path, "/proc/%ld/stat", pid);
    FILE *f = fopen(path, "r");
    if (!f)
        return -1;
    size_t n = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    buf[n] = 0;
    /* The command name may hold spaces: fields are counted after its closing parenthesis. */
    char *p = strrchr(buf, ')');
    if (!p)
        return -1;
    unsigned long long ut = 0, st = 0;
    if (sscanf(p + 2, "%*c %*d %*d %*d %*d %*d %*u %*u %*u %*u %*u %llu %llu", &ut, &st) != 2)
        return -1;
    return (double)(ut + st) / (double)sysconf(_SC_CLK_TCK);
}

/* Seconds the thread waited on a run queue for a CPU while runnable (/proc/PID/task/TID/
 * schedstat, second field, in ns): on a machine shared with other work, the time the master
 * wanted a core and did not get one. -1 if unreadable. */
static double proc_wait_s(long pid)
{
    char path[96];
    snprintf(path, sizeof path, "/proc/%ld/task/%ld/schedstat", pid, pid);
    FILE *f = fopen(path, "r");
    if (!f)
        return -1;
    unsigned long long run = 0, wait = 0;
    int n = fscanf(f, "%llu %llu", &run, &wait);
    fclose(f);
    return n == 2 ? (double)wait * 1e-9 : -1;
}

/* A "Key:   N kB" line of /proc/PID/status in MB; -1 if absent. */
static double proc_status_mb(long pid, const char *key)
{
    char path[64], line[256];
    snprintf(path, sizeof path, "/proc/%ld/status", pid);
    FILE *f = fopen(path, "r");
    if (!f)
        return -1;
    double mb = -1;
    size_t k = strlen(key);
    while (fgets(line, sizeof line, f))
        if (!strncmp(line, key, k) && line[k] == ':') {
            mb = strtod(line + k + 1, NULL) / 1024.0;
            break;
        }
    fclose(f);
    return mb;
}

static int send_or_log(sim_t *s, sworker_t *w, const proto_msg_t *m)
{
    err_t err;
    int rc = net_send(w->net, NULL, m, &err);
    if (rc < 0 && rc != PROTO_EAGAIN)
        say(s, "worker %d: %s", w->idx, err.msg);
    if (rc == 0)
        w->last_sent = now_s();
    return rc;
}

static void hello(sim_t *s, sworker_t *w)
{
    char name[32];
    snprintf(name, sizeof name, "sim%04d", w->idx);
    proto_msg_t m = {.type = PROTO_HELLO,
                     .hello = {.name = name, .threads = s->o.threads, .software = "farm_sim"}};
    (void)send_or_log(s, w, &m);
}

static void connect_worker(sim_t *s, sworker_t *w)
{
    net_options_t no = net_options_default();
    no.limits = s->lim;
    no.linger_ms = 0; /* a dropped worker's unsent results vanish with it, as a dead host's */
    err_t err;
    if (!(w->net = net_new(s->ctx, NET_DEALER, &no, &err)) ||
        net_connect(w->net, s->o.workers, &err) < 0)
        die("worker %d: %s", w->idx, err.msg);
    w->state = W_UP;
    w->nheld = 0;
    if (!w->slot_free && !(w->slot_free = calloc((size_t)s->o.threads, sizeof *w->slot_free)))
        die("out of memory");
    for (int t = 0; t < s->o.threads; t++)
        w->slot_free[t] = 0;
    w->nsent = w->sent_head = 0;
    hello(s, w);
}

static const prepared_t *prepared_for(sim_t *s, const proto_tile_t *r)
{
    for (size_t i = 0; i < s->nprep; i++) {
        const prepared_t *p = &s->prep[i];
        if (p->w == r->w && p->h == r->h && p->sb == r->sample_begin && p->se == r->sample_end)
            return p;
    }
    prepared_t *np = realloc(s->prep, (s->nprep + 1) * sizeof *np);
    if (!np)
        die("out of memory");
    s->prep = np;
    prepared_t *p = &s->prep[s->nprep++];
    size_t px = (size_t)r->w * (size_t)r->h, nb = (size_t)s->o.buckets;
    *p = (prepared_t){.w = r->w, .h = r->h, .sb = r->sample_begin, .se = r->sample_end};
    p->sums = malloc(px * nb * sizeof *p->sums);
    p->xyz = malloc(px * 3 * sizeof *p->xyz);
    p->lum = malloc(px * sizeof *p->lum);
    p->lum2 = malloc(px * sizeof *p->lum2);
    p->counts = malloc(px * sizeof *p->counts);
    if (!p->sums || !p->xyz || !p->lum || !p->lum2 || !p->counts)
        die("out of memory");
    /* Integer sums: float32 values, so they travel as a worker's usually do (sums_bits 32). */
    double n = (double)(r->sample_end - r->sample_begin), v = (double)r->sample_begin + 1.0;
    for (size_t i = 0; i < px; i++) {
        for (size_t b = 0; b < nb; b++)
            p->sums[i * nb + b] = n * v;
        for (int c = 0; c < 3; c++)
            p->xyz[i * 3 + (size_t)c] = n * v;
        p->lum[i] = n * v;
        p->lum2[i] = n * v * v;
        p->counts[i] = (uint64_t)n;
    }
    return p;
}

/* The per-task tallies, grown to hold task id. */
static void grow_ids(sim_t *s, uint32_t id)
{
    if (id < s->ntask_ids)
        return;
    size_t cap = s->ntask_ids ? s->ntask_ids : 1024;
    while (cap <= id)
        cap *= 2;
    uint8_t *a = realloc(s->answers, cap), *b = realloc(s->received, cap);
    if (!a || !b)
        die("out of memory");
    memset(a + s->ntask_ids, 0, cap - s->ntask_ids);
    memset(b + s->ntask_ids, 0, cap - s->ntask_ids);
    s->answers = a;
    s->received = b;
    s->ntask_ids = cap;
}

static void count(uint8_t *c)
{
    if (*c < 255)
        (*c)++;
}

static void send_result(sim_t *s, sworker_t *w, const held_t *t)
{
    const prepared_t *p = prepared_for(s, &t->rect);
    proto_msg_t m = {.type = PROTO_RESULT};
    m.result.job = t->job;
    m.result.task = t->task;
    m.result.attempt = t->attempt;
    m.result.kind = PROTO_KIND_CAMERA_TILE;
    m.result.tile = (proto_tile_result_t){.rect = t->rect,
                                          .nbuckets = s->o.buckets,
                                          .sums_bits = 32,
                                          .sums = p->sums,
                                          .xyz = p->xyz,
                                          .counts = p->counts,
                                          .lum = p->lum,
                                          .lum_sq = p->lum2};
    m.result.stats = (proto_task_stats_t){.samples = (uint64_t)t->rect.w * (uint64_t)t->rect.h *
                                                     (t->rect.sample_end - t->rect.sample_begin),
                                          .elapsed = s->o.hold_s};
    if (send_or_log(s, w, &m) != 0)
        return;
    uint32_t id = (uint32_t)(t->task & UINT32_MAX);
    grow_ids(s, id);
    if (!s->answers[id]) {
        s->distinct++;
        if (!s->t5 && s->distinct * 20 >= s->ntasks)
            s->t5 = w->last_sent;
        if (!s->t95 && s->distinct * 20 >= s->ntasks * 19)
            s->t95 = w->last_sent;
    }
    count(&s->answers[id]);
    s->results_sent++;
    if (w->nsent == w->sent_cap) {
        size_t cap = w->sent_cap ? 2 * w->sent_cap : 16;
        sent_t *a = malloc(cap * sizeof *a);
        if (!a)
            die("out of memory");
        for (size_t i = 0; i < w->nsent; i++)
            a[i] = w->sent_at[(w->sent_head + i) % (w->sent_cap ? w->sent_cap : 1)];
        free(w->sent_at);
        w->sent_at = a;
        w->sent_cap = cap;
        w->sent_head = 0;
    }
    w->sent_at[(w->sent_head + w->nsent++) % w->sent_cap] =
        (sent_t){.sent = w->last_sent, .received = t->received};
}

static int cmp_double(const void *a, const void *b);

static void lat_add(lat_t *l, double v, double at)
{
    if (l->n == l->cap) {
        size_t cap = l->cap ? 2 * l->cap : 4096;
        double *a = realloc(l->v, cap * sizeof *a), *b = a ? realloc(l->at, cap * sizeof *b) : NULL;
        if (a)
            l->v = a;
        if (!a || !b)
            die("out of memory");
        l->at = b;
        l->cap = cap;
    }
    l->v[l->n] = v;
    l->at[l->n++] = at;
}

/* Keeps the samples whose result was sent between t0 and t1 (the steady part of the job: at
 * its end a worker that sent a result may get no task for seconds, because none is left until
 * a silent worker's are issued again, which says nothing about the master), then sorts them. */
static void lat_steady(lat_t *l, double t0, double t1)
{
    size_t k = 0;
    for (size_t i = 0; i < l->n; i++)
        if (l->at[i] >= t0 && l->at[i] <= t1)
            l->v[k++] = l->v[i];
    l->n = k;
    qsort(l->v, l->n, sizeof *l->v, cmp_double);
}

static void on_task(sim_t *s, sworker_t *w, const proto_msg_t *m, double now)
{
    s->tasks_received++;
    uint32_t id = (uint32_t)(m->task.task & UINT32_MAX);
    grow_ids(s, id);
    if (s->received[id])
        s->reissued++;
    count(&s->received[id]);
    if (m->task.kind != PROTO_KIND_CAMERA_TILE)
        die("task %u is not a camera tile: the simulator answers camera tiles only", id);
    if (w->nsent > 0) {
        sent_t r = w->sent_at[w->sent_head];
        w->sent_head = (w->sent_head + 1) % w->sent_cap;
        w->nsent--;
        lat_add(&s->turnaround, now - r.sent, r.sent);
        lat_add(&s->cycle, now - r.received, r.sent);
    }
    if (w->nheld == w->cap) {
        size_t cap = w->cap ? 2 * w->cap : 8;
        held_t *a = realloc(w->held, cap * sizeof *a);
        if (!a)
            die("out of memory");
        w->held = a;
        w->cap = cap;
    }
    w->held[w->nheld++] = (held_t){.job = m->task.job,
                                   .task = m->task.task,
                                   .attempt = m->task.attempt,
                                   .rect = m->task.tile,
                                   .received = now,
                                   .finish = -1};
}

static void drop_job(sworker_t *w, uint64_t job)
{
    size_t k = 0;
    for (size_t i = 0; i < w->nheld; i++)
        if (w->held[i].job != job)
            w->held[k++] = w->held[i];
    w->nheld = k;
}

static void on_worker_msg(sim_t *s, sworker_t *w, const proto_msg_t *m, double now)
{
    switch (m->type) {
    case PROTO_TASK:
        on_task(s, w, m, now);
        break;
    case PROTO_CANCEL:
        drop_job(w, m->cancel.job);
        break;
    case PROTO_REFUSE:
        /* The master forgot us (we were silent too long): start afresh, as worker/ does. */
        s->refused++;
        w->nheld = 0;
        w->nsent = w->sent_head = 0;
        hello(s, w);
        break;
    default: /* WELCOME, HEARTBEAT, SCENE: nothing to do */
        break;
    }
}

/* Starts what free slots can start, sends what is finished, heartbeats when quiet. Returns the
 * earliest time something is due. */
static double serve(sim_t *s, sworker_t *w, double now)
{
    double due = now + 1.0;
    if (w->state == W_DOWN) {
        if (now >= w->until) {
            connect_worker(s, w);
            say(s, "worker %d connected again", w->idx);
        }
        return w->state == W_DOWN ? w->until : now;
    }
    if (w->state == W_STALLED) {
        if (now < w->until)
            return w->until;
        w->state = W_UP; /* its held results go out late below */
        for (size_t i = 0; i < w->nheld; i++)
            w->held[i].finish = now;
    }
    /* What is finished goes out first, so that a slot it frees starts its next task now. Once
     * its disconnection is due, it sends nothing more (maybe_disconnect acts next). */
    size_t k = 0;
    bool quiet = false;
    for (size_t i = 0; i < w->nheld; i++) {
        if (!quiet && w->held[i].finish >= 0 && w->held[i].finish <= now) {
            send_result(s, w, &w->held[i]);
            quiet = w->trigger && s->results_sent >= w->trigger;
            continue;
        }
        w->held[k++] = w->held[i];
    }
    w->nheld = k;
    int running = 0;
    for (size_t i = 0; i < w->nheld; i++)
        running += w->held[i].finish >= 0;
    /* A slot starts its next task when its last one finished or when the task came, whichever
     * is later -- not when this loop got round to it -- so that the offered rate holds however
     * late a loaded machine wakes the simulator. */
    for (size_t i = 0; i < w->nheld && running < s->o.threads; i++)
        if (w->held[i].finish < 0) {
            int slot = 0;
            for (int t = 1; t < s->o.threads; t++)
                if (w->slot_free[t] < w->slot_free[slot])
                    slot = t;
            double start =
                w->slot_free[slot] > w->held[i].received ? w->slot_free[slot] : w->held[i].received;
            w->held[i].finish = w->slot_free[slot] = start + s->o.hold_s;
            running++;
        }
    for (size_t i = 0; i < w->nheld; i++)
        if (w->held[i].finish >= 0 && w->held[i].finish < due)
            due = w->held[i].finish;
    if (now - w->last_sent >= 1.0) {
        proto_msg_t hb = {.type = PROTO_HEARTBEAT};
        (void)send_or_log(s, w, &hb);
    }
    if (w->last_sent + 1.0 < due)
        due = w->last_sent + 1.0;
    return due;
}

static void maybe_disconnect(sim_t *s, sworker_t *w, double now)
{
    if (!w->trigger || s->results_sent < w->trigger || w->state != W_UP)
        return;
    w->trigger = 0;
    s->disconnects++;
    if (w->drop) {
        say(s, "worker %d drops its connection with %zu tasks held", w->idx, w->nheld);
        net_destroy(&w->net);
        w->state = W_DOWN;
        w->until = now + REJOIN_S;
        w->nheld = 0;
    } else {
        say(s, "worker %d goes silent with %zu tasks held", w->idx, w->nheld);
        w->state = W_STALLED;
        w->until = now + STALL_S;
    }
}

static void usage(void)
{
    fprintf(stderr, "usage: farm_sim --workers EP --clients EP --scene FILE --res WxH --spp N "
                    "--buckets NB --tile T [--n 100] [--threads 1] [--hold-ms 0] "
                    "[--disconnect 0.1] [--seed 1] [--master-pid PID] [--timeout 600] "
                    "[--quiet]\n");
    exit(2);
}

static opts_t parse(int argc, char **argv)
{
    opts_t o = {.n = 100, .threads = 1, .disconnect = 0.1, .seed = 1, .timeout_s = 600};
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--quiet")) {
            o.quiet = true;
            continue;
        }
        if (!v)
            usage();
        i++;
        if (!strcmp(a, "--workers"))
            o.workers = v;
        else if (!strcmp(a, "--clients"))
            o.clients = v;
        else if (!strcmp(a, "--scene"))
            o.scene = v;
        else if (!strcmp(a, "--res")) {
            if (sscanf(v, "%dx%d", &o.xres, &o.yres) != 2)
                usage();
        } else if (!strcmp(a, "--spp"))
            o.spp = atoi(v);
        else if (!strcmp(a, "--buckets"))
            o.buckets = atoi(v);
        else if (!strcmp(a, "--tile"))
            o.tile = atoi(v);
        else if (!strcmp(a, "--n"))
            o.n = atoi(v);
        else if (!strcmp(a, "--threads"))
            o.threads = atoi(v);
        else if (!strcmp(a, "--hold-ms"))
            o.hold_s = atof(v) / 1000.0;
        else if (!strcmp(a, "--disconnect"))
            o.disconnect = atof(v);
        else if (!strcmp(a, "--seed"))
            o.seed = strtoull(v, NULL, 10);
        else if (!strcmp(a, "--master-pid"))
            o.master_pid = atol(v);
        else if (!strcmp(a, "--timeout"))
            o.timeout_s = atof(v);
        else
            usage();
    }
    if (!o.workers || !o.clients || !o.scene || o.xres < 1 || o.yres < 1 || o.spp < 1 ||
        o.buckets < 1 || o.tile < 1 || o.n < 1 || o.n > 10000 || o.threads < 1 ||
        o.threads > 4096 || o.hold_s < 0 || o.disconnect < 0 || o.disconnect > 1 ||
        o.timeout_s <= 0)
        usage();
    return o;
}

/* One request on the client socket and its answer, waiting at most timeout_s. */
static proto_msg_t client_ask(sim_t *s, const proto_msg_t *req, double timeout_s)
{
    err_t err;
    if (net_send(s->client, NULL, req, &err) < 0)
        die("client: %s", err.msg);
    proto_msg_t m;
    int rc;
    /* A PROGRESS (a scene loading) comes before the answer and restarts the wait, as it does
     * for the farm's own client (cli/client_rpc.h). */
    while ((rc = net_recv(s->client, NULL, &m, (int)(timeout_s * 1000), &err)) == 0 &&
           m.type == PROTO_PROGRESS)
        proto_msg_free(&m);
    if (rc == PROTO_EAGAIN)
        die("the master did not answer %s within %.0f s", proto_type_name(req->type), timeout_s);
    if (rc < 0)
        die("client: %s", err.msg);
    if (m.type == PROTO_ERROR)
        die("the master refused %s: %s", proto_type_name(req->type), m.error.message);
    return m;
}

static uint64_t submit(sim_t *s)
{
    uint8_t *data;
    size_t size;
    err_t err;
    if (files_read(s->o.scene, 1 << 20, &data, &size, &err) < 0)
        die("%s", err.msg);
    proto_bundle_file_t f = {.path = "scene.pbrt", .data = data, .size = size};
    proto_msg_t req = {.type = PROTO_SUBMIT};
    req.submit.name = "farm_sim";
    req.submit.settings =
        (proto_settings_t){.spp = s->o.spp, .xres = s->o.xres, .yres = s->o.yres, .seed = -1};
    req.submit.bundle = (proto_bundle_t){.main = "scene.pbrt", .files = &f, .nfiles = 1};
    proto_msg_t m = client_ask(s, &req, 120);
    free(data);
    if (m.type != PROTO_SUBMITTED)
        die("SUBMIT answered by %s", proto_type_name(m.type));
    uint64_t job = m.submitted.job;
    proto_msg_free(&m);
    return job;
}

/* The EXR's check: every pixel the same spectrum (each pass merged once everywhere) and the
 * job's sample count in its prismfarm attribute. Returns the number of pixels that differ, or -1
 * when the file cannot be read. */
static long check_exr(sim_t *s, const char *path, char *why, size_t size)
{
    err_t err;
    image_exr_t *img = image_exr_read(path, &err);
    if (!img) {
        snprintf(why, size, "%s", err.msg);
        return -1;
    }
    long bad = 0;
    int w = image_exr_width(img), h = image_exr_height(img), nb = image_exr_n_spectral(img);
    const float *sp = image_exr_spectral(img);
    if (w != s->o.xres || h != s->o.yres || nb != s->o.buckets || !sp) {
        snprintf(why, size, "the EXR is %dx%d with %d buckets, expected %dx%d with %d", w, h, nb,
                 s->o.xres, s->o.yres, s->o.buckets);
        image_exr_destroy(&img);
        return -1;
    }
    for (long i = 1; i < (long)w * h; i++)
        if (memcmp(sp + (size_t)i * (size_t)nb, sp, (size_t)nb * sizeof *sp) != 0)
            bad++;
    const char *info = image_exr_attribute(img, "prismfarm");
    const char *p = info ? strstr(info, "samples=") : NULL;
    unsigned long long samples = p ? strtoull(p + 8, NULL, 10) : 0;
    unsigned long long want = (unsigned long long)s->o.xres * (unsigned long long)s->o.yres *
                              (unsigned long long)s->o.spp;
    if (samples != want) {
        snprintf(why, size, "the EXR says samples=%llu, expected %llu", samples, want);
        bad = bad ? bad : 1;
    } else if (bad) {
        snprintf(why, size, "%ld pixels differ from pixel (0, 0)", bad);
    }
    image_exr_destroy(&img);
    return bad;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static double quantile(const double *v, size_t n, double q)
{
    if (n == 0)
        return 0;
    size_t i = (size_t)(q * (double)(n - 1) + 0.5);
    return v[i < n ? i : n - 1];
}

int main(int argc, char **argv)
{
    sim_t s = {.o = parse(argc, argv), .lim = proto_limits_default()};
    /* Two descriptors per connection (its TCP socket and its mailbox) and a monitor each. */
    struct rlimit rl;
    if (getrlimit(RLIMIT_NOFILE, &rl) == 0 && rl.rlim_cur < rl.rlim_max) {
        rl.rlim_cur = rl.rlim_max;
        (void)setrlimit(RLIMIT_NOFILE, &rl);
    }
    if (!(s.ctx = zmq_ctx_new()) || zmq_ctx_set(s.ctx, ZMQ_MAX_SOCKETS, 4 * s.o.n + 64) != 0)
        die("zmq context: %s", zmq_strerror(zmq_errno()));
    err_t err;
    net_options_t co = net_options_default();
    co.limits = s.lim;
    co.linger_ms = 0;
    if (!(s.client = net_new(s.ctx, NET_DEALER, &co, &err)) ||
        net_connect(s.client, s.o.clients, &err) < 0)
        die("client: %s", err.msg);
    s.job = submit(&s);
    say(&s, "job %llu submitted", (unsigned long long)s.job);

    s.w = calloc((size_t)s.o.n, sizeof *s.w);
    zmq_pollitem_t *items = calloc((size_t)s.o.n + 1, sizeof *items);
    if (!s.w || !items)
        die("out of memory");
    /* The disconnection plan, from the seed alone: which workers, at what share of the tasks
     * answered, dropping or stalling. */
    uint64_t ntiles = (uint64_t)((s.o.xres + s.o.tile - 1) / s.o.tile) *
                      (uint64_t)((s.o.yres + s.o.tile - 1) / s.o.tile);
    int npasses = 0;
    for (uint64_t b = 0; b < (uint64_t)s.o.spp; b = b == 0 ? 1 : 2 * b)
        npasses++;
    uint64_t ntasks = ntiles * (uint64_t)npasses;
    s.ntasks = ntasks;
    int ndis = (int)lround(s.o.disconnect * s.o.n);
    for (int k = 0; k < s.o.n; k++)
        s.w[k].idx = k;
    for (int k = 0, chosen = 0; chosen < ndis && k < 100 * s.o.n; k++) {
        int i = (int)(rng_uniform(s.o.seed, (uint64_t)k, 0, 0) * s.o.n) % s.o.n;
        if (s.w[i].trigger)
            continue;
        double at = 0.05 + 0.7 * rng_uniform(s.o.seed, (uint64_t)k, 0, 1);
        s.w[i].trigger = 1 + (uint64_t)(at * (double)ntasks);
        s.w[i].drop = chosen % 2 == 0;
        chosen++;
    }

    double cpu0 = proc_cpu_s(s.o.master_pid, 0), main0 = proc_cpu_s(s.o.master_pid, s.o.master_pid);
    double wait0 = proc_wait_s(s.o.master_pid);
    double t0 = now_s();
    for (int k = 0; k < s.o.n; k++)
        connect_worker(&s, &s.w[k]);
    say(&s, "%d workers connected", s.o.n);

    double next_status = t0, deadline = t0 + s.o.timeout_s, t_first = 0, t_end = 0;
    bool asked = false;
    job_state_t state = JOB_QUEUED;
    char failure[600] = "";
    uint64_t samples_done = 0, samples_total = 0;
    while (!t_end) {
        double now = now_s();
        if (now > deadline) {
            snprintf(failure, sizeof failure, "timed out after %.0f s at %llu of %llu samples",
                     s.o.timeout_s, (unsigned long long)samples_done,
                     (unsigned long long)samples_total);
            break;
        }
        double due = now + 0.1;
        for (int k = 0; k < s.o.n; k++) {
            maybe_disconnect(&s, &s.w[k], now);
            double d = serve(&s, &s.w[k], now);
            if (d < due)
                due = d;
        }
        if (!asked && now >= next_status) {
            proto_msg_t st = {.type = PROTO_STATUS, .status = {.job = s.job}};
            if (net_send(s.client, NULL, &st, &err) < 0)
                die("client: %s", err.msg);
            asked = true;
            next_status = now + STATUS_INTERVAL_S;
        }
        if (!asked && next_status < due)
            due = next_status;
        int n = 0;
        for (int k = 0; k < s.o.n; k++)
            if (s.w[k].net && s.w[k].state != W_STALLED)
                items[n++] =
                    (zmq_pollitem_t){.socket = net_socket(s.w[k].net), .events = ZMQ_POLLIN};
        items[n++] = (zmq_pollitem_t){.socket = net_socket(s.client), .events = ZMQ_POLLIN};
        double wait = due - now_s();
        int rc = zmq_poll(items, n, wait > 0 ? (long)(wait * 1000) + 1 : 0);
        if (rc < 0 && zmq_errno() != EINTR)
            die("zmq_poll: %s", zmq_strerror(zmq_errno()));
        now = now_s();
        for (int k = 0, i = 0; k < s.o.n; k++) {
            sworker_t *w = &s.w[k];
            if (!w->net || w->state == W_STALLED)
                continue;
            bool ready = items[i++].revents & ZMQ_POLLIN;
            while (ready) {
                proto_msg_t m;
                int r = net_recv(w->net, NULL, &m, 0, &err);
                if (r == PROTO_EAGAIN)
                    break;
                if (r < 0)
                    die("worker %d: %s", k, err.msg);
                if (m.type == PROTO_TASK && !t_first)
                    t_first = now;
                on_worker_msg(&s, w, &m, now);
                proto_msg_free(&m);
            }
        }
        while (asked) {
            proto_msg_t m;
            int r = net_recv(s.client, NULL, &m, 0, &err);
            if (r == PROTO_EAGAIN)
                break;
            if (r < 0)
                die("client: %s", err.msg);
            asked = false;
            if (m.type == PROTO_STATUS_REPLY && m.status_reply.njobs == 1) {
                const proto_job_info_t *j = &m.status_reply.jobs[0];
                state = j->state;
                samples_done = j->samples_done;
                samples_total = j->samples_total;
                if (state == JOB_DONE)
                    t_end = now;
                else if (state == JOB_FAILED || state == JOB_CANCELLED) {
                    snprintf(failure, sizeof failure, "the job %s: %s", proto_job_state_name(state),
                             j->error ? j->error : "");
                    t_end = now;
                }
            } else if (m.type == PROTO_ERROR) {
                die("STATUS: %s", m.error.message);
            }
            proto_msg_free(&m);
        }
    }
    double cpu1 = proc_cpu_s(s.o.master_pid, 0), main1 = proc_cpu_s(s.o.master_pid, s.o.master_pid);
    double wait1 = proc_wait_s(s.o.master_pid);
    double hwm = proc_status_mb(s.o.master_pid, "VmHWM"),
           rss = proc_status_mb(s.o.master_pid, "VmRSS");
    for (int k = 0; k < s.o.n; k++)
        net_destroy(&s.w[k].net);

    /* What was answered: every task at least once (a task never answered would have kept the
     * job from ending), some twice (re-issued after a disconnection). */
    uint64_t distinct = 0, twice = 0;
    for (size_t i = 0; i < s.ntask_ids; i++) {
        distinct += s.answers[i] > 0;
        twice += s.answers[i] > 1;
    }
    long bad = -1;
    char why[700] = "";
    if (!failure[0]) {
        proto_msg_t f = {.type = PROTO_FETCH, .fetch = {.job = s.job, .what = PROTO_FETCH_EXR}};
        proto_msg_t m = client_ask(&s, &f, 120);
        char path[64];
        snprintf(path, sizeof path, "/tmp/farm_sim-%ld.exr", (long)getpid());
        if (m.type != PROTO_FILE ||
            files_write_atomic(path, m.file.data, m.file.size, false, &err) < 0)
            snprintf(why, sizeof why, "cannot fetch the EXR: %s",
                     m.type == PROTO_FILE ? err.msg : proto_type_name(m.type));
        else
            bad = check_exr(&s, path, why, sizeof why);
        (void)unlink(path);
        proto_msg_free(&m);
        if (bad != 0 && !failure[0])
            snprintf(failure, sizeof failure, "%s", why);
    }
    net_destroy(&s.client);
    (void)zmq_ctx_term(s.ctx);

    lat_steady(&s.turnaround, s.t5, s.t95 > 0 ? s.t95 : now_s());
    lat_steady(&s.cycle, s.t5, s.t95 > 0 ? s.t95 : now_s());
    const lat_t *ta = &s.turnaround, *cy = &s.cycle;
    double run = t_end > t_first && t_first > 0 ? t_end - t_first : 0;
    /* The steady rate, between 5 % and 95 % of the tasks answered: without the joining at the
     * start and the tail, where the last tasks wait for a stalled worker's timeout. */
    double steady = s.t95 > s.t5 ? 0.9 * (double)ntasks / (s.t95 - s.t5) : 0;
    double cpu = cpu1 >= 0 && cpu0 >= 0 ? cpu1 - cpu0 : -1;
    double main_cpu = main1 >= 0 && main0 >= 0 ? main1 - main0 : -1;
    double wall = (t_end ? t_end : now_s()) - t0;
    printf(
        "workers=%d threads=%d hold_ms=%.0f tasks=%" PRIu64 " done=%s run_s=%.3f "
        "results_per_s=%.1f steady_results_per_s=%.1f master_cpu_s=%.2f master_main_cpu_s=%.2f "
        "cpu_core_share=%.3f "
        "main_core_share=%.3f main_runqueue_share=%.3f cpu_us_per_task=%.1f main_us_per_task=%.1f "
        "turnaround_ms_p50=%.2f turnaround_ms_p90=%.2f turnaround_ms_p99=%.2f "
        "turnaround_ms_max=%.2f cycle_ms_p50=%.2f cycle_ms_p99=%.2f rss_peak_mb=%.1f "
        "rss_end_mb=%.1f results_sent=%" PRIu64 " tasks_received=%" PRIu64 " reissued=%" PRIu64
        " answered_distinct=%" PRIu64 " answered_twice=%" PRIu64 " disconnects=%" PRIu64
        " refused=%" PRIu64 " lost=%" PRIu64 " pixels_bad=%ld\n",
        s.o.n, s.o.threads, s.o.hold_s * 1000, ntasks, failure[0] ? "no" : "yes", run,
        run > 0 ? (double)ntasks / run : 0, steady, cpu, main_cpu,
        cpu >= 0 && wall > 0 ? cpu / wall : -1, main_cpu >= 0 && wall > 0 ? main_cpu / wall : -1,
        wait1 >= 0 && wait0 >= 0 && wall > 0 ? (wait1 - wait0) / wall : -1,
        cpu >= 0 ? cpu / (double)ntasks * 1e6 : -1,
        main_cpu >= 0 ? main_cpu / (double)ntasks * 1e6 : -1, quantile(ta->v, ta->n, 0.5) * 1e3,
        quantile(ta->v, ta->n, 0.9) * 1e3, quantile(ta->v, ta->n, 0.99) * 1e3,
        ta->n ? ta->v[ta->n - 1] * 1e3 : 0, quantile(cy->v, cy->n, 0.5) * 1e3,
        quantile(cy->v, cy->n, 0.99) * 1e3, hwm, rss, s.results_sent, s.tasks_received, s.reissued,
        distinct, twice, s.disconnects, s.refused, ntasks > distinct ? ntasks - distinct : 0, bad);
    if (failure[0])
        fprintf(stderr, "farm_sim: FAILED: %s\n", failure);
    for (int k = 0; k < s.o.n; k++) {
        free(s.w[k].held);
        free(s.w[k].sent_at);
        free(s.w[k].slot_free);
    }
    for (size_t i = 0; i < s.nprep; i++) {
        free(s.prep[i].sums);
        free(s.prep[i].xyz);
        free(s.prep[i].lum);
        free(s.prep[i].lum2);
        free(s.prep[i].counts);
    }
    free(s.prep);
    free(s.w);
    free(items);
    free(s.answers);
    free(s.received);
    free(s.turnaround.v);
    free(s.turnaround.at);
    free(s.cycle.v);
    free(s.cycle.at);
    return failure[0] ? 1 : 0;
}
