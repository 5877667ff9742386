/* load_options: the camera (with a realistic camera's lens system), the film (resolution,
 * crop, sensor, wavelength range, the master's image budget), the pixel filter and the sampler
 * into the scene's camera and render settings, the command line's overrides applied. */
#ifndef PRISMFARM_LOAD_OPTIONS_H
#define PRISMFARM_LOAD_OPTIONS_H

#include "loader.h"
#include "overrides.h"

/* The camera, film, filter and sampler into sc->camera and sc->settings (ov: the command
 * line's resolution, spp and seed, which replace the file's). */
int load_options(loader_t *L, const scene_overrides_t *ov, err_t *err);

#endif
