/* load_integrator: the Integrator directive (or the command line's --integrator) into the render
 * settings: the integrator and its parameters, pbrt-v4's integrators read as prismfarm's
 * (scenefile/integrators.h) with a warning for what is not simulated, and the photon pass's
 * settings; media are kept only where the integrator simulates them. Runs after load_options
 * (sppm's photon count follows the film and the sampler). */
#ifndef PRISMFARM_LOAD_INTEGRATOR_H
#define PRISMFARM_LOAD_INTEGRATOR_H

#include "loader.h"
#include "overrides.h"

/* The integrator and its parameters into sc->settings (ov: --integrator, --dispersion). */
int load_integrator(loader_t *L, const scene_overrides_t *ov, err_t *err);

#endif
