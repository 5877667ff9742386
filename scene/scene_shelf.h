/* scene_shelf: the scenes loaded in one process, shared by key, so that the parties of the
 * process that need the same scene -- `prismfarm render`'s client, master and workers, or a
 * worker's jobs and photon stores of one bundle -- load it once (issue 15: a farm render loaded
 * its scene three times). A key names what makes the scene (a bundle hash and the settings that
 * change it: settings_scene_key); a scene is shared only under the key it was loaded with.
 * Thread-safe: one caller loads a key while the others asking for it wait. The shelf holds one
 * reference of each scene (scene_retain) until no other holder is left and scene_shelf_trim or
 * the next get or put sees it: it keeps a scene alive for as long as someone uses it, no
 * longer. */
#ifndef PRISMFARM_SCENE_SHELF_H
#define PRISMFARM_SCENE_SHELF_H

#include "err.h"
#include "scene.h"

#include <stdint.h>

typedef struct scene_shelf scene_shelf_t;

/* Loads the scene a key names, on the caller's thread; NULL with err. */
typedef scene_t *(*scene_shelf_load_fn)(void *arg, err_t *err);

/* What the shelf did: scenes loaded (by a get, or given by a put), and gets answered with a
 * scene already there. */
typedef struct scene_shelf_stats {
    uint64_t loads, shares;
} scene_shelf_stats_t;

scene_shelf_t *scene_shelf_new(err_t *err);
/* Drops the shelf's references; the scenes others hold stay theirs. */
void scene_shelf_destroy(scene_shelf_t **self_p);

/* A reference to the scene under key (free it with scene_destroy): the one on the shelf, else
 * load(arg) -- waiting while another caller loads the same key -- put on the shelf. A failed
 * load is not kept: the next get tries again. NULL with load's err, or when out of memory. */
scene_t *scene_shelf_get(scene_shelf_t *self, const char *key, scene_shelf_load_fn load, void *arg,
                         err_t *err);

/* Shares a scene the caller loaded itself under key (the shelf takes a reference of its own);
 * a scene already under key stays. -1 with err when out of memory. */
int scene_shelf_put(scene_shelf_t *self, const char *key, scene_t *scene, err_t *err);

/* Drops the scenes nobody but the shelf holds. */
void scene_shelf_trim(scene_shelf_t *self);

scene_shelf_stats_t scene_shelf_stats(scene_shelf_t *self);

#endif
