/* loader: the master's one thread for work that takes seconds -- loading a submitted scene
 * (issue 16, item 4: the master blocked 16.8 s on a 20 MB bundle; issue 15: clients gave up
 * after 60 s) -- so that its loop never waits on it. Work runs one item at a time, in the
 * order given, on a compute thread of the pool (pool.h); the master takes each finished item
 * back on its own thread with loader_done and only then touches master state with it. The
 * work function must touch nothing but its own argument. Items wait for one another, so a
 * scene load is bounded by its budget (budget.h: its text, vertices and texels, and a parse
 * deadline, --max-load-seconds, whose clock starts when the item starts): one upload holds
 * the thread for seconds, not minutes (issue 26, finding 2). */
#ifndef PRISMFARM_LOADER_H
#define PRISMFARM_LOADER_H

#include "err.h"

#include <stdbool.h>
#include <stddef.h>

typedef struct loader loader_t;

/* Runs on the loader's thread; arg is the caller's and is handed back by loader_done. */
typedef void (*loader_fn)(void *arg);

loader_t *loader_new(err_t *err);

/* Queues fn(arg). -1 with err when out of memory (arg stays the caller's). */
int loader_run(loader_t *self, loader_fn fn, void *arg, err_t *err);

/* A finished item's arg, oldest first, or NULL when none has finished. Never waits. */
void *loader_done(loader_t *self);

/* Items queued, running or finished and not yet taken back. */
size_t loader_pending(const loader_t *self);

/* Waits for the item running (a scene load cannot be cut short), then hands every arg still
 * held -- run or not -- to release, and frees the loader. */
void loader_destroy(loader_t **self_p, void (*release)(void *arg));

#endif
