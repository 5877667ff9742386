/* overrides: what a user changes of a scene file from outside it (the command line, a job's
 * settings on the farm), as plain data. The loader applies them (scene_load.h) and the effect
 * plan asks which were given (plan.h); each field's "keep" value leaves the file's own. */
#ifndef PRISMFARM_OVERRIDES_H
#define PRISMFARM_OVERRIDES_H

/* Command-line overrides of the scene file; 0 / NULL / -1 leave the file's value. */
typedef struct scene_overrides {
    int spp;
    int xres, yres;
    long long seed;         /* -1: keep */
    const char *integrator; /* "path", "simplepath", "whitted" (scenefile/integrators.h) */
    const char *dispersion; /* "hero", "fanout" */
} scene_overrides_t;

#endif
