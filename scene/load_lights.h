/* load_lights: LightSource and AreaLightSource made into the scene's lights: spectra normalised
 * as pbrt-v4 does, "power" / "illuminance" turned into scale, lights' images read into envmaps,
 * goniometric and projection maps, and polarised emission's plane in world space. */
#ifndef PRISMFARM_LOAD_LIGHTS_H
#define PRISMFARM_LOAD_LIGHTS_H

#include "loader.h"

/* The description's LightSource directives into the scene's lights, in its order. */
int load_lights(loader_t *L, err_t *err);

/* pbrt-v4 DiffuseAreaLight "power": scale *= power / k_e with k_e = pi A (2 pi A when
 * two-sided), A the area of the shape, so that the light emits that power. pbrt-v4 makes one
 * light per triangle of a mesh, each emitting the whole power over its own area; prismfarm's
 * light is the whole mesh, so it follows pbrt-v4 exactly when the triangles have equal areas
 * (quads, regular meshes: n triangles emit n times the power) and refuses other meshes.
 * A collimated light carries its radiance through its area: k_e = A. */
int load_lights_area_power(loader_t *L, const scene_area_light_t *a, const shape_t *sh, light_t *l,
                           err_t *err);

/* A shape's AreaLightSource as a light of the scene (its index into *light, -1 when the shape
 * has none); the shape itself is added after it. */
int load_lights_area(loader_t *L, const scene_shape_t *s, int object, int *light, err_t *err);

#endif
