/* photon_phase: the master's side of a job's photon pass (docs/farm.md, "Photon jobs"). The
 * pass is cut into batches of photon indices; each worker's result is a partial store with raw
 * power and the photons it emitted. Results are decoded against the job's scene (nothing a
 * worker sends is trusted), kept until every earlier batch is in, and merged in batch order,
 * so the merged store is the same whichever workers traced what, and the same as one machine's
 * photon_pass_run. The post-pass rescale is the merged emitted count: the store divides by the
 * monochrome photons actually emitted, so several lanes a photon, a batch lost and traced
 * again (duplicates are ignored) or batches added later by `prismfarm refine` all come out
 * with the right energy (docs/physics.md §4.4, §5.2: the thesis's rescale post-pass). */
#ifndef PRISMFARM_PHOTON_PHASE_H
#define PRISMFARM_PHOTON_PHASE_H

#include "err.h"
#include "photon_store.h"
#include "proto.h"
#include "scene.h"

#include <stdint.h>

typedef struct photon_phase photon_phase_t;

typedef struct photon_phase_stats {
    uint64_t photons;     /* photon indices in the batches merged so far */
    uint64_t total;       /* photon indices in every batch, merged or not (refinements too) */
    uint64_t emitted;     /* monochrome photons emitted by them: the store's N */
    uint64_t nonfinite;   /* photons the workers dropped for a NaN or Inf power */
    uint64_t bytes_in;    /* wire bytes of the partial stores received (duplicates included) */
    uint32_t batches, batches_merged;
} photon_phase_stats_t;

/* Photons per batch for a pass of `photons`: about 32 batches, so that workers share the pass
 * and a lost batch costs little, but never fewer than 20000 photons (a batch's round trip is
 * then well under its tracing time) nor more than 1000000. */
uint64_t photon_phase_batch_size(uint64_t photons);

/* The photon pass of the job whose scene (loaded with the job's settings, photon integrator
 * enabled) is *scene; the phase owns the scene from here on (also on failure). Batches cover
 * photons [0, settings.photon.photons). */
photon_phase_t *photon_phase_new(scene_t **scene, err_t *err);
void photon_phase_destroy(photon_phase_t **self_p);

/* A finished pass brought back from the wire form of its merged store (the master keeps it on
 * disk between a job's end and a refinement rather than in memory): photons [0, photons) as
 * one merged batch. The store's emitted count must be photons times the scene's lanes. The
 * phase owns *scene from here on (also on failure). */
photon_phase_t *photon_phase_restore(scene_t **scene, const uint8_t *data, size_t size,
                                     uint64_t photons, err_t *err);

const scene_t *photon_phase_scene(const photon_phase_t *self);
uint32_t photon_phase_nbatches(const photon_phase_t *self);
proto_photon_batch_t photon_phase_batch(const photon_phase_t *self, uint32_t batch);

/* A worker's result for a batch. The range must be the batch's and the emitted count the range
 * times the job's lanes; the store must decode against the scene. Returns 1 when the result was
 * new and kept, 0 for a batch already in (ignored), -1 with err for a result that must be
 * refused (the task then counts as failed). */
int photon_phase_add(photon_phase_t *self, uint32_t batch, const proto_photon_result_t *r,
                     err_t *err);

/* Every batch is merged. */
int photon_phase_complete(const photon_phase_t *self);

/* The merged store's wire form and its SHA-256 (lower-case hex), made on the first call after
 * completion and kept until the next refinement; the pointers stay valid until then. */
int photon_phase_store(photon_phase_t *self, const uint8_t **data, size_t *size,
                       const char **hash, err_t *err);

/* More photons for a finished pass: batches for photons [current end, current end + photons)
 * follow the existing ones; the pass is incomplete again until they are merged. */
int photon_phase_refine(photon_phase_t *self, uint64_t photons, err_t *err);

photon_phase_stats_t photon_phase_stats(const photon_phase_t *self);

#endif
