/* diffuse: pbrt-v4's DiffuseBxDF as the row bsdf_model_diffuse (bsdf_model.h), and its pdf for
 * the other models that sample the cosine on wo's side. Internal to bsdf/. */
#ifndef PRISMFARM_DIFFUSE_H
#define PRISMFARM_DIFFUSE_H

#include "bsdf_model.h"

/* Every lane's pdf of the cosine-weighted hemisphere on wo's side (0 on the other): a row's
 * pdf (b and rng unused). */
void diffuse_pdf(const bsdf_t *b, int n, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *pdf);

#endif
