#include "jobs.h"

#include "bisect.h"
#include "clock.h"
#include "files.h"
#include "film.h"
#include "jobinfo.h"
#include "peers.h"
#include "persist.h"
#include "polar_pilot.h"
#include "polar_seq.h"
#include "scene_load.h"
#include "settings.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Room for one more job in the list. */
static int jobs_reserve(master_t *m)
{
    if (m->njobs == m->cap_jobs) {
        size_t cap = m->cap_jobs ? 2 * m->cap_jobs : 16;
        job_t **p = realloc(m->jobs, cap * sizeof *p);
        if (!p)
            return -1;
        m->jobs = p;
        m->cap_jobs = cap;
    }
    return 0;
}

static uint64_t job_key(const void *jobs, size_t i)
{
    return ((job_t *const *)jobs)[i]->id;
}

job_t *jobs_find(const master_t *m, uint64_t id)
{
    size_t i = bisect_lower(m->jobs, m->njobs, job_key, id);
    return i < m->njobs && m->jobs[i]->id == id ? m->jobs[i] : NULL;
}

int jobs_append(master_t *m, job_t *j)
{
    if (jobs_reserve(m) < 0)
        return -1;
    m->jobs[m->njobs++] = j;
    return 0;
}

void job_destroy(job_t **self_p)
{
    job_t *j = self_p ? *self_p : NULL;
    if (j) {
        photon_phase_destroy(&j->photons.phase);
        free(j->main);
        free(j->name);
        free(j->error);
        free(j->accuracy.tile_passes);
        free(j);
        *self_p = NULL;
    }
}

void job_set_error(job_t *j, const char *msg)
{
    free(j->error);
    j->error = master_strdup(msg);
}

/* The job's name as a file name: its last path component without ".pbrt", with anything but
 * letters, digits, '.', '-' and '_' replaced, no leading '.', never "preview" (the progressive
 * image's name). */
static void make_stem(const char *name, char *out, size_t size)
{
    const char *base = strrchr(name, '/');
    base = base && base[1] ? base + 1 : name;
    size_t n = strlen(base);
    if (n > 5 && !strcmp(base + n - 5, ".pbrt"))
        n -= 5;
    size_t k = 0;
    for (size_t i = 0; i < n && k + 2 < size; i++) {
        char c = base[i];
        bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                  c == '-' || c == '_' || (c == '.' && k > 0);
        out[k++] = ok ? c : '_';
    }
    out[k] = 0;
    if (k == 0)
        snprintf(out, size, "job");
    else if (!strcmp(out, "preview"))
        snprintf(out, size, "preview_");
}

/* The figures a job takes from its loaded scene: sizes, seed, grid, what it runs with. */
static void job_take_scene(job_t *j, const scene_t *scene)
{
    const render_settings_t *rs = &scene->settings;
    j->scene.integrator = integrators_used_name(rs->integrator, rs->photon.enabled, rs->media);
    j->scene.dispersion = integrators_dispersion_used(rs->dispersion, scene->has_dispersion);
    j->scene.xres = rs->xres;
    j->scene.yres = rs->yres;
    j->scene.spp = rs->spp;
    j->scene.seed = rs->seed;
    j->scene.grid = rs->grid;
    j->scene.nbuckets = render_settings_buckets(rs);
}

static void job_set_settings(job_t *j, const proto_settings_t *set)
{
    proto_settings_copy(&j->settings, set, &j->setting_names);
}

/* What the shelf loads on a miss: the job's scene, confined to its bundle's folder. */
typedef struct confined_load {
    const char *main_path, *dir;
    scene_overrides_t ov;
} confined_load_t;

static scene_t *load_confined(void *arg, err_t *err)
{
    confined_load_t *c = arg;
    return scene_load_file_confined(c->main_path, c->dir, &c->ov, err);
}

/* The scene reads nothing outside dir, so no message can show a client a file of the master's
 * host; a photon job's phase keeps the scene to check and merge batches against. */
job_t *job_new(uint64_t id, const char *name, const char *hash, const char *main,
               const proto_settings_t *set, const char *dir, const scene_budget_t *budget,
               scene_shelf_t *shelf, int threads, job_polar_mode_t mode, err_t *err)
{
    size_t main_size = strlen(dir) + strlen(main) + 2;
    char *main_path = malloc(main_size);
    job_t *j = calloc(1, sizeof *j);
    if (!main_path || !j || !(j->name = master_strdup(name)) || !(j->main = master_strdup(main))) {
        free(main_path);
        job_destroy(&j);
        err_set(err, "the master is out of memory");
        return NULL;
    }
    snprintf(main_path, main_size, "%s/%s", dir, main);
    confined_load_t cl = {.main_path = main_path, .dir = dir, .ov = settings_to_overrides(set)};
    cl.ov.budget = budget;
    cl.ov.threads = threads;
    char key[SETTINGS_KEY_SIZE];
    settings_scene_key(hash, main, set, key);
    scene_t *scene = shelf ? scene_shelf_get(shelf, key, load_confined, &cl, err)
                           : load_confined(&cl, err);
    free(main_path);
    if (!scene) {
        job_destroy(&j);
        return NULL;
    }
    job_take_scene(j, scene);
    /* Polarisation decided once, here, for every host that renders the job (the pilot reads
     * the scene without changing it: it may be shared on the shelf). */
    proto_settings_t decided = *set;
    polar_decision_t polar = {0};
    if (mode != JOB_POLAR_KEEP && set->polarized == SCENE_POLARIZED_FILE) {
        int rc = mode == JOB_POLAR_DECIDE
                     ? polar_pilot_decide(scene, set->target_error, &polar, err)
                     : polar_seq_frame(scene, mode == JOB_POLAR_FRAME_PILOT, set->target_error,
                                       &polar, err);
        if (rc < 0) {
            err_prefix(err, "the polarisation pilot: ");
            scene_destroy(&scene);
            job_destroy(&j);
            return NULL;
        }
        if (mode == JOB_POLAR_DECIDE)
            decided.polarized = polar.setting;
    }
    j->polar = (job_polar_t){.cause_file = polar.cause_file,
                             .measured = polar.measured,
                             .change = polar.pilot.change,
                             .change_hi = polar.pilot.change_hi,
                             .target = polar.target};
    bool photon = scene->settings.photon.enabled;
    uint64_t photons = scene->settings.photon.photons;
    if (photon && !(j->photons.phase = photon_phase_new(&scene, err))) {
        job_destroy(&j);
        return NULL;
    }
    scene_destroy(&scene);
    j->id = id;
    make_stem(j->name, j->stem, sizeof j->stem);
    snprintf(j->hash, sizeof j->hash, "%s", hash);
    job_set_settings(j, &decided);
    j->photons.enabled = photon;
    j->journal.round_photons = photon ? photons : 0;
    j->state = JOB_QUEUED;
    j->accuracy.stop = PROTO_STOP_NONE;
    return j;
}

job_state_t jobs_wire_state(const job_t *j)
{
    if (j->ops.paused && !job_over(j))
        return JOB_PAUSED;
    return (unsigned)j->state <= JOB_CANCELLED ? j->state : JOB_FAILED;
}

job_t *job_from_record(const journal_job_t *r)
{
    job_t *j = calloc(1, sizeof *j);
    if (!j || !(j->name = master_strdup(r->name)) || !(j->main = master_strdup(r->main)) ||
        (r->error && !(j->error = master_strdup(r->error)))) {
        job_destroy(&j);
        return NULL;
    }
    j->id = r->id;
    make_stem(j->name, j->stem, sizeof j->stem);
    snprintf(j->hash, sizeof j->hash, "%s", r->hash);
    snprintf(j->owner, sizeof j->owner, "%s", r->owner);
    job_set_settings(j, &r->settings);
    j->state = (job_state_t)r->state;
    j->outputs.final = r->outputs;
    j->accuracy.stop = (proto_stop_t)r->stop;
    j->sched.samples_done = r->samples_done;
    j->sched.samples_total = r->samples_total;
    j->sched.nonfinite = r->nonfinite;
    j->accuracy.spp_done = r->spp_done;
    j->sched.round = r->round;
    j->photons.saved = r->photons_saved;
    j->photons.enabled = r->photons_saved > 0;
    j->journal.round_photons = r->round_photons;
    j->scene.integrator = j->scene.dispersion = "?";
    j->ops.priority = r->priority;
    j->ops.paused = r->paused;
    j->seq.parent = r->parent;
    j->seq.frame = r->frame;
    j->seq.nframes = r->nframes;
    return j;
}

job_t *job_new_sequence(const char *name, const char *hash, const char *main,
                         const proto_settings_t *set, uint32_t nframes)
{
    journal_job_t r = {.name = (char *)name, .hash = (char *)hash, .main = (char *)main,
                       .settings = *set, .state = JOB_QUEUED, .nframes = nframes};
    return job_from_record(&r);
}

job_t *jobs_frame(const master_t *m, const job_t *seq, uint32_t k)
{
    job_t *f = k < seq->seq.nframes ? jobs_find(m, seq->id + 1 + k) : NULL;
    return f && f->seq.parent == seq->id ? f : NULL;
}

/* A sequence's state from its frames': over when every frame is (done when all are, else failed
 * when one failed, else cancelled), running once one started, else queued. A frame not listed
 * (a journal that lost it) keeps it unfinished. */
void jobs_sequence_refresh(master_t *m, job_t *seq, double now)
{
    uint32_t over = 0, done = 0, failed = 0, started = 0, paused = 0;
    const job_t *first_failed = NULL;
    double t0 = 0, t1 = 0;
    for (uint32_t k = 0; k < seq->seq.nframes; k++) {
        const job_t *f = jobs_frame(m, seq, k);
        if (!f)
            continue;
        bool fo = job_over(f);
        over += fo;
        done += f->state == JOB_DONE && !f->outputs.waiting;
        if (f->state == JOB_FAILED && !failed++)
            first_failed = f;
        started += f->started > 0;
        paused += !fo && f->ops.paused;
        if (f->started > 0 && (t0 == 0 || f->started < t0))
            t0 = f->started;
        if (f->finished > t1)
            t1 = f->finished;
    }
    job_state_t st = over == seq->seq.nframes
                         ? (done == over ? JOB_DONE : failed ? JOB_FAILED : JOB_CANCELLED)
                     : started ? JOB_RUNNING
                               : JOB_QUEUED;
    if (t0 > 0 && (seq->started == 0 || t0 < seq->started))
        seq->started = t0;
    seq->ops.paused = over < seq->seq.nframes && paused == seq->seq.nframes - over;
    if (st == seq->state)
        return;
    seq->state = st;
    if (job_over(seq)) {
        seq->finished = t1 > 0 ? t1 : now;
        if (st == JOB_FAILED) {
            char msg[700];
            snprintf(msg, sizeof msg, "frame %u (job %llu) failed: %s", first_failed->seq.frame,
                     (unsigned long long)first_failed->id,
                     first_failed->error ? first_failed->error : "failed");
            job_set_error(seq, msg);
        }
        seq->outputs.final = st == JOB_DONE;
        master_log(m, "job %llu '%s' (%u frames) %s", (unsigned long long)seq->id, seq->name,
                   seq->seq.nframes, proto_job_state_name(st));
    } else {
        /* Running again: a frame refined after the sequence was done. */
        seq->finished = 0;
        seq->outputs.final = false;
    }
    persist_state(m, seq, now);
}

int job_restore_photons(master_t *m, job_t *j, err_t *err)
{
    char dir[PATH_MAX], path[PATH_MAX + 32], scene_dir[PATH_MAX], main_path[2 * PATH_MAX];
    if (spool_job_dir(m->spool, j->id, dir, sizeof dir, err) < 0)
        return -1;
    snprintf(path, sizeof path, "%s/photons.store", dir);
    snprintf(scene_dir, sizeof scene_dir, "%s/scenes/%s", spool_path(m->spool), j->hash);
    snprintf(main_path, sizeof main_path, "%s/%s", scene_dir, j->main);
    scene_overrides_t ov = settings_to_overrides(&j->settings);
    ov.budget = &m->opts->budget;
    scene_t *scene = scene_load_file_confined(main_path, scene_dir, &ov, err);
    if (!scene)
        return -1;
    job_take_scene(j, scene); /* a job a restarted master read from its journal has no figures */
    uint8_t *data = NULL;
    size_t size = 0;
    if (files_read(path, m->limits.max_message_bytes, &data, &size, err) < 0) {
        scene_destroy(&scene);
        return -1;
    }
    j->photons.phase = photon_phase_restore(&scene, data, size, j->photons.saved, err);
    free(data);
    return j->photons.phase ? 0 : -1;
}

stopping_rule_t job_stopping_rule(const job_t *j)
{
    return (stopping_rule_t){.target_error = j->settings.target_error,
                             .time_limit = j->settings.time_limit};
}

int jobs_apply_stopping(master_t *m, const job_t *j, err_t *err)
{
    stopping_rule_t rule = job_stopping_rule(j);
    if (!stopping_active(&rule))
        return 0;
    if (sched_set_whole_passes(m->sched, j->id, err) < 0)
        return -1;
    return rule.target_error > 0 && j->settings.adaptive
               ? sched_set_adaptive(m->sched, j->id, rule.target_error, err)
               : 0;
}

int jobs_apply_ops(master_t *m, const job_t *j, err_t *err)
{
    if (sched_set_job_owner(m->sched, j->id, j->owner, err) < 0 ||
        sched_set_job_priority(m->sched, j->id, j->ops.priority, err) < 0)
        return -1;
    return j->ops.paused ? sched_pause_job(m->sched, j->id, true, clock_now_s(), err) : 0;
}

int job_schedule(master_t *m, job_t *j, uint32_t photon_batches, err_t *err)
{
    if (jobs_reserve(m) < 0)
        return err_set(err, "the master is out of memory");
    sched_job_info_t info;
    if (sched_add_job(m->sched, j->id, j->scene.xres, j->scene.yres, j->scene.spp, j->scene.grid,
                      j->scene.nbuckets, err) < 0)
        return -1;
    if (jobs_apply_ops(m, j, err) < 0 || jobs_apply_stopping(m, j, err) < 0 ||
        (photon_batches > 0 &&
         sched_add_photon_batches(m->sched, j->id, photon_batches, err) < 0) ||
        sched_job_info(m->sched, j->id, &info) < 0) {
        err_t ignore;
        sched_cancel_job(m->sched, j->id, &ignore);
        (void)sched_remove_job(m->sched, j->id, &ignore);
        return -1;
    }
    j->sched.ntiles = info.ntiles;
    j->sched.samples_total = info.samples_total;
    j->sched.tile = m->opts->sched.tile_size;
    j->sched.known = true;
    m->jobs[m->njobs++] = j;
    return 0;
}

/* For a submission that could not be journaled. */
void job_unschedule(master_t *m, job_t *j)
{
    err_t ignore;
    (void)sched_cancel_job(m->sched, j->id, &ignore);
    (void)sched_remove_job(m->sched, j->id, &ignore);
    for (size_t i = 0; i < m->njobs; i++)
        if (m->jobs[i] == j) {
            memmove(&m->jobs[i], &m->jobs[i + 1], (m->njobs - i - 1) * sizeof *m->jobs);
            m->njobs--;
            break;
        }
    job_destroy(&j);
}

int job_write_image(master_t *m, job_t *j, bool final, err_t *err)
{
    char dir[PATH_MAX], exr[PATH_MAX + 100], png[PATH_MAX + 100];
    if (spool_job_dir(m->spool, j->id, dir, sizeof dir, err) < 0)
        return -1;
    const tilebuf_t *image = sched_job_image(m->sched, j->id);
    if (!image)
        return err_set(err, "job %llu has no image", (unsigned long long)j->id);
    sched_job_info_t si;
    if (sched_job_info(m->sched, j->id, &si) < 0)
        return err_set(err, "job %llu is unknown to the scheduler", (unsigned long long)j->id);
    /* Adaptive sampling: each tile's samples, from the pass it merges next; kept for the
     * dashboard's map once the scheduler forgets the job. */
    int *tile_spp = NULL;
    tilegrid_t grid = tilegrid_make(j->scene.xres, j->scene.yres, m->opts->sched.tile_size);
    if (si.adaptive && (tile_spp = malloc((size_t)si.ntiles * sizeof *tile_spp)) &&
        sched_job_next_pass(m->sched, j->id, tile_spp, si.ntiles) == si.ntiles) {
        if (final && !j->accuracy.tile_passes &&
            (j->accuracy.tile_passes = malloc((size_t)si.ntiles * sizeof *tile_spp))) {
            memcpy(j->accuracy.tile_passes, tile_spp, (size_t)si.ntiles * sizeof *tile_spp);
            j->accuracy.ntiles = si.ntiles;
        }
        uint32_t bounds[PASSES_MAX_BOUNDS];
        passes_bounds(j->scene.spp, bounds);
        for (int t = 0; t < si.ntiles; t++)
            tile_spp[t] = (int)bounds[tile_spp[t]];
    } else {
        free(tile_spp);
        tile_spp = NULL;
    }
    char info[16384];
    jobinfo_t ji = {
        .job = j->id,
        .name = j->stem,
        .scene = j->hash,
        .spp = j->scene.spp,
        .xres = j->scene.xres,
        .yres = j->scene.yres,
        .seed = j->scene.seed,
        .integrator = j->scene.integrator,
        .dispersion = j->scene.dispersion,
        .samples = si.samples_done,
        .nonfinite = si.nonfinite,
        .photons = j->photons.phase ? photon_phase_stats(j->photons.phase).photons : 0,
        .rays = -1,
        .seconds = j->started > 0 ? clock_now_s() - j->started : 0.0,
        .spp_done = si.spp_done,
        .stop = (stopping_why_t)j->accuracy.stop,
        .rule = job_stopping_rule(j),
        .history = j->accuracy.history,
        .nhistory = j->accuracy.nhistory,
        .tile_spp = tile_spp,
        .grid = grid};
    jobinfo_format(&ji, info, sizeof info);
    film_output_t out = {
        .spectral = 1, .tonemap = {.exposure_stops = 0, .curve = COLOUR_CURVE_ACES}, .info = info};
    if (final) {
        snprintf(exr, sizeof exr, "%s/%s.exr", dir, j->stem);
        snprintf(png, sizeof png, "%s/%s.png", dir, j->stem);
        out.exr_path = exr;
    } else {
        snprintf(png, sizeof png, "%s/preview.png", dir);
    }
    out.png_path = png;
    free(tile_spp);
    return film_write(image, j->scene.grid, &out, err);
}

/* A photon job that is over gives back its store's memory: a finished job's merged store goes
 * to jobs/<id>/photons.store (for a refinement, which loads the scene again and restores it),
 * and the scene and batches are dropped; a failed or cancelled one cannot be refined. Kept in
 * memory only if it cannot be written. */
static void release_photons(master_t *m, job_t *j)
{
    if (!j->photons.phase)
        return;
    err_t err;
    if (j->state == JOB_DONE && persist_save_photons(m, j, &err) < 0) {
        master_log(m, "job %llu: keeping its photon store in memory: %s", (unsigned long long)j->id,
                   err.msg);
        return;
    }
    photon_phase_destroy(&j->photons.phase);
    j->photons.store_ready = false;
}

void job_cancel(master_t *m, job_t *j, double now)
{
    for (uint32_t k = 0; k < j->seq.nframes; k++) {
        job_t *f = jobs_frame(m, j, k);
        if (f)
            job_cancel(m, f, now); /* the last one's refresh ends the sequence */
    }
    if (j->seq.nframes > 0)
        return;
    err_t err;
    if (j->outputs.waiting)
        job_give_up_outputs(m, j, now);
    else if (j->sched.known && sched_cancel_job(m->sched, j->id, &err) < 0)
        master_log(m, "cancel: %s", err.msg);
    job_refresh(m, j, now);
    /* A frame that gave up its outputs changed state before job_refresh looked. */
    job_t *seq = j->seq.parent ? jobs_find(m, j->seq.parent) : NULL;
    if (seq && seq->seq.nframes > 0)
        jobs_sequence_refresh(m, seq, now);
}

static void job_refresh_one(master_t *m, job_t *j, double now);

/* A job over: its task counts kept, and its figures written beside its outputs so that a
 * restarted master shows them (persist_save_figures), before the scheduler forgets it. */
static void forget_tasks(master_t *m, job_t *j, const sched_job_info_t *info)
{
    j->sched.has_tasks = true;
    j->sched.tasks_total = info->tasks_total;
    j->sched.tasks_done = info->tasks_done;
    err_t err;
    if (m->journal && persist_save_figures(m, j, &err) < 0)
        master_log(m, "job %llu: its figures are not kept for a restart: %s",
                   (unsigned long long)j->id, err.msg);
}

void job_refresh(master_t *m, job_t *j, double now)
{
    job_state_t before = j->state;
    job_refresh_one(m, j, now);
    job_t *seq = j->seq.parent && j->state != before ? jobs_find(m, j->seq.parent) : NULL;
    if (seq && seq->seq.nframes > 0)
        jobs_sequence_refresh(m, seq, now);
}

static void job_refresh_one(master_t *m, job_t *j, double now)
{
    sched_job_info_t info;
    if (!j->sched.known || sched_job_info(m->sched, j->id, &info) < 0 || info.state == j->state)
        return;
    j->state = info.state;
    if (info.state == JOB_RUNNING || info.state == JOB_QUEUED) {
        if (info.state == JOB_RUNNING && j->started == 0)
            j->started = now;
        return;
    }
    if (j->started == 0)
        j->started = now;
    j->finished = now;
    if (info.state == JOB_DONE) {
        err_t err;
        /* Ended before its last pass (target error, time limit): the tasks still out are of
         * passes that will never be merged, so the workers drop them, as for a cancel. */
        if (j->accuracy.stop != PROTO_STOP_NONE)
            peers_cancel_job(m, j->id);
        int wrote = job_write_image(m, j, true, &err);
        if (wrote < 0 && !m->opts->wait_for_space) {
            char msg[600];
            snprintf(msg, sizeof msg, "writing the outputs: %s", err.msg);
            job_set_error(j, msg);
            j->state = JOB_FAILED;
            master_log(m, "job %llu '%s' failed: %s", (unsigned long long)j->id, j->name, msg);
        } else if (wrote < 0) {
            /* A full disk must not lose a finished render: the image stays in memory, the job
             * is shown running with the reason, and the write is tried again. */
            bool first = !j->outputs.waiting;
            j->outputs.waiting = true;
            j->outputs.retry_at = now + JOB_OUTPUT_RETRY_S;
            snprintf(j->outputs.why, sizeof j->outputs.why,
                     "rendered; waiting to write its outputs (tried again every %.0f s): %s",
                     JOB_OUTPUT_RETRY_S, err.msg);
            j->state = JOB_RUNNING;
            j->finished = 0;
            if (first)
                master_log(m, "job %llu '%s' %s", (unsigned long long)j->id, j->name,
                           j->outputs.why);
            return;
        } else {
            if (j->outputs.waiting)
                master_log(m, "job %llu '%s': its outputs are written at last",
                           (unsigned long long)j->id, j->name);
            j->outputs.waiting = false;
            j->outputs.final = true;
            tasklog_add(m->tasklog, j->id, "job done at %d of %d spp", info.spp_done, j->scene.spp);
            const pass_record_t *last =
                j->accuracy.nhistory > 0 ? &j->accuracy.history[j->accuracy.nhistory - 1] : NULL;
            char acc[160] = "";
            if (last && last->valid)
                snprintf(acc, sizeof acc, ", relative error %.4g", last->rel_error);
            const char *why = stopping_reason((stopping_why_t)j->accuracy.stop);
            master_log(m, "job %llu '%s' done in %.2f s at %d of %d spp%s%s%s%s: %s/jobs/%llu/%s.exr",
                       (unsigned long long)j->id, j->name, job_elapsed(m, j, j->finished), info.spp_done,
                       j->scene.spp, acc, *why ? " (" : "", why, *why ? ")" : "",
                       spool_path(m->spool), (unsigned long long)j->id, j->stem);
        }
    } else if (info.state == JOB_FAILED) {
        job_set_error(j, info.error[0] ? info.error : "failed");
        tasklog_add(m->tasklog, j->id, "job failed: %s", j->error);
        master_log(m, "job %llu '%s' failed: %s", (unsigned long long)j->id, j->name, j->error);
        peers_cancel_job(m, j->id);
    } else {
        master_log(m, "job %llu '%s' cancelled", (unsigned long long)j->id, j->name);
        tasklog_add(m->tasklog, j->id, "job cancelled: %u tasks running were dropped",
                    info.tasks_running);
        peers_cancel_job(m, j->id);
    }
    release_photons(m, j);
    j->sched.samples_done = info.samples_done;
    j->sched.samples_total = info.samples_total;
    j->sched.nonfinite = info.nonfinite;
    j->accuracy.spp_done = info.spp_done;
    forget_tasks(m, j, &info);
    persist_state(m, j, now);
    j->ops.paused_s = sched_job_paused_s(m->sched, j->id, j->finished > 0 ? j->finished : now);
    err_t err;
    if (sched_remove_job(m->sched, j->id, &err) < 0)
        master_log(m, "job %llu: %s", (unsigned long long)j->id, err.msg);
    else
        j->sched.known = false;
}

void jobs_retry_outputs(master_t *m, double now)
{
    for (size_t i = 0; i < m->njobs; i++) {
        job_t *j = m->jobs[i];
        if (j->outputs.waiting && j->sched.known && now >= j->outputs.retry_at)
            job_refresh(m, j, now);
    }
}

void job_give_up_outputs(master_t *m, job_t *j, double now)
{
    if (!j->outputs.waiting || !j->sched.known)
        return;
    j->outputs.waiting = false;
    j->state = JOB_CANCELLED;
    j->finished = now;
    master_log(m, "job %llu '%s' cancelled while waiting to write its outputs: its image is dropped",
               (unsigned long long)j->id, j->name);
    release_photons(m, j);
    sched_job_info_t info;
    if (sched_job_info(m->sched, j->id, &info) == 0)
        forget_tasks(m, j, &info);
    persist_state(m, j, now);
    j->ops.paused_s = sched_job_paused_s(m->sched, j->id, j->finished > 0 ? j->finished : now);
    err_t err;
    if (sched_remove_job(m->sched, j->id, &err) < 0)
        master_log(m, "job %llu: %s", (unsigned long long)j->id, err.msg);
    else
        j->sched.known = false;
}

/* The time limits: a job past its limit with at least one whole pass ends now with the passes
 * merged (the pass in flight is dropped, its tasks cancelled on the workers by job_refresh); one
 * without a pass yet ends at its first pass boundary (merge.c). */
void jobs_enforce_time_limits(master_t *m, double now)
{
    for (size_t i = 0; i < m->njobs; i++) {
        job_t *j = m->jobs[i];
        sched_job_info_t info;
        if (!j->sched.known || !(j->settings.time_limit > 0) || j->started <= 0 ||
            job_elapsed(m, j, now) < j->settings.time_limit ||
            sched_job_info(m->sched, j->id, &info) < 0 || info.state != JOB_RUNNING ||
            info.passes_done < 1)
            continue;
        err_t err;
        if (sched_finish_job_at_pass(m->sched, j->id, &err) < 0) {
            master_log(m, "job %llu: cannot end it at its time limit: %s",
                       (unsigned long long)j->id, err.msg);
            continue;
        }
        j->accuracy.stop = PROTO_STOP_TIME;
        master_log(m, "job %llu time limit %g s reached during pass %d: ends with %d spp",
                   (unsigned long long)j->id, j->settings.time_limit, info.passes_done + 1,
                   info.spp_done);
        job_refresh(m, j, now);
    }
}
