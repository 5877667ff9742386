/* bundle: the scene bundles that travel with jobs (in SUBMIT and SCENE, proto.h): the path rules
 * every bundle obeys, its content hash, and writing it into a folder. A bundle that passes
 * proto_bundle_check can only create files below the folder it is extracted into. It sits below
 * the codec, which checks and hashes the bundles it carries, and knows nothing of messages. */
#ifndef PRISMFARM_BUNDLE_H
#define PRISMFARM_BUNDLE_H

#include "err.h"
#include "proto_limits.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* A scene bundle: the main scene file and every file it references, by relative path. Paths use
 * '/', and are relative and normalised (proto_bundle_path_check states the rules); each appears
 * once. */
typedef struct proto_bundle_file {
    const char *path;
    const uint8_t *data;
    size_t size;
} proto_bundle_file_t;

typedef struct proto_bundle {
    const char *main; /* the scene file to load; one of the files' paths */
    const proto_bundle_file_t *files;
    size_t nfiles;
} proto_bundle_t;

/* A path inside a bundle: 1..PROTO_MAX_STRING bytes of '/'-separated components, at most
 * PROTO_MAX_PATH_DEPTH of them, each 1..PROTO_MAX_PATH_COMPONENT bytes, none "." or "..". No
 * leading '/', no empty component ("a//b", trailing '/'), no backslash, no control character. */
int proto_bundle_path_check(const char *path, err_t *err);

/* Every path valid and unique, no file also used as a folder ("a" and "a/b"), main among the
 * files, count and total size within limits (NULL: defaults). */
int proto_bundle_check(const proto_bundle_t *bundle, const proto_limits_t *limits, err_t *err);

/* The bundle's identity: lower-case hex SHA-256 over its canonical form (docs/protocol.md,
 * "Scene bundles"), independent of the order of files. Fails only on a bundle that does not
 * pass proto_bundle_check without limits, or when out of memory. */
int proto_bundle_hash(const proto_bundle_t *bundle, char hex[PROTO_HASH_HEX + 1], err_t *err);

/* Writes the bundle's files below dir (created if missing; its parent must exist), creating
 * subfolders as needed. Never follows a symbolic link below dir: a link where a subfolder is
 * expected is an error, and a link at a file's place is replaced, not written through. Each file
 * is written to a temporary name, synced when durable (else it survives the process, not a
 * power cut) and renamed, so it appears whole or not at all. On failure the files before the
 * faulty one stay written: to make a whole bundle appear at once, extract into a fresh folder
 * and rename that folder into place. */
int proto_bundle_extract(const proto_bundle_t *bundle, const char *dir, bool durable, err_t *err);

#endif
