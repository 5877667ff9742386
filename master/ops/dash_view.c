#include "dash_view.h"

#include "access.h"
#include "clock.h"
#include "dash_auth.h"
#include "dash_provider.h"
#include "dash_route.h"
#include "dash_server.h"
#include "files.h"
#include "jobs.h"
#include "logbook.h"
#include "metrics.h"
#include "ops.h"
#include "passes.h"
#include "peers.h"
#include "tasklog.h"
#include "tilegrid.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_PREVIEW_BYTES (64u << 20) /* a preview PNG larger than this is not served */

struct dash_view {
    master_t *m;
    dash_provider_t provider;
    dash_auth_t *auth;
    dash_router_t *router;
    dash_server_t *server;
    sched_running_t running[DASH_MAX_TASKS]; /* scratch of the tasks callback */
    logbook_line_t lines[DASH_MAX_LOG];      /* scratch of the log callback */
};

/* ---------------------------------------------------------------- reading the state */

static void fill_job(master_t *m, const job_t *j, double now, dash_job_t *o)
{
    *o = (dash_job_t){
        .id = j->id,
        .name = j->name,
        .owner = j->owner,
        .state = proto_job_state_name(jobs_wire_state(j)), /* "paused" as `jobs` says it */
        .xres = j->scene.xres,
        .yres = j->scene.yres,
        .spp = j->scene.spp,
        .integrator = j->scene.integrator ? j->scene.integrator : j->settings.integrator,
        .samples_done = j->sched.samples_done,
        .samples_total = j->sched.samples_total,
        .nonfinite = j->sched.nonfinite,
        .spp_done = j->accuracy.spp_done,
        .stop = j->accuracy.stop == PROTO_STOP_NONE ? "" : proto_stop_name(j->accuracy.stop),
        /* As STATUS says it: a failure, or why a done job's outputs wait (a full disk). */
        .error = j->state == JOB_FAILED ? (j->error ? j->error : "failed")
                 : j->outputs.waiting   ? j->outputs.why
                                        : "",
        .photons = j->photons.enabled,
        .has_paused = true,
        .paused = j->ops.paused && !job_over(j),
        .has_priority = true,
        .priority = j->ops.priority,
    };
    o->npasses = j->scene.spp > 0 ? passes_bounds(j->scene.spp, NULL) : 0;
    /* A job restored after a restart has no size until its scene is loaded again. */
    o->has_size = j->scene.xres > 0 && j->scene.yres > 0 && j->scene.spp > 0;
    o->passes_done =
        j->accuracy.nhistory > 0 ? j->accuracy.history[j->accuracy.nhistory - 1].pass : 0;
    sched_job_info_t info;
    if (j->sched.known && sched_job_info(m->sched, j->id, &info) == 0) {
        o->samples_done = info.samples_done;
        o->samples_total = info.samples_total;
        o->nonfinite = info.nonfinite;
        o->spp_done = info.spp_done;
        o->passes_done = info.passes_done;
        o->npasses = info.npasses;
        o->has_tasks = true;
        o->tasks_total = info.tasks_total;
        o->tasks_done = info.tasks_done;
        o->tasks_running = info.tasks_running;
        o->photon_batches = info.photon_batches;
        o->photon_batches_done = info.photon_batches_done;
    } else if (j->sched.has_tasks) { /* over: what the scheduler had when it forgot the job */
        o->has_tasks = true;
        o->tasks_total = j->sched.tasks_total;
        o->tasks_done = j->sched.tasks_done;
    }
    const pass_record_t *last =
        j->accuracy.nhistory > 0 ? &j->accuracy.history[j->accuracy.nhistory - 1] : NULL;
    if (last && last->valid) {
        o->has_rel_error = true;
        o->rel_error = last->rel_error;
    }
    o->elapsed_s = job_elapsed(m, j, now);
    /* A new image on disk changes the version: the final outputs after the last preview. */
    if (j->outputs.final)
        o->preview_version = (uint64_t)(j->finished * 1000.0) + 2;
    else if (j->outputs.preview)
        o->preview_version = (uint64_t)(j->outputs.last_preview * 1000.0) + 1;
    if (j->photons.phase) {
        photon_phase_stats_t ps = photon_phase_stats(j->photons.phase);
        o->photons_traced = ps.photons;
        o->photons_total = ps.total;
        o->photons_emitted = ps.emitted;
        if (!j->sched.known) {
            o->photon_batches = ps.batches;
            o->photon_batches_done = ps.batches_merged;
        }
        o->photons_complete = photon_phase_complete(j->photons.phase);
    } else if (j->photons.enabled) {
        o->photons_traced = o->photons_total = j->photons.saved;
        o->photons_complete = j->photons.saved > 0; /* kept on disk once merged */
    }
    o->sequence = j->seq.parent;
    o->frame = j->seq.frame;
    o->nframes = j->seq.nframes;
    if (j->seq.nframes > 0) {
        /* A sequence's figures are its frames' summed (as STATUS shows them). */
        dash_job_t f;
        o->samples_done = o->samples_total = o->nonfinite = 0;
        o->tasks_total = o->tasks_done = o->tasks_running = 0;
        o->has_tasks = true;
        for (uint32_t k = 0; k < j->seq.nframes; k++) {
            const job_t *fj = jobs_frame(m, j, k);
            if (!fj)
                continue;
            fill_job(m, fj, now, &f);
            o->samples_done += f.samples_done;
            o->samples_total += f.samples_total;
            o->nonfinite += f.nonfinite;
            o->tasks_total += f.tasks_total;
            o->tasks_done += f.tasks_done;
            o->tasks_running += f.tasks_running;
            o->has_tasks = o->has_tasks && f.has_tasks;
        }
    }
}

/* The most recent jobs but the frames of a sequence, which its view lists (pv_frames). */
static size_t pv_jobs(void *user, dash_job_t *out, size_t max)
{
    dash_view_t *v = user;
    master_t *m = v->m;
    double now = clock_now_s();
    size_t n = 0, i = m->njobs;
    while (i > 0 && n < max)
        n += m->jobs[--i]->seq.parent == 0;
    for (size_t k = 0; i < m->njobs; i++)
        if (m->jobs[i]->seq.parent == 0)
            fill_job(m, m->jobs[i], now, &out[k++]);
    return n;
}

static int pv_frames(void *user, uint64_t id, dash_job_t *out, int max)
{
    dash_view_t *v = user;
    const job_t *j = jobs_find(v->m, id);
    if (!j)
        return DASH_ENOENT;
    double now = clock_now_s();
    int n = 0;
    for (uint32_t k = 0; k < j->seq.nframes && n < max; k++) {
        const job_t *f = jobs_frame(v->m, j, k);
        if (f)
            fill_job(v->m, f, now, &out[n++]);
    }
    return n;
}

static int pv_job(void *user, uint64_t id, dash_job_t *out)
{
    dash_view_t *v = user;
    const job_t *j = jobs_find(v->m, id);
    if (!j)
        return DASH_ENOENT;
    fill_job(v->m, j, clock_now_s(), out);
    return 0;
}

static int pv_preview(void *user, uint64_t id, uint8_t **png, size_t *size, err_t *err)
{
    dash_view_t *v = user;
    const job_t *j = jobs_find(v->m, id);
    if (!j)
        return DASH_ENOENT;
    if (!j->outputs.final && !j->outputs.preview)
        return DASH_ENOENT;
    /* The file on_fetch sends too: the final PNG once the job is done, else the preview. */
    char path[PATH_MAX + 200];
    if (j->outputs.final)
        snprintf(path, sizeof path, "%s/jobs/%llu/%s.png", spool_path(v->m->spool),
                 (unsigned long long)j->id, j->stem);
    else
        snprintf(path, sizeof path, "%s/jobs/%llu/preview.png", spool_path(v->m->spool),
                 (unsigned long long)j->id);
    return files_read(path, MAX_PREVIEW_BYTES, png, size, err);
}

static int pv_passes(void *user, uint64_t id, dash_pass_t *out, int max)
{
    dash_view_t *v = user;
    const job_t *j = jobs_find(v->m, id);
    if (!j)
        return DASH_ENOENT;
    int n = 0;
    for (int i = 0; i < j->accuracy.nhistory && n < max; i++) {
        const pass_record_t *r = &j->accuracy.history[i];
        out[n++] = (dash_pass_t){.pass = r->pass,
                                 .spp = r->spp,
                                 .elapsed_s = r->elapsed,
                                 .valid = r->valid,
                                 .rel_error = r->rel_error};
    }
    return n;
}

static int fill_merged(master_t *m, const job_t *j, bool live, dash_tilemap_t *map, int n,
                       err_t *err);

static int pv_tiles(void *user, uint64_t id, dash_tilemap_t *map, err_t *err)
{
    dash_view_t *v = user;
    master_t *m = v->m;
    const job_t *j = jobs_find(m, id);
    if (!j)
        return DASH_ENOENT;
    if (j->scene.xres < 1 || j->scene.yres < 1 || j->scene.spp < 1)
        return err_set(err, "its scene is not loaded: no tiles to show");
    tilegrid_t g = tilegrid_make(j->scene.xres, j->scene.yres,
                                 j->sched.tile > 0 ? j->sched.tile : m->opts->sched.tile_size);
    int *merged = map->merged, *spp = map->spp;
    *map = (dash_tilemap_t){.xres = g.xres,
                            .yres = g.yres,
                            .tile = g.tile,
                            .tiles_x = g.tiles_x,
                            .tiles_y = g.tiles_y,
                            .npasses = passes_bounds(j->scene.spp, NULL),
                            .merged = merged,
                            .spp = spp};
    sched_job_info_t si;
    bool live = j->sched.known && sched_job_info(m->sched, j->id, &si) == 0;
    if (live) {
        map->adaptive = si.adaptive;
        map->passes_done = si.passes_done;
    } else {
        map->adaptive = j->accuracy.tile_passes != NULL;
        map->passes_done = j->accuracy.stop != PROTO_STOP_NONE && j->accuracy.nhistory > 0
                               ? j->accuracy.history[j->accuracy.nhistory - 1].pass
                               : map->npasses;
    }
    if (!merged)
        return 0;
    int n = tilegrid_count(&g);
    if (fill_merged(m, j, live, map, n, err) < 0)
        return -1;
    if (spp) {
        uint32_t bounds[PASSES_MAX_BOUNDS];
        passes_bounds(j->scene.spp, bounds);
        for (int i = 0; i < n; i++)
            spp[i] = merged[i] >= 0 && merged[i] <= map->npasses ? (int)bounds[merged[i]] : 0;
    }
    return 0;
}

/* Per tile the passes merged: the scheduler's while it holds the job, else what the job kept. */
static int fill_merged(master_t *m, const job_t *j, bool live, dash_tilemap_t *map, int n,
                       err_t *err)
{
    int *merged = map->merged;
    if (live)
        return sched_job_next_pass(m->sched, j->id, merged, n) == n
                   ? 0
                   : err_set(err, "the scheduler's tiles differ from the scene's");
    if (j->accuracy.tile_passes && j->accuracy.ntiles == n) {
        memcpy(merged, j->accuracy.tile_passes, (size_t)n * sizeof *merged);
        return 0;
    }
    /* Over: the scheduler forgot the tiles with the image. A job done merged every pass of
     * every tile (or, ended early, the passes its record says: whole passes only). */
    if (j->state != JOB_DONE)
        return err_set(err, "it is %s: the scheduler forgot its tiles when it ended",
                       proto_job_state_name(j->state));
    for (int i = 0; i < n; i++)
        merged[i] = map->passes_done;
    return 0;
}

static int pv_tasks(void *user, uint64_t id, dash_task_t *out, int max)
{
    dash_view_t *v = user;
    master_t *m = v->m;
    const job_t *j = jobs_find(m, id);
    if (!j)
        return DASH_ENOENT;
    if (!j->sched.known)
        return 0;
    if (max > DASH_MAX_TASKS)
        max = DASH_MAX_TASKS;
    int n = sched_job_running(m->sched, id, v->running, max);
    double now = clock_now_s();
    for (int i = 0; i < n; i++) {
        const sched_running_t *r = &v->running[i];
        const mworker_t *w = peers_by_id(m, r->worker);
        double age = now - r->issued;
        out[i] = (dash_task_t){.task = r->task,
                               .photon = r->kind == SCHED_PHOTON,
                               .tile = r->tile,
                               .pass = r->pass,
                               .batch = r->batch,
                               .sample_begin = r->sample_begin,
                               .sample_end = r->sample_end,
                               .attempt = r->attempt,
                               .worker = r->worker,
                               .worker_name = w && w->name ? w->name : "?",
                               .running_s = age > 0 ? age : 0};
    }
    return n < 0 ? 0 : n;
}

static int pv_log(void *user, uint64_t job, uint64_t since, dash_log_line_t *out, int max)
{
    dash_view_t *v = user;
    if (!v->m->logbook)
        return 0;
    if (max > DASH_MAX_LOG)
        max = DASH_MAX_LOG;
    int n = logbook_read(v->m->logbook, job, since, v->lines, max);
    double now = clock_now_s();
    for (int i = 0; i < n; i++)
        out[i] = (dash_log_line_t){
            .seq = v->lines[i].seq, .age_s = now - v->lines[i].t, .text = v->lines[i].text};
    return n;
}

static size_t pv_workers(void *user, dash_worker_t *out, size_t max)
{
    dash_view_t *v = user;
    master_t *m = v->m;
    size_t ns = peers_sched_table(m);
    double now = clock_now_s();
    size_t n = m->nworkers < max ? m->nworkers : max;
    for (size_t i = 0; i < n; i++) {
        const mworker_t *w = m->workers[i];
        const sched_worker_info_t *si = peers_sched_info(m, ns, w->id);
        double seen = now - w->last_seen;
        out[i] = (dash_worker_t){
            .id = w->id,
            .name = w->name ? w->name : "",
            .key = w->key,
            .threads = w->threads,
            .state = proto_worker_state_name(peers_wire_state(w, si)),
            .tasks_running = w->alive && si ? si->busy : 0,
            .tasks_done = si ? si->tasks_done : 0,
            .tasks_failed = si ? si->tasks_failed : 0,
            .samples_done = si ? si->samples_done : 0,
            .has_rate = w->alive,
            .samples_per_s = w->alive ? peers_samples_per_s(w, now) : 0,
            .last_seen_s = seen > 0 ? seen : 0,
            .has_blocklisted = true,
            .blocklisted = si && si->blocked,
        };
    }
    return n;
}

static int pv_metrics(void *user, char **text, size_t *len, err_t *err)
{
    dash_view_t *v = user;
    return master_metrics_text(v->m, clock_now_s(), text, len, err);
}

/* ---------------------------------------------------------------- actions */

/* The master's one rule (access.h): a token always names a key, so a job submitted without
 * keys (owner "") is an administrator's to act on, as on the clients endpoint. */
static bool pv_allowed(void *user, const dash_identity_t *who, const dash_job_t *job)
{
    (void)user;
    return who->name[0] && access_allowed(job->owner ? job->owner : "", who->name, who->admin);
}

static int pv_cancel(void *user, const dash_identity_t *who, uint64_t id, err_t *err)
{
    dash_view_t *v = user;
    job_t *j = jobs_find(v->m, id);
    if (!j) {
        err_set(err, "no job %llu", (unsigned long long)id);
        return DASH_ENOENT;
    }
    if (job_over(j))
        return err_set(err, "job %llu is %s already", (unsigned long long)id,
                       proto_job_state_name(j->state));
    master_log(v->m, "job %llu '%s': cancel from the dashboard by '%s'%s", (unsigned long long)id,
               j->name, who->name, who->admin ? " (admin)" : "");
    job_cancel(v->m, j, clock_now_s());
    return 0;
}

/* The operations (ops.h): the same functions as the clients' ACT, so that both check, journal
 * and log alike. */
static master_actor_t actor_of(const dash_identity_t *who)
{
    return (master_actor_t){.name = who->name, .admin = who->admin};
}

static int ops_result(master_t *m, uint64_t id, int rc)
{
    return rc < 0 && !jobs_find(m, id) ? DASH_ENOENT : rc;
}

static int pv_pause(void *user, const dash_identity_t *who, uint64_t id, bool pause, err_t *err)
{
    dash_view_t *v = user;
    master_actor_t a = actor_of(who);
    return ops_result(v->m, id,
                      pause ? master_job_pause(v->m, id, &a, err)
                            : master_job_resume(v->m, id, &a, err));
}

static int pv_set_priority(void *user, const dash_identity_t *who, uint64_t id, int priority,
                           err_t *err)
{
    dash_view_t *v = user;
    master_actor_t a = actor_of(who);
    return ops_result(v->m, id, master_job_set_priority(v->m, id, priority, &a, err));
}

static int pv_requeue(void *user, const dash_identity_t *who, uint64_t id, uint32_t task,
                      err_t *err)
{
    dash_view_t *v = user;
    master_actor_t a = actor_of(who);
    return ops_result(v->m, id, master_task_requeue(v->m, id, task, &a, err));
}

static int pv_blocklist(void *user, const dash_identity_t *who, uint64_t worker, bool block,
                        err_t *err)
{
    dash_view_t *v = user;
    master_actor_t a = actor_of(who);
    char id[32];
    snprintf(id, sizeof id, "%llu", (unsigned long long)worker);
    return block ? master_worker_block(v->m, id, &a, err)
                 : master_worker_unblock(v->m, id, &a, err);
}

/* ---------------------------------------------------------------- the server */

int dash_view_check(const master_opts_t *o, err_t *err)
{
    if (!o->http)
        return o->http_token_file
                   ? err_set(err, "--http-token-file needs --http ADDR:PORT, the dashboard")
               : o->metrics_token_file
                   ? err_set(err, "--metrics-token-file needs --http ADDR:PORT, the dashboard")
               : o->dashboard_public
                   ? err_set(err, "--dashboard-public needs --http ADDR:PORT, the dashboard")
                   : 0;
    dash_server_config_t sc;
    if (dash_server_parse_address(o->http, &sc, err) < 0)
        return -1;
    if (!dash_server_loopback(&sc) && !o->http_public)
        return err_set(err,
                       "--http %s is reachable from other hosts, and the dashboard is plain "
                       "HTTP: its pages, and any token sent to it, can be read on the network. "
                       "Give --http-public to accept that, or keep 127.0.0.1 and reach it "
                       "through an SSH tunnel (docs/dashboard.md, \"Security\")",
                       o->http);
    return 0;
}

/* The bytes of a job's task log that a restarted master puts in the logbook for its page. */
#define DASH_SEED_BYTES 4096

/* A restarted master's logbook starts empty, so the page of a job from before the restart would
 * show no log. Its task log (tasklog.h: jobs/<id>/tasks.log, kept in the spool) says what
 * happened to it: its last lines go into the logbook first, each "job N: " and its time stamp,
 * and the lines logged from now on follow them in order. */
static void seed_log(master_t *m)
{
    for (size_t i = 0; i < m->njobs; i++) {
        char *text = NULL, line[LOGBOOK_TEXT];
        size_t len = 0;
        err_t err;
        if (tasklog_read(m->tasklog, m->jobs[i]->id, -1, DASH_SEED_BYTES, &text, &len, &err) < 0)
            continue;
        for (char *p = text, *end; p && *p; p = end ? end + 1 : NULL) {
            end = strchr(p, '\n');
            if (end)
                *end = 0;
            if (*p) {
                snprintf(line, sizeof line, "job %llu: %s", (unsigned long long)m->jobs[i]->id, p);
                logbook_add(m->logbook, clock_now_s(), line);
            }
        }
        free(text);
    }
}

dash_view_t *dash_view_open(master_t *m, char *bound, size_t size, err_t *err)
{
    const master_opts_t *o = m->opts;
    dash_server_config_t sc;
    if (dash_view_check(o, err) < 0 || dash_server_parse_address(o->http, &sc, err) < 0)
        return NULL;
    dash_view_t *v = calloc(1, sizeof *v);
    if (!v) {
        err_set(err, "dashboard: out of memory");
        return NULL;
    }
    v->m = m;
    if (m->logbook && m->tasklog)
        seed_log(m);
    v->provider = (dash_provider_t){
        .user = v,
        .jobs = pv_jobs,
        .job = pv_job,
        .frames = pv_frames,
        .preview = pv_preview,
        .passes = pv_passes,
        .tiles = pv_tiles,
        .tasks = pv_tasks,
        .log = pv_log,
        .workers = pv_workers,
        .metrics = pv_metrics,
        .allowed = pv_allowed,
        .cancel = pv_cancel,
        .pause = pv_pause,
        .set_priority = pv_set_priority,
        .requeue = pv_requeue,
        .blocklist = pv_blocklist,
    };
    /* Tokens from the folders the clients' keys come from (never the workers'). */
    dash_auth_config_t ac = {.any_dir = o->authorized_dir,
                             .clients_dir = o->authorized_clients_dir,
                             .admins_dir = o->authorized_admins_dir,
                             .token_file = o->http_token_file,
                             .metrics_token_file = o->metrics_token_file};
    dash_router_config_t rc = {.check_host = dash_server_loopback(&sc),
                               .public_reads = o->dashboard_public != 0};
    if (!(v->auth = dash_auth_new(&ac, err)) ||
        !(v->router = dash_router_new(&v->provider, v->auth, &rc, err)) ||
        !(v->server = dash_server_new(&sc, v->router, err))) {
        dash_view_close(&v);
        return NULL;
    }
    snprintf(bound, size, "http://%s:%d/", sc.address, dash_server_port(v->server));
    return v;
}

void dash_view_close(dash_view_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    dash_view_t *v = *self_p;
    dash_server_destroy(&v->server); /* before the router it calls */
    dash_router_destroy(&v->router);
    dash_auth_destroy(&v->auth);
    free(v);
    *self_p = NULL;
}

int dash_view_fd(const dash_view_t *self)
{
    return dash_server_fd(self->server);
}

int dash_view_timeout_ms(dash_view_t *self, int cap_ms)
{
    return dash_server_timeout_ms(self->server, cap_ms);
}

int dash_view_run(dash_view_t *self, err_t *err)
{
    return dash_server_run(self->server, err);
}
