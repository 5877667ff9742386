/* photon: the photon tracer (thesis alg. 4 and 5.5): shoots photons from the lights and
 * deposits them where they land on diffuse surfaces (and, in a photon map, on glossy ones:
 * every non-delta surface that is not Lambertian), into a caustic store (photon_store.h:
 * a photon map or light maps).
 * photon_trace traces a range [i0, i1) of a job's photon indices; every random number of
 * photon i is keyed by (job seed, i, 0, dimension) -- the seed mixed with a photon-pass
 * constant so that photon i and pixel i never share numbers -- so a photon lands in the same
 * place with the same power whatever batch traced it, and batches concatenated in index order
 * give the same map as one batch. Deposits carry raw power: photon i of light l at wavelength
 * lambda starts with Phi_l(lambda) / (p_l * p_lambda), and the map divides by the number of
 * photons emitted only when it is queried. This is the kernel: photon_pass.h runs a job's
 * whole photon pass (or a farm worker's batch) on this machine, photon_wire.h decodes the store
 * the master merged from every worker's batches; either store is handed to render_tile by its
 * caller. */
#ifndef PRISMFARM_PHOTON_H
#define PRISMFARM_PHOTON_H

#include "photon_store.h"
#include "scene.h"

#include <stdint.h>

typedef enum photon_store_policy {
    /* The caustic store of the photon integrator: a photon is deposited at its first
     * non-delta hit -- diffuse, or glossy when the store keeps directions (a photon map) --
     * only if every bounce before it was specular and there was at least one (L S+ D and
     * L S+ G paths), and ends there; a collimated light's photons also at a first hit straight
     * from the light (no camera path can find that light). The camera pass traces every other
     * path. */
    PHOTON_STORE_CAUSTIC,
    /* The thesis's store (alg. 4): deposits at every diffuse hit except a first hit straight
     * from the light, and continues diffusely by Russian roulette on the albedo. */
    PHOTON_STORE_ALL,
} photon_store_policy_t;

typedef struct photon_job {
    uint64_t seed;    /* the job's seed (render_settings.seed) */
    int maxdepth;     /* scattering events a photon may undergo; a hit after the last one is
                       * still deposited */
    int mindepth;     /* the thesis's minimum depth: the caustic store keeps a photon only after
                       * this many specular events (1: L S+ D), the full store after this many
                       * events of any kind; a collimated light's direct hits are kept always */
    int monochromerays; /* wavelengths (lanes) a photon carries, 1..PHOTON_MAX_MONOCHROME_RAYS:
                         * stratified over the film's range, travelling together until a
                         * dispersive interface, where every one is followed as a photon of its
                         * own (thesis 5.5); each counts as one emitted photon */
    int visible;      /* wavelengths by the eye's response (Integrator "string wavelengths"
                       * "visible"), the pdf divided out; else uniform over the film's range */
    double threshold; /* below this fraction of its emitted power a photon survives Russian
                       * roulette with probability (fraction / threshold) and is scaled back up
                       * (an unbiased cull); 0: never */
    photon_store_policy_t policy;
} photon_job_t;

/* The job of the photon integrator as scene->settings describes it (caustic store). */
photon_job_t photon_job_from_settings(const render_settings_t *rs);

#define PHOTON_MAX_MONOCHROME_RAYS 64

typedef struct photon_stats {
    uint64_t emitted;     /* monochrome photons emitted: photon indices traced x lanes */
    uint64_t deposited;   /* deposits made */
    uint64_t rays;        /* intersection queries */
    uint64_t escaped;     /* photons that left the scene */
    uint64_t culled;      /* ended by the threshold roulette or the depth limit */
    uint64_t nonfinite;   /* photons dropped because their power was not finite */
    double power_emitted; /* sum of raw emitted power (W/nm, as deposits) over photons */
    double power_deposited;
} photon_stats_t;

/* Traces photons [i0, i1) of the job in scene and deposits them into out (unfinished, made for
 * this scene) in index order, adding (i1 - i0) x monochromerays to its emitted count.
 * Lights are chosen in proportion to their power (scene->light_power); for the caustic store
 * photons are aimed at a sphere around every mirror and glass surface (a photon whose first
 * hit is diffuse could never be stored) and lights are weighted by the share of their power
 * that goes there. Infinite (environment) lights emit no photons: light from them through
 * glass is left to the camera pass. Each lane carries one wavelength, uniform over the
 * grid's range (a randomly shifted golden-ratio sequence over the photon index and its
 * rotations, so buckets get equal shares). Adds to *stats (may be NULL). */
int photon_trace(const scene_t *scene, const photon_job_t *job, uint64_t i0, uint64_t i1,
                 photon_store_t *out, photon_stats_t *stats, err_t *err);

void photon_stats_add(photon_stats_t *sum, const photon_stats_t *s);

#endif
