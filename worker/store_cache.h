/* store_cache: photon stores in the wire form the master sent them (STORE), by hash, until no
 * task needs them: up to STORE_CACHE_SLOTS, each counted while render threads decode it, so a
 * store being decoded is never dropped. It does no locking: the worker calls it under its lock. */
#ifndef PRISMFARM_STORE_CACHE_H
#define PRISMFARM_STORE_CACHE_H

#include "proto.h"

#include <stddef.h>
#include <stdint.h>

#define STORE_CACHE_SLOTS 4

typedef struct store_bytes {
    char hash[PROTO_HASH_HEX + 1]; /* "" for an empty slot */
    uint8_t *data;
    size_t size;
    int users; /* render threads installing it right now */
    unsigned long stamp;
} store_bytes_t;

typedef struct store_cache {
    store_bytes_t slots[STORE_CACHE_SLOTS];
    unsigned long clock; /* stamps, counting up */
} store_cache_t;

/* The store of that hash, or NULL when it is not held. */
store_bytes_t *store_cache_find(store_cache_t *self, const char *hash);

/* Keeps a copy of a store: in its own slot if it is held already, else in an empty one, else in
 * the first slot no render thread is decoding (the first such slot, not the least recently
 * used one). *dropped is the hash of the store it replaced, "" for none. -1 when every slot is
 * being decoded or there is no memory: nothing changed. */
int store_cache_put(store_cache_t *self, const char *hash, const uint8_t *data, size_t size,
                    char dropped[PROTO_HASH_HEX + 1]);

/* Marks a held store as being decoded (NULL when it is not held), until store_cache_release,
 * which also stamps it as used. */
store_bytes_t *store_cache_hold(store_cache_t *self, const char *hash);
void store_cache_release(store_cache_t *self, store_bytes_t *sb);

/* Frees every store. */
void store_cache_clear(store_cache_t *self);

#endif
