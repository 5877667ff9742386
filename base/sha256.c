#include "sha256.h"

#include <sodium/utils.h>

/* libsodium's SHA-256 functions need no sodium_init(): they use no random source and no CPU
 * dispatch (crypto_hash_sha256 is portable C in 1.0.18), and they cannot fail. */
void sha256_init(sha256_t *self)
{
    crypto_hash_sha256_init(&self->state);
}

void sha256_update(sha256_t *self, const void *data, size_t n)
{
    if (n > 0)
        crypto_hash_sha256_update(&self->state, data, (unsigned long long)n);
}

void sha256_final(sha256_t *self, uint8_t digest[SHA256_DIGEST_BYTES])
{
    crypto_hash_sha256_final(&self->state, digest);
}

void sha256_hex(const uint8_t digest[SHA256_DIGEST_BYTES], char hex[SHA256_HEX_CHARS + 1])
{
    sodium_bin2hex(hex, SHA256_HEX_CHARS + 1, digest, SHA256_DIGEST_BYTES);
}

void sha256_hex_of(const void *data, size_t n, char hex[SHA256_HEX_CHARS + 1])
{
    sha256_t s;
    uint8_t digest[SHA256_DIGEST_BYTES];
    sha256_init(&s);
    sha256_update(&s, data, n);
    sha256_final(&s, digest);
    sha256_hex(digest, hex);
}
