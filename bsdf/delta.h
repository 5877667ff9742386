/* delta: the smooth interfaces as delta lobes for a path's spectral lanes -- a smooth
 * dielectric (Snell, the unpolarised Fresnel terms; hero-wavelength lanes and the thesis's
 * monochrome fan-out at a dispersive one) and a smooth conductor (the complex Fresnel term) --
 * in world space about the normal the caller chose (render/specular.h's rule for shading
 * normals), in radiance mode (camera paths, Whitted) or importance mode (photons, which carry
 * flux). The one home of that physics: the camera pass, Whitted and the photon tracer all call
 * it, and keep only their path policy (which branch to follow, when to end lanes or split).
 *
 * Guarantees: every direction is unit or the zero vector, every weight finite and >= 0 for
 * finite inputs; R + T = 1 per lane; in importance mode a branch chosen in proportion to its
 * probability carries weight exactly 1 (flux crossing an interface takes T alone, and R / R,
 * T / T are 1), in radiance mode the refracted branch carries (n_i / n_t)^2 in addition
 * (docs/physics.md §3.4; Veach 1997 §5.2). The arithmetic of every weight is fixed (the same
 * products in the same order whatever the caller), so that images stay bit-identical. */
#ifndef PRISMFARM_DELTA_H
#define PRISMFARM_DELTA_H

#include "bsdf_types.h"
#include "dispersion.h"
#include "fanout.h"
#include "stokes.h"
#include "vec3.h"

#include <stdbool.h>

/* ---- Smooth dielectric ---- */

/* n_incident / n_transmitted for glass of index n (outside: 1): 1/n entering, n leaving. */
double delta_eta_ratio(double n, bool entering);

/* One crossing of a smooth dielectric of index n[j] per lane (outside index 1) by a ray
 * travelling along dir toward the surface, about the unit normal nrm (either side). Lane 0
 * decides the refracted direction (the hero, or every lane of a grey event). */
typedef struct delta_dielectric {
    bsdf_mode_t mode;
    vec3_t reflect;      /* the mirror direction: every lane's */
    vec3_t refract;      /* lane 0's refracted direction; the zero vector under total reflection */
    bool refracts;       /* lane 0 is not totally reflected */
    double ratio;        /* lane 0's n_incident / n_transmitted */
    double prob_reflect; /* P_r: lane 0's Fresnel reflectance, 1 when it cannot refract */
    int nr;              /* lanes whose reflectance was computed */
    double reflectance[BSDF_MAX_LANES]; /* R_j = F(cos_i, n_j), unpolarised (fresnel.h) */
    /* A coated interface (delta_dielectric_coat): the lanes' transmittances T_j = 1 - R_j, and
     * P_r is the lanes' mean reflectance. */
    bool coated;
    double transmittance[BSDF_MAX_LANES];
} delta_dielectric_t;

/* Fills *e for lanes [0, count) with indices n (count 1 for a grey event: every lane at lane 0's
 * index). entering: the ray comes from outside (the side the geometric normal faces). */
void delta_dielectric_make(vec3_t dir, vec3_t nrm, bool entering, const double *n, int count,
                           bsdf_mode_t mode, delta_dielectric_t *e);

/* A grey event's factor for every lane on the branch the caller chose with probability P
 * (P_r or 1 - P_r) and multiplies by scale (1 / P after a random choice, 1 when both branches
 * are followed, as Whitted does): reflection P_r scale; refraction (1 - P_r) scale, times
 * (n_i / n_t)^2 in radiance mode. A hero event's refraction gives lane 0 the same factor. */
double delta_dielectric_weight(const delta_dielectric_t *e, bool reflect, double scale);

/* A hero event's reflection factor for lane j: every lane reflects along the mirror
 * direction, weighted by its own R_j -- over P_r when reflection was chosen with that
 * probability (chosen), as is when both branches are followed. */
double delta_dielectric_reflect_lane(const delta_dielectric_t *e, int j, bool chosen);

/* Lane j's factor on the refracted branch chosen with probability 1 - P_r and multiplied by
 * scale: T_j scale (coated) or (1 - P_r) scale (bare: every lane's), times (n_i / n_t)^2 in
 * radiance mode. */
double delta_dielectric_transmit_lane(const delta_dielectric_t *e, int j, double scale);

/* A thin-film coating (polar/thinfilm.h) on the outside of a smooth dielectric or on a
 * conductor: thickness in nm (> 0) and the film's index model. */
typedef struct delta_film {
    double thickness_nm;
    const ior_model_t *ior;
} delta_film_t;

/* Turns a bare event (delta_dielectric_make with the same count lanes) into the coated one:
 * each lane's R_j is the film's unpolarised Airy reflectance (R_s + R_p) / 2 at wavelength
 * lambda[j] between the outside (index 1) and the glass (n[j]), seen from the side the ray
 * comes from, and T_j = 1 - R_j (a lossless film: what it does not reflect it transmits, so
 * energy is conserved exactly); directions do not change (Snell's invariant n sin theta
 * crosses the film). Interference makes R_j differ between lanes even where n does not, so the
 * reflection is chosen with the lanes' mean reflectance P_r (1 when lane 0 cannot refract) and
 * each lane weighed by its own R_j / P_r or T_j / (1 - P_r) (delta_dielectric_reflect_lane,
 * delta_dielectric_transmit_lane): unbiased for every lane. */
void delta_dielectric_coat(delta_dielectric_t *e, vec3_t dir, vec3_t nrm, bool entering,
                           const double *n, const double *lambda, const delta_film_t *film);

/* Polarised transport (docs/physics.md §14): the Mueller matrix, in the s-p frames of
 * polar/polar_frame.h's polar_event_interface, of one lane's branch of a smooth dielectric
 * crossed by a camera path (radiance mode) that leaves along `out` (e->reflect or a refracted
 * direction): the light travels the other way, so it arrives along -out -- from the path's side
 * on reflection, from the far side on refraction -- in medium n_i and leaves into n_t (outside
 * index 1, glass n). The matrix is polar/polar_fresnel.h's (with a coating: polar/thinfilm.h's
 * Airy matrices, the film on the outside; film NULL: bare) divided by its M[0][0], the
 * unpolarised factor that the weights above carry: a path multiplies its scalar weights as
 * without polarisation and its carrier by this (mueller_normalised). */
mueller_t delta_dielectric_mueller(vec3_t out, vec3_t nrm, bool entering, double n, double lambda,
                                   const delta_film_t *film, bool reflect);

/* The branch a uniform u in [0, 1) chooses in proportion to its probability: reflection when
 * u < P_r. *dir is its direction, and the returned factor is every lane's (a grey event):
 * exactly 1 in importance mode, and on refraction (n_i / n_t)^2 in radiance mode. */
double delta_dielectric_choose(const delta_dielectric_t *e, double u, bool *reflect, vec3_t *dir);

/* The thesis's monochrome fan-out of a polychrome ray at a dispersive interface (5.3;
 * optics/fanout.h): count monochrome rays at wavelengths lambda (fanout_split's), outside
 * index 1, inside `inside`, about nrm; the polychrome reflect-or-refract decision uses the
 * mean-index terms R_P, T_P and ray i carries k t_i (fanout_fresnel_scale). Returns -1 when
 * fanout_refract refuses its arguments. */
typedef struct delta_fan {
    bsdf_mode_t mode;
    vec3_t reflect;
    fanout_ray_t rays[BSDF_MAX_LANES];
    fanout_poly_t poly;
    int count;
} delta_fan_t;

int delta_fan_make(vec3_t dir, vec3_t nrm, const ior_model_t *inside, const double *lambda,
                   int count, bsdf_mode_t mode, delta_fan_t *fan);

/* Monochrome ray i's factor on refraction after the polychrome refraction was chosen with
 * scale (1 / (1 - R_P), or 1) and the ray picked with pick (1, or the ray count when one ray
 * stands for all): k t_i scale pick, times (n_i / n_t)^2 at its own wavelength in radiance
 * mode. 0 for a ray that is totally reflected or transmits nothing. */
double delta_fan_weight(const delta_fan_t *fan, int i, double scale, double pick);

/* ---- Smooth conductor ---- */

/* A mirror event on a conductor: the normal turned toward the incoming ray, the mirror
 * direction and the incidence cosine for the Fresnel term. */
typedef struct delta_conductor {
    vec3_t reflect;
    double cos_i;
} delta_conductor_t;

delta_conductor_t delta_conductor_make(vec3_t dir, vec3_t nrm);

/* The factor of a lane whose conductor index is eta + i k: its unpolarised reflectance
 * (fresnel_conductor), the same in both modes. */
double delta_conductor_weight(const delta_conductor_t *e, double eta, double k);

/* The same under a thin-film coating at wavelength lambda: the film's unpolarised Airy
 * reflectance over the conductor (polar/thinfilm.h with a complex substrate). */
double delta_conductor_coated_weight(const delta_conductor_t *e, double eta, double k,
                                     double lambda, const delta_film_t *film);

/* The conductor's reflection Mueller matrix (polar_fresnel_conductor's, or with film not NULL
 * the coating's Airy matrix over the metal), divided by its M[0][0] as delta_dielectric_mueller. */
mueller_t delta_conductor_mueller(const delta_conductor_t *e, double eta, double k, double lambda,
                                  const delta_film_t *film);

#endif
