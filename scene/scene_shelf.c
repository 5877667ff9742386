#include "scene_shelf.h"

#include <pthread.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

typedef struct entry {
    char *key;
    scene_t *scene; /* NULL while loading */
} entry_t;

struct scene_shelf {
    pthread_mutex_t lock;
    pthread_cond_t loaded; /* a load ended, well or not */
    entry_t *entries;
    size_t n, cap;
    scene_shelf_stats_t stats;
};

scene_shelf_t *scene_shelf_new(err_t *err)
{
    scene_shelf_t *self = calloc(1, sizeof *self);
    if (!self) {
        err_set(err, "scene shelf: out of memory");
        return NULL;
    }
    pthread_mutex_init(&self->lock, NULL);
    pthread_cond_init(&self->loaded, NULL);
    return self;
}

static void remove_at(scene_shelf_t *self, size_t i)
{
    free(self->entries[i].key);
    scene_destroy(&self->entries[i].scene);
    self->entries[i] = self->entries[--self->n];
}

/* With the lock held: entries whose scene has no holder but the shelf go. */
static void trim_locked(scene_shelf_t *self)
{
    for (size_t i = self->n; i-- > 0;)
        if (self->entries[i].scene && atomic_load(&self->entries[i].scene->holders) <= 1)
            remove_at(self, i);
}

void scene_shelf_destroy(scene_shelf_t **self_p)
{
    scene_shelf_t *self = self_p ? *self_p : NULL;
    if (!self)
        return;
    /* No get may be running: a load in progress would still write its entry. */
    while (self->n > 0)
        remove_at(self, self->n - 1);
    free(self->entries);
    pthread_cond_destroy(&self->loaded);
    pthread_mutex_destroy(&self->lock);
    free(self);
    *self_p = NULL;
}

static long find(const scene_shelf_t *self, const char *key)
{
    for (size_t i = 0; i < self->n; i++)
        if (!strcmp(self->entries[i].key, key))
            return (long)i;
    return -1;
}

/* With the lock held: a new entry for key, holding scene (NULL: loading); -1 when out of
 * memory. */
static long add_locked(scene_shelf_t *self, const char *key, scene_t *scene)
{
    if (self->n == self->cap) {
        size_t cap = self->cap ? 2 * self->cap : 4;
        entry_t *e = realloc(self->entries, cap * sizeof *e);
        if (!e)
            return -1;
        self->entries = e;
        self->cap = cap;
    }
    char *k = strdup(key);
    if (!k)
        return -1;
    self->entries[self->n] = (entry_t){.key = k, .scene = scene};
    return (long)self->n++;
}

scene_t *scene_shelf_get(scene_shelf_t *self, const char *key, scene_shelf_load_fn load, void *arg,
                         err_t *err)
{
    pthread_mutex_lock(&self->lock);
    trim_locked(self);
    long i;
    while ((i = find(self, key)) >= 0 && !self->entries[i].scene)
        pthread_cond_wait(&self->loaded, &self->lock);
    if (i >= 0) {
        scene_t *sc = scene_retain(self->entries[i].scene);
        self->stats.shares++;
        pthread_mutex_unlock(&self->lock);
        return sc;
    }
    if (add_locked(self, key, NULL) < 0) {
        pthread_mutex_unlock(&self->lock);
        err_set(err, "scene shelf: out of memory");
        return NULL;
    }
    pthread_mutex_unlock(&self->lock);
    scene_t *sc = load(arg, err);
    pthread_mutex_lock(&self->lock);
    /* The entry may have moved (others were added or trimmed), never gone: only a finished
     * scene is trimmed. */
    i = find(self, key);
    if (sc) {
        self->entries[i].scene = scene_retain(sc);
        self->stats.loads++;
    } else {
        remove_at(self, (size_t)i);
    }
    pthread_cond_broadcast(&self->loaded);
    pthread_mutex_unlock(&self->lock);
    return sc;
}

int scene_shelf_put(scene_shelf_t *self, const char *key, scene_t *scene, err_t *err)
{
    pthread_mutex_lock(&self->lock);
    trim_locked(self);
    int r = 0;
    if (find(self, key) < 0) {
        if (add_locked(self, key, scene_retain(scene)) < 0) {
            scene_destroy(&scene);
            r = err_set(err, "scene shelf: out of memory");
        } else {
            self->stats.loads++;
        }
    }
    pthread_mutex_unlock(&self->lock);
    return r;
}

void scene_shelf_trim(scene_shelf_t *self)
{
    pthread_mutex_lock(&self->lock);
    trim_locked(self);
    pthread_mutex_unlock(&self->lock);
}

scene_shelf_stats_t scene_shelf_stats(scene_shelf_t *self)
{
    pthread_mutex_lock(&self->lock);
    scene_shelf_stats_t s = self->stats;
    pthread_mutex_unlock(&self->lock);
    return s;
}
