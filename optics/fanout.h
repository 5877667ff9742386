/* fanout: the thesis's monochrome fan-out at a dispersive interface (Subtil 2006, 5.3).
 * fanout_split turns a polychrome sample into N monochrome samples carrying exactly its
 * energy; fanout_fresnel_scale makes the monochrome transmittances average to the
 * polychrome one (thesis eq. 5.3, see below); fanout_refract gives directions and scaled
 * Fresnel terms for one interface crossing.
 * Nothing returned is ever NaN or Inf, even when every wavelength is totally reflected. */
#ifndef PRISMFARM_FANOUT_H
#define PRISMFARM_FANOUT_H

#include "dispersion.h"
#include "err.h"
#include "vec3.h"

#include <stdbool.h>

/* One monochrome sample: traced at lambda_nm, it carries energy[0] in bucket[0] (its own
 * bucket i) and energy[1] in bucket[1] (the neighbour towards the shift; equal to i with
 * energy[1] = 0 when there is none). */
typedef struct fanout_sample {
    double lambda_nm;
    int bucket[2];
    double energy[2];
} fanout_sample_t;

/* Monochrome sample reconstruction (thesis 5.3.1, fig. 5.1). lambda_nm[0..count-1] are the
 * bucket centres (strictly increasing), energy[] the polychrome sample P_i, shift S in
 * [-0.5, 0.5] (one random number shared by all buckets). Sample i gets
 *   lambda'_i = lambda_i + S * (lambda_{i+-1} - lambda_i)     (neighbour on the side of S)
 *   energy (1 - |S|) P_i in bucket i and |S| P_i in bucket i+-1.
 * So |S| = 0.5 puts lambda'_i half-way to the neighbour, on the bucket boundary, with the
 * energy split equally, as the thesis says; and the two weights are the linear (tent)
 * interpolation weights of lambda'_i between the two centres. (Reading "S times half the
 * distance" literally would reach only the middle half of each bucket, leaving gaps in the
 * spectrum, and would not match the stated equal split at S = 0.5.)
 * End buckets: where there is no neighbour on the side of S (bucket 0 with S < 0, the last
 * with S > 0), lambda'_i still moves by S times the distance to the other neighbour, so it
 * stays inside the end bucket, and all of P_i stays in bucket i: energy is conserved and the
 * whole grid range is covered (the clamped tent, as spectral_grid's TENT splat does). With
 * count == 1 there is no spacing: lambda' = lambda_0 and all energy stays.
 * For every S, sum of all energies = sum P_i up to rounding (each P_i is split as
 * (P_i - |S| P_i) + |S| P_i). Returns -1 for count < 1, centres not finite and strictly
 * increasing, non-finite energies, or S outside [-0.5, 0.5] or NaN. */
int fanout_split(const double *lambda_nm, const double *energy, int count, double shift,
                 fanout_sample_t *out, err_t *err);

/* Fresnel term scaling (thesis 5.3.2, eq. 5.1-5.3). The thesis writes k = T_P / sum t_i so
 * that the monochrome terms "add up to" T_P. Read as a scalar sum that gives every ray about
 * T_P / N: but each monochrome ray carries only its own bucket's energy (fanout_split), so
 * the transmitted energy would be divided by N and glass would go dark in a furnace. The
 * sum that must equal the polychrome filter is the spectral composition of the monochrome
 * filters, t_i at lambda_i, whose total over N samples is N T_P. Hence here
 *   k = T_P / mean(t_i) = N T_P / sum t_i,
 * so mean(k t_i) = T_P, k = 1 for a non-dispersive material (every t_i = T_P), and for a
 * spectrum flat over the buckets R_P sum P_i + sum k t_i P_i = sum P_i exactly.
 * k t_i may exceed 1 near the critical angle, where some wavelengths are reflected and others
 * not: the energy moves between wavelengths, its total is conserved.
 * Writes scaled[i] = T_P * (N t_i / sum t) (finite: N t_i / sum <= N) and returns k. When
 * sum t_i is 0 (every wavelength totally reflected) k = 0 and every scaled[i] = 0: no
 * monochrome light is transmitted. Non-finite t_i or T_P count as 0. k is capped at DBL_MAX
 * when the sum is so small that the division would overflow. t[] must be in [0, 1]; scaled
 * may alias t. */
double fanout_fresnel_scale(const double *t, int count, double t_poly, double *scaled);

/* One monochrome refraction ray. */
typedef struct fanout_ray {
    double lambda_nm;
    double n_incident, n_transmitted; /* n(lambda) on each side, for radiance (n_t/n_i)^2 */
    vec3_t dir;                       /* refracted direction; the mirror direction if tir */
    double transmittance;             /* k * t_i (mean over rays = T_P); 0 if tir */
    bool tir;
} fanout_ray_t;

/* The polychrome split at the same interface, computed with the mean indices (thesis 5.3.2:
 * "the average IOR of the material"): mean of n(lambda) over the wavelengths given. */
typedef struct fanout_poly {
    double n_incident, n_transmitted;
    vec3_t reflect_dir;
    vec3_t refract_dir;                /* zero vector if tir */
    double reflectance, transmittance; /* R_P + T_P = 1 */
    double scale;                      /* k = T_P / mean(t_i), see fanout_fresnel_scale */
    bool tir;
} fanout_poly_t;

/* The fan-out of one crossing of the interface between `outside` (the medium n points into)
 * and `inside`. d is the incident direction (towards the surface), n the surface normal;
 * d.n < 0 means the ray comes from outside. Both are normalised here. For each of the count
 * wavelengths (typically the lambda'_i of fanout_split) it computes n on both sides, Snell's
 * direction, the Fresnel transmittance t_i (cosine form) and TIR, then scales the t_i by
 * k = T_P / mean(t_i) (fanout_fresnel_scale), with T_P the polychrome transmittance at the
 * mean indices, so that R_P + mean(k t_i) = 1. The caller weights ray i by k t_i and the
 * energies of fanout_split; radiance carried along the ray also takes the factor
 * (n_transmitted / n_incident)^2, a camera path, which carries light the other way,
 * (n_incident / n_transmitted)^2 (docs/physics.md §3.4): that is left to the caller.
 * In the degenerate case sum t_i = 0 with T_P > 0 (every wavelength
 * totally reflected but the mean-index ray not, possible only through rounding, since the
 * ratio of mean indices is a weighted mean of the per-wavelength ratios; or grazing
 * incidence) the polychrome ray gets R_P = 1, T_P = 0, so energy is still conserved.
 * Returns -1 for count < 1, NULL arrays, or a zero-length d or n. Both models should have
 * been checked with ior_validate over the wavelengths used. */
int fanout_refract(const ior_model_t *outside, const ior_model_t *inside, vec3_t d, vec3_t n,
                   const double *lambda_nm, int count, fanout_ray_t *rays, fanout_poly_t *poly,
                   err_t *err);

#endif
