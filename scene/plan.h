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
#include "plan_types.h"
#include "scene.h"
#include "scene_desc.h"
#include "overrides.h"

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

/* The request for a parsed scene loaded with these overrides (ov may be NULL). */
plan_request_t plan_request_make(const scene_desc_t *desc, const scene_overrides_t *ov);

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
const char *plan_verdict_name(plan_verdict_t verdict);

#endif
