#include "dispatch.h"

#include "jobs.h"
#include "peers.h"

#include <string.h>

static int send_task(master_t *m, mworker_t *w, const sched_task_t *t, double now)
{
    job_t *j = jobs_find(m, t->job);
    if (!j || !j->sched.known)
        return 0; /* cancelled meanwhile: the scheduler already took the task back */
    proto_msg_t msg = {.type = PROTO_TASK};
    msg.task.job = t->job;
    msg.task.task = (uint64_t)j->sched.round << 32 | t->task;
    msg.task.attempt = t->attempt;
    memcpy(msg.task.scene, j->hash, sizeof msg.task.scene);
    msg.task.settings = j->settings;
    /* A frame of a sequence loads its own scene file of the shared bundle; a single scene
     * leaves it absent (the bundle's main), as before sequences. */
    msg.task.main = j->seq.parent ? j->main : NULL;
    if (t->kind == SCHED_PHOTON) {
        msg.task.kind = PROTO_KIND_PHOTON_BATCH;
        msg.task.photons = photon_phase_batch(j->photons.phase, j->photons.base + t->batch);
    } else {
        msg.task.kind = PROTO_KIND_CAMERA_TILE;
        msg.task.tile = (proto_tile_t){.x0 = t->x0,
                                       .y0 = t->y0,
                                       .w = t->w,
                                       .h = t->h,
                                       .sample_begin = t->sample_begin,
                                       .sample_end = t->sample_end};
        /* The camera phase starts only after every batch is merged (sched.h). */
        if (j->photons.phase)
            memcpy(msg.task.store, j->photons.store, sizeof msg.task.store);
    }
    int rc = peers_send(m, w, &msg);
    if (rc == 0) {
        char what[96];
        if (t->kind == SCHED_PHOTON)
            snprintf(what, sizeof what, "(photon batch %u)", t->batch);
        else
            snprintf(what, sizeof what, "(pass %d, tile %dx%d at %d,%d)", t->pass, t->w, t->h,
                     t->x0, t->y0);
        char label[PROTO_TASK_LABEL_MAX];
        tasklog_add(m->tasklog, j->id, "task %s %s attempt %u assigned to worker %llu '%s'",
                    proto_task_label(t->task, label), what, t->attempt, (unsigned long long)w->id,
                    w->name);
    }
    if (rc == 0 && j->started == 0) {
        j->started = now;
        j->state = JOB_RUNNING;
        master_log(m, "job %llu '%s' started", (unsigned long long)j->id, j->name);
    }
    return rc;
}

void dispatch_tasks(master_t *m, double now)
{
    for (size_t i = 0; i < m->nworkers; i++) {
        mworker_t *w = m->workers[i];
        if (w->alive && w->has_unsent) {
            int rc = send_task(m, w, &w->unsent, now);
            if (rc == PROTO_EAGAIN)
                continue;
            w->has_unsent = false;
        }
        sched_task_t t;
        while (w->alive && sched_next_task(m->sched, w->id, now, &t) == 1) {
            int rc = send_task(m, w, &t, now);
            if (rc == PROTO_EAGAIN) {
                w->unsent = t;
                w->has_unsent = true;
            }
            if (rc < 0)
                break;
        }
    }
}
