#include "lowdisc.h"

/* The finaliser of SplitMix64 (Steele, Lea and Flood 2014) over a + a multiple of b: every
 * input bit reaches every output bit. */
uint64_t lowdisc_hash(uint64_t a, uint64_t b)
{
    uint64_t z = a + 0x9E3779B97F4A7C15ull * (b + 1);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

uint32_t lowdisc_permute(uint32_t i, uint32_t n, uint64_t seed)
{
    if (n <= 1)
        return 0;
    uint32_t mask = n - 1;
    mask |= mask >> 1;
    mask |= mask >> 2;
    mask |= mask >> 4;
    mask |= mask >> 8;
    mask |= mask >> 16;
    int bits = 0;
    while (bits < 32 && (mask >> bits))
        bits++;
    const int shift = bits > 1 ? (bits + 1) / 2 : 1;
    /* Rounds of an odd multiplier and an offset (bijections mod 2^bits), each followed by
     * x ^= x >> shift (invertible too, and it carries high bits into low ones, which the
     * affine maps alone never do); the walk ends because the map is a bijection of the
     * power-of-two range that contains [0, n). */
    uint32_t x = i;
    do {
        for (uint64_t r = 0; r < 3; r++) {
            uint64_t h = lowdisc_hash(seed, r);
            x = (x * ((uint32_t)(h >> 32) | 1u) + (uint32_t)h) & mask;
            x ^= x >> shift;
        }
    } while (x >= n);
    return x;
}

double lowdisc_halton(uint64_t index, uint32_t b, uint64_t seed)
{
    /* Indices past 2^32 take another scramble (their digits there lie below the 2^-32 that
     * the strata below resolve). */
    uint64_t h = lowdisc_hash(seed, index >> 32);
    uint32_t i = (uint32_t)index;
    if (b == 2) {
        /* Base 2: the radical inverse is the reversed bits, and nested scrambling is
         * lowdisc_owen; the bits below 2^-32 are uniform. */
        uint32_t v = lowdisc_owen(lowdisc_reverse(i), (uint32_t)h);
        double r = ((double)v + (double)(lowdisc_hash(h, i) >> 11) * 0x1p-53) * 0x1p-32;
        return r < 1.0 ? r : 0x1.fffffffffffffp-1;
    }
    const double inv_b = 1.0 / b;
    double v = 0.0, scale = inv_b;
    /* Digit by digit down to 2^-32: the index's digits, then its zeros, each through its
     * affine map; h carries the digits so far (one multiply and shift per digit). */
    while (i) {
        uint32_t d = i % b;
        i /= b;
        uint32_t m = 1 + (uint32_t)(((h >> 32) * (b - 1)) >> 32);
        uint32_t c = (uint32_t)(((h & 0xFFFFFFFFu) * b) >> 32);
        v += (double)((m * d + c) % b) * scale;
        scale *= inv_b;
        h = (h ^ (d + 1)) * 0x9E3779B97F4A7C15ull;
        h ^= h >> 32;
    }
    /* The index's zeros: digit 0 goes to c (the same arithmetic, without the divisions). */
    while (scale > 0x1p-32) {
        v += (double)(uint32_t)(((h & 0xFFFFFFFFu) * b) >> 32) * scale;
        scale *= inv_b;
        h = (h ^ 1u) * 0x9E3779B97F4A7C15ull;
        h ^= h >> 32;
    }
    /* Below that, the remaining digits are uniform: one number over the last interval. */
    v += (double)(lowdisc_hash(h, 0x7A11u) >> 11) * 0x1p-53 * scale * b;
    return v < 1.0 ? v : 0x1.fffffffffffffp-1;
}

static const uint16_t PRIMES[LOWDISC_PRIMES] = {
    2,   3,   5,   7,   11,  13,  17,  19,  23,  29,  31,  37,  41,  43,  47,  53,  59,  61,  67,
    71,  73,  79,  83,  89,  97,  101, 103, 107, 109, 113, 127, 131, 137, 139, 149, 151, 157, 163,
    167, 173, 179, 181, 191, 193, 197, 199, 211, 223, 227, 229, 233, 239, 241, 251, 257, 263, 269,
    271, 277, 281, 283, 293, 307, 311, 313, 317, 331, 337, 347, 349, 353, 359, 367, 373, 379, 383,
    389, 397, 401, 409, 419, 421, 431, 433, 439, 443, 449, 457, 461, 463, 467, 479, 487, 491, 499,
    503, 509, 521, 523, 541, 547, 557, 563, 569, 571, 577, 587, 593, 599, 601, 607, 613, 617, 619,
    631, 641, 643, 647, 653, 659, 661, 673, 677, 683, 691, 701, 709, 719};

uint32_t lowdisc_prime(int i)
{
    return PRIMES[i];
}
