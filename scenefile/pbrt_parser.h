/* pbrt_parser: reads a scene in pbrt-v4's file format into a scene_desc, with pbrt-v4's
 * meaning for every directive it accepts. Anything outside the subset, any parameter a
 * directive does not use, and any malformed input fails with one message
 * "file:line:col: what is wrong"; the parser never crashes (fuzzed under ASan).
 *
 * The subset (user documentation: docs/scene-format.md):
 *   transforms  LookAt Translate Scale Rotate Transform ConcatTransform Identity
 *               CoordinateSystem CoordSysTransform ReverseOrientation
 *   structure   WorldBegin AttributeBegin/End (TransformBegin/End as pbrt-v4 reads them)
 *               Include Import ObjectBegin/End ObjectInstance
 *   options     Camera "perspective", Film "rgb"|"spectral", Sampler (any pbrt-v4 name),
 *               Integrator "simplepath"|"path"|"whitted"|"photon"|"auto" (raw parameters)
 *   world       Shape sphere|disk|trianglemesh|plymesh|bilinearmesh; Material and
 *               MakeNamedMaterial diffuse|conductor|dielectric|interface; NamedMaterial;
 *               Texture constant|checkerboard|imagemap (EXR, PFM, PNG, stb_image)|scale|mix
 *               ("uv" mapping), ptex warned; material displacement/normalmap, shape alpha;
 *               AreaLightSource diffuse|collimated; LightSource point|spot|distant|infinite
 *   extensions  dielectric "string glass", "float sellmeier" [B1 C1 ...], "float cauchy" [A B];
 *               AreaLightSource "collimated"; rgb film "nbuckets"/"lambdamin"/"lambdamax"
 * Deliberate differences from pbrt-v4, all stricter: named materials, textures and
 * coordinate systems must be defined before use (objects may still be instanced before their
 * definition, as in pbrt-v4); a parameter given twice is an error. A "spectrum" string that
 * names a file is read as a pbrt-v4 spectrum file (others are left to the loader as names). A relative file name is looked up in the folder of the file that names it,
 * then in the main file's folder (pbrt-v4's only rule). Every file read is listed in the
 * scene_desc's files, with its path relative to the main file's folder, for bundling. */
#ifndef PRISMFARM_PBRT_PARSER_H
#define PRISMFARM_PBRT_PARSER_H

#include "err.h"
#include "pbrt_limits.h"
#include "scene_desc.h"
#include "warnings.h"

#include <stddef.h>

/* Parses the scene file at path. Include, Import, plymesh, imagemap and spectrum file names resolve
 * against the folder of the file that names them, else of the main file. Returns NULL with err
 * filled on failure. For the user's own files (`prismfarm render`): any file the scene names
 * is read. */
scene_desc_t *pbrt_parse_file(const char *path, err_t *err);

/* As pbrt_parse_file with the bundle rule (pbrt_parse_opts_t.bundle), for `prismfarm check`,
 * so that check refuses what the farm's client refuses: a refused directive is added to errors (its
 * "file:line:col: message") and the parse goes on at the next directive, so one run finds
 * every refusal the parser can see. Returns the scene as far as it was parsed (its warnings
 * included), or NULL with err filled only when nothing could be read (the main file missing,
 * out of memory). The result may lack what was refused: load it only to look for more. */
scene_desc_t *pbrt_parse_file_check(const char *path, warnings_t *errors, err_t *err);

/* Parses a scene from an untrusted source whose files were extracted into the folder root
 * (the master's spool/scenes/<hash>/, a worker's <cache>/<hash>/). Every file the scene reads
 * (the main file, Include/Import, plymesh, imagemap, spectrum files) must be, after lexical normalisation and
 * after following symbolic links (realpath), a regular file inside root; it is checked before
 * it is opened, so a FIFO, a device or a file elsewhere is never opened. Anything else fails
 * with "file:line:col: \"NAME\" is outside the scene's folder" or "... \"NAME\" is not a
 * regular file" (NAME as the scene writes it; no location for the main file). A file over
 * PBRT_FILE_BYTES_MAX or a scene over PBRT_TOTAL_BYTES_MAX fails too, and so does one over
 * budget's shapes or triangles (budget.h; NULL: no budget), at the directive that passes it.
 * The imagemap file names in the result are the checked real paths. */
scene_desc_t *pbrt_parse_file_confined(const char *path, const char *root,
                                       const scene_budget_t *budget, err_t *err);


/* pbrt_parse_file or pbrt_parse_file_confined as opts says (NULL: all zero). */
scene_desc_t *pbrt_parse_file_opts(const char *path, const pbrt_parse_opts_t *opts, err_t *err);

/* Parses scene text held in memory; name is used in messages and as the base for relative
 * file names (e.g. "tests/data/scenes/x.pbrt" resolves "inc.pbrt" in tests/data/scenes). The
 * text itself is not listed among the files read; the files it reads are. */
scene_desc_t *pbrt_parse_string(const char *text, size_t len, const char *name, err_t *err);

#endif
