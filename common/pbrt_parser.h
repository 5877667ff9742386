/* pbrt_parser: reads a scene in pbrt-v4's file format (the subset in docs/scene-format.md,
 * with prismfarm's extensions) into a scene_desc, with pbrt-v4's meaning for every directive.
 * Anything outside the subset, any parameter a directive does not use, and any malformed
 * input fails with one message "file:line:col: what is wrong"; the parser never crashes. */
#ifndef PRISMFARM_PBRT_PARSER_H
#define PRISMFARM_PBRT_PARSER_H

#include "err.h"
#include "scene_desc.h"

#include <stddef.h>

/* Include/Import nesting limit (the main file counts as one) and the most files one scene
 * may read in total, so that a scene that includes a file many times cannot run for ever. */
#define PBRT_INCLUDE_DEPTH_MAX 16
#define PBRT_FILES_MAX 4096

/* Parses the scene file at path. Include, Import, plymesh and imagemap file names resolve
 * against the folder of the file that names them. Returns NULL with err filled on failure. */
scene_desc_t *pbrt_parse_file(const char *path, err_t *err);

/* Parses scene text held in memory; name is used in messages and as the base for relative
 * file names (e.g. "tests/data/scenes/x.pbrt" resolves "inc.pbrt" in tests/data/scenes). */
scene_desc_t *pbrt_parse_string(const char *text, size_t len, const char *name, err_t *err);

#endif
