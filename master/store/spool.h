/* spool: the master's folder on disk. scenes/<hash>/ holds each submitted bundle extracted (the
 * master loads it once to validate the job), scenes/<hash>.scene the bundle's encoded SCENE
 * message (reloaded for each worker that asks, so no bundle stays in memory), jobs/<id>/ each
 * job's outputs. Everything appears whole or not at all: bundles are extracted into tmp/ and
 * renamed into place, files are written under a temporary name, synced and renamed. */
#ifndef PRISMFARM_SPOOL_H
#define PRISMFARM_SPOOL_H

#include "err.h"
#include "proto.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef struct spool spool_t;

/* Opens the spool at dir, creating dir (and missing parents), scenes/, jobs/ and tmp/, and
 * removing whatever an earlier run left in tmp/. The spool is locked (flock on dir/lock, which
 * holds our pid) until spool_destroy or the process's death: a spool another process holds is
 * an error naming the folder and the holder's pid. */
spool_t *spool_new(const char *dir, err_t *err);
void spool_destroy(spool_t **self_p);

const char *spool_path(const spool_t *self);

/* The highest numeric folder name in jobs/ (0 if none), so that new job ids never reuse an
 * earlier run's output folder. */
uint64_t spool_last_job_id(const spool_t *self);

/* Makes a bundle's files available for loading: when scenes/<hash>/ exists, *dir is that folder
 * and *staged false; otherwise the bundle is extracted into a fresh folder below tmp/, *dir
 * names it and *staged is true. Follow with spool_scene_commit or spool_scene_discard. hash
 * must be the bundle's proto_bundle_hash. */
int spool_scene_stage(spool_t *self, const proto_bundle_t *bundle, const char *hash, char *dir,
                      size_t size, bool *staged, err_t *err);

/* The SCENE message workers are sent for a bundle, encoded into *out (free with free()), for
 * spool_scene_commit. limits bound it as proto_encode checks it (NULL: defaults). */
int spool_scene_encode(const proto_bundle_t *bundle, const char *hash,
                       const proto_limits_t *limits, uint8_t **out, size_t *size, err_t *err);

/* spool_scene_stage, spool_scene_commit and spool_scene_discard run on the master's loader
 * thread (loader.h), one submission at a time, and nothing else of the spool's state is
 * touched there: the staging counter is theirs alone. */

/* Stores the encoded SCENE message as scenes/<hash>.scene (if missing) and, for a staged
 * folder, renames it to scenes/<hash>/. Touches only files: safe on the loader's thread
 * (loader.h) while the master thread stages other bundles. */
int spool_scene_commit(const spool_t *self, const uint8_t *scene_msg, size_t size,
                       const char *hash, const char *dir, bool staged, err_t *err);

/* Removes a staged folder (harmless for a committed one: it does nothing unless staged). */
void spool_scene_discard(spool_t *self, const char *dir, bool staged);

/* Reads back the SCENE message of a stored bundle into *out (free with proto_msg_free). The
 * decoder re-checks the bundle and that it hashes to hash, so a damaged spool file is an error,
 * never a wrong scene. */
int spool_scene_read(spool_t *self, const char *hash, const proto_limits_t *limits,
                     proto_msg_t *out, err_t *err);

/* jobs/<id>/, created if missing; its path in buf. */
int spool_job_dir(spool_t *self, uint64_t job, char *buf, size_t size, err_t *err);

#endif
