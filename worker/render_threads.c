#include "render_threads.h"

#include "clock.h"
#include "photon_pass.h"
#include "render.h"
#include "worker_state.h"

#include <stdbool.h>
#include <stdio.h>
#include <unistd.h>

/* Whether the task's job was cancelled or the worker is shutting down. Takes the lock. */
static bool stop_requested(worker_t *w, uint64_t job)
{
    pthread_mutex_lock(&w->lock);
    bool stop = w->quit || task_queue_is_cancelled(&w->tasks, job);
    pthread_mutex_unlock(&w->lock);
    return stop;
}

/* Samples rendered between two looks at stop_requested: a cancelled job or a SIGTERM reaches
 * the thread within about this many samples, where it used to wait for the whole tile (issue 16:
 * minutes at high sample counts). Small passes are rendered in bands of rows, large ones row by
 * row and, within a row, in ranges of samples. */
#define STOP_POLL_SAMPLES 4096

/* The tile in pieces, each one render_tile call adding into the same buffer. render_tile adds
 * each sample to its pixel as it is taken and a sample depends only on (seed, pixel, sample),
 * so a pixel that gets its samples in the same ascending order ends with the same sums as from
 * one call over the tile, bit for bit. */
static int render_tile_stoppable(worker_t *w, task_t *t, const job_scene_t *js, err_t *err)
{
    const proto_tile_t *r = &t->tile;
    uint64_t n = r->sample_end - r->sample_begin, row = (uint64_t)r->w * n;
    int band = row >= STOP_POLL_SAMPLES ? 1 : (int)(STOP_POLL_SAMPLES / (row ? row : 1));
    uint32_t chunk = row >= STOP_POLL_SAMPLES ? (uint32_t)(STOP_POLL_SAMPLES / (uint64_t)r->w) : 0;
    if (chunk == 0 || chunk > n)
        chunk = (uint32_t)n;
    for (int y = r->y0; y < r->y0 + r->h; y += band) {
        int h = band < r->y0 + r->h - y ? band : r->y0 + r->h - y;
        for (uint32_t s = r->sample_begin; s < r->sample_end;) {
            if (stop_requested(w, t->job))
                return err_set(err, "job cancelled (stopped at row %d of %d)", y - r->y0, r->h);
            uint32_t e = r->sample_end - s > chunk ? s + chunk : r->sample_end;
            if (render_tile(js->scene, js->photons, r->x0, y, r->w, h, s, e, t->result,
                            &t->stats, err))
                return -1;
            s = e;
        }
    }
    return 0;
}

/* Runs a task on its scene, filling its result, ok and elapsed time. Called without the lock. */
static void task_run(worker_t *w, task_t *t, const job_scene_t *js, err_t *err)
{
    double t0 = clock_now_s();
    if (t->kind == PROTO_KIND_PHOTON_BATCH) {
        t->ok = photon_batch_run(js->scene, t->photons.first, t->photons.end, &t->photon_data,
                                 &t->photon_size, &t->pstats, err) == 0;
    } else {
        const proto_tile_t *r = &t->tile;
        t->result = tilebuf_new(r->x0, r->y0, r->w, r->h,
                                render_settings_buckets(&js->scene->settings), err);
        if (t->result && render_tile_stoppable(w, t, js, err))
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
                : scene_cache_acquire(&w->scenes, t->job, t->hash, t->main, t->store, &t->settings, &err);
        if (js) {
            pthread_mutex_unlock(&w->lock);
            task_run(w, t, js, &err);
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
