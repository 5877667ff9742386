/* layered: pbrt-v4's LayeredBxDF (Guo et al. 2018, "Position-Free Monte Carlo Simulation for
 * Arbitrary Layered BSDFs"; pbrt-v4 sec. 14.3) for the coated models of bsdf.h
 * (BSDF_COATED_DIFFUSE, BSDF_COATED_CONDUCTOR): a dielectric interface on top, a diffuse or
 * conductor base, a homogeneous Henyey-Greenstein medium of unit extinction between them, two-sided
 * (a wo below is flipped to the top). f, the sampled weights and the pdf are stochastic estimates
 * whose randomness comes from the rng stream only (a NULL stream is replaced by one keyed by the
 * directions' bits, so the value is then a pure function of the arguments, as in pbrt-v4). One
 * departure from pbrt-v4: a sample reflects off the coating first with Mitsuba roughplastic's
 * probability R / (R + (1 - R) a) (a the base's albedo; layered.c, top_reflect_prob), not the
 * Fresnel share, and the pdf estimate mixes with that probability. Internal to bsdf/.
 *
 * Lanes: when every lane has the same coating eta, one walk (its directions are
 * lane-independent) carries every lane's throughput, and the pdf is the same for every lane.
 * When the coating disperses, each lane is estimated by its own walk: a sample's direction
 * comes from the hero's walk and each other lane gets its own estimate of f and pdf at that
 * direction (0 for a specular direction other than the top's mirror reflection). */
#ifndef PRISMFARM_LAYERED_H
#define PRISMFARM_LAYERED_H

#include "bsdf_model.h"

/* Its interface is its two rows, bsdf_model_coated_diffuse and bsdf_model_coated_conductor
 * (bsdf_model.h, registered in bsdf_types.h's BSDF_MODEL_LIST). */

#endif
