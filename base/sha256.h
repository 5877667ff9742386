/* sha256: the SHA-256 hash of FIPS 180-4, for content-addressing scene bundles and photon
 * stores, computed by libsodium (crypto_hash_sha256; already loaded through libzmq's CURVE).
 * Incremental: init, update any number of times with any split of the input, final. The digest
 * depends only on the bytes hashed, never on how they were split. */
#ifndef PRISMFARM_SHA256_H
#define PRISMFARM_SHA256_H

#include <sodium/crypto_hash_sha256.h>
#include <stddef.h>
#include <stdint.h>

#define SHA256_DIGEST_BYTES 32
#define SHA256_HEX_CHARS 64

/* A hash in progress: libsodium's state, a plain value (copy it to fork a computation). */
typedef struct sha256 {
    crypto_hash_sha256_state state;
} sha256_t;

void sha256_init(sha256_t *self);
void sha256_update(sha256_t *self, const void *data, size_t n);
/* Pads, finishes and writes the digest; self must be initialised again before reuse. */
void sha256_final(sha256_t *self, uint8_t digest[SHA256_DIGEST_BYTES]);

/* Lower-case hex of a digest, NUL-terminated (65 bytes). */
void sha256_hex(const uint8_t digest[SHA256_DIGEST_BYTES], char hex[SHA256_HEX_CHARS + 1]);

/* One-shot: the hex digest of data[0..n). */
void sha256_hex_of(const void *data, size_t n, char hex[SHA256_HEX_CHARS + 1]);

#endif
