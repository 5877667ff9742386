/* task_queue: the worker's tasks from their TASK message to their result. A task is ready (in
 * arrival order, for the render threads), parked (waiting for its bundle or photon store),
 * running (taken by a render thread) or done (rendered or failed, for the loop to send); the queue also remembers the jobs cancelled
 * lately, so that results of their tasks still in flight are dropped. It does no locking: the
 * worker calls it under its lock. */
#ifndef PRISMFARM_TASK_QUEUE_H
#define PRISMFARM_TASK_QUEUE_H

#include "photon.h"
#include "proto.h"
#include "render.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define TASK_QUEUE_CANCELLED 64 /* cancelled jobs remembered; the oldest is forgotten first */

typedef struct task {
    struct task *next;
    uint64_t job, id;
    uint32_t attempt;
    unsigned generation; /* connection generation that received it */
    char hash[PROTO_HASH_HEX + 1];
    char main[PROTO_MAX_STRING + 1]; /* the scene file of the bundle to load; "": its main */
    proto_settings_t settings;
    char strings[2][16];
    proto_kind_t kind;
    proto_tile_t tile;              /* camera tiles */
    char store[PROTO_HASH_HEX + 1]; /* camera tiles of a photon job: the store to gather from */
    proto_photon_batch_t photons;   /* photon batches */
    /* filled by the render thread */
    tilebuf_t *result;
    uint8_t *photon_data; /* a batch's partial store, wire form */
    size_t photon_size;
    int ok;
    photon_stats_t pstats;
    render_stats_t stats;
    double elapsed;
    char error[640];
} task_t;

/* A task from a TASK message (m), with copies of everything it points to; NULL when out of
 * memory. */
task_t *task_new(const proto_msg_t *m, unsigned generation);

/* Frees a list of tasks linked by next, with their results. */
void task_list_free(task_t *t);

typedef struct task_queue {
    task_t *ready, *ready_tail;               /* ready to render */
    task_t *parked;                           /* waiting for their bundle or photon store */
    task_t *running;                          /* taken by a render thread */
    task_t *done;                             /* rendered, to send */
    uint64_t cancelled[TASK_QUEUE_CANCELLED]; /* recently cancelled jobs */
    int ncancelled;
} task_queue_t;

/* Appends t to the ready tasks / takes the first ready one (NULL if none), which is running
 * until task_queue_finish. */
void task_queue_push(task_queue_t *self, task_t *t);
task_t *task_queue_pop(task_queue_t *self);

/* Parks t. *scene_asked and *store_asked say whether a task parked before waits for the same
 * bundle, or the same photon store (and so has asked for it already). */
void task_queue_park(task_queue_t *self, task_t *t, bool *scene_asked, bool *store_asked);

/* Takes the parked tasks for which pick(t, arg) is true: to the ready tasks when error is NULL,
 * else to the done ones, failed with error. */
typedef bool (*task_pick_fn)(const task_t *t, void *arg);
void task_queue_unpark(task_queue_t *self, task_pick_fn pick, void *arg, const char *error);

/* Puts t (running or not) among the done tasks / takes them all (a list, newest first). */
void task_queue_finish(task_queue_t *self, task_t *t);
task_t *task_queue_take_done(task_queue_t *self);

/* Remembers job as cancelled and frees its ready and parked tasks; returns how many. Its
 * running tasks finish, their results unsent. */
int task_queue_cancel(task_queue_t *self, uint64_t job);

/* How many tasks of job the queue holds (ready, parked, running or done), plus those in the
 * list also (the done tasks the loop is sending; may be NULL). */
int task_queue_held(const task_queue_t *self, uint64_t job, const task_t *also);
bool task_queue_is_cancelled(const task_queue_t *self, uint64_t job);
/* Forgets that job was cancelled: a task of that id again is of a new job. */
void task_queue_uncancel(task_queue_t *self, uint64_t job);

/* Frees the ready and parked tasks (what a lost connection held) / every task. */
void task_queue_abandon(task_queue_t *self);
void task_queue_clear(task_queue_t *self);

#endif
