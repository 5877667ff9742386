/* overrides: what a user changes of a scene file from outside it (the command line, a job's
 * settings on the farm), as plain data. The loader applies them (scene_load.h) and the effect
 * plan asks which were given (plan.h); each field's "keep" value leaves the file's own. */
#ifndef PRISMFARM_OVERRIDES_H
#define PRISMFARM_OVERRIDES_H

#include "budget.h"

/* The values of scene_overrides_t.polarized (the job setting `polarized`). */
#define SCENE_POLARIZED_FILE 0
#define SCENE_POLARIZED_OFF 1
#define SCENE_POLARIZED_ON 2

/* Command-line overrides of the scene file; 0 / NULL / -1 leave the file's value. */
typedef struct scene_overrides {
    int spp;
    int xres, yres;
    long long seed;         /* -1: keep */
    const char *integrator; /* "path", "simplepath", "whitted" (scenefile/integrators.h) */
    const char *dispersion; /* "hero", "fanout" */
    /* Polarised transport as the plan decided it (render/polar_pilot.h): SCENE_POLARIZED_FILE
     * leaves the file's, _OFF too (the decision found nothing to carry), _ON carries it. */
    int polarized;
    /* What a scene from an untrusted source may make the loader build (budget.h): checked
     * by scene_load_file_confined; NULL: no budget. */
    const scene_budget_t *budget;
    /* The threads the load runs on (PLY decoding, loopsubdiv, image textures; <= 0: all
     * cores). Not a change to the scene: the loaded scene, and so every image rendered from
     * it, is the same whatever the value (tests/unit/test_load_threads.c). */
    int threads;
} scene_overrides_t;

#endif
