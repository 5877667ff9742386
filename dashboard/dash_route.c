#include "dash_route.h"

#include "dash_assets.h"

#include <jansson.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct dash_router {
    const dash_provider_t *p;
    dash_auth_t *auth;
    dash_router_config_t cfg;
    /* Scratch for the provider's answers, allocated once: the largest lists are bounded by
     * dash_provider.h's limits, so no request makes the master allocate more. */
    dash_job_t *jobs;
    dash_worker_t *workers;
    dash_task_t *tasks;
    dash_log_line_t *log;
};

dash_router_t *dash_router_new(const dash_provider_t *provider, dash_auth_t *auth,
                               const dash_router_config_t *cfg, err_t *err)
{
    dash_router_t *self = calloc(1, sizeof *self);
    if (self) {
        self->jobs = calloc(DASH_MAX_JOBS, sizeof *self->jobs);
        self->workers = calloc(DASH_MAX_WORKERS, sizeof *self->workers);
        self->tasks = calloc(DASH_MAX_TASKS, sizeof *self->tasks);
        self->log = calloc(DASH_MAX_LOG, sizeof *self->log);
    }
    if (!self || !self->jobs || !self->workers || !self->tasks || !self->log) {
        dash_router_destroy(&self);
        err_set(err, "dashboard: out of memory");
        return NULL;
    }
    self->p = provider;
    self->auth = auth;
    self->cfg = cfg ? *cfg : (dash_router_config_t){.check_host = true};
    return self;
}

void dash_router_destroy(dash_router_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    dash_router_t *self = *self_p;
    free(self->jobs);
    free(self->workers);
    free(self->tasks);
    free(self->log);
    free(self);
    *self_p = NULL;
}

void dash_response_free(dash_response_t *r)
{
    if (r && !r->is_static)
        free(r->body);
    if (r)
        r->body = NULL;
}

/* ---------------------------------------------------------------- answers */

/* The JSON answer (taken: decref'd here). */
static void answer_json(dash_response_t *out, int status, json_t *j)
{
    char *text = j ? json_dumps(j, JSON_COMPACT) : NULL;
    json_decref(j);
    if (!text) {
        static const char oom[] = "{\"error\":\"the master is out of memory\"}";
        *out = (dash_response_t){.status = 500,
                                 .content_type = "application/json",
                                 .body = (uint8_t *)oom,
                                 .size = sizeof oom - 1,
                                 .is_static = true};
        return;
    }
    *out = (dash_response_t){.status = status,
                             .content_type = "application/json",
                             .body = (uint8_t *)text,
                             .size = strlen(text)};
}

__attribute__((format(printf, 3, 4))) static void answer_error(dash_response_t *out, int status,
                                                               const char *fmt, ...)
{
    char text[600];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    json_t *j = json_object();
    /* jansson refuses text that is not UTF-8: a message quoting a request's bytes is cut to
     * what it accepts. */
    json_t *s = json_string(text);
    if (!s)
        s = json_string("malformed request");
    json_object_set_new(j, "error", s);
    answer_json(out, status, j);
    out->www_authenticate = status == 401;
}

/* ---------------------------------------------------------------- parsing */

/* A decimal id of 1..20 digits that fits in 64 bits; -1 otherwise. */
static int parse_u64(const char *s, size_t n, uint64_t *out)
{
    if (n == 0 || n > 20)
        return -1;
    uint64_t v = 0;
    for (size_t i = 0; i < n; i++) {
        if (s[i] < '0' || s[i] > '9')
            return -1;
        uint64_t d = (uint64_t)(s[i] - '0');
        if (v > (UINT64_MAX - d) / 10)
            return -1;
        v = v * 10 + d;
    }
    *out = v;
    return 0;
}

/* The path cut at '/' into at most max segments (the first '/' required, no empty segment
 * but a trailing slash); returns the count or -1. */
typedef struct seg {
    const char *s;
    size_t n;
} seg_t;

static int split_path(const char *path, seg_t *segs, int max)
{
    if (path[0] != '/')
        return -1;
    int n = 0;
    const char *p = path + 1;
    while (*p) {
        const char *e = strchr(p, '/');
        size_t len = e ? (size_t)(e - p) : strlen(p);
        if (len == 0)
            return e && e[1] == 0 ? n : -1; /* "/api/jobs/" is "/api/jobs"; "//" is malformed */
        if (n == max)
            return -1;
        segs[n++] = (seg_t){p, len};
        p += len + (e ? 1 : 0);
    }
    return n;
}

static bool seg_is(const seg_t *s, const char *word)
{
    return s->n == strlen(word) && !memcmp(s->s, word, s->n);
}

static const char *arg_find(const dash_request_t *req, const char *key)
{
    for (size_t i = 0; i < req->nargs; i++)
        if (req->args[i].key && !strcmp(req->args[i].key, key))
            return req->args[i].value ? req->args[i].value : "";
    return NULL;
}

/* Host "127.0.0.1", "localhost" or "[::1]", each with ":PORT" or without. */
static bool host_is_loopback(const char *host)
{
    static const char *names[] = {"127.0.0.1", "localhost", "[::1]"};
    for (size_t i = 0; i < sizeof names / sizeof *names; i++) {
        size_t n = strlen(names[i]);
        if (strncmp(host, names[i], n) != 0)
            continue;
        const char *rest = host + n;
        if (!*rest)
            return true;
        if (*rest != ':' || !rest[1] || strlen(rest + 1) > 5)
            continue;
        bool digits = true;
        for (const char *c = rest + 1; *c; c++)
            digits = digits && *c >= '0' && *c <= '9';
        if (digits)
            return true;
    }
    return false;
}

/* ---------------------------------------------------------------- JSON of the state */

static json_t *str(const char *s)
{
    json_t *j = json_string(s ? s : "");
    return j ? j : json_string("?"); /* a name that is not UTF-8 */
}

static json_t *job_json(const dash_job_t *j)
{
    json_t *o = json_object();
    json_object_set_new(o, "id", json_integer((json_int_t)j->id));
    json_object_set_new(o, "name", str(j->name));
    json_object_set_new(o, "owner", str(j->owner));
    json_object_set_new(o, "state", str(j->state));
    if (j->has_paused)
        json_object_set_new(o, "paused", json_boolean(j->paused));
    if (j->has_priority)
        json_object_set_new(o, "priority", json_integer(j->priority));
    if (j->has_size) {
        json_object_set_new(o, "xres", json_integer(j->xres));
        json_object_set_new(o, "yres", json_integer(j->yres));
        json_object_set_new(o, "spp", json_integer(j->spp));
        json_object_set_new(o, "npasses", json_integer(j->npasses));
    }
    json_object_set_new(o, "integrator", str(j->integrator));
    json_object_set_new(o, "samples_done", json_integer((json_int_t)j->samples_done));
    json_object_set_new(o, "samples_total", json_integer((json_int_t)j->samples_total));
    json_object_set_new(o, "nonfinite", json_integer((json_int_t)j->nonfinite));
    json_object_set_new(o, "spp_done", json_integer(j->spp_done));
    json_object_set_new(o, "passes_done", json_integer(j->passes_done));
    if (j->has_tasks) {
        json_object_set_new(o, "tasks_total", json_integer(j->tasks_total));
        json_object_set_new(o, "tasks_done", json_integer(j->tasks_done));
        json_object_set_new(o, "tasks_running", json_integer(j->tasks_running));
    }
    double progress = j->samples_total ? (double)j->samples_done / (double)j->samples_total : 0;
    bool over =
        !strcmp(j->state, "done") || !strcmp(j->state, "failed") || !strcmp(j->state, "cancelled");
    if (over && !strcmp(j->state, "done"))
        progress = 1;
    json_object_set_new(o, "progress", json_real(progress));
    if (j->has_rel_error)
        json_object_set_new(o, "rel_error", json_real(j->rel_error));
    json_object_set_new(o, "elapsed_s", json_real(j->elapsed_s));
    /* The time left if the samples still to do go as fast as those done so far: an estimate
     * for a job that runs every pass (one with a target error may end sooner); none while it
     * is paused. */
    bool paused = j->paused || !strcmp(j->state, "paused");
    if (!over && !paused && progress > 0 && progress < 1 && j->elapsed_s > 0)
        json_object_set_new(o, "eta_s", json_real(j->elapsed_s * (1 - progress) / progress));
    if (j->stop && *j->stop)
        json_object_set_new(o, "stop", str(j->stop));
    if (j->error && *j->error)
        json_object_set_new(o, "error", str(j->error));
    json_object_set_new(o, "preview_version", json_integer((json_int_t)j->preview_version));
    if (j->nframes > 0)
        json_object_set_new(o, "nframes", json_integer(j->nframes));
    if (j->sequence) {
        json_object_set_new(o, "sequence", json_integer((json_int_t)j->sequence));
        json_object_set_new(o, "frame", json_integer(j->frame));
    }
    if (j->photons) {
        json_t *ph = json_object();
        json_object_set_new(ph, "batches", json_integer(j->photon_batches));
        json_object_set_new(ph, "batches_done", json_integer(j->photon_batches_done));
        json_object_set_new(ph, "photons", json_integer((json_int_t)j->photons_traced));
        json_object_set_new(ph, "total", json_integer((json_int_t)j->photons_total));
        json_object_set_new(ph, "emitted", json_integer((json_int_t)j->photons_emitted));
        json_object_set_new(ph, "complete", json_boolean(j->photons_complete));
        json_object_set_new(o, "photon_phase", ph);
    }
    return o;
}

/* ---------------------------------------------------------------- who reads */

#define SIGN_IN                                                                                    \
    "sign in with your token (the NAME.token that prismfarm keygen wrote beside NAME.key) to "     \
    "see the jobs and workers (docs/security.md, \"The dashboard's HTTP port\")"

/* Who asks for a read: nobody (no token), a key or an administrator, or the scrapers' token. */
typedef struct viewer {
    bool token;     /* an accepted token, the scrapers' included */
    bool signed_in; /* a key's token or --http-token-file's: a user of the farm */
    dash_identity_t who;
} viewer_t;

static int identify(dash_router_t *self, const dash_request_t *req, dash_identity_t *who,
                    dash_response_t *out);

/* The viewer of a read; -1 with a 401 answered when a token was sent and is not accepted, so a
 * stale token says so instead of showing less. */
static int viewer_of(dash_router_t *self, const dash_request_t *req, viewer_t *v,
                     dash_response_t *out)
{
    memset(v, 0, sizeof *v);
    if (!req->authorization || !*req->authorization)
        return 0;
    if (identify(self, req, &v->who, out) < 0)
        return -1;
    v->token = true;
    v->signed_in = !v->who.scraper;
    return 0;
}

/* The master's one rule (p->allowed), or the owner or an administrator. */
static bool job_allowed(const dash_router_t *self, const dash_identity_t *who, const dash_job_t *j)
{
    if (who->scraper)
        return false;
    return self->p->allowed ? self->p->allowed(self->p->user, who, j)
                            : who->admin || (j->owner && *j->owner && !strcmp(j->owner, who->name));
}

/* The list of jobs, their figures and the workers: what every client key reads. */
static bool may_list(const dash_router_t *self, const viewer_t *v)
{
    return self->cfg.public_reads || v->signed_in;
}

/* A job's preview, log and tasks: what `fetch` and `logs` give its owner and administrators. */
static bool may_read_job(const dash_router_t *self, const viewer_t *v, const dash_job_t *j)
{
    return self->cfg.public_reads || (v->signed_in && job_allowed(self, &v->who, j));
}

/* 401 (no token) or 403 (another's), saying what would be needed; -1 when refused. */
static int check_list(dash_router_t *self, const viewer_t *v, const char *what,
                      dash_response_t *out)
{
    if (may_list(self, v))
        return 0;
    if (v->token)
        answer_error(out, 403, "%s: the scrapers' token reads /metrics only", what);
    else
        answer_error(out, 401, "%s: %s", what, SIGN_IN);
    return -1;
}

static int check_job(dash_router_t *self, const viewer_t *v, const dash_job_t *j, const char *what,
                     dash_response_t *out)
{
    if (may_read_job(self, v, j))
        return 0;
    if (!v->signed_in)
        answer_error(out, v->token ? 403 : 401, "the %s of job %llu: %s", what,
                     (unsigned long long)j->id,
                     v->token ? "the scrapers' token reads /metrics only" : SIGN_IN);
    else if (j->owner && *j->owner)
        answer_error(out, 403,
                     "job %llu belongs to '%s': its %s is for its owner and administrators only "
                     "('%s' reads its own jobs')",
                     (unsigned long long)j->id, j->owner, what, v->who.name);
    else
        answer_error(out, 403, "job %llu has no owner: only an administrator may read its %s",
                     (unsigned long long)j->id, what);
    return -1;
}

static json_t *actions_json(const dash_router_t *self, const viewer_t *v)
{
    json_t *a = json_object();
    json_object_set_new(a, "public_reads", json_boolean(self->cfg.public_reads));
    if (v && v->token) {
        json_object_set_new(a, "viewer", str(v->who.name));
        json_object_set_new(a, "admin", json_boolean(v->who.admin));
    }
    json_object_set_new(a, "cancel", json_boolean(self->p->cancel != NULL));
    json_object_set_new(a, "pause", json_boolean(self->p->pause != NULL));
    json_object_set_new(a, "priority", json_boolean(self->p->set_priority != NULL));
    json_object_set_new(a, "requeue", json_boolean(self->p->requeue != NULL));
    json_object_set_new(a, "blocklist", json_boolean(self->p->blocklist != NULL));
    json_object_set_new(a, "tokens", json_boolean(self->auth && dash_auth_any(self->auth)));
    return a;
}

/* A job as the viewer sees it in a list: with whether its preview, log and tasks are theirs
 * to read and whether they may act on it, so the page offers only what applies. */
static json_t *job_json_for(const dash_router_t *self, const viewer_t *v, const dash_job_t *j)
{
    json_t *o = job_json(j);
    json_object_set_new(o, "can_read", json_boolean(may_read_job(self, v, j)));
    json_object_set_new(o, "can_act", json_boolean(v->signed_in && job_allowed(self, &v->who, j)));
    return o;
}

static void get_jobs(dash_router_t *self, const viewer_t *v, dash_response_t *out)
{
    size_t n = self->p->jobs ? self->p->jobs(self->p->user, self->jobs, DASH_MAX_JOBS) : 0;
    json_t *list = json_array();
    json_t *o = json_object();
    if (may_list(self, v))
        for (size_t i = 0; i < n && i < DASH_MAX_JOBS; i++)
            json_array_append_new(list, job_json_for(self, v, &self->jobs[i]));
    else {
        /* What is public: how many jobs there are, by state; no name, owner or figure. */
        json_t *counts = json_object();
        for (size_t i = 0; i < n && i < DASH_MAX_JOBS; i++) {
            const char *st = self->jobs[i].paused ? "paused" : self->jobs[i].state;
            json_t *c = json_object_get(counts, st ? st : "?");
            json_object_set_new(counts, st ? st : "?",
                                json_integer(c ? json_integer_value(c) + 1 : 1));
        }
        json_object_set_new(o, "hidden", json_true());
        json_object_set_new(o, "counts", counts);
        json_object_set_new(o, "signin", json_string(SIGN_IN));
    }
    json_object_set_new(o, "jobs", list);
    json_object_set_new(o, "actions", actions_json(self, v));
    answer_json(out, 200, o);
}

static int find_job(dash_router_t *self, uint64_t id, dash_job_t *j, dash_response_t *out)
{
    int rc = self->p->job ? self->p->job(self->p->user, id, j) : DASH_ENOENT;
    if (rc < 0)
        answer_error(out, 404, "no job %llu", (unsigned long long)id);
    return rc;
}

static void get_job(dash_router_t *self, const viewer_t *v, uint64_t id, dash_response_t *out)
{
    dash_job_t j;
    if (check_list(self, v, "a job's figures", out) < 0 || find_job(self, id, &j, out) < 0)
        return;
    json_t *o = job_json_for(self, v, &j);
    json_t *passes = json_array();
    dash_pass_t recs[DASH_MAX_PASSES];
    int n = self->p->passes ? self->p->passes(self->p->user, id, recs, DASH_MAX_PASSES) : 0;
    for (int i = 0; i < n && i < DASH_MAX_PASSES; i++) {
        json_t *r = json_object();
        json_object_set_new(r, "pass", json_integer(recs[i].pass));
        json_object_set_new(r, "spp", json_integer(recs[i].spp));
        json_object_set_new(r, "elapsed_s", json_real(recs[i].elapsed_s));
        if (recs[i].valid)
            json_object_set_new(r, "rel_error", json_real(recs[i].rel_error));
        json_array_append_new(passes, r);
    }
    json_object_set_new(o, "passes", passes);
    /* A sequence's view lists its frames, each as /api/jobs shows a job. */
    if (j.nframes > 0 && self->p->frames) {
        json_t *frames = json_array();
        int nf = self->p->frames(self->p->user, id, self->jobs, DASH_MAX_JOBS);
        for (int i = 0; i < nf && i < DASH_MAX_JOBS; i++)
            json_array_append_new(frames, job_json_for(self, v, &self->jobs[i]));
        json_object_set_new(o, "frames", frames);
    }
    json_object_set_new(o, "actions", actions_json(self, v));
    answer_json(out, 200, o);
}

static void get_preview(dash_router_t *self, const viewer_t *v, uint64_t id, dash_response_t *out)
{
    dash_job_t j;
    if (find_job(self, id, &j, out) < 0 || check_job(self, v, &j, "preview", out) < 0)
        return;
    uint8_t *png = NULL;
    size_t size = 0;
    err_t err;
    if (!self->p->preview || j.preview_version == 0) {
        answer_error(out, 404, "job %llu has no image yet (a preview follows each pass)",
                     (unsigned long long)id);
        return;
    }
    int rc = self->p->preview(self->p->user, id, &png, &size, &err);
    if (rc < 0) {
        answer_error(out, rc == DASH_ENOENT ? 404 : 500, "job %llu: %s", (unsigned long long)id,
                     rc == DASH_ENOENT ? "no image yet" : err.msg);
        return;
    }
    *out = (dash_response_t){.status = 200, .content_type = "image/png", .body = png, .size = size};
}

static void get_tiles(dash_router_t *self, const viewer_t *v, uint64_t id, dash_response_t *out)
{
    dash_job_t j;
    if (check_list(self, v, "a job's tile map", out) < 0 || find_job(self, id, &j, out) < 0)
        return;
    if (!self->p->tiles) {
        answer_error(out, 501, "this master does not show tile maps");
        return;
    }
    dash_tilemap_t map = {0};
    err_t err;
    int rc = self->p->tiles(self->p->user, id, &map, &err);
    if (rc < 0) {
        answer_error(out, rc == DASH_ENOENT ? 404 : 409, "job %llu: %s", (unsigned long long)id,
                     rc == DASH_ENOENT ? "no such job" : err.msg);
        return;
    }
    size_t ntiles =
        map.tiles_x > 0 && map.tiles_y > 0 ? (size_t)map.tiles_x * (size_t)map.tiles_y : 0;
    /* The buffers are ours whatever the provider does with the map: one that knows nothing of
     * spp may leave it NULL, and then the answer has none. */
    int *merged_buf = NULL, *spp_buf = NULL;
    if (ntiles > 0 && (!(merged_buf = calloc(ntiles, sizeof *merged_buf)) ||
                       !(spp_buf = calloc(ntiles, sizeof *spp_buf)))) {
        free(merged_buf);
        answer_error(out, 500, "the master is out of memory");
        return;
    }
    map.merged = merged_buf;
    map.spp = spp_buf;
    if (ntiles > 0 && self->p->tiles(self->p->user, id, &map, &err) < 0) {
        free(merged_buf);
        free(spp_buf);
        answer_error(out, 409, "job %llu: %s", (unsigned long long)id, err.msg);
        return;
    }
    json_t *o = json_object();
    json_object_set_new(o, "xres", json_integer(map.xres));
    json_object_set_new(o, "yres", json_integer(map.yres));
    json_object_set_new(o, "tile", json_integer(map.tile));
    json_object_set_new(o, "tiles_x", json_integer(map.tiles_x));
    json_object_set_new(o, "tiles_y", json_integer(map.tiles_y));
    json_object_set_new(o, "npasses", json_integer(map.npasses));
    json_t *merged = json_array();
    for (size_t i = 0; i < ntiles && map.merged; i++)
        json_array_append_new(merged, json_integer(map.merged[i]));
    json_object_set_new(o, "merged", merged);
    json_t *spp = json_array();
    for (size_t i = 0; i < ntiles && map.spp == spp_buf && spp_buf; i++)
        json_array_append_new(spp, json_integer(spp_buf[i]));
    free(merged_buf);
    free(spp_buf);
    json_object_set_new(o, "spp", spp);
    json_object_set_new(o, "adaptive", json_boolean(map.adaptive));
    json_object_set_new(o, "passes_done", json_integer(map.passes_done));
    /* The running tasks place the workers on the map. */
    int n = self->p->tasks ? self->p->tasks(self->p->user, id, self->tasks, DASH_MAX_TASKS) : 0;
    json_t *run = json_array();
    for (int i = 0; i < n && i < DASH_MAX_TASKS; i++) {
        if (self->tasks[i].photon)
            continue;
        json_t *t = json_object();
        json_object_set_new(t, "tile", json_integer(self->tasks[i].tile));
        json_object_set_new(t, "pass", json_integer(self->tasks[i].pass));
        json_object_set_new(t, "worker", json_integer((json_int_t)self->tasks[i].worker));
        json_object_set_new(t, "running_s", json_real(self->tasks[i].running_s));
        json_array_append_new(run, t);
    }
    json_object_set_new(o, "running", run);
    answer_json(out, 200, o);
}

static void get_tasks(dash_router_t *self, const viewer_t *v, uint64_t id, dash_response_t *out)
{
    dash_job_t j;
    if (find_job(self, id, &j, out) < 0 || check_job(self, v, &j, "tasks", out) < 0)
        return;
    int n = self->p->tasks ? self->p->tasks(self->p->user, id, self->tasks, DASH_MAX_TASKS) : 0;
    json_t *list = json_array();
    for (int i = 0; i < n && i < DASH_MAX_TASKS; i++) {
        const dash_task_t *t = &self->tasks[i];
        json_t *o = json_object();
        json_object_set_new(o, "task", json_integer(t->task));
        json_object_set_new(o, "kind", json_string(t->photon ? "photon" : "camera"));
        if (t->photon)
            json_object_set_new(o, "batch", json_integer(t->batch));
        else {
            json_object_set_new(o, "tile", json_integer(t->tile));
            json_object_set_new(o, "pass", json_integer(t->pass));
            json_object_set_new(o, "sample_begin", json_integer(t->sample_begin));
            json_object_set_new(o, "sample_end", json_integer(t->sample_end));
        }
        json_object_set_new(o, "attempt", json_integer(t->attempt));
        json_object_set_new(o, "worker", json_integer((json_int_t)t->worker));
        json_object_set_new(o, "worker_name", str(t->worker_name));
        json_object_set_new(o, "running_s", json_real(t->running_s));
        json_array_append_new(list, o);
    }
    json_t *o = json_object();
    json_object_set_new(o, "job", json_integer((json_int_t)id));
    json_object_set_new(o, "state", str(j.state));
    json_object_set_new(o, "tasks", list);
    answer_json(out, 200, o);
}

static void get_log(dash_router_t *self, const viewer_t *v, const dash_request_t *req, uint64_t job,
                    dash_response_t *out)
{
    if (job) {
        dash_job_t j;
        if (find_job(self, job, &j, out) < 0 || check_job(self, v, &j, "log", out) < 0)
            return;
    } else if (!self->cfg.public_reads && !(v->signed_in && v->who.admin)) {
        /* Every job's lines: an administrator's (a user reads their own jobs' logs). */
        if (v->signed_in)
            answer_error(out, 403,
                         "the whole log is for administrators: '%s' reads its own jobs' logs",
                         v->who.name);
        else
            answer_error(out, v->token ? 403 : 401, "the master's log: %s",
                         v->token ? "the scrapers' token reads /metrics only" : SIGN_IN);
        return;
    }
    uint64_t since = 0;
    const char *s = arg_find(req, "since");
    if (s && parse_u64(s, strlen(s), &since) < 0) {
        answer_error(out, 400, "since must be a line number (0..2^64-1)");
        return;
    }
    int n = self->p->log ? self->p->log(self->p->user, job, since, self->log, DASH_MAX_LOG) : 0;
    json_t *lines = json_array();
    for (int i = 0; i < n && i < DASH_MAX_LOG; i++) {
        json_t *o = json_object();
        json_object_set_new(o, "seq", json_integer((json_int_t)self->log[i].seq));
        json_object_set_new(o, "age_s", json_real(self->log[i].age_s));
        json_object_set_new(o, "text", str(self->log[i].text));
        json_array_append_new(lines, o);
    }
    json_t *o = json_object();
    json_object_set_new(o, "lines", lines);
    answer_json(out, 200, o);
}

static void get_workers(dash_router_t *self, const viewer_t *v, dash_response_t *out)
{
    if (check_list(self, v, "the workers", out) < 0)
        return;
    size_t n =
        self->p->workers ? self->p->workers(self->p->user, self->workers, DASH_MAX_WORKERS) : 0;
    json_t *list = json_array();
    for (size_t i = 0; i < n && i < DASH_MAX_WORKERS; i++) {
        const dash_worker_t *w = &self->workers[i];
        json_t *o = json_object();
        json_object_set_new(o, "id", json_integer((json_int_t)w->id));
        json_object_set_new(o, "name", str(w->name));
        json_object_set_new(o, "key", str(w->key));
        json_object_set_new(o, "threads", json_integer(w->threads));
        json_object_set_new(o, "state", str(w->state));
        json_object_set_new(o, "tasks_running", json_integer(w->tasks_running));
        json_object_set_new(o, "tasks_done", json_integer((json_int_t)w->tasks_done));
        json_object_set_new(o, "tasks_failed", json_integer((json_int_t)w->tasks_failed));
        json_object_set_new(o, "samples_done", json_integer((json_int_t)w->samples_done));
        if (w->has_rate)
            json_object_set_new(o, "samples_per_s", json_real(w->samples_per_s));
        json_object_set_new(o, "last_seen_s", json_real(w->last_seen_s));
        if (w->has_blocklisted)
            json_object_set_new(o, "blocklisted", json_boolean(w->blocklisted));
        json_array_append_new(list, o);
    }
    json_t *o = json_object();
    json_object_set_new(o, "workers", list);
    json_object_set_new(o, "actions", actions_json(self, v));
    answer_json(out, 200, o);
}

/* GET /metrics: Prometheus' text, for any accepted token (a scraper's: --metrics-token-file). */
static void get_metrics(dash_router_t *self, const viewer_t *v, dash_response_t *out)
{
    if (!self->p->metrics) {
        answer_error(out, 501, "this master has no metrics");
        return;
    }
    if (!self->cfg.public_reads && !v->token) {
        answer_error(out, 401,
                     "/metrics needs 'Authorization: Bearer TOKEN': a key's NAME.token or the "
                     "scrapers' --metrics-token-file (docs/deploy.md, \"Prometheus\")");
        return;
    }
    char *text = NULL;
    size_t len = 0;
    err_t err;
    if (self->p->metrics(self->p->user, &text, &len, &err) < 0) {
        answer_error(out, 500, "%s", err.msg);
        return;
    }
    *out = (dash_response_t){.status = 200,
                             .content_type = "text/plain; version=0.0.4; charset=utf-8",
                             .body = (uint8_t *)text,
                             .size = len};
}

/* ---------------------------------------------------------------- actions */

/* Who the request's token is; 401 answered when none is accepted. */
static int identify(dash_router_t *self, const dash_request_t *req, dash_identity_t *who,
                    dash_response_t *out)
{
    err_t err;
    if (!self->auth) {
        answer_error(out, 401,
                     "this master accepts no token: actions need its authorised key "
                     "folders or --http-token-file (docs/dashboard.md)");
        return -1;
    }
    if (dash_auth_identify(self->auth, req->authorization, who, &err) < 0) {
        answer_error(out, 401, "%s", err.msg);
        return -1;
    }
    return 0;
}

static void get_whoami(dash_router_t *self, const dash_request_t *req, dash_response_t *out)
{
    dash_identity_t who;
    if (identify(self, req, &who, out) < 0)
        return;
    json_t *o = json_object();
    json_object_set_new(o, "name", str(who.name));
    json_object_set_new(o, "admin", json_boolean(who.admin));
    if (who.scraper)
        json_object_set_new(o, "scraper", json_true());
    answer_json(out, 200, o);
}

static void answer_done(dash_response_t *out, const char *what, uint64_t id)
{
    json_t *o = json_object();
    json_object_set_new(o, "ok", json_true());
    json_object_set_new(o, "action", json_string(what));
    json_object_set_new(o, "id", json_integer((json_int_t)id));
    answer_json(out, 200, o);
}

/* The body's {"priority": N}. */
static int body_priority(const dash_request_t *req, int *out, char *why, size_t size)
{
    json_error_t jerr;
    json_t *j =
        req->body_len ? json_loadb(req->body, req->body_len, JSON_REJECT_DUPLICATES, &jerr) : NULL;
    json_t *v = j ? json_object_get(j, "priority") : NULL;
    int rc = -1;
    if (!j)
        snprintf(why, size, "the body must be JSON {\"priority\": N}%s%s",
                 req->body_len ? ": " : "", req->body_len ? jerr.text : "");
    else if (!json_is_integer(v))
        snprintf(why, size, "the body must be {\"priority\": N} with N an integer");
    else if (json_integer_value(v) < -DASH_PRIORITY_MAX ||
             json_integer_value(v) > DASH_PRIORITY_MAX)
        snprintf(why, size, "priority %lld is outside %d..%d", (long long)json_integer_value(v),
                 -DASH_PRIORITY_MAX, DASH_PRIORITY_MAX);
    else {
        *out = (int)json_integer_value(v);
        rc = 0;
    }
    json_decref(j);
    return rc;
}

/* POST /api/jobs/ID/ACTION[/...]: the job's owner or an administrator. */
static void job_action(dash_router_t *self, const dash_request_t *req, uint64_t id,
                       const seg_t *segs, int nseg, dash_response_t *out)
{
    const seg_t *act = &segs[3];
    enum { CANCEL, PAUSE, RESUME, PRIORITY, REQUEUE } kind;
    uint64_t task = 0;
    if (nseg == 4 && seg_is(act, "cancel"))
        kind = CANCEL;
    else if (nseg == 4 && seg_is(act, "pause"))
        kind = PAUSE;
    else if (nseg == 4 && seg_is(act, "resume"))
        kind = RESUME;
    else if (nseg == 4 && seg_is(act, "priority"))
        kind = PRIORITY;
    else if (nseg == 6 && seg_is(act, "tasks") && seg_is(&segs[5], "requeue") &&
             parse_u64(segs[4].s, segs[4].n, &task) == 0 && task <= UINT32_MAX)
        kind = REQUEUE;
    else {
        answer_error(out, 404,
                     "no such action: POST /api/jobs/ID/cancel, pause, resume, "
                     "priority or tasks/TASK/requeue");
        return;
    }
    const dash_provider_t *p = self->p;
    static const char *names[] = {"cancel", "pause", "resume", "priority", "requeue"};
    bool have = kind == CANCEL     ? p->cancel != NULL
                : kind == PRIORITY ? p->set_priority != NULL
                : kind == REQUEUE  ? p->requeue != NULL
                                   : p->pause != NULL;
    if (!have) {
        answer_error(out, 501, "this master cannot %s a %s yet", names[kind],
                     kind == REQUEUE ? "task" : "job");
        return;
    }
    int priority = 0;
    char why[300];
    if (kind == PRIORITY && body_priority(req, &priority, why, sizeof why) < 0) {
        answer_error(out, 400, "%s", why);
        return;
    }
    dash_identity_t who;
    if (identify(self, req, &who, out) < 0)
        return;
    dash_job_t j;
    if (find_job(self, id, &j, out) < 0)
        return;
    if (who.scraper) {
        answer_error(out, 403, "the scrapers' token reads /metrics only");
        return;
    }
    if (!job_allowed(self, &who, &j)) {
        if (j.owner && *j.owner)
            answer_error(out, 403,
                         "job %llu belongs to '%s': '%s' may act only on its own jobs "
                         "(an administrator's key may act on any)",
                         (unsigned long long)id, j.owner, who.name);
        else
            answer_error(out, 403, "job %llu has no owner: only an administrator may act on it",
                         (unsigned long long)id);
        return;
    }
    err_t err;
    int rc = kind == CANCEL     ? p->cancel(p->user, &who, id, &err)
             : kind == PRIORITY ? p->set_priority(p->user, &who, id, priority, &err)
             : kind == REQUEUE  ? p->requeue(p->user, &who, id, (uint32_t)task, &err)
                                : p->pause(p->user, &who, id, kind == PAUSE, &err);
    if (rc < 0)
        answer_error(out, rc == DASH_ENOENT ? 404 : 409, "%s", err.msg);
    else
        answer_done(out, names[kind], id);
}

/* POST /api/workers/ID/blocklist or unblock: an administrator. */
static void worker_action(dash_router_t *self, const dash_request_t *req, uint64_t id,
                          const seg_t *act, dash_response_t *out)
{
    bool block = seg_is(act, "blocklist");
    if (!block && !seg_is(act, "unblock")) {
        answer_error(out, 404, "no such action: POST /api/workers/ID/blocklist or unblock");
        return;
    }
    if (!self->p->blocklist) {
        answer_error(out, 501, "this master cannot %s a worker yet",
                     block ? "blocklist" : "unblock");
        return;
    }
    dash_identity_t who;
    if (identify(self, req, &who, out) < 0)
        return;
    if (!who.admin || who.scraper) {
        answer_error(out, 403,
                     "'%s' is not an administrator: only an administrator's key "
                     "may blocklist or unblock a worker",
                     who.name);
        return;
    }
    err_t err;
    int rc = self->p->blocklist(self->p->user, &who, id, block, &err);
    if (rc < 0)
        answer_error(out, rc == DASH_ENOENT ? 404 : 409, "%s", err.msg);
    else
        answer_done(out, block ? "blocklist" : "unblock", id);
}

/* ---------------------------------------------------------------- the routes */

static void route_get(dash_router_t *self, const dash_request_t *req, const seg_t *segs, int n,
                      dash_response_t *out)
{
    viewer_t v = {0};
    if (n == 1 && seg_is(&segs[0], "metrics")) {
        if (viewer_of(self, req, &v, out) == 0)
            get_metrics(self, &v, out);
        return;
    }
    if (n == 0 || !seg_is(&segs[0], "api")) {
        const dash_asset_t *a = n <= 1 ? dash_asset_find(req->path) : NULL;
        if (!a) {
            answer_error(out, 404, "no page %.200s", req->path);
            return;
        }
        *out = (dash_response_t){.status = 200,
                                 .content_type = a->content_type,
                                 .body = (uint8_t *)a->data,
                                 .size = a->size,
                                 .is_static = true,
                                 .cacheable = true};
        return;
    }
    uint64_t id = 0;
    bool has_id = n >= 3 && parse_u64(segs[2].s, segs[2].n, &id) == 0;
    bool whoami = n == 2 && seg_is(&segs[1], "whoami");
    if (!whoami && viewer_of(self, req, &v, out) < 0)
        return;
    if (n == 2 && seg_is(&segs[1], "jobs"))
        get_jobs(self, &v, out);
    else if (n == 2 && seg_is(&segs[1], "workers"))
        get_workers(self, &v, out);
    else if (n == 2 && seg_is(&segs[1], "log"))
        get_log(self, &v, req, 0, out);
    else if (n == 2 && seg_is(&segs[1], "whoami"))
        get_whoami(self, req, out);
    else if (n >= 3 && seg_is(&segs[1], "jobs") && !has_id)
        answer_error(out, 400, "a job id is a decimal number, not '%.*s'",
                     (int)(segs[2].n > 40 ? 40 : segs[2].n), segs[2].s);
    else if (n == 3 && seg_is(&segs[1], "jobs"))
        get_job(self, &v, id, out);
    else if (n == 4 && seg_is(&segs[1], "jobs") && seg_is(&segs[3], "preview.png"))
        get_preview(self, &v, id, out);
    else if (n == 4 && seg_is(&segs[1], "jobs") && seg_is(&segs[3], "tiles"))
        get_tiles(self, &v, id, out);
    else if (n == 4 && seg_is(&segs[1], "jobs") && seg_is(&segs[3], "tasks"))
        get_tasks(self, &v, id, out);
    else if (n == 4 && seg_is(&segs[1], "jobs") && seg_is(&segs[3], "log"))
        get_log(self, &v, req, id, out);
    else
        answer_error(out, 404, "no such resource (docs/dashboard.md lists the API)");
}

static void route_post(dash_router_t *self, const dash_request_t *req, const seg_t *segs, int n,
                       dash_response_t *out)
{
    uint64_t id = 0;
    bool api = n >= 1 && seg_is(&segs[0], "api");
    bool has_id = n >= 3 && parse_u64(segs[2].s, segs[2].n, &id) == 0;
    if (api && n >= 4 && seg_is(&segs[1], "jobs") && has_id)
        job_action(self, req, id, segs, n, out);
    else if (api && n == 4 && seg_is(&segs[1], "workers") && has_id)
        worker_action(self, req, id, &segs[3], out);
    else if (api && n >= 3 && !has_id && (seg_is(&segs[1], "jobs") || seg_is(&segs[1], "workers")))
        answer_error(out, 400, "an id is a decimal number");
    else
        answer_error(out, 404, "no such action (docs/dashboard.md lists the API)");
}

void dash_route(dash_router_t *self, const dash_request_t *req, dash_response_t *out)
{
    memset(out, 0, sizeof *out);
    if (!req->method || !req->path) {
        answer_error(out, 400, "malformed request");
        return;
    }
    size_t plen = strnlen(req->path, DASH_MAX_PATH + 1);
    if (plen > DASH_MAX_PATH) {
        answer_error(out, 414, "the path is longer than %d bytes", DASH_MAX_PATH);
        return;
    }
    if (req->body_len > DASH_MAX_BODY) {
        answer_error(out, 413, "the body is larger than %d bytes", DASH_MAX_BODY);
        return;
    }
    for (size_t i = 0; i < req->nargs; i++)
        if ((req->args[i].key && strnlen(req->args[i].key, DASH_MAX_ARG + 1) > DASH_MAX_ARG) ||
            (req->args[i].value && strnlen(req->args[i].value, DASH_MAX_ARG + 1) > DASH_MAX_ARG)) {
            answer_error(out, 400, "a query argument is longer than %d bytes", DASH_MAX_ARG);
            return;
        }
    if (self->cfg.check_host && req->host && !host_is_loopback(req->host)) {
        answer_error(out, 421,
                     "this dashboard answers on 127.0.0.1 only (Host '%.80s' "
                     "refused; docs/dashboard.md, \"Security\")",
                     req->host);
        return;
    }
    seg_t segs[8];
    int n = split_path(req->path, segs, 8);
    if (n < 0) {
        answer_error(out, 404, "malformed path");
        return;
    }
    bool get = !strcmp(req->method, "GET") || !strcmp(req->method, "HEAD");
    bool api = n >= 1 && seg_is(&segs[0], "api");
    /* Reads are GETs; an action is a POST to /api, so that no link or image a page embeds can
     * act (and it needs the token besides). */
    if (get)
        route_get(self, req, segs, n, out);
    else if (!strcmp(req->method, "POST") && api)
        route_post(self, req, segs, n, out);
    else {
        answer_error(out, 405, "%.16s is not a method of %s", req->method,
                     api ? "the API: GET reads, POST acts" : "the pages: GET");
        out->allow = api ? "GET, HEAD, POST" : "GET, HEAD";
    }
}
