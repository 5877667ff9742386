/* plan_types: what the plan (plan.h) finds and decides, as plain data: the request it
 * answers, its decisions, the materials and lights it looked at and its choice, with the
 * thresholds its rules use. Apart from plan.h so that the plan's own files (plan_detect,
 * plan_internal) share them without including the plan's interface. */
#ifndef PRISMFARM_PLAN_TYPES_H
#define PRISMFARM_PLAN_TYPES_H

#include "scene.h"

#include <stdint.h>

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

typedef enum plan_effect {
    PLAN_SPLITTING,     /* wavelength splitting at dispersive refraction */
    PLAN_COLOUR,        /* spectrally varying emission or reflectance */
    PLAN_STRATEGY,      /* dispersion strategy: hero or fan-out */
    PLAN_PHOTON,        /* the photon pass */
    PLAN_PHOTON_PARAMS, /* its photon count and gather radius */
    PLAN_INTEGRATOR,    /* the camera pass's integrator */
    PLAN_POLARISATION,  /* Stokes carriers on camera paths (render_settings_t.polarised) */
    PLAN_SUBSURFACE,    /* subsurface materials' BSSRDF (render/subsurface.h) */
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
} plan_choice_t;

#endif
