/* sched_testutil: what the scheduler tests share: a spectral grid of n buckets over 400-700 nm,
 * all the tasks a worker is given at once, and a fixed pseudo-random order of their results.
 * Header-only (each test is its own executable); include after cmocka.h. */
#ifndef PRISMFARM_SCHED_TESTUTIL_H
#define PRISMFARM_SCHED_TESTUTIL_H

#include "sched.h"
#include "spectral_grid.h"

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

/* Puts the n tasks in a fixed pseudo-random order of the seed (Fisher-Yates on an LCG), the
 * order their results then arrive in. */
static inline void testutil_shuffle_tasks(sched_task_t *tasks, int n, unsigned seed)
{
    unsigned x = seed;
    for (int i = n - 1; i > 0; i--) {
        x = x * 1103515245u + 12345u;
        int k = (int)((x >> 8) % (unsigned)(i + 1));
        sched_task_t tmp = tasks[i];
        tasks[i] = tasks[k];
        tasks[k] = tmp;
    }
}

#endif
