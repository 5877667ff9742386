/* bsdf: the surface scattering models, evaluated for a path's spectral lanes at once (hero
 * wavelengths or fan-out buckets), in a local shading frame (z is the shading normal, x the
 * u direction; the caller converts). A bsdf_t is a plain value a renderer fills at a hit
 * from a material and its textures (per lane: what varies with wavelength), then samples and
 * evaluates. pbrt-v4's BxDFs are the reference for what each model and parameter means:
 * DiffuseBxDF, DiffuseTransmissionBxDF, ConductorBxDF, DielectricBxDF, ThinDielectricBxDF,
 * CoatedDiffuseBxDF and CoatedConductorBxDF (its stochastic LayeredBxDF), MeasuredBxDF (RGL's
 * measured files, measured.h).
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
 * refraction, where only the hero's direction has any density).
 *
 * Delta lobes per lane: a smooth mirror direction is every lane's (f[j] |cos| = lane j's
 * reflectance, pdf[j] = lane j's probability of that lobe); a smooth refraction is shared by
 * the lanes whose eta equals the hero's within 1e-9 (relative), the others get f = pdf = 0.
 * eta exactly 1 is pbrt-v4's pass-through (wi = -wo, weight 1) at any roughness.
 *
 * The coated models are pbrt-v4's stochastic LayeredBxDF: bsdf_eval's f, bsdf_pdf and the
 * sample are Monte-Carlo estimates (pdf_is_estimate is set) whose randomness comes only from
 * rng (rng_stream_next; NULL: a stream keyed by the arguments' bits, so the result is then a
 * pure function of them). Their pdf is pbrt-v4's approximation for MIS, not the density of
 * their sampling (it integrates to more than 1); the sample's f / pdf is an unbiased weight.
 * When every lane has the same coating eta one walk carries every lane; when the coating
 * disperses each lane is estimated by its own walk (the hero's walk picks the direction; the
 * other lanes get their own f and pdf estimates there, 0 for a specular path other than the
 * top's mirror reflection). One departure from pbrt-v4: f's next-event estimate through the
 * exit interface is MIS-weighed against that interface's own sampling density
 * PDF(wi, -w), where pbrt-v4 uses PDF(-w, wi) and is biased bright by 9-27 % against a
 * path-sampled ground truth (tests/unit/test_bsdf_layered.c, docs/physics.md §10.4).
 *
 * The models: each kind of bsdf_types.h's BSDF_MODEL_LIST is a row of operations
 * (bsdf_model.h) in its own file (diffuse.c, conductor.c, dielectric.c, layered.c, ...); the
 * functions below do what every model shares and call the row once per call. */
#ifndef PRISMFARM_BSDF_H
#define PRISMFARM_BSDF_H

#include "bsdf_types.h"
#include "rng.h"
#include "stokes.h"
#include "vec3.h"

#include <stdbool.h>

/* Samples a direction from lane hero's lobes for outgoing wo (unit, local frame) with the
 * uniforms uc (lobe choice) and u1, u2 (direction); rng supplies the layered models' random
 * walk (others do not use it). Returns false when nothing is sampled (wo in the plane, the
 * sampled direction below the surface for a reflection, a zero lobe): the path ends. */
bool bsdf_sample(const bsdf_t *b, vec3_t wo, int hero, double uc, double u1, double u2,
                 rng_stream_t *rng, bsdf_sample_t *out);

/* f(wo, wi) for every lane (without the cosine); 0 for delta lobes. */
void bsdf_eval(const bsdf_t *b, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *f);

/* A cheap, deterministic stand-in for f(wo, wi), positive wherever f can be, for choosing
 * among many directions in proportion to it (the glossy photon gather): the coated models'
 * coating lobe plus a Lambertian guess at what the layer returns (layered.h); 1 for every
 * other model (a choice in proportion to power alone). Any positive guide keeps such a choice
 * unbiased; the closer to f, the less noise. */
double bsdf_guide(const bsdf_t *b, vec3_t wo, vec3_t wi);

/* The pdf of sampling wi from wo under each lane's own sampling (solid angle; 0 for delta
 * lobes). */
void bsdf_pdf(const bsdf_t *b, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *pdf);

/* Polarised transport (docs/physics.md §14): lane j's Mueller matrix for light arriving along
 * -wi and leaving along wo (local frame, radiance mode: wo toward the camera) where the model
 * is a conductor or dielectric, smooth or microfacet: the Fresnel matrix (polar/polar_fresnel.h)
 * of the microfacet that scatters wi into wo -- the half vector, or the generalized one for a
 * refraction (lobe.h's lobe_half) -- at the incidence cosine |wi . wm|, in that microfacet's
 * s-p frames (polar/polar_frame.h's polar_event_interface with n = *wm), divided by its
 * M[0][0]: the scalar Fresnel term that bsdf_eval and the sample's f already carry, so that
 * the lobe's matrix is f (the scalar) times this. D, G and the Jacobians are scalars and do not
 * polarise (Baek et al. 2018, "Simulating Polarization using Polarized Microfacet Models";
 * Mitsuba 3's polarized roughconductor / roughdielectric do the same). False for every other
 * model (diffuse, thin and layered: depolarising) and for directions no microfacet joins. */
bool bsdf_mueller(const bsdf_t *b, int j, vec3_t wo, vec3_t wi, mueller_t *m, vec3_t *wm);

/* The model has only delta lobes (smooth conductor or dielectric, thin dielectric): no light
 * sampling at it. */
bool bsdf_is_specular(const bsdf_t *b);

/* The lanes' lobes differ in direction, not only in value: a dielectric (or coating) whose eta
 * differs between lanes. */
bool bsdf_lanes_disperse(const bsdf_t *b);

/* The model's f and pdf are stochastic estimates (the coated models): a sample's f / pdf is an
 * unbiased weight, but its pdf is not a density to mix the lanes by. */
bool bsdf_pdf_is_estimate(const bsdf_t *b);

#endif
