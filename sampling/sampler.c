#include "sampler.h"

#include "lowdisc.h"
#include "rng.h"

#include <math.h>
#include <string.h>

static const struct {
    const char *name;
    sampler_kind_t kind;
    const char *why; /* NULL: implemented as the name says */
} NAMES[] = {
    {"zsobol", SAMPLER_ZSOBOL, NULL},
    {"paddedsobol", SAMPLER_PADDEDSOBOL, NULL},
    {"halton", SAMPLER_HALTON, NULL},
    {"stratified", SAMPLER_STRATIFIED, NULL},
    {"independent", SAMPLER_INDEPENDENT, NULL},
    {"sobol", SAMPLER_SOBOL,
     "Sampler \"sobol\" (one Sobol sequence over the whole image) is rendered as \"zsobol\": "
     "the same Owen-scrambled Sobol points, each pixel's taken in Morton order (the position "
     "in the pixel, as pbrt-v4's, independent of the seed)"},
    {"pmj02bn", SAMPLER_PADDEDSOBOL,
     "Sampler \"pmj02bn\" is rendered as \"paddedsobol\": each pair of dimensions is a (0,2) "
     "net over the pixel's samples as with pmj02bn, without its blue-noise selection"},
};

int sampler_kind_parse(const char *name, sampler_kind_t *kind, const char **mapped_why)
{
    if (mapped_why)
        *mapped_why = NULL;
    if (!name || !*name)
        name = "zsobol";
    for (size_t i = 0; i < sizeof NAMES / sizeof NAMES[0]; i++)
        if (!strcmp(name, NAMES[i].name)) {
            *kind = NAMES[i].kind;
            if (mapped_why)
                *mapped_why = NAMES[i].why;
            return 0;
        }
    return -1;
}

const char *sampler_kind_name(sampler_kind_t kind)
{
    for (size_t i = 0; i < sizeof NAMES / sizeof NAMES[0]; i++)
        if (NAMES[i].kind == kind)
            return NAMES[i].name;
    return "?";
}

static int ceil_log2(uint64_t n)
{
    int k = 0;
    while ((1ull << k) < n)
        k++;
    return k;
}

sampler_setup_t sampler_setup_make(sampler_kind_t kind, uint64_t seed, uint32_t spp, int full_w,
                                   int full_h)
{
    sampler_setup_t st = {.kind = kind, .seed = seed, .spp = spp > 0 ? spp : 1};
    st.log2_block = ceil_log2(st.spp);
    int res = full_w > full_h ? full_w : full_h;
    st.base4_digits = ceil_log2(res > 0 ? (uint64_t)res : 1) + (st.log2_block + 1) / 2;
    return st;
}

/* Interleaves the bits of x (even positions) and y (odd). */
static uint64_t morton2(uint32_t x, uint32_t y)
{
    uint64_t r = 0;
    for (int b = 0; b < 32; b++)
        r |= (uint64_t)((x >> b) & 1) << (2 * b) | (uint64_t)((y >> b) & 1) << (2 * b + 1);
    return r;
}

sampler_t sampler_start(const sampler_setup_t *setup, int x, int y, int full_w, uint32_t s)
{
    const int L = setup->log2_block;
    const uint32_t low = L >= 32 ? s : s & ((1u << L) - 1);
    sampler_t r = {.setup = setup,
                   .pixel = (uint64_t)y * (uint64_t)full_w + (uint64_t)x,
                   .epoch = L >= 32 ? 0 : s >> L,
                   .sample = s};
    if (setup->kind == SAMPLER_ZSOBOL || setup->kind == SAMPLER_SOBOL)
        r.morton = (morton2((uint32_t)x, (uint32_t)y) << L) | low;
    return r;
}

void sampler_use_cache(sampler_t *s, sampler_cache_t *cache)
{
    if (cache->gen == 0 || cache->setup != s->setup || cache->pixel != s->pixel) {
        if (++cache->gen == 0) { /* wrapped: no stamp may match an old generation */
            memset(cache->stamp, 0, sizeof cache->stamp);
            cache->gen = 1;
        }
        cache->setup = s->setup;
        cache->pixel = s->pixel;
    }
    s->cache = cache;
}

/* The 24 orderings of {0, 1, 2, 3}, which permute one base-4 digit. */
static const uint8_t PERM4[24][4] = {
    {0, 1, 2, 3}, {0, 1, 3, 2}, {0, 2, 1, 3}, {0, 2, 3, 1}, {0, 3, 1, 2}, {0, 3, 2, 1},
    {1, 0, 2, 3}, {1, 0, 3, 2}, {1, 2, 0, 3}, {1, 2, 3, 0}, {1, 3, 0, 2}, {1, 3, 2, 0},
    {2, 0, 1, 3}, {2, 0, 3, 1}, {2, 1, 0, 3}, {2, 1, 3, 0}, {2, 3, 0, 1}, {2, 3, 1, 0},
    {3, 0, 1, 2}, {3, 0, 2, 1}, {3, 1, 0, 2}, {3, 1, 2, 0}, {3, 2, 0, 1}, {3, 2, 1, 0}};

/* A hash of a digit's higher digits under a dimension's salt (a full 64-bit salt from
 * lowdisc_hash): two multiply-xorshift rounds, enough for the choice of one of 24 orderings. */
static inline uint64_t digit_hash(uint64_t higher, uint64_t salt)
{
    uint64_t x = (higher ^ salt) * 0x9E3779B97F4A7C15ull;
    x ^= x >> 31;
    x *= 0xBF58476D1CE4E5B9ull;
    return x ^ (x >> 29);
}

/* ZSobol's index for one dimension (Ahmed and Wonka 2020; pbrt-v4 sec. 8.7.7): the Morton
 * index (pixel code, then the sample index) is read as base-4 digits from the top, and each
 * digit is permuted by one of the 24 orderings, chosen by a hash of the dimension and of the
 * digits above it. Consecutive aligned blocks of 4^k indices stay consecutive blocks, so a
 * pixel's samples are one aligned block (a (0,2)-net of the Sobol points), and so are the
 * samples of each 2x2, 4x4, ... group of pixels: neighbours fill each other's gaps, and the
 * error is spread like blue noise. The random ordering per dimension decorrelates the
 * dimensions. With an odd log2 block the lowest digit is binary and flipped by a hash. */
static uint64_t zsobol_digits(const sampler_t *s, uint64_t salt, int from, int to)
{
    const int odd = s->setup->log2_block & 1;
    uint64_t out = 0;
    /* The digits' hashes do not depend on each other, so the loop runs at the multipliers'
     * throughput rather than their latency. */
    for (int i = from - 1; i >= to; i--) {
        const int shift = 2 * i - odd;
        const unsigned digit = (unsigned)(s->morton >> shift) & 3u;
        const uint64_t higher = shift + 2 < 64 ? s->morton >> (shift + 2) : 0;
        out |= (uint64_t)PERM4[(digit_hash(higher, salt) >> 40) % 24u][digit] << shift;
    }
    return out;
}

/* The digits i >= (log2_block + 1) / 2 hold only the pixel's Morton code (their bits and the
 * bits above them are at or above log2_block), so a pixel's samples share them: from the
 * cache when there is one. */
static uint64_t zsobol_index(const sampler_t *s, uint32_t dim, uint64_t salt)
{
    const sampler_setup_t *st = s->setup;
    const int odd = st->log2_block & 1;
    const int split = (st->log2_block + 1) / 2;
    uint64_t out;
    sampler_cache_t *c = s->cache;
    if (c && dim < SAMPLER_CACHE_DIMS && s->epoch == 0) {
        if (c->stamp[dim] != c->gen) {
            c->high[dim] = zsobol_digits(s, salt, st->base4_digits, split);
            c->stamp[dim] = c->gen;
        }
        out = c->high[dim];
    } else {
        out = zsobol_digits(s, salt, st->base4_digits, split);
    }
    out |= zsobol_digits(s, salt, split, odd);
    if (odd)
        out |= (s->morton & 1) ^ ((digit_hash(s->morton >> 1, salt) >> 40) & 1);
    return out;
}

/* The key that takes the seed's place in the pixel dimensions of SAMPLER_SOBOL, which keeps
 * them fixed (SAMPLER_PIXEL_DIMS). */
static const uint64_t PIXEL_DIMS_KEY = 0x5DEECE66Dull;

/* The salt of one dimension of one sample: the job's seed (or PIXEL_DIMS_KEY), the dimension
 * and the epoch (sample bits above the block), and for the per-pixel kinds the pixel. */
static uint64_t salt_of(const sampler_t *s, uint32_t dim, int per_pixel)
{
    const sampler_kind_t kind = s->setup->kind;
    const int fixed = dim < SAMPLER_PIXEL_DIMS && kind == SAMPLER_SOBOL;
    uint64_t h = lowdisc_hash(fixed ? PIXEL_DIMS_KEY : s->setup->seed, dim);
    if (per_pixel)
        h = lowdisc_hash(h, s->pixel);
    if (s->epoch)
        h = lowdisc_hash(h, s->epoch);
    return h;
}

/* The sample's index into the (0,2)-sequence for dimension dim and the two 32-bit Owen seeds
 * of its points, for the Sobol kinds. */
static uint32_t sobol_index(const sampler_t *s, uint32_t dim, uint32_t seeds[2])
{
    const sampler_setup_t *st = s->setup;
    if (st->kind == SAMPLER_ZSOBOL || st->kind == SAMPLER_SOBOL) {
        const uint64_t salt = salt_of(s, dim, 0);
        const uint64_t h = lowdisc_hash(salt, 1);
        seeds[0] = (uint32_t)h;
        seeds[1] = (uint32_t)(h >> 32);
        return (uint32_t)zsobol_index(s, dim, salt);
    }
    /* paddedsobol: the sample index shuffled by an Owen scramble of its bits (Burley 2020,
     * sec. 4), which keeps the block of the pixel's 2^log2_block samples and reorders it, so
     * each dimension pair is paired with the others at random. */
    const uint64_t salt = salt_of(s, dim, 1);
    const uint64_t h = lowdisc_hash(salt, 1);
    seeds[0] = (uint32_t)h;
    seeds[1] = (uint32_t)(h >> 32);
    const uint32_t low =
        st->log2_block >= 32 ? s->sample : s->sample & ((1u << st->log2_block) - 1);
    return lowdisc_owen(low, (uint32_t)(salt >> 32));
}

/* A jittered stratum of n (permuted per pixel and dimension), or an independent number past
 * the strata. */
static double stratum(const sampler_t *s, uint32_t dim, uint32_t n, uint32_t k_index, uint64_t salt)
{
    const double j = rng_uniform(s->setup->seed, s->pixel, s->sample, dim);
    return ((double)lowdisc_permute(k_index, n, salt) + j) / n;
}

double sampler_1d(const sampler_t *s, uint32_t dim)
{
    const sampler_setup_t *st = s->setup;
    switch (st->kind) {
    case SAMPLER_ZSOBOL:
    case SAMPLER_SOBOL:
    case SAMPLER_PADDEDSOBOL: {
        uint32_t seeds[2];
        const uint32_t i = sobol_index(s, dim, seeds);
        return lowdisc_unit(lowdisc_owen_sobol(i, 0, seeds[0]));
    }
    case SAMPLER_HALTON:
        if (dim < SAMPLER_PIXEL_DIMS) {
            double u[2];
            sampler_2d(s, 0, u);
            return u[dim];
        }
        if (dim < LOWDISC_PRIMES)
            return lowdisc_halton(s->sample, lowdisc_prime((int)dim), salt_of(s, dim, 1));
        break;
    case SAMPLER_STRATIFIED:
        if (s->sample < st->spp)
            return stratum(s, dim, st->spp, s->sample, salt_of(s, dim, 1));
        break;
    case SAMPLER_INDEPENDENT:
        break;
    }
    return rng_uniform(st->seed, s->pixel, s->sample, dim);
}

/* The stratified kind's 2D grid: nx columns, nx the largest divisor of n at most sqrt(n)
 * (pbrt-v4's xsamples x ysamples; a 4 x 4 grid for 16). */
static uint32_t grid_columns(uint32_t n)
{
    uint32_t nx = 1;
    for (uint32_t d = 1; (uint64_t)d * d <= n; d++)
        if (n % d == 0)
            nx = d;
    return nx;
}

void sampler_2d(const sampler_t *s, uint32_t dim, double out[2])
{
    const sampler_setup_t *st = s->setup;
    switch (st->kind) {
    case SAMPLER_ZSOBOL:
    case SAMPLER_SOBOL:
    case SAMPLER_PADDEDSOBOL: {
        uint32_t seeds[2];
        const uint32_t i = sobol_index(s, dim, seeds);
        out[0] = lowdisc_unit(lowdisc_owen_sobol(i, 0, seeds[0]));
        out[1] = lowdisc_unit(lowdisc_owen_sobol(i, 1, seeds[1]));
        return;
    }
    case SAMPLER_HALTON:
        if (dim == 0) {
            /* The position in the pixel: the Owen-scrambled (0,2)-sequence at the sample
             * index, whose first 2^m points are stratified in every 2^a x 2^(m-a) grid, where
             * bases 2 and 3 stratify only the 2^a x 3^b grids below the sample count. */
            const uint64_t h = lowdisc_hash(salt_of(s, 0, 1), 1);
            const uint32_t i = (uint32_t)s->sample;
            out[0] = lowdisc_unit(lowdisc_owen_sobol(i, 0, (uint32_t)h));
            out[1] = lowdisc_unit(lowdisc_owen_sobol(i, 1, (uint32_t)(h >> 32)));
            return;
        }
        if (dim < SAMPLER_PIXEL_DIMS) {
            out[0] = sampler_1d(s, dim);
            out[1] = sampler_1d(s, dim + 1);
            return;
        }
        if (dim + 1 < LOWDISC_PRIMES) {
            out[0] = lowdisc_halton(s->sample, lowdisc_prime((int)dim), salt_of(s, dim, 1));
            out[1] = lowdisc_halton(s->sample, lowdisc_prime((int)dim + 1), salt_of(s, dim + 1, 1));
            return;
        }
        break;
    case SAMPLER_STRATIFIED: {
        const uint32_t nx = grid_columns(st->spp);
        if (s->sample < st->spp && nx > 1) {
            /* One permutation for the cell, so every cell of the grid gets one sample. */
            const uint32_t ny = st->spp / nx;
            const uint32_t k = lowdisc_permute(s->sample, st->spp, salt_of(s, dim, 1));
            out[0] = ((double)(k % nx) + rng_uniform(st->seed, s->pixel, s->sample, dim)) / nx;
            out[1] = ((double)(k / nx) + rng_uniform(st->seed, s->pixel, s->sample, dim + 1)) / ny;
            return;
        }
        /* A prime count: each axis in its own permuted strata (a Latin hypercube). */
        out[0] = sampler_1d(s, dim);
        out[1] = sampler_1d(s, dim + 1);
        return;
    }
    case SAMPLER_INDEPENDENT:
        break;
    }
    out[0] = rng_uniform(st->seed, s->pixel, s->sample, dim);
    out[1] = rng_uniform(st->seed, s->pixel, s->sample, dim + 1);
}

void sampler_pixel_extra(const sampler_t *s, uint32_t k, uint32_t K, const double u0[2],
                         double out[2])
{
    const sampler_setup_t *st = s->setup;
    const int L = st->log2_block;
    const int pow2 = K > 0 && (K & (K - 1)) == 0;
    if (pow2 && s->epoch == 0 && (uint64_t)K << L <= (1ull << 32) &&
        (st->kind == SAMPLER_HALTON || st->kind == SAMPLER_PADDEDSOBOL)) {
        /* The same scramble as dimensions 0 and 1 (sampler_2d), at an index outside the
         * pixel's block: the scrambled points of an aligned block of K 2^L indices form a
         * (0,2)-net. */
        uint32_t i, seed0, seed1;
        if (st->kind == SAMPLER_HALTON) {
            const uint64_t h = lowdisc_hash(salt_of(s, 0, 1), 1);
            seed0 = (uint32_t)h;
            seed1 = (uint32_t)(h >> 32);
            i = s->sample;
        } else {
            uint32_t seeds[2];
            i = sobol_index(s, 0, seeds);
            seed0 = seeds[0];
            seed1 = seeds[1];
        }
        /* XOR, not +: paddedsobol's indices carry constant bits above the block (the Owen
         * shuffle's), and the K blocks must be one aligned block of K 2^L indices. */
        i ^= k << L;
        out[0] = lowdisc_unit(lowdisc_owen_sobol(i, 0, seed0));
        out[1] = lowdisc_unit(lowdisc_owen_sobol(i, 1, seed1));
        return;
    }
    const double fk = (double)k;
    double x = u0[0] + fk / (double)(K > 0 ? K : 1), y = u0[1] + fk * 0.61803398874989485;
    x -= floor(x);
    y -= floor(y);
    out[0] = x < 1.0 ? x : 0x1.fffffffffffffp-1;
    out[1] = y < 1.0 ? y : 0x1.fffffffffffffp-1;
}

double sampler_index_1d(uint64_t seed, uint64_t index, uint32_t dim)
{
    if (dim < LOWDISC_PRIMES)
        return lowdisc_halton(index, lowdisc_prime((int)dim), lowdisc_hash(seed, dim));
    return rng_uniform(seed, index, 0, dim);
}
