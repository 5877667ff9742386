/* bsdf: the surface scattering models, evaluated for a path's spectral lanes at once (hero
 * wavelengths or fan-out buckets), in a local shading frame (z is the shading normal, x the
 * u direction; the caller converts). A bsdf_t is a plain value a renderer fills at a hit
 * from a material and its textures (per lane: what varies with wavelength), then samples and
 * evaluates. pbrt-v4's BxDFs are the reference for what each model and parameter means:
 * DiffuseBxDF, DiffuseTransmissionBxDF, ConductorBxDF, DielectricBxDF, ThinDielectricBxDF,
 * CoatedDiffuseBxDF and CoatedConductorBxDF (its stochastic LayeredBxDF).
 *
 * Guarantees: every f, pdf and weight is finite and >= 0 for any unit wo, wi (grazing,
 * wo or wi in the plane, roughness down to 1e-4): never NaN or Inf. Sampling is consistent
 * with evaluation (sample's f and pdf equal bsdf_eval / bsdf_pdf at the returned wi, for
 * non-specular lobes). Lanes are independent: lane j sees only lane j's parameters, so with
 * equal parameters all lanes give the same numbers.
 *
 * Spectral lanes and dispersion: the direction is sampled from one lane's lobe (the `hero`
 * argument); every lane's f and pdf at that direction are returned, so a renderer may weight
 * the lanes by spectral MIS (the pdfs differ where the lanes' indices differ: a rough
 * dispersive dielectric) or terminate the lanes whose pdf is 0 (a smooth dispersive
 * refraction, where only the hero's direction has any density). */
#ifndef PRISMFARM_BSDF_H
#define PRISMFARM_BSDF_H

#include "microfacet.h"
#include "rng.h"
#include "vec3.h"

#include <stdbool.h>

/* At least the renderer's lane count (render.h RENDER_MAX_BUCKETS). */
#define BSDF_MAX_LANES 64

typedef enum bsdf_kind {
    BSDF_DIFFUSE,              /* Lambertian: reflectance[j] */
    BSDF_DIFFUSE_TRANSMISSION, /* Lambertian reflection reflectance[j], transmission transmittance[j] */
    BSDF_CONDUCTOR,            /* Fresnel of the complex index cond_eta[j] + i cond_k[j]; mf (smooth: mirror) */
    BSDF_DIELECTRIC,           /* index eta[j] (inside over outside, +z is outside); mf (smooth: delta) */
    BSDF_THIN_DIELECTRIC,      /* a thin slab of index eta[j]: reflection and straight transmission */
    BSDF_COATED_DIFFUSE,       /* dielectric interface (eta[j], mf) over a medium (thickness, albedo[j], g)
                                * over Lambertian reflectance[j] */
    BSDF_COATED_CONDUCTOR,     /* dielectric interface (eta[j], mf) over a medium over a conductor
                                * (cond_eta[j], cond_k[j] relative to the coating, mf_base) */
} bsdf_kind_t;

/* pbrt-v4's TransportMode: radiance for camera paths, importance for light (photon) paths;
 * it decides the 1/eta^2 scaling of refracted radiance. */
typedef enum bsdf_mode { BSDF_RADIANCE, BSDF_IMPORTANCE } bsdf_mode_t;

/* What a sample or a lobe is. */
enum {
    BSDF_REFLECTION = 1,
    BSDF_TRANSMISSION = 2,
    BSDF_SPECULAR = 4, /* a delta lobe: f and pdf are the weights of a Dirac, not densities */
};

typedef struct bsdf {
    bsdf_kind_t kind;
    bsdf_mode_t mode;
    int n; /* lanes, 1..BSDF_MAX_LANES */
    microfacet_t mf;      /* conductor, dielectric, coating interface */
    microfacet_t mf_base; /* coated conductor: the conductor under the coating */
    double eta[BSDF_MAX_LANES];
    double cond_eta[BSDF_MAX_LANES], cond_k[BSDF_MAX_LANES];
    double reflectance[BSDF_MAX_LANES];
    double transmittance[BSDF_MAX_LANES];
    /* Layered (coated) models: the medium between interface and base, and the random walk. */
    double thickness;               /* pbrt-v4 default 0.01 */
    double albedo[BSDF_MAX_LANES];  /* medium single-scattering albedo, 0: no medium */
    double g;                       /* Henyey-Greenstein asymmetry */
    int maxdepth, nsamples;         /* pbrt-v4 defaults 10 and 1 */
} bsdf_t;

typedef struct bsdf_sample {
    vec3_t wi;
    int flags;                  /* BSDF_REFLECTION or BSDF_TRANSMISSION, | BSDF_SPECULAR */
    /* Per lane: f (without the cosine) and the pdf of wi under lane j's own sampling (solid
     * angle; for a delta lobe, the discrete probability of choosing this lobe for lanes whose
     * delta direction is wi, and 0 for lanes whose delta direction is elsewhere). For a delta
     * lobe f[j] / pdf[j] * |cos| is the usual weight, i.e. f includes 1/|cos|. */
    double f[BSDF_MAX_LANES];
    double pdf[BSDF_MAX_LANES];
    double eta; /* the hero's relative index along wi (transmission), 1 for reflection */
    /* The stochastic layered models: pdf is an estimate (pbrt-v4 pdfIsProportional). */
    bool pdf_is_estimate;
} bsdf_sample_t;

/* Samples a direction from lane hero's lobes for outgoing wo (unit, local frame) with the
 * uniforms uc (lobe choice) and u1, u2 (direction); rng supplies the layered models' random
 * walk (others do not use it). Returns false when nothing is sampled (wo in the plane, the
 * sampled direction below the surface for a reflection, a zero lobe): the path ends. */
bool bsdf_sample(const bsdf_t *b, vec3_t wo, int hero, double uc, double u1, double u2,
                 rng_stream_t *rng, bsdf_sample_t *out);

/* f(wo, wi) for every lane (without the cosine); 0 for delta lobes. */
void bsdf_eval(const bsdf_t *b, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *f);

/* The pdf of sampling wi from wo under each lane's own sampling (solid angle; 0 for delta
 * lobes). */
void bsdf_pdf(const bsdf_t *b, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *pdf);

/* The model has only delta lobes (smooth conductor or dielectric, thin dielectric): no light
 * sampling at it. */
bool bsdf_is_specular(const bsdf_t *b);

/* The lanes' lobes differ in direction, not only in value: a dielectric (or coating) whose eta
 * differs between lanes. */
bool bsdf_lanes_disperse(const bsdf_t *b);

#endif
