/* scene_bundle: packs a scene file and every file it reads (Include/Import, PLY meshes, image
 * textures) into a proto bundle for submission, refusing files outside the scene's folder. */
#ifndef PRISMFARM_SCENE_BUNDLE_H
#define PRISMFARM_SCENE_BUNDLE_H

#include "err.h"
#include "proto.h"

typedef struct scene_bundle scene_bundle_t;

/* Parses the scene (so a broken scene fails here, with file:line:col) and reads its files. */
scene_bundle_t *scene_bundle_new(const char *scene_path, err_t *err);
void scene_bundle_destroy(scene_bundle_t **self_p);

/* The bundle, valid while self lives. */
const proto_bundle_t *scene_bundle_get(const scene_bundle_t *self);
/* Total bytes of the bundled files. */
size_t scene_bundle_bytes(const scene_bundle_t *self);

#endif
