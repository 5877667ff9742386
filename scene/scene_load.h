/* scene_load: builds a renderable scene (scene.h) from a parsed description (scene_desc.h):
 * resolves spectra (uplifting RGB, normalising lights and applying "power"/"illuminance" as
 * pbrt-v4 does), glasses, textures and image files, transforms shapes to world space, turns
 * each instanced object into one scene object placed by Embree instances, and reads the
 * integrator's parameters. Everything it cannot build fails with "file:line:col: what is
 * wrong". docs/scene-format.md is the user's description of the result. Each entity is read by
 * its own module (load_options, load_integrator, load_textures, load_materials, load_lights,
 * load_media, load_shapes, load_instances) over the context they share (loader.h); this one
 * calls them in order. */
#ifndef PRISMFARM_SCENE_LOAD_H
#define PRISMFARM_SCENE_LOAD_H

#include "err.h"
#include "overrides.h"
#include "scene.h"
#include "scene_desc.h"

scene_t *scene_load(const scene_desc_t *desc, const scene_overrides_t *ov, err_t *err);

/* Every material of desc read by its class (scene/material_<name>.c), each refusal added to
 * refusals: what prismfarm check reports of a scene that did not parse cleanly, beside the
 * parser's refusals (the textures stand in as constants; nothing else is loaded). -1 with err
 * only when out of memory. */
int scene_load_check_materials(const scene_desc_t *desc, warnings_t *refusals, err_t *err);

/* Parses the file and loads it (the user's own files: whatever the scene names is read). */
scene_t *scene_load_file(const char *path, const scene_overrides_t *ov, err_t *err);

/* The same for a scene from an untrusted source extracted into the folder root (a bundle on
 * the master or a worker): parsed by pbrt_parse_file_confined, so it reads only regular files
 * inside root, within PBRT_FILE_BYTES_MAX each and PBRT_TOTAL_BYTES_MAX in all. */
scene_t *scene_load_file_confined(const char *path, const char *root, const scene_overrides_t *ov,
                                  err_t *err);

#endif
