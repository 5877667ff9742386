#include "scene_cache.h"

#include "photon_wire.h"
#include "settings.h"

#include <stdio.h>
#include <string.h>

/* Frees a scene slot's scene and store and empties it. */
static void job_scene_clear(job_scene_t *js)
{
    scene_destroy(&js->scene);
    photon_store_destroy(&js->photons);
    memset(js, 0, sizeof *js);
}

void scene_cache_init(scene_cache_t *self, pthread_mutex_t *lock, pthread_cond_t *wake,
                      const bundle_cache_t *bundles, store_cache_t *stores, scene_shelf_t *shelf)
{
    *self = (scene_cache_t){.lock = lock, .wake = wake, .bundles = bundles, .stores = stores,
                            .shelf = shelf};
}

/* What the shelf loads on a miss: the scene file main ("" for the bundle's own) of the bundle
 * from the cache folder. */
typedef struct bundle_load {
    const bundle_cache_t *bundles;
    const char *hash, *main;
    scene_overrides_t ov;
} bundle_load_t;

static scene_t *load_bundle(void *arg, err_t *err)
{
    bundle_load_t *b = arg;
    scene_t *s = bundle_cache_load(b->bundles, b->hash, b->main, &b->ov, err);
    return s;
}

/* Decodes the photon store for a scene slot that has none yet. Called with the lock held;
 * released while the store is decoded and built. */
static int install_store(scene_cache_t *self, job_scene_t *js, const char *hash, err_t *err)
{
    store_bytes_t *sb = store_cache_hold(self->stores, hash);
    if (!sb)
        return err_set(err, "photon store %.12s is no longer held: the master will send it again",
                       hash);
    pthread_mutex_unlock(self->lock);
    photon_store_t *store = photon_pass_from_wire(js->scene, sb->data, sb->size, err);
    pthread_mutex_lock(self->lock);
    int r = store ? 0 : -1;
    js->photons = store;
    store_cache_release(self->stores, sb);
    if (!r)
        snprintf(js->store, sizeof js->store, "%s", hash);
    return r;
}

job_scene_t *scene_cache_acquire(scene_cache_t *self, uint64_t job, const char *hash,
                                 const char *main, const char *store, const proto_settings_t *settings, err_t *err)
{
    for (;;) {
        job_scene_t *hit = NULL, *victim = NULL;
        for (int i = 0; i < SCENE_CACHE_SLOTS; i++) {
            job_scene_t *s = &self->slots[i];
            /* Photon batches take any scene of their job (they leave its store slot alone);
             * a tile needs its store installed, or a scene with none yet to install it in. */
            if ((s->scene || s->loading || s->error[0]) && s->job == job && !strcmp(s->main, main) &&
                (s->error[0] || !store[0] || !s->store[0] || !strcmp(s->store, store))) {
                hit = s;
                break;
            }
            if (!s->loading && s->users == 0 && (!victim || s->stamp < victim->stamp))
                victim = s;
        }
        if (hit && hit->loading) {
            pthread_cond_wait(self->wake, self->lock);
            continue;
        }
        if (hit) {
            if (hit->error[0]) {
                err_set(err, "%s", hit->error);
                return NULL;
            }
            if (store[0] && !hit->store[0]) {
                /* Wait for the scene's own users to leave? No: batches do not touch the store
                 * slot, and tiles of this job all want this store. */
                hit->loading = 1;
                int r = install_store(self, hit, store, err);
                hit->loading = 0;
                pthread_cond_broadcast(self->wake);
                if (r)
                    return NULL;
            }
            hit->users++;
            hit->stamp = ++self->clock;
            return hit;
        }
        if (!victim) {
            pthread_cond_wait(self->wake, self->lock);
            continue;
        }
        job_scene_clear(victim);
        victim->job = job;
        victim->loading = 1;
        snprintf(victim->hash, sizeof victim->hash, "%s", hash);
        snprintf(victim->main, sizeof victim->main, "%s", main);
        pthread_mutex_unlock(self->lock);
        err_t lerr = {{0}};
        bundle_load_t bl = {.bundles = self->bundles, .hash = hash, .main = main,
                            .ov = settings_to_overrides(settings)};
        /* Keyed by the file loaded, the bundle's own main when the task names none, so that
         * the frames of a sequence (one bundle) never share a scene and a job of the bundle's
         * main shares the one its client and master loaded (prismfarm render). */
        char key[SETTINGS_KEY_SIZE], mainname[PROTO_MAX_STRING + 1];
        scene_t *sc = NULL;
        if (main[0])
            snprintf(mainname, sizeof mainname, "%s", main);
        if (main[0] || bundle_cache_main(self->bundles, hash, mainname, sizeof mainname, &lerr) == 0) {
            settings_scene_key(hash, mainname, settings, key);
            sc = scene_shelf_get(self->shelf, key, load_bundle, &bl, &lerr);
        }
        pthread_mutex_lock(self->lock);
        victim->scene = sc;
        victim->stamp = ++self->clock;
        if (!sc)
            snprintf(victim->error, sizeof victim->error, "%s", lerr.msg);
        else if (store[0] && install_store(self, victim, store, &lerr)) {
            /* The scene is fine for batches; this tile fails (and is tried again). */
            victim->loading = 0;
            pthread_cond_broadcast(self->wake);
            err_set(err, "%s", lerr.msg);
            return NULL;
        }
        victim->loading = 0;
        pthread_cond_broadcast(self->wake);
    }
}

void scene_cache_release(scene_cache_t *self, job_scene_t *js)
{
    js->users--;
    pthread_cond_broadcast(self->wake);
}

void scene_cache_drop_job(scene_cache_t *self, uint64_t job)
{
    for (int i = 0; i < SCENE_CACHE_SLOTS; i++)
        if (self->slots[i].job == job && !self->slots[i].users && !self->slots[i].loading)
            job_scene_clear(&self->slots[i]);
    scene_shelf_trim(self->shelf);
}

void scene_cache_clear(scene_cache_t *self)
{
    for (int i = 0; i < SCENE_CACHE_SLOTS; i++)
        job_scene_clear(&self->slots[i]);
}
