#include "rng.h"

/* Philox constants from Salmon et al. 2011, §3.3: the round multipliers, and the Weyl
 * increments of the key schedule (golden ratio and sqrt(3) - 1 as 32-bit fractions). */
enum {
    PHILOX_M0 = 0xD2511F53u,
    PHILOX_M1 = 0xCD9E8D57u,
    PHILOX_W0 = 0x9E3779B9u,
    PHILOX_W1 = 0xBB67AE85u,
};

/* One Philox4x32 round (Salmon et al. 2011, §3.3): the two products' high halves are xored
 * with the other words and the round key, the low halves pass through, and the words are
 * permuted so that every input word reaches every output word within a few rounds. */
static inline void philox_round(uint32_t x[4], uint32_t k0, uint32_t k1)
{
    uint64_t p0 = (uint64_t)PHILOX_M0 * x[0];
    uint64_t p1 = (uint64_t)PHILOX_M1 * x[2];
    uint32_t y0 = (uint32_t)(p1 >> 32) ^ x[1] ^ k0;
    uint32_t y1 = (uint32_t)p1;
    uint32_t y2 = (uint32_t)(p0 >> 32) ^ x[3] ^ k1;
    uint32_t y3 = (uint32_t)p0;
    x[0] = y0;
    x[1] = y1;
    x[2] = y2;
    x[3] = y3;
}

void rng_philox4x32_r(const uint32_t ctr[4], const uint32_t key[2], unsigned rounds,
                      uint32_t out[4])
{
    uint32_t x[4] = {ctr[0], ctr[1], ctr[2], ctr[3]};
    uint32_t k0 = key[0], k1 = key[1];
    for (unsigned r = 0; r < rounds; r++) {
        if (r > 0) { /* the key schedule bumps the key between rounds, not before the first */
            k0 += PHILOX_W0;
            k1 += PHILOX_W1;
        }
        philox_round(x, k0, k1);
    }
    out[0] = x[0];
    out[1] = x[1];
    out[2] = x[2];
    out[3] = x[3];
}

/* Counter layout: one cipher call yields 128 bits = two 53-bit doubles, so dimensions are
 * taken in pairs: ctr = (dim / 2, sample, index low, index high), key = seed. Dimension dim
 * uses output words 2(dim mod 2) and 2(dim mod 2) + 1. Every (seed, index, sample, dim) thus
 * maps to a distinct (key, counter, word pair), and the cipher is a bijection on counters. */
static inline void rng_block(uint64_t seed, uint64_t index, uint32_t sample, uint32_t pair,
                             uint32_t out[4])
{
    const uint32_t ctr[4] = {pair, sample, (uint32_t)index, (uint32_t)(index >> 32)};
    const uint32_t key[2] = {(uint32_t)seed, (uint32_t)(seed >> 32)};
    rng_philox4x32_r(ctr, key, 10, out);
}

/* The top 53 of 64 bits, scaled by 2^-53: exact in a double, largest value 1 - 2^-53. */
static inline double rng_to_unit(uint32_t hi, uint32_t lo)
{
    uint64_t bits = ((uint64_t)hi << 32 | lo) >> 11;
    return (double)bits * 0x1.0p-53;
}

double rng_uniform(uint64_t seed, uint64_t index, uint32_t sample, uint32_t dim)
{
    uint32_t w[4];
    rng_block(seed, index, sample, dim >> 1, w);
    unsigned j = 2 * (dim & 1u);
    return rng_to_unit(w[j], w[j + 1]);
}

void rng_uniform4(uint64_t seed, uint64_t index, uint32_t sample, uint32_t dim, double out[4])
{
    /* dims dim..dim+3 span blocks dim/2 .. dim/2 + 2 (three only when dim is odd); words are
     * read as if the blocks were laid end to end, starting at word 2(dim mod 2). */
    uint32_t w[12];
    uint32_t pair = dim >> 1;
    unsigned blocks = (dim & 1u) ? 3 : 2;
    for (unsigned b = 0; b < blocks; b++)
        rng_block(seed, index, sample, (pair + b) & 0x7FFFFFFFu, w + 4 * b);
    const uint32_t *v = w + 2 * (dim & 1u);
    for (unsigned k = 0; k < 4; k++)
        out[k] = rng_to_unit(v[2 * k], v[2 * k + 1]);
}

double rng_stream_next(rng_stream_t *s)
{
    uint32_t dim = s->next_dim++;
    if (dim & 1u) {
        if (s->has_spare) {
            s->has_spare = 0;
            return s->spare;
        }
        return rng_uniform(s->seed, s->index, s->sample, dim);
    }
    uint32_t w[4];
    rng_block(s->seed, s->index, s->sample, dim >> 1, w);
    s->spare = rng_to_unit(w[2], w[3]);
    s->has_spare = 1;
    return rng_to_unit(w[0], w[1]);
}
