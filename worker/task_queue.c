#include "task_queue.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void copy_settings(task_t *t, const proto_settings_t *s)
{
    t->settings = *s;
    snprintf(t->strings[0], sizeof t->strings[0], "%s", s->integrator ? s->integrator : "");
    snprintf(t->strings[1], sizeof t->strings[1], "%s", s->dispersion ? s->dispersion : "");
    t->settings.integrator = s->integrator ? t->strings[0] : NULL;
    t->settings.dispersion = s->dispersion ? t->strings[1] : NULL;
}

task_t *task_new(const proto_msg_t *m, unsigned generation)
{
    task_t *t = calloc(1, sizeof *t);
    if (!t)
        return NULL;
    t->job = m->task.job;
    t->id = m->task.task;
    t->attempt = m->task.attempt;
    t->generation = generation;
    snprintf(t->hash, sizeof t->hash, "%s", m->task.scene);
    snprintf(t->main, sizeof t->main, "%s", m->task.main ? m->task.main : "");
    copy_settings(t, &m->task.settings);
    t->kind = m->task.kind;
    t->tile = m->task.tile;
    t->photons = m->task.photons;
    snprintf(t->store, sizeof t->store, "%s", m->task.store);
    return t;
}

void task_list_free(task_t *t)
{
    while (t) {
        task_t *n = t->next;
        tilebuf_destroy(&t->result);
        free(t->photon_data);
        free(t);
        t = n;
    }
}

void task_queue_push(task_queue_t *self, task_t *t)
{
    t->next = NULL;
    if (self->ready_tail)
        self->ready_tail->next = t;
    else
        self->ready = t;
    self->ready_tail = t;
}

task_t *task_queue_pop(task_queue_t *self)
{
    task_t *t = self->ready;
    if (!t)
        return NULL;
    self->ready = t->next;
    if (!self->ready)
        self->ready_tail = NULL;
    t->next = self->running;
    self->running = t;
    return t;
}

void task_queue_park(task_queue_t *self, task_t *t, bool *scene_asked, bool *store_asked)
{
    *scene_asked = *store_asked = false;
    for (task_t *p = self->parked; p; p = p->next) {
        *scene_asked |= !strcmp(p->hash, t->hash);
        *store_asked |= t->store[0] && !strcmp(p->store, t->store);
    }
    t->next = self->parked;
    self->parked = t;
}

void task_queue_unpark(task_queue_t *self, task_pick_fn pick, void *arg, const char *error)
{
    task_t **pp = &self->parked;
    while (*pp) {
        task_t *t = *pp;
        if (!pick(t, arg)) {
            pp = &t->next;
            continue;
        }
        *pp = t->next;
        t->next = NULL;
        if (!error) {
            task_queue_push(self, t);
        } else {
            snprintf(t->error, sizeof t->error, "%s", error);
            task_queue_finish(self, t);
        }
    }
}

void task_queue_finish(task_queue_t *self, task_t *t)
{
    for (task_t **pp = &self->running; *pp; pp = &(*pp)->next)
        if (*pp == t) {
            *pp = t->next;
            break;
        }
    t->next = self->done;
    self->done = t;
}

task_t *task_queue_take_done(task_queue_t *self)
{
    task_t *done = self->done;
    self->done = NULL;
    return done;
}

int task_queue_cancel(task_queue_t *self, uint64_t job)
{
    if (self->ncancelled == TASK_QUEUE_CANCELLED) {
        memmove(self->cancelled, self->cancelled + 1,
                (TASK_QUEUE_CANCELLED - 1) * sizeof *self->cancelled);
        self->ncancelled--;
    }
    self->cancelled[self->ncancelled++] = job;
    /* Queued tasks of the job go, and those waiting for its scene; the master reclaims their
     * slots itself. Tasks being rendered finish, unsent. */
    int dropped = 0;
    task_t **pp = &self->ready;
    self->ready_tail = NULL;
    while (*pp) {
        task_t *t = *pp;
        if (t->job == job) {
            *pp = t->next;
            free(t);
            dropped++;
        } else {
            self->ready_tail = t;
            pp = &t->next;
        }
    }
    for (pp = &self->parked; *pp;) {
        task_t *t = *pp;
        if (t->job == job) {
            *pp = t->next;
            free(t);
            dropped++;
        } else {
            pp = &t->next;
        }
    }
    return dropped;
}

int task_queue_held(const task_queue_t *self, uint64_t job, const task_t *also)
{
    const task_t *lists[] = {self->ready, self->parked, self->running, self->done, also};
    int n = 0;
    for (size_t i = 0; i < sizeof lists / sizeof *lists; i++)
        for (const task_t *t = lists[i]; t; t = t->next)
            n += t->job == job;
    return n;
}

bool task_queue_is_cancelled(const task_queue_t *self, uint64_t job)
{
    for (int i = 0; i < self->ncancelled; i++)
        if (self->cancelled[i] == job)
            return true;
    return false;
}

void task_queue_uncancel(task_queue_t *self, uint64_t job)
{
    for (int i = 0; i < self->ncancelled; i++)
        if (self->cancelled[i] == job)
            self->cancelled[i] = self->cancelled[--self->ncancelled];
}

void task_queue_abandon(task_queue_t *self)
{
    task_list_free(self->ready);
    self->ready = self->ready_tail = NULL;
    task_list_free(self->parked);
    self->parked = NULL;
}

void task_queue_clear(task_queue_t *self)
{
    task_queue_abandon(self);
    task_list_free(self->done);
    self->done = NULL;
}
