/* sched_testutil: what the scheduler tests share: a scheduler with the tests' settings, a
 * spectral grid of n buckets over 400-700 nm, a worker's stand-in result for a task, all the
 * tasks a worker is given at once, and a fixed pseudo-random order of their results.
 * Header-only (each test is its own executable); include after cmocka.h. */
#ifndef PRISMFARM_SCHED_TESTUTIL_H
#define PRISMFARM_SCHED_TESTUTIL_H

#include "sched.h"
#include "spectral_grid.h"
#include "tilebuf.h"

#include <string.h>

/* The defaults but tile-pixel tiles and short clocks: a task not back within 10 s is issued
 * again, a worker silent 3 s is lost (the tests' fake clocks move by seconds). */
static inline sched_config_t testutil_sched_config(int tile)
{
    sched_config_t c = sched_config_default();
    c.tile_size = tile;
    c.task_deadline_s = 10;
    c.worker_timeout_s = 3;
    return c;
}

static inline sched_t *testutil_sched_new(const sched_config_t *c)
{
    sched_t *s = sched_new(c, NULL);
    assert_non_null(s);
    return s;
}

/* A worker's stand-in result for camera task t with nb buckets (at most 16): sample s of pixel
 * (x, y) adds a value unique to (x, y, s, bucket), with digits that make float sums depend on
 * their order, so that an image shows exactly which samples were merged, and in what order. */
static inline tilebuf_t *testutil_fake_result(const sched_task_t *t, int nb)
{
    tilebuf_t *r = tilebuf_new(t->x0, t->y0, t->w, t->h, nb, NULL);
    assert_non_null(r);
    double v[16];
    for (int y = t->y0; y < t->y0 + t->h; y++)
        for (int x = t->x0; x < t->x0 + t->w; x++)
            for (uint32_t s = t->sample_begin; s < t->sample_end; s++) {
                for (int b = 0; b < nb && b < 16; b++)
                    v[b] = (b + 1) * (x + 100.0 * y + 0.001 * s) * 1.0000001 + 1.0 / (s + 3);
                tilebuf_add_sample(r, x, y, v, (const double[3]){0.0, v[0], 0.0});
            }
    return r;
}

/* n buckets over 400-700 nm. */
static inline spectral_grid_t testutil_grid(int n)
{
    spectral_grid_t g;
    assert_int_equal(spectral_grid_init(&g, n, 400, 700, NULL), 0);
    return g;
}

/* The tasks worker 1 is given at time 0 until there is none or max of them; returns how many. */
static inline int testutil_take_all(sched_t *s, sched_task_t *tasks, int max)
{
    int n = 0;
    while (n < max && sched_next_task(s, 1, 0.0, &tasks[n]))
        n++;
    return n;
}

/* Puts the n items of size bytes in a fixed pseudo-random order of the seed (Fisher-Yates on an
 * LCG). */
static inline void testutil_shuffle(void *items, int n, size_t size, unsigned seed)
{
    unsigned char *p = items, tmp[256];
    assert_true(size <= sizeof tmp);
    unsigned x = seed;
    for (int i = n - 1; i > 0; i--) {
        x = x * 1103515245u + 12345u;
        int k = (int)((x >> 8) % (unsigned)(i + 1));
        memcpy(tmp, p + (size_t)i * size, size);
        memcpy(p + (size_t)i * size, p + (size_t)k * size, size);
        memcpy(p + (size_t)k * size, tmp, size);
    }
}

/* The n tasks in a fixed pseudo-random order of the seed, the order their results then arrive
 * in. */
static inline void testutil_shuffle_tasks(sched_task_t *tasks, int n, unsigned seed)
{
    testutil_shuffle(tasks, n, sizeof *tasks, seed);
}

#endif
