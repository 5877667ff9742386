/* bsdf_model: what one BSDF model is to bsdf.c, a row of operations per bsdf_kind_t
 * (BSDF_MODEL_LIST in bsdf_types.h), each row constant data defined in the model's own file, and
 * the helpers the models share. bsdf.c does what every model shares once -- the lanes' count
 * clamped to 1..BSDF_MAX_LANES, the checks on wo and the hero, the sample's defaults and the
 * other lanes' f and pdf at the hero's direction -- and calls the row once per call, the loop
 * over the lanes inside the model (one indirect call per bsdf_eval, not one per lane).
 * Internal to bsdf/: bsdf.h is the interface.
 *
 * Every operation gets n, the lanes, already clamped (1 <= n <= BSDF_MAX_LANES), and must keep
 * bsdf.h's guarantees (finite, >= 0, sampling consistent with evaluation). */
#ifndef PRISMFARM_BSDF_MODEL_H
#define PRISMFARM_BSDF_MODEL_H

#include "bsdf_types.h"
#include "lobe.h"
#include "rng.h"
#include "stokes.h"

#include <complex.h>
#include <math.h>
#include <stdbool.h>
#include <stddef.h>

/* What a model's sample filled. */
typedef enum bsdf_sampled {
    BSDF_SAMPLED_NONE, /* nothing sampled: bsdf_sample returns false */
    BSDF_SAMPLED_HERO, /* wi, flags and the hero's f and pdf (a non-delta lobe): bsdf.c gives
                        * every other lane the row's eval and pdf at wi */
    BSDF_SAMPLED_ALL,  /* wi, flags, eta and every lane's f and pdf */
} bsdf_sampled_t;

/* A row's flags. */
enum {
    BSDF_MODEL_DISPERSIVE = 1,   /* the lanes' eta[j] steer its lobes (bsdf_lanes_disperse) */
    BSDF_MODEL_PDF_ESTIMATE = 2, /* its f and pdf are stochastic estimates (pdf_is_estimate) */
};

typedef struct bsdf_model {
    /* f(wo, wi) for lanes 0..n-1 into f; rng as bsdf.h's bsdf_eval. NULL (with pdf NULL): the
     * model has only delta lobes, f = pdf = 0 and bsdf_is_specular holds. */
    void (*eval)(const bsdf_t *b, int n, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *f);
    void (*pdf)(const bsdf_t *b, int n, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *pdf);
    /* bsdf_sample for a wo with wo.z != 0 and finite, a hero in 0..n-1, out->flags 0, out->eta
     * 1 and out->pdf_is_estimate from the row's flags. */
    bsdf_sampled_t (*sample)(const bsdf_t *b, int n, vec3_t wo, int hero, double uc, double u1,
                             double u2, rng_stream_t *rng, bsdf_sample_t *out);
    /* bsdf_guide; NULL: 1. */
    double (*guide)(const bsdf_t *b, int n, vec3_t wo, vec3_t wi);
    /* bsdf_is_specular for a model with an eval; NULL: false. */
    bool (*is_specular)(const bsdf_t *b, int n);
    /* bsdf_mueller for a lane j in 0..n-1 and wo.z, wi.z != 0; NULL: false (depolarising). */
    bool (*mueller)(const bsdf_t *b, int j, vec3_t wo, vec3_t wi, mueller_t *m, vec3_t *wm);
    /* regularize_bsdf (regularize.h): roughens the model's near-specular lobes in place; NULL:
     * nothing to roughen (pbrt-v4's Regularize is a no-op). */
    void (*regularize)(bsdf_t *b);
    int flags; /* BSDF_MODEL_* */
} bsdf_model_t;

#define BSDF_MODEL_DECLARE(kind, row) extern const bsdf_model_t row;
BSDF_MODEL_LIST(BSDF_MODEL_DECLARE)
#undef BSDF_MODEL_DECLARE

/* b's row; NULL for a kind outside the enum (bsdf.c then evaluates 0 and samples nothing). */
const bsdf_model_t *bsdf_model_of(const bsdf_t *b);

/* b's lanes clamped to 0..BSDF_MAX_LANES. */
static inline int bsdf_lanes(const bsdf_t *b)
{
    return b->n < 1 ? 0 : b->n > BSDF_MAX_LANES ? BSDF_MAX_LANES : b->n;
}

/* Two lanes share a delta refraction when their indices agree to 1e-9 (relative): closer
 * than any dispersion the renderer models, far above rounding. */
static inline bool bsdf_eta_same(double a, double b)
{
    return fabs(a - b) <= 1e-9 * fabs(b);
}

/* Some lane's eta differs from lane 0's (bsdf_eta_same). */
bool bsdf_eta_varies(const bsdf_t *b, int n);

/* Lane j's thin film (in *tmp), or NULL without one. */
static inline const lobe_film_t *bsdf_lane_film(const bsdf_t *b, int j, lobe_film_t *tmp)
{
    if (!(b->film_nm > 0.0))
        return NULL;
    *tmp = (lobe_film_t){b->film_nm, b->film_n[j], b->lambda[j]};
    return tmp;
}

/* The normalised Mueller matrix of lane j's interface for light in n_i meeting n_t at incidence
 * cosine cos_i: Fresnel's, or with a film (on the outside, index 1's side) the Airy sum's. */
mueller_t bsdf_interface_mueller(const bsdf_t *b, int j, double cos_i, double complex n_i,
                                 double complex n_t, bool reflect);

#endif
