#include "render_threads.h"

#include "clock.h"
#include "photon.h"
#include "render.h"
#include "worker_state.h"

#include <stdio.h>
#include <unistd.h>

/* Runs a task on its scene, filling its result, ok and elapsed time. Called without the lock. */
static void task_run(task_t *t, const job_scene_t *js, err_t *err)
{
    double t0 = clock_now_s();
    if (t->kind == PROTO_KIND_PHOTON_BATCH) {
        t->ok = photon_batch_run(js->scene, t->photons.first, t->photons.end, &t->photon_data,
                                 &t->photon_size, &t->pstats, err) == 0;
    } else {
        const proto_tile_t *r = &t->tile;
        t->result = tilebuf_new(r->x0, r->y0, r->w, r->h, js->scene->settings.grid.n, err);
        if (t->result && render_tile(js->scene, js->photons, r->x0, r->y0, r->w, r->h,
                                     r->sample_begin, r->sample_end, t->result, &t->stats, err))
            tilebuf_destroy(&t->result);
        t->ok = t->result != NULL;
    }
    t->elapsed = clock_now_s() - t0;
}

void *render_thread_main(void *arg)
{
    worker_t *w = arg;
    pthread_mutex_lock(&w->lock);
    for (;;) {
        while (!w->quit && !w->tasks.ready)
            pthread_cond_wait(&w->wake, &w->lock);
        if (w->quit)
            break;
        task_t *t = task_queue_pop(&w->tasks);
        err_t err = {{0}};
        job_scene_t *js =
            task_queue_is_cancelled(&w->tasks, t->job)
                ? NULL
                : scene_cache_acquire(&w->scenes, t->job, t->hash, t->store, &t->settings, &err);
        if (js) {
            pthread_mutex_unlock(&w->lock);
            task_run(t, js, &err);
            pthread_mutex_lock(&w->lock);
            scene_cache_release(&w->scenes, js);
        }
        if (!t->ok)
            snprintf(t->error, sizeof t->error, "%s", err.msg[0] ? err.msg : "job cancelled");
        task_queue_finish(&w->tasks, t);
        /* Wake the network loop at once rather than at its next poll timeout. */
        char one = 1;
        if (write(w->wake_fd[1], &one, 1) < 0) {
            /* A full pipe already holds a wake-up: nothing is lost. */
        }
    }
    pthread_mutex_unlock(&w->lock);
    return NULL;
}
