/* bsdf_types: the plain data of bsdf.h (the models' list and kinds, their parameters, their
 * samples, the lobe flags and the transport mode), in their own header so that bsdf/'s
 * internal modules (lobe, the models) can use them without a circle through bsdf.h. Include
 * bsdf.h, not this. */
#ifndef PRISMFARM_BSDF_TYPES_H
#define PRISMFARM_BSDF_TYPES_H

#include "microfacet.h"
#include "vec3.h"

#include <stdbool.h>

/* At least the renderer's lane count (render.h RENDER_MAX_BUCKETS). */
#define BSDF_MAX_LANES 64

/* The models, one line each: its kind and its row of operations (bsdf_model.h, the row defined
 * in the model's own file in bsdf/). A new model is its file and one line here; the kind's
 * fields in bsdf_t are its parameters. */
#define BSDF_MODEL_LIST(X)                                                                         \
    /* Lambertian: reflectance[j] (diffuse.c) */                                                   \
    X(BSDF_DIFFUSE, bsdf_model_diffuse)                                                            \
    /* Lambertian reflection reflectance[j], transmission transmittance[j]                         \
     * (diffuse_transmission.c) */                                                                 \
    X(BSDF_DIFFUSE_TRANSMISSION, bsdf_model_diffuse_transmission)                                  \
    /* Fresnel of the complex index cond_eta[j] + i cond_k[j]; mf (smooth: mirror); film           \
     * (conductor.c) */                                                                            \
    X(BSDF_CONDUCTOR, bsdf_model_conductor)                                                        \
    /* index eta[j] (inside over outside, +z is outside); mf (smooth: delta); film                 \
     * (dielectric.c) */                                                                           \
    X(BSDF_DIELECTRIC, bsdf_model_dielectric)                                                      \
    /* a thin slab of index eta[j]: reflection and straight transmission (thin_dielectric.c) */    \
    X(BSDF_THIN_DIELECTRIC, bsdf_model_thin_dielectric)                                            \
    /* dielectric interface (eta[j], mf) over a medium (thickness, albedo[j], g) over Lambertian   \
     * reflectance[j] (layered.c) */                                                               \
    X(BSDF_COATED_DIFFUSE, bsdf_model_coated_diffuse)                                              \
    /* dielectric interface (eta[j], mf) over a medium over a conductor (cond_eta[j], cond_k[j]    \
     * relative to the coating, mf_base) (layered.c) */                                            \
    X(BSDF_COATED_CONDUCTOR, bsdf_model_coated_conductor)                                          \
    /* RGL's measured BRDF data (measured.h) read at lambda[j] (measured.c) */                     \
    X(BSDF_MEASURED, bsdf_model_measured)                                                          \
    /* a hair fibre (hair.h): hair_* and sigma_a[j] (hair.c) */                                    \
    X(BSDF_HAIR, bsdf_model_hair)                                                                  \
    /* where a BSSRDF's light leaves (bssrdf.h): pbrt-v4's NormalizedFresnelBxDF of index eta[j]   \
     * (bssrdf.c) */                                                                               \
    X(BSDF_SSS_EXIT, bsdf_model_sss_exit)

#define BSDF_KIND_ENUM(kind, row) kind,
typedef enum bsdf_kind { BSDF_MODEL_LIST(BSDF_KIND_ENUM) } bsdf_kind_t;
#undef BSDF_KIND_ENUM

/* pbrt-v4's TransportMode: radiance for camera paths, importance for light (photon) paths;
 * it decides the 1/eta^2 scaling of refracted radiance. */
typedef enum bsdf_mode { BSDF_RADIANCE, BSDF_IMPORTANCE } bsdf_mode_t;

/* What a sample or a lobe is. */
enum {
    BSDF_REFLECTION = 1,
    BSDF_TRANSMISSION = 2,
    BSDF_SPECULAR = 4, /* a delta lobe: f and pdf are the weights of a Dirac, not densities */
};

struct measured;

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
    /* Each lane's wavelength in nm (measured data and thin films are read at it). */
    double lambda[BSDF_MAX_LANES];
    /* Measured: the data (the scene's). */
    const struct measured *measured;
    /* Hair (bsdf/hair.h): the offset h in [-1, 1] across the fibre, its index (one for every
     * lane), longitudinal and azimuthal roughness in [0.01, 1], the scales' tilt in degrees,
     * and each lane's absorption per unit radius. */
    double hair_h, hair_eta, hair_beta_m, hair_beta_n, hair_alpha;
    double sigma_a[BSDF_MAX_LANES];
    /* A thin-film coating (polar/thinfilm.h) on a conductor or dielectric, on the outside:
     * its thickness in nm (0: none), and per lane the film's index. */
    double film_nm;
    double film_n[BSDF_MAX_LANES];
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

#endif
