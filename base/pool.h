/* pool: the one place prismfarm starts threads that compute (render tiles, trace photons), and
 * the one place their floating-point mode is set. Every such thread runs with flush-to-zero
 * and denormals-are-zero (Embree's advice: denormals slow its traversal and never matter for an
 * image), so a tile's bytes are the same on whichever thread, process or host renders it. The
 * pool knows nothing of what the work is; threads that wait on sockets (ZAP) or on a disk (the
 * master's checkpoint writer, master/persist.c) compute nothing and are not its. */
#ifndef PRISMFARM_POOL_H
#define PRISMFARM_POOL_H

#include "err.h"

/* Cores this process may run on (its CPU affinity), at least 1. */
int pool_cores(void);

/* Sets the calling thread's floating-point mode to the compute threads' (above). */
void pool_fp_mode_set(void);

/* One index of a pool_for: 0 done, > 0 stop handing out further indices (no error), < 0 failed
 * with err filled. Called from several threads at once: it must guard what it shares. */
typedef int (*pool_index_fn)(void *user, int index, err_t *err);

/* Runs fn(user, i, err) for i = 0, 1, ..., n-1 on min(threads, n) threads (threads <= 0: all
 * cores), handing the indices out in increasing order from a shared counter, each at most
 * once. After the first call that fails or asks to stop, no further index starts; those in
 * flight finish. Returns 0 when every index ran, 1 when one asked to stop, -1 with the first
 * failure's err. If no thread can be started the indices run on the calling thread (with the
 * compute mode, restored afterwards). */
int pool_for(int threads, int n, pool_index_fn fn, void *user, err_t *err);

/* Long-lived compute threads (a worker's render threads), each running main(arg) with the
 * compute mode set. */
typedef struct pool pool_t;

/* Starts up to threads threads; NULL with err if none could start. */
pool_t *pool_start(int threads, void *(*main)(void *), void *arg, err_t *err);

/* The number of threads running. */
int pool_size(const pool_t *self);

/* Waits for every thread's main to return, then frees the pool and nulls *self_p. */
void pool_join(pool_t **self_p);

#endif
