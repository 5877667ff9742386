/* volume: light transport through the participating media of scene/medium.h for the camera
 * pass's spectral lanes -- free-flight sampling (where a path scatters, is absorbed or reaches
 * the next surface) and transmittance along shadow rays.
 *
 * How the lanes share one decision (docs/physics.md, "Media"): every lane of a path follows
 * the same flight, and each lane j is weighted by its own density over the mixture density of
 * the lanes, f_j / sum_k sel_k p_k, sel_k proportional to the lanes' throughputs (the
 * one-sample spectral MIS that pbrt-v4's r_u weights compute, with the balance heuristic).
 * A homogeneous medium is sampled analytically: a lane k chosen by sel, a distance drawn from
 * its exp(-sigma_t,k t), the other lanes weighted by the mixture, so no lane's weight exceeds
 * the path's total throughput over its own share however different the sigma_t. A grid is
 * delta-tracked against a grey majorant (the largest sigma_t over the lanes times the
 * majorant cell's density bound) with the event (absorb, scatter, null) chosen by the mixture
 * of the lanes' probabilities; shadow rays are ratio-tracked against the same majorant
 * (homogeneous media: exp(-sigma_t d) exactly). Guarantees: weights and transmittances are
 * finite and >= 0 for any coefficients (0, 1e150, zero-density regions), every loop is
 * bounded (VOLUME_MAX_COLLISIONS), and the random numbers come from the caller's stream. */
#ifndef PRISMFARM_VOLUME_H
#define PRISMFARM_VOLUME_H

#include "bsdf_types.h"
#include "medium.h"
#include "rng.h"
#include "vec3.h"

#include <stdint.h>

#define VOLUME_MAX_LANES BSDF_MAX_LANES

/* Tentative collisions one flight or one transmittance estimate may visit; past it the flight
 * counts as absorbed (the transmittance as 0). A real scene stays far below: collisions
 * number about the majorant's optical depth along the ray. */
#define VOLUME_MAX_COLLISIONS (1u << 20)

/* Ratio tracking's Russian roulette (pbrt-v4 VolPathIntegrator::SampleLd): once every lane's
 * transmittance is below VOLUME_RR_THRESHOLD, the estimate survives with probability
 * VOLUME_RR_SURVIVE and is divided by it. */
#define VOLUME_RR_THRESHOLD 0.05
#define VOLUME_RR_SURVIVE 0.25

/* A medium's coefficients at a path's n lanes (per unit density). */
typedef struct volume_lanes {
    int n;
    double sigma_a[VOLUME_MAX_LANES], sigma_s[VOLUME_MAX_LANES], Le[VOLUME_MAX_LANES];
    double sigma_t_max; /* max over lanes of sigma_a + sigma_s */
    int emissive;
    int Le_varies;                    /* Le is read per point (medium_Le_at), not from Le[] */
    double lambda[VOLUME_MAX_LANES]; /* for medium_Le_at */
} volume_lanes_t;

void volume_lanes_make(const medium_t *m, const double *lambda, int n, volume_lanes_t *out);

typedef enum volume_event {
    VOLUME_PASSED,    /* reached tmax (the next surface, or the end of the ray) */
    VOLUME_SCATTERED, /* scatters at distance t */
    VOLUME_ABSORBED,  /* absorbed: the path ends */
} volume_event_t;

typedef struct volume_flight {
    volume_event_t event;
    double t;                        /* VOLUME_SCATTERED: the distance along the ray */
    double weight[VOLUME_MAX_LANES]; /* PASSED, SCATTERED: multiply each lane's throughput */
    /* The medium's emission collected on the way (pbrt-v4: sigma_a Le at every collision over
     * its density), per lane, to be multiplied by the lane's throughput at the flight's start. */
    double emitted[VOLUME_MAX_LANES];
} volume_flight_t;

/* One free flight along org + t dir (dir unit), t in [0, tmax) (tmax may be INFINITY) in m
 * with coefficients k, the lanes' throughputs beta choosing how they share it (a lane with
 * beta <= 0 never decides). No lane carrying anything: absorbed. */
void volume_sample(const medium_t *m, const volume_lanes_t *k, vec3_t org, vec3_t dir, double tmax,
                   const double *beta, rng_stream_t *rng, volume_flight_t *out);

/* The density with which volume_sample, given the same k and beta, returns VOLUME_SCATTERED at
 * distance t in [0, tmax) of a homogeneous medium: the lanes' mixture
 * sum_j sel_j sigma_s,j exp(-sigma_t,j t), sel in proportion to beta (0 when no lane carries
 * anything). What the equiangular estimator's MIS weights (render.c) compare with; a grid has
 * no closed form for it, so it is not asked there. */
double volume_scatter_pdf(const volume_lanes_t *k, const double *beta, double t);

/* Multiplies T[j] by an unbiased estimate of lane j's transmittance exp(-int sigma_t,j) over
 * [0, tmax): exact for a homogeneous medium, ratio tracking (with its Russian roulette) for a
 * grid. */
void volume_transmittance(const medium_t *m, const volume_lanes_t *k, vec3_t org, vec3_t dir,
                          double tmax, rng_stream_t *rng, double *T);

#endif
