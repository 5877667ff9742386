#include "store_cache.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

store_bytes_t *store_cache_find(store_cache_t *self, const char *hash)
{
    for (int i = 0; i < STORE_CACHE_SLOTS; i++)
        if (self->slots[i].hash[0] && !strcmp(self->slots[i].hash, hash))
            return &self->slots[i];
    return NULL;
}

int store_cache_put(store_cache_t *self, const char *hash, const uint8_t *data, size_t size,
                    char dropped[PROTO_HASH_HEX + 1])
{
    dropped[0] = 0;
    store_bytes_t *slot = store_cache_find(self, hash);
    for (int i = 0; i < STORE_CACHE_SLOTS && !slot; i++)
        if (!self->slots[i].hash[0])
            slot = &self->slots[i];
    for (int i = 0; i < STORE_CACHE_SLOTS && !slot; i++) {
        store_bytes_t *c = &self->slots[i];
        if (!c->users && (!slot || c->stamp < slot->stamp))
            slot = c;
    }
    uint8_t *copy = slot ? malloc(size ? size : 1) : NULL;
    if (!copy)
        return -1;
    if (slot->hash[0] && strcmp(slot->hash, hash) != 0)
        snprintf(dropped, PROTO_HASH_HEX + 1, "%s", slot->hash);
    free(slot->data);
    memcpy(copy, data, size);
    slot->data = copy;
    slot->size = size;
    slot->stamp = ++self->clock;
    snprintf(slot->hash, sizeof slot->hash, "%s", hash);
    return 0;
}

store_bytes_t *store_cache_hold(store_cache_t *self, const char *hash)
{
    store_bytes_t *sb = store_cache_find(self, hash);
    if (sb)
        sb->users++;
    return sb;
}

void store_cache_release(store_cache_t *self, store_bytes_t *sb)
{
    sb->users--;
    sb->stamp = ++self->clock;
}

void store_cache_clear(store_cache_t *self)
{
    for (int i = 0; i < STORE_CACHE_SLOTS; i++)
        free(self->slots[i].data);
    memset(self, 0, sizeof *self);
}
