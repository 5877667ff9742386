/* scene_cache: the scenes loaded for the worker's jobs, up to SCENE_CACHE_SLOTS (one per job, or
 * one per photon store of a refined job), each with the photon store its camera tiles gather
 * from. Render threads acquire a slot for a task and release it after: a scene is loaded from
 * the bundle cache, and a store decoded from the store cache, once, while the other threads keep
 * rendering; the least recently used idle slot goes first. Every call is made with the worker's
 * lock (given to scene_cache_init) held; acquiring releases it while it loads and waits on the
 * worker's condition variable, which it broadcasts when a slot changes. Scenes come from a
 * shelf (scene_shelf.h) under their bundle hash and settings, so slots of jobs or stores that
 * need the same scene share one, and a process's other parties may have loaded it already. */
#ifndef PRISMFARM_SCENE_CACHE_H
#define PRISMFARM_SCENE_CACHE_H

#include "bundle_cache.h"
#include "err.h"
#include "photon_store.h"
#include "proto.h"
#include "scene.h"
#include "scene_shelf.h"
#include "store_cache.h"

#include <pthread.h>
#include <stdint.h>

#define SCENE_CACHE_SLOTS 4

typedef struct job_scene {
    uint64_t job;
    char hash[PROTO_HASH_HEX + 1];
    /* The bundle's scene file it loaded ("": the bundle's main): the frames of a sequence share
     * one bundle, each with its own main, so a scene is told by hash and main together. */
    char main[PROTO_MAX_STRING + 1];
    /* The photon store decoded for the scene's camera tasks (photons), "" for none yet: a
     * refined job's new store needs a scene of its own, as a store is decoded once. */
    char store[PROTO_HASH_HEX + 1];
    scene_t *scene;
    photon_store_t *photons;
    char error[512];
    int loading, users;
    unsigned long stamp;
} job_scene_t;

typedef struct scene_cache {
    job_scene_t slots[SCENE_CACHE_SLOTS];
    unsigned long clock; /* stamps, counting up */
    pthread_mutex_t *lock;
    pthread_cond_t *wake;
    const bundle_cache_t *bundles;
    store_cache_t *stores;
    scene_shelf_t *shelf;
} scene_cache_t;

/* An empty cache that loads from bundles through shelf and stores, under lock, waiting on
 * wake. */
void scene_cache_init(scene_cache_t *self, pthread_mutex_t *lock, pthread_cond_t *wake,
                      const bundle_cache_t *bundles, store_cache_t *stores, scene_shelf_t *shelf);

/* The slot of job's scene (bundle hash and its scene file main, "" for the bundle's main;
 * loaded with settings) for one task, loading it if
 * needed; store is the photon store a camera tile gathers from ("" for none), decoded into the
 * slot if it has none yet. A photon batch takes any scene of its job. NULL with err when the
 * scene cannot be loaded (the slot keeps the error for the job's other tasks) or the store is
 * not held or bad. Waits while a slot it needs is loading, or while every slot is in use. */
job_scene_t *scene_cache_acquire(scene_cache_t *self, uint64_t job, const char *hash,
                                 const char *main, const char *store, const proto_settings_t *settings, err_t *err);

/* Gives back a slot that scene_cache_acquire returned. */
void scene_cache_release(scene_cache_t *self, job_scene_t *js);

/* Frees the job's slots that no thread is using or loading (its job was cancelled). */
void scene_cache_drop_job(scene_cache_t *self, uint64_t job);

/* Frees every slot; no thread may be using one. */
void scene_cache_clear(scene_cache_t *self);

#endif
