/* emitters: the scene's lights as the light samplers see them, as pbrt-v4 sees them: every
 * triangle of an area light's mesh is an emitter of its own (pbrt-v4 makes one
 * DiffuseAreaLight per triangle), any other light one emitter. Each emitter has an index
 * (scene_t.light_emitter0) and bounds (pbrt-v4's Light::Bounds(): its box, normal cone,
 * emission spread and power), and the light BVH over them is built here at load time, with
 * the distant and infinite lights listed beside it (they have no bounds). */
#ifndef PRISMFARM_EMITTERS_H
#define PRISMFARM_EMITTERS_H

#include "scene.h"

/* (scene_emitters_build, declared in scene.h for scene_finish, builds them: this file.) */

/* Emitter e's light and, for a mesh, its triangle (else 0). e < nemitters. O(log nlights). */
int emitters_light(const scene_t *self, size_t e, size_t *tri);

/* The emitter of light l's triangle tri (tri ignored unless l is on a mesh). */
size_t emitters_index(const scene_t *self, int l, size_t tri);

/* Emitter e's bounds; phi 0 for an emitter the BVH leaves out (distant, infinite and
 * collimated lights, zero-area triangles, black lights). phi is pbrt-v4's: pi A L for an area
 * emitter (one side), 4 pi I for a point, spot (its cone does the rest), goniometric (I the
 * image's mean) or projection light (I its mean over the frustum), in the luminance of
 * scene_light_luminance. */
void emitters_bounds(const scene_t *self, size_t e, light_bounds_t *b);

/* Area of triangle t of mesh s, as the light samplers use it (half the cross product's
 * length). */
double emitters_triangle_area(const shape_t *s, size_t t);

#endif
