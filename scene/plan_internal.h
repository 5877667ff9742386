/* plan_internal: the plan's object, shared by its files (plan.c decides, plan_report.c writes
 * the report); nothing outside scene/plan*.c includes it. */
#ifndef PRISMFARM_PLAN_INTERNAL_H
#define PRISMFARM_PLAN_INTERNAL_H

#include "plan_types.h"

#include <stddef.h>
#include <stdint.h>

struct plan {
    plan_request_t req;
    plan_decision_t decisions[PLAN_EFFECT_COUNT];
    char *strings[2 * PLAN_EFFECT_COUNT];
    plan_material_t *materials;
    size_t nmaterials;
    plan_light_t *lights;
    size_t nlights;
    plan_choice_t choice;
    uint64_t rays;
    size_t nplacements; /* mirror and glass placements looked at */
    /* What the scene renders with now, for the report. */
    integrator_kind_t current_integrator;
    int current_media; /* the camera pass simulates media ("volpath") */
    dispersion_kind_t current_dispersion;
    photon_settings_t current_photon;
    spectral_grid_t grid;
};

#endif
