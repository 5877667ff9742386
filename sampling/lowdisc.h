/* lowdisc: the building blocks of the low-discrepancy samplers (sampler.h): a 64-bit hash,
 * the first two Sobol dimensions (the (0,2)-sequence), Owen scrambling of 32-bit binary
 * fractions by hashing (Laine and Karras 2011; Burley 2020), a hashed permutation of [0, n),
 * and nested-scrambled radical inverses for Halton. Every function is pure: the same
 * arguments give the same bits on every machine. */
#ifndef PRISMFARM_LOWDISC_H
#define PRISMFARM_LOWDISC_H

#include <stdint.h>

/* A well-mixed 64-bit hash of two words (never the identity on either). */
uint64_t lowdisc_hash(uint64_t a, uint64_t b);

/* The 32-bit binary fraction of Sobol dimension dim (0 or 1) at index i: dimension 0 is the
 * van der Corput sequence (the bits of i reversed), dimension 1 has the upper-triangular
 * Pascal matrix mod 2 as generator (primitive polynomial x + 1). Together every aligned block
 * of 2^m indices is a (0, m, 2)-net in base 2 (Sobol 1967; pbrt-v4 sec. 8.7.1). Index bits
 * past 32 do not change the 32-bit value. */
static inline uint32_t lowdisc_sobol(uint32_t i, int dim);

/* Owen scrambling of a 32-bit binary fraction v (Owen 1995): bit k (from the top) is flipped
 * by a hash of the seed and of the bits above it, so a scrambled net is still a net and each
 * point is uniform. As Burley 2020 ("Practical Hash-based Owen Scrambling", JCGT 9(4)): the
 * bits reversed, a Laine-Karras-style permutation in which every output bit depends only on
 * the input bits below it, reversed back. The seed should be well mixed (a hash: Burley
 * hashes it first, as neighbouring seeds scramble the top bits alike). Also used on sample indices:
 * for i < 2^m the result stays inside one aligned block of 2^m values and is a permutation of it (a
 * shuffle). */
static inline uint32_t lowdisc_owen(uint32_t v, uint32_t seed);

/* A permutation of [0, n) chosen by seed: i -> its image (i < n; n >= 1). A hashed bijection
 * on the next power of two, cycle-walked until it lands inside [0, n). */
uint32_t lowdisc_permute(uint32_t i, uint32_t n, uint64_t seed);

/* The radical inverse of index in prime base b, Owen-scrambled (nested): digit k of the
 * fraction goes through a random affine map d -> (m d + c) mod b, m != 0, drawn from a hash of
 * seed and of the digits before it (for distinct digits the images are a uniform pair, the
 * property Owen's variance bound needs), down to 2^-32 (the index's zero digits too, so any
 * b^k indices fill the b^k intervals once each); below, one hashed uniform. Base 2 is exactly
 * lowdisc_owen of the reversed bits. Index bits past 32 choose another scramble. In [0, 1). */
double lowdisc_halton(uint64_t index, uint32_t b, uint64_t seed);

/* The i-th prime (i = 0: 2), for i < LOWDISC_PRIMES. */
#define LOWDISC_PRIMES 128
uint32_t lowdisc_prime(int i);

/* The bits of v in reverse order. */
static inline uint32_t lowdisc_reverse(uint32_t v)
{
    v = __builtin_bswap32(v);
    v = ((v >> 4) & 0x0F0F0F0Fu) | ((v & 0x0F0F0F0Fu) << 4);
    v = ((v >> 2) & 0x33333333u) | ((v & 0x33333333u) << 2);
    return ((v >> 1) & 0x55555555u) | ((v & 0x55555555u) << 1);
}

/* Burley 2020, listing 3 (after Laine and Karras 2011): additions and products by even
 * constants carry information only upward, so output bit k depends on input bits 0..k. */
static inline uint32_t lowdisc_laine_karras(uint32_t x, uint32_t seed)
{
    x += seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

static inline uint32_t lowdisc_owen(uint32_t v, uint32_t seed)
{
    return lowdisc_reverse(lowdisc_laine_karras(lowdisc_reverse(v), seed));
}

/* Sobol dimension 1 with its bits reversed: direction numbers v_1 = 1/2,
 * v_k = v_{k-1} xor v_{k-1}/2 (the recurrence m_k = 2 m_{k-1} xor m_{k-1} of the polynomial
 * x + 1 with m_1 = 1, Joe and Kuo's second dimension: the Pascal matrix mod 2), reversed. */
static inline uint32_t lowdisc_sobol1_reversed(uint32_t i)
{
    uint32_t v = 1u, r = 0;
    for (; i; i >>= 1, v ^= v << 1)
        r ^= v & (0u - (i & 1u));
    return r;
}

static inline uint32_t lowdisc_sobol(uint32_t i, int dim)
{
    return dim == 0 ? lowdisc_reverse(i) : lowdisc_reverse(lowdisc_sobol1_reversed(i));
}

/* lowdisc_owen(lowdisc_sobol(i, dim), seed) without the reversals that cancel. */
static inline uint32_t lowdisc_owen_sobol(uint32_t i, int dim, uint32_t seed)
{
    return lowdisc_reverse(lowdisc_laine_karras(dim == 0 ? i : lowdisc_sobol1_reversed(i), seed));
}

/* A 32-bit fraction as a double in [0, 1). */
static inline double lowdisc_unit(uint32_t v)
{
    return (double)v * 0x1p-32;
}

#endif
