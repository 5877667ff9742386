/* regularize: pbrt-v4's path regularisation ("bool regularize" on the path, volpath and bdpt
 * integrators): once a path has made a non-specular bounce, every near-specular lobe it meets
 * is roughened, so that a caustic seen through a diffuse bounce (light through glass or off a
 * mirror, found by chance otherwise) becomes a blurred glossy path that next-event estimation
 * finds. Biased (the image is blurrier than the scene), as in pbrt-v4; off by default.
 *
 * The rule is pbrt-v4's TrowbridgeReitzDistribution::Regularize: each alpha below 0.3 becomes
 * clamp(2 alpha, 0.1, 0.3); larger alphas are kept. A smooth interface (alpha 0) thus becomes
 * a rough one of alpha 0.1, as pbrt-v4's DielectricBxDF and ConductorBxDF do when regularized.
 * The layered models regularize both interfaces (LayeredBxDF::Regularize); the diffuse models
 * and the thin dielectric are unchanged (pbrt-v4's are no-ops). */
#ifndef PRISMFARM_REGULARIZE_H
#define PRISMFARM_REGULARIZE_H

#include "bsdf_types.h"

/* The roughened distribution; finite for any input (a non-finite alpha reads as 0). */
microfacet_t regularize_microfacet(microfacet_t m);

/* Roughens b->mf alone: the row's regularize of the models with one interface (conductor,
 * dielectric, coated diffuse). */
void regularize_interface(bsdf_t *b);

/* Regularizes the model's lobes in place: its row's regularize (bsdf_model.h), which applies
 * regularize_microfacet to the microfacets the model has. */
void regularize_bsdf(bsdf_t *b);

#endif
