/* settings: a job's settings between the wire and the scene loader. proto_settings_t (proto/)
 * is what a SUBMIT and a TASK carry; scene_overrides_t (scene/) is what the loader takes. The
 * conversion lives here, in a module above both, because neither may see the other: proto/
 * depends on base/ alone, and the scene knows nothing of messages. The master, the worker and
 * the CLI, which each see both, link it. Values pass unchanged (0, NULL and -1 still mean "the
 * scene file's"); strings still point into the struct they came from. */
#ifndef PRISMFARM_SETTINGS_H
#define PRISMFARM_SETTINGS_H

#include "proto.h"
#include "overrides.h"

/* The settings as the scene loader takes them. The stopping rules (target_error, time_limit)
 * are the master's, not the scene's: no override carries them. */
scene_overrides_t settings_to_overrides(const proto_settings_t *settings);

/* The key under which a scene loaded from the file main of the bundle of this hash with these
 * settings is shared (scene_shelf.h): the hash, the file (the frames of a sequence share one
 * bundle, each its own main file) and every setting settings_to_overrides passes to the loader,
 * so that two loads with one key make the same scene. SETTINGS_KEY_SIZE bytes hold any. */
#define SETTINGS_KEY_SIZE (PROTO_HASH_HEX + PROTO_MAX_STRING + 256)
void settings_scene_key(const char *hash, const char *main, const proto_settings_t *settings,
                        char key[SETTINGS_KEY_SIZE]);

#endif
