/* scene_bundle: packs a scene file and every file it reads (Include/Import, PLY meshes, image
 * textures) into a proto bundle for submission. The scene is parsed with the bundle rule
 * (pbrt_confine.h: absolute paths and symbolic links out of the folder refused before they
 * are read), and the bundle is rooted at the nearest folder that holds every file the scene
 * names ("../assets/wood.png" roots it one level above the scene's folder), each file under its
 * path below that root, so relative names work unchanged on the master. A
 * frame sequence packs several scene files of one folder into one bundle: a file that frames
 * share (a mesh, a texture, an included file) is in it once. */
#ifndef PRISMFARM_SCENE_BUNDLE_H
#define PRISMFARM_SCENE_BUNDLE_H

#include "err.h"
#include "proto.h"

#include <stdbool.h>

typedef struct scene_bundle scene_bundle_t;

/* Parses the scene (so a broken scene fails here, with file:line:col) and reads its files. */
scene_bundle_t *scene_bundle_new(const char *scene_path, err_t *err);
/* The n scene files of a sequence, all in one folder, each parsed as scene_bundle_new does: the
 * bundle's files are the union of theirs, its main the first's. A file missing, or frames in
 * different folders, is an error naming the frame. */
scene_bundle_t *scene_bundle_new_frames(const char *const *scene_paths, size_t n, err_t *err);
/* Whether the n scene files are in one folder, as scene_bundle_new_frames needs them. */
bool scene_bundle_one_folder(const char *const *scene_paths, size_t n);
void scene_bundle_destroy(scene_bundle_t **self_p);

/* The bundle, valid while self lives. */
const proto_bundle_t *scene_bundle_get(const scene_bundle_t *self);
/* Total bytes of the bundled files. */
size_t scene_bundle_bytes(const scene_bundle_t *self);
/* Frame k's main file in the bundle (scene_bundle_new: k = 0, the bundle's main). */
const char *scene_bundle_frame_main(const scene_bundle_t *self, size_t k);

#endif
