#include "photon_phase.h"

#include "sha256.h"

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

struct photon_phase {
    scene_t *scene;
    uint64_t batch_size;
    uint64_t total;   /* photons the batches cover: [0, total) */
    uint32_t nbatches;
    proto_photon_batch_t *ranges; /* [nbatches] */
    photon_store_t *merged;   /* batches [0, next) merged */
    uint32_t next;
    photon_store_t **pending; /* [nbatches]: results in, waiting for an earlier batch */
    uint8_t *wire;            /* the merged store's wire form, once made */
    size_t wire_size;
    char hash[PROTO_HASH_HEX + 1];
    photon_phase_stats_t stats;
};

uint64_t photon_phase_batch_size(uint64_t photons)
{
    uint64_t b = photons / 32 + (photons % 32 != 0);
    return b < 20000 ? 20000 : b > 1000000 ? 1000000 : b;
}

/* Batches for photons [total, total + photons) at the phase's batch size, after the existing
 * ones (whose ranges never change). */
static int add_batches(photon_phase_t *self, uint64_t photons, err_t *err)
{
    uint64_t n = photons / self->batch_size + (photons % self->batch_size != 0);
    if (n > UINT32_MAX / 2 - self->nbatches)
        return err_set(err, "photon pass: %" PRIu64 " photons make too many batches", photons);
    size_t total_n = (size_t)(self->nbatches + n);
    photon_store_t **p = realloc(self->pending, (total_n ? total_n : 1) * sizeof *p);
    if (p)
        self->pending = p;
    proto_photon_batch_t *r = p ? realloc(self->ranges, (total_n ? total_n : 1) * sizeof *r) : NULL;
    if (!p || !r)
        return err_set(err, "out of memory");
    self->ranges = r;
    for (uint64_t i = 0; i < n; i++) {
        uint64_t first = self->total + i * self->batch_size;
        uint64_t end = first + self->batch_size;
        p[self->nbatches + i] = NULL;
        r[self->nbatches + i] =
            (proto_photon_batch_t){first, end < self->total + photons ? end : self->total + photons};
    }
    self->nbatches = (uint32_t)total_n;
    self->total += photons;
    self->stats.batches = self->nbatches;
    return 0;
}

photon_phase_t *photon_phase_new(scene_t **scene, err_t *err)
{
    photon_phase_t *self = calloc(1, sizeof *self);
    if (!self) {
        scene_destroy(scene);
        err_set(err, "out of memory");
        return NULL;
    }
    self->scene = *scene;
    *scene = NULL;
    const photon_settings_t *ph = &self->scene->settings.photon;
    if (!ph->enabled || ph->photons == 0) {
        err_set(err, "photon pass: the job's integrator has no photon pass");
        photon_phase_destroy(&self);
        return NULL;
    }
    self->batch_size = photon_phase_batch_size(ph->photons);
    if (!(self->merged = photon_store_new(self->scene, err)) ||
        add_batches(self, ph->photons, err)) {
        photon_phase_destroy(&self);
        return NULL;
    }
    return self;
}

photon_phase_t *photon_phase_restore(scene_t **scene, const uint8_t *data, size_t size,
                                     uint64_t photons, err_t *err)
{
    photon_phase_t *self = calloc(1, sizeof *self);
    if (!self) {
        scene_destroy(scene);
        err_set(err, "out of memory");
        return NULL;
    }
    self->scene = *scene;
    *scene = NULL;
    const photon_settings_t *ph = &self->scene->settings.photon;
    uint64_t lanes = (uint64_t)ph->monochromerays;
    if (!ph->enabled || photons == 0 || photons > ((uint64_t)1 << 62)) {
        err_set(err, "photon pass: nothing to restore (%" PRIu64 " photons)", photons);
        photon_phase_destroy(&self);
        return NULL;
    }
    self->batch_size = photon_phase_batch_size(ph->photons);
    if (!(self->merged = photon_store_decode(self->scene, data, size, err))) {
        err_prefix(err, "photon pass: the saved store: ");
        photon_phase_destroy(&self);
        return NULL;
    }
    if (photon_store_emitted(self->merged) != photons * lanes) {
        err_set(err, "photon pass: the saved store has %" PRIu64 " photons emitted, expected %" PRIu64,
                photon_store_emitted(self->merged), photons * lanes);
        photon_phase_destroy(&self);
        return NULL;
    }
    /* One batch, already merged: the batch size stays the pass's, so refinements cut the
     * same batches as they would have without the restore. */
    uint64_t bs = self->batch_size;
    self->batch_size = photons;
    int r = add_batches(self, photons, err);
    self->batch_size = bs;
    if (r) {
        photon_phase_destroy(&self);
        return NULL;
    }
    self->next = 1;
    self->stats.batches_merged = 1;
    self->stats.photons = photons;
    self->stats.emitted = photons * lanes;
    return self;
}

void photon_phase_destroy(photon_phase_t **self_p)
{
    photon_phase_t *self = self_p ? *self_p : NULL;
    if (!self)
        return;
    for (uint32_t i = 0; self->pending && i < self->nbatches; i++)
        photon_store_destroy(&self->pending[i]);
    free(self->pending);
    free(self->ranges);
    photon_store_destroy(&self->merged);
    free(self->wire);
    scene_destroy(&self->scene);
    free(self);
    *self_p = NULL;
}

const scene_t *photon_phase_scene(const photon_phase_t *self)
{
    return self->scene;
}

uint32_t photon_phase_nbatches(const photon_phase_t *self)
{
    return self->nbatches;
}

proto_photon_batch_t photon_phase_batch(const photon_phase_t *self, uint32_t batch)
{
    return self->ranges[batch];
}

int photon_phase_add(photon_phase_t *self, uint32_t batch, const proto_photon_result_t *r,
                     err_t *err)
{
    if (batch >= self->nbatches)
        return err_set(err, "photon batch %" PRIu32 " does not exist (the pass has %" PRIu32 ")",
                       batch, self->nbatches);
    self->stats.bytes_in += r->size;
    if (batch < self->next || self->pending[batch])
        return 0;
    proto_photon_batch_t want = photon_phase_batch(self, batch);
    if (r->range.first != want.first || r->range.end != want.end)
        return err_set(err,
                       "photon batch %" PRIu32 ": result covers [%" PRIu64 ", %" PRIu64
                       "), the batch is [%" PRIu64 ", %" PRIu64 ")",
                       batch, r->range.first, r->range.end, want.first, want.end);
    uint64_t lanes = (uint64_t)self->scene->settings.photon.monochromerays;
    uint64_t expect = (want.end - want.first) * lanes;
    photon_store_t *st = photon_store_decode(self->scene, r->data, r->size, err);
    if (!st)
        return err_prefix(err, "photon batch %" PRIu32 ": ", batch);
    if (r->emitted != expect || photon_store_emitted(st) != expect) {
        uint64_t got = photon_store_emitted(st);
        photon_store_destroy(&st);
        return err_set(err,
                       "photon batch %" PRIu32 ": %" PRIu64 " photons emitted (store says %" PRIu64
                       "), expected %" PRIu64 " (%" PRIu64 " photons x %" PRIu64 " lanes)",
                       batch, r->emitted, got, expect, want.end - want.first, lanes);
    }
    self->pending[batch] = st;
    self->stats.nonfinite += r->nonfinite;
    /* Merge every batch now in order: the store grows in batch order only. */
    while (self->next < self->nbatches && self->pending[self->next]) {
        photon_store_t *p = self->pending[self->next];
        if (photon_store_merge(self->merged, p, err))
            return err_prefix(err, "photon batch %" PRIu32 ": ", self->next);
        proto_photon_batch_t b = photon_phase_batch(self, self->next);
        self->stats.photons += b.end - b.first;
        self->stats.emitted += photon_store_emitted(p);
        photon_store_destroy(&self->pending[self->next]);
        self->next++;
        self->stats.batches_merged = self->next;
    }
    return 1;
}

int photon_phase_complete(const photon_phase_t *self)
{
    return self->next == self->nbatches;
}

int photon_phase_store(photon_phase_t *self, const uint8_t **data, size_t *size,
                       const char **hash, err_t *err)
{
    if (!photon_phase_complete(self))
        return err_set(err, "photon pass: %" PRIu32 " of %" PRIu32 " batches merged", self->next,
                       self->nbatches);
    if (!self->wire) {
        if (photon_store_encode(self->merged, &self->wire, &self->wire_size, err))
            return -1;
        sha256_hex_of(self->wire_size ? self->wire : (const uint8_t *)"", self->wire_size,
                      self->hash);
    }
    *data = self->wire;
    *size = self->wire_size;
    *hash = self->hash;
    return 0;
}

int photon_phase_refine(photon_phase_t *self, uint64_t photons, err_t *err)
{
    if (photons == 0)
        return err_set(err, "refine: at least one more photon is needed");
    if (!photon_phase_complete(self))
        return err_set(err, "refine: the photon pass is still running");
    if (photons > ((uint64_t)1 << 62) - self->total)
        return err_set(err, "refine: %" PRIu64 " more photons is too many", photons);
    /* The batches merged keep their ranges; the new ones start where they end. */
    if (add_batches(self, photons, err))
        return -1;
    free(self->wire);
    self->wire = NULL;
    self->wire_size = 0;
    return 0;
}

photon_phase_stats_t photon_phase_stats(const photon_phase_t *self)
{
    photon_phase_stats_t s = self->stats;
    s.total = self->total;
    return s;
}
