/* sampler: the camera samples' uniform numbers, as pbrt-v4's samplers make them
 * (`Sampler "zsobol"` and the others its files name). A value is a pure function of the job's
 * sampler settings (kind, seed, spp, full film size), the pixel, the sample index and the
 * dimension: never of the thread, tile, pass or the order of draws, so a farm's image is the
 * same bits whatever splits the work. A dimension is addressed directly (a render gives each
 * decision of a path a fixed dimension: docs/rendering.md, "Sampler"); a 2D draw takes
 * dimensions d and d + 1 and is a (0,2)-net over the pixel's samples for the Sobol kinds. */
#ifndef PRISMFARM_SAMPLER_H
#define PRISMFARM_SAMPLER_H

#include <stddef.h>
#include <stdint.h>

typedef enum sampler_kind {
    SAMPLER_ZSOBOL,      /* Morton-ordered, Owen-scrambled Sobol (Ahmed and Wonka 2020) */
    SAMPLER_PADDEDSOBOL, /* per dimension an Owen-scrambled (0,2)-sequence over the samples */
    SAMPLER_HALTON,      /* per pixel Owen-scrambled radical inverses, each dimension its
                          * prime (2D draws: two primes); the pixel position too, drawn anew
                          * per seed (SAMPLER_PIXEL_DIMS) */
    SAMPLER_STRATIFIED,  /* per dimension permuted jittered strata */
    SAMPLER_INDEPENDENT, /* Philox, every number independent */
    SAMPLER_SOBOL,       /* zsobol's numbers, the pixel position's independent of the seed */
} sampler_kind_t;

/* Dimensions 0 and 1 are the position in the pixel (a render's first 2D draw). pbrt-v4's
 * "halton" and "sobol" samplers do not randomise them (HaltonSampler::GetPixel2D and
 * SobolSampler::GetPixel2D take the unscrambled sequence): the seed changes every other
 * dimension but not where a pixel's samples lie. SAMPLER_SOBOL does the same: its pixel
 * dimensions are scrambled per pixel by a fixed key instead of the seed, so a pixel's
 * antialiasing error is the same for every seed (a fixed pattern that the spread between seeds
 * does not show, as with pbrt-v4's). SAMPLER_HALTON draws them anew per seed, as the other
 * kinds do: on killeroo-simple at 48 x 48 and 16 spp (test_cli_corpus) a fixed pattern put
 * the lamp's 9 pixels 4 % low (pbrt-v4's own pattern, one Halton sequence over the film, 3 %
 * high), an error that the test's estimate, from the spread between two seeds, cannot see
 * once the lamp's colour is exact (render.c's direct lanes); and that pattern shifted per seed
 * as one whole moved every pixel's error together (veach-mis's smallest lamp: 27 times the
 * variance of a scramble per pixel). */
#define SAMPLER_PIXEL_DIMS 2u

/* The kind that pbrt-v4's sampler name (as in `Sampler "name"`) gets here; NULL or "" is
 * zsobol, pbrt-v4's default. Returns 0, or -1 for an unknown name. When the name has no
 * implementation of its own and is mapped to the nearest kind, *mapped_why (when not NULL) is
 * set to a sentence saying so (static text), else to NULL. */
int sampler_kind_parse(const char *name, sampler_kind_t *kind, const char **mapped_why);

/* The kind's pbrt-v4 name. */
const char *sampler_kind_name(sampler_kind_t kind);

/* A job's fixed sampler settings. log2_block is the power of two >= spp that the sample
 * index's bits are based on: nothing extends a job's spp afterwards, and a sample index past
 * it (never in a render) still gets well-defined numbers, from another scramble. */
typedef struct sampler_setup {
    sampler_kind_t kind;
    uint64_t seed;
    uint32_t spp;
    int log2_block;   /* ceil(log2 spp) */
    int base4_digits; /* zsobol: base-4 digits of a Morton index and sample index */
} sampler_setup_t;

/* The setup for a film of full_w x full_h pixels (a crop's full film) and spp samples. */
sampler_setup_t sampler_setup_make(sampler_kind_t kind, uint64_t seed, uint32_t spp, int full_w,
                                   int full_h);

/* What zsobol's numbers of one pixel share between its samples (the permuted digits of the
 * pixel's Morton code, per dimension), kept by a caller that renders a pixel's samples one
 * after another (one per thread): a pure function of (setup, pixel, dimension), so the numbers
 * are the same bits with or without it. Zero-initialise it; about 3 kB. */
#define SAMPLER_CACHE_DIMS 256
typedef struct sampler_cache {
    const sampler_setup_t *setup;
    uint64_t pixel;
    uint32_t gen; /* entries with stamp == gen are this pixel's; 0: none */
    uint32_t stamp[SAMPLER_CACHE_DIMS];
    uint64_t high[SAMPLER_CACHE_DIMS];
} sampler_cache_t;

/* One camera sample's numbers: a small value, copied freely. dim is the cursor of
 * sampler_next_1d / sampler_next_2d; sampler_1d / sampler_2d read any dimension. */
typedef struct sampler {
    const sampler_setup_t *setup;
    sampler_cache_t *cache; /* NULL: none */
    uint64_t pixel;         /* y * full width + x */
    uint64_t morton; /* zsobol: the Morton code of (x, y) shifted over the sample bits, | s */
    uint64_t epoch;  /* the sample index's bits above log2_block (0 in every render) */
    uint32_t sample;
    uint32_t dim;
} sampler_t;

/* The sample of index s of pixel (x, y) of the full film; *setup must outlive it. */
sampler_t sampler_start(const sampler_setup_t *setup, int x, int y, int full_w, uint32_t s);

/* Lets s keep per-pixel work in cache (sampler_cache_t), which then belongs to s's pixel. A
 * cache serves samples of one setup object while it lives (it is matched by address). */
void sampler_use_cache(sampler_t *s, sampler_cache_t *cache);

/* Dimension dim of the sample, in [0, 1). */
double sampler_1d(const sampler_t *s, uint32_t dim);

/* Dimensions dim and dim + 1 as one 2D point, in [0, 1)^2. */
void sampler_2d(const sampler_t *s, uint32_t dim, double out[2]);

/* The cursor's next one or two dimensions. */
static inline double sampler_next_1d(sampler_t *s)
{
    return sampler_1d(s, s->dim++);
}
static inline void sampler_next_2d(sampler_t *s, double out[2])
{
    sampler_2d(s, s->dim, out);
    s->dim += 2;
}

/* The k-th of K - 1 further positions in the pixel (k = 1 .. K - 1) for sample s, whose own
 * position (dimensions 0 and 1) is u0: a render that estimates part of a sample's light from K
 * positions instead of one (render.c's lamp probes) takes them from here. Each is uniform
 * over [0, 1)^2 on its own, as u0 is, so any average of a function over the K positions is an
 * unbiased estimate of its mean. Under "halton" and "paddedsobol" (K a power of two) they are
 * the points of indices i XOR k 2^log2_block of the pixel's own scrambled (0,2)-sequence, i its
 * sample's index there: a pixel's spp x K positions are then one (0,2)-net, as if it had K
 * times the samples. The other kinds shift u0 by the rank-1 lattice (k / K, frac(k g)), g the
 * golden ratio's fraction (a Cranley-Patterson rotation of the sample's own point). */
void sampler_pixel_extra(const sampler_t *s, uint32_t k, uint32_t K, const double u0[2],
                         double out[2]);

/* A low-discrepancy sequence over one long index (a photon's): dimension dim < LOWDISC_PRIMES
 * is the Owen-scrambled radical inverse of the index in the dim-th prime base (a scrambled
 * Halton sequence, whose dimensions are jointly uniform over any long run of indices), past
 * that Philox; a pure function of (seed, index, dim), so any batches give the same numbers. */
double sampler_index_1d(uint64_t seed, uint64_t index, uint32_t dim);

#endif
