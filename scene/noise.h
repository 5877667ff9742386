/* noise: Perlin's gradient noise in 3D and the sums of its octaves that pbrt-v4's procedural
 * textures are built from (fbm, wrinkled, windy, marble, dots), with pbrt-v4's semantics
 * (util/noise.cpp): the same permutation (Perlin's 2002 reference table), the same gradient
 * choice and quintic fade, the same octave frequencies (x1.99) and weights (omega^i).
 *
 * Guarantees: noise_perlin is 0 at every lattice point (integer x, y, z), continuous, and
 * bounded by 1.5 in magnitude; every function is finite for finite inputs (coordinates are
 * wrapped modulo 2^30 first, as pbrt-v4 does) and a pure function of its arguments.
 *
 * Octaves: pbrt-v4 derives the octave count from the ray differentials' footprint and fades
 * the last one in; prismfarm's rays carry no differentials, which is pbrt-v4's case of a zero
 * footprint: every one of the octaves is summed, and turbulence adds pbrt-v4's 0.2 omega^octaves
 * for the clamped remainder. */
#ifndef PRISMFARM_NOISE_H
#define PRISMFARM_NOISE_H

#include "vec3.h"

/* Perlin noise at p, in [-1.5, 1.5] (in practice within about [-1, 1]). */
double noise_perlin(vec3_t p);

/* Fractional Brownian motion: sum over i < octaves of omega^i noise(1.99^i p). */
double noise_fbm(vec3_t p, double omega, int octaves);

/* Turbulence: sum over i < octaves of omega^i |noise(1.99^i p)|, plus 0.2 omega^octaves. */
double noise_turbulence(vec3_t p, double omega, int octaves);

#endif
