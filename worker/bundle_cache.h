/* bundle_cache: the worker's scene bundles on disk, one folder per bundle hash below the cache
 * folder. A bundle is checked against its hash and extracted into a fresh folder that is renamed
 * into place with a ".complete" mark, so a half-written bundle never looks complete; nothing is
 * written outside the cache folder, and its scene is loaded confined to its own folder. The
 * cache holds no lock and no memory: the file system is its state.
 *
 * Files are written without fsync: syncing a large bundle took seconds on a busy disk, on the
 * worker's main thread, which then sent no heartbeat and was given up by the master (issue 16,
 * item 9). What is written survives the process, only a power cut or a crash of the host can
 * lose it; so the cache trusts its bundles within one boot of the host only: it records the
 * kernel's boot id (/proc/sys/kernel/random/boot_id) and, opened in another boot, empties
 * itself (a bundle is fetched again from the master when a task needs it). */
#ifndef PRISMFARM_BUNDLE_CACHE_H
#define PRISMFARM_BUNDLE_CACHE_H

#include "err.h"
#include "proto.h"
#include "scene_load.h"

#include <stdbool.h>

typedef struct bundle_cache {
    char dir[512];
} bundle_cache_t;

/* Uses dir, or $TMPDIR/prismfarm-worker-<uid> (/tmp without TMPDIR) when dir is NULL, creating
 * it and its parents (mode 0700), emptied when it was filled in another boot (above). Returns
 * -1 with errno set if a folder cannot be created; self->dir names the cache folder either
 * way. */
int bundle_cache_open(bundle_cache_t *self, const char *dir);

/* Whether the bundle of that hash is here, complete. */
bool bundle_cache_has(const bundle_cache_t *self, const char *hash);

/* Keeps a received bundle, which must hash to hash (an existing copy is kept as it is). */
int bundle_cache_put(const bundle_cache_t *self, const char *hash, const proto_bundle_t *bundle,
                     err_t *err);

/* The name of the main scene file of a bundle that is here (size bytes at most, with its 0);
 * -1 with err when the bundle is incomplete. */
int bundle_cache_main(const bundle_cache_t *self, const char *hash, char *out, size_t size,
                      err_t *err);

/* Loads the scene of a bundle that is here, confined to the bundle's folder
 * (scene_load_file_confined): its scene file main (a frame of a sequence), or its main file when
 * main is NULL or ""; NULL with err when the bundle is incomplete or the scene is bad. */
scene_t *bundle_cache_load(const bundle_cache_t *self, const char *hash, const char *main,
                           const scene_overrides_t *ov, err_t *err);

#endif
