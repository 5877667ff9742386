/* rng: counter-based random numbers (Philox4x32-10, Salmon et al. 2011, "Parallel random
 * numbers: as easy as 1, 2, 3"). A number is a pure function of (job seed, pixel or photon
 * index, sample index, dimension), so results never depend on thread, worker or call order. */
#ifndef PRISMFARM_RNG_H
#define PRISMFARM_RNG_H

#include <stdint.h>

/* The raw block cipher: encrypts the 128-bit counter ctr under the 64-bit key with `rounds`
 * Philox rounds into out. The generator uses 10 rounds; other counts exist only so tests can
 * check the published 7-round known answers as well. */
void rng_philox4x32_r(const uint32_t ctr[4], const uint32_t key[2], unsigned rounds,
                      uint32_t out[4]);

/* A uniform double in [0, 1) with 53 random bits (a multiple of 2^-53, never 1.0), determined
 * only by (seed, index, sample, dim). */
double rng_uniform(uint64_t seed, uint64_t index, uint32_t sample, uint32_t dim);

/* out[k] = rng_uniform(seed, index, sample, dim + k) for k = 0..3 (dim + k wraps mod 2^32),
 * bit for bit, at the cost of two or three cipher calls instead of four. */
void rng_uniform4(uint64_t seed, uint64_t index, uint32_t sample, uint32_t dim, double out[4]);

/* A value-type cursor for code that just wants "the next number" of one sample; copying it
 * copies the position. next_dim wraps after 2^32 draws (no path uses that many). One cipher
 * call yields dimensions 2k and 2k + 1; the stream keeps the second for the next draw, so a
 * stream costs half a cipher call per number and gives exactly rng_uniform's values. */
typedef struct rng_stream {
    uint64_t seed;
    uint64_t index;
    uint32_t sample;
    uint32_t next_dim;
    double spare; /* rng_uniform(..., next_dim) when next_dim is odd and has_spare */
    int has_spare;
} rng_stream_t;

static inline rng_stream_t rng_stream_make(uint64_t seed, uint64_t index, uint32_t sample)
{
    return (rng_stream_t){seed, index, sample, 0, 0.0, 0};
}

/* Returns rng_uniform(s->seed, s->index, s->sample, s->next_dim) and advances next_dim. */
double rng_stream_next(rng_stream_t *s);

#endif
