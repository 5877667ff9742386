/* plan: what a scene calls for. From a finished scene (and what its file asked for) it decides
 * which effects to simulate and says why, naming the materials, lights and shapes that caused
 * each choice: wavelength splitting (any dispersive material), spectral colour (emission or
 * reflectance that varies over the film's range), the dispersion strategy, a photon pass (an
 * L S+ D or L S+ G path -- G a glossy receiver -- from a delta, collimated, or small and
 * bright area light, found by tracing visibility rays with geometry_intersect) with its
 * parameters, and the integrator. Integrator
 * "auto" takes the plan's choice (plan_apply_auto, called by scene_load), and pbrt-v4's
 * light-path integrators (bdpt, mlt, lightpath) its photon pass; other explicit integrators
 * are kept and the plan reports what it would have chosen. The plan is deterministic: fixed
 * random keys, no dependence on threads or time. docs/plan.md states the rules. */
#ifndef PRISMFARM_PLAN_H
#define PRISMFARM_PLAN_H

#include "err.h"
#include "scene.h"
#include "scene_desc.h"
#include "overrides.h"

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

/* An area light is "small" when it subtends less than this solid angle (sr) from the centre of
 * a mirror or glass placement it lights: a cosine-sampled bounce from a diffuse point near the
 * glass then finds it through the glass with probability below Omega / pi = 1/64, i.e. less
 * than once per pixel at the shipped scenes' 64 samples, so its caustic is made of isolated
 * fireflies rather than noise (docs/plan.md). */
#define PLAN_SMALL_SOLID_ANGLE (PF_PI / 64.0)
/* ... and "bright" when it emits at least this share of the scene's light power (the weights
 * of scene->light_power): a dimmer light's caustic is small beside the rest of the image. */
#define PLAN_BRIGHT_SHARE 0.05

/* What the file (and the command line) asked for. */
typedef struct plan_request {
    char integrator[16];       /* "auto", "path", "simplepath", "whitted" or "photon" */
    int integrator_named;      /* the file has an Integrator directive */
    int overridden;            /* the integrator came from the command line */
    char dispersion[16];       /* "hero" or "fanout" when asked explicitly, else "" */
    int dispersion_overridden; /* ... by the command line */
} plan_request_t;

/* The request for a parsed scene loaded with these overrides (ov may be NULL). */
plan_request_t plan_request_make(const scene_desc_t *desc, const scene_overrides_t *ov);

typedef enum plan_effect {
    PLAN_SPLITTING,     /* wavelength splitting at dispersive refraction */
    PLAN_COLOUR,        /* spectrally varying emission or reflectance */
    PLAN_STRATEGY,      /* dispersion strategy: hero or fan-out */
    PLAN_PHOTON,        /* the photon pass */
    PLAN_PHOTON_PARAMS, /* its photon count and gather radius */
    PLAN_INTEGRATOR,    /* the camera pass's integrator */
    PLAN_POLARISATION,  /* Stokes carriers on camera paths (render_settings_t.polarised) */
    PLAN_EFFECT_COUNT,
} plan_effect_t;

typedef struct plan_decision {
    plan_effect_t effect;
    const char *effect_name; /* "wavelength splitting", ... */
    int on;
    const char *choice; /* short: "hero", "photon (path gather)", "off", ... */
    const char *reason; /* one or more sentences naming the scene elements */
} plan_decision_t;

typedef struct plan_material {
    int index;
    char name[64]; /* the material's name, or "#index" when unnamed */
    material_kind_t kind;
    int dispersive;
    int spectral; /* reflectance (or a conductor's eta, k) varies over the film's range */
    /* Dielectrics: n at the film's ends and centre; the Abbe-like number over the film,
     * v_film = (n_mid - 1) / (n_lo - n_hi) (0 when n_lo == n_hi); the catalogue's n_d and
     * v_d = (n_d - 1) / (n_F - n_C) (has_v_d 0 when n_F == n_C). */
    double n_lo, n_mid, n_hi, v_film, n_d, v_d;
    int has_v_d;
} plan_material_t;

typedef enum plan_verdict {
    PLAN_LIGHT_NOT_NEEDED, /* no photon pass for this light */
    PLAN_LIGHT_NEEDED,     /* its light is missing without photons (delta or collimated) */
    PLAN_LIGHT_ADVISED,    /* small and bright behind glass: path tracing gives fireflies */
} plan_verdict_t;

typedef struct plan_light {
    int index;
    light_kind_t kind;
    int shape;          /* area and collimated lights, else -1 */
    double power_share; /* of the scene's total light power */
    int spectral;       /* the emission varies over the film's range */
    /* Area lights: the smallest solid angle (sr) it subtends from the centre of a mirror or
     * glass placement, -1 when not applicable. */
    double solid_angle;
    int small, bright;
    int reaches_specular;  /* a visibility ray from it reached a mirror or glass */
    int caustic;           /* an L S+ D path was found */
    int direct;            /* collimated: it lights a diffuse surface directly */
    int undecided;         /* the ray budget ran out: assumed to need photons */
    int glass_material;    /* the first mirror or glass of the caustic path, or -1 */
    int receiver_material; /* the diffuse surface it lights (caustic or direct), or -1 */
    uint64_t rays;         /* visibility rays traced for it */
    plan_verdict_t verdict;
} plan_light_t;

typedef struct plan_choice {
    integrator_kind_t integrator; /* camera pass (the gather when photon is set) */
    dispersion_kind_t dispersion;
    int photon;       /* run the photon pass */
    uint64_t photons; /* when photon: photons to emit */
    double radius;    /* when photon: gather radius in scene units */
    int differs;      /* an explicit integrator differs from this choice */
    /* Lights whose caustics called for a photon pass that the plan left off because the
     * scene's media are simulated (the camera pass carries them, the photon pass cannot):
     * their caustics through smooth glass and mirrors are left to the path tracer. */
    int photon_off_for_media;
} plan_choice_t;

typedef struct plan plan_t;

/* Plans a finished scene. Reads the scene's geometry, materials, lights, camera, film and
 * maxdepth, never its integrator, dispersion or photon settings (except to describe them),
 * so the plan is the same before and after plan_apply. NULL on failure (out of memory). */
plan_t *plan_new(const scene_t *scene, const plan_request_t *req, err_t *err);
void plan_destroy(plan_t **self_p);

size_t plan_decision_count(const plan_t *self);
const plan_decision_t *plan_decision_at(const plan_t *self, size_t i);
/* The decision about one effect (every effect has exactly one). */
const plan_decision_t *plan_decision_of(const plan_t *self, plan_effect_t effect);
size_t plan_material_count(const plan_t *self);
const plan_material_t *plan_material_at(const plan_t *self, size_t i);
size_t plan_light_count(const plan_t *self);
const plan_light_t *plan_light_at(const plan_t *self, size_t i);
plan_choice_t plan_choice(const plan_t *self);
const plan_request_t *plan_request(const plan_t *self);
/* Visibility rays traced in all. */
uint64_t plan_rays(const plan_t *self);

/* Sets rs's integrator, photon settings and (unless the request names one) dispersion
 * strategy to the plan's choice: what integrator "auto" means. */
void plan_apply(const plan_t *self, render_settings_t *rs);

/* Whether the request names one of pbrt-v4's light-path integrators (bdpt, mlt, lightpath:
 * integrator_name_t.plan_photons) whose photon pass the plan decides. */
int plan_follows_photons(const plan_request_t *req);

/* For scene_load: when the request's integrator is "auto", plans the finished scene and
 * applies the plan; when it is a light-path integrator (plan_follows_photons), applies only the
 * plan's photon pass (on or off, its count and radius); otherwise does nothing. */
int plan_apply_auto(scene_t *scene, const scene_desc_t *desc, const scene_overrides_t *ov,
                    err_t *err);

/* The readable report `prismfarm plan` prints: a table of the decisions with their reasons,
 * the materials and lights it looked at, and what was switched off. Returns 0, or -1 when
 * writing failed. */
int plan_write_text(const plan_t *self, FILE *out);

const char *plan_light_kind_name(light_kind_t kind);
const char *plan_material_kind_name(material_kind_t kind);
const char *plan_verdict_name(plan_verdict_t verdict);

#endif
