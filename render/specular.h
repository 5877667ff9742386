/* specular: which normal a mirror or smooth-glass event uses (shading or geometric), the same
 * rule for the camera pass (render.c) and the photon pass (photon.c), so that light follows the
 * same specular chains in both directions. The events' physics is bsdf/delta.h's. A pure
 * function of the surface and the direction. */
#ifndef PRISMFARM_SPECULAR_H
#define PRISMFARM_SPECULAR_H

#include "scene.h"

/* The normal a mirror or glass event at sf uses for a ray travelling along dir. The
 * interpolated (shading) normal gives the mirror and refraction directions and the Fresnel
 * cosines, but it may disagree with the real surface: near a silhouette the incident
 * direction can lie on the other side of it, or the mirror (or refracted) direction computed
 * with it can point back through the geometric surface, which would leak light through the
 * mesh. For such an event the geometric normal is used instead, for every branch of the event
 * (the choice is made before any random choice, so reflection and refraction probabilities
 * stay R and 1 - R and energy is conserved). eta_rel is n_incident / n_transmitted for glass,
 * 0 for a mirror. Both normals are outward. *shading (may be NULL) says whether the shading
 * normal was chosen. */
vec3_t specular_normal(const surface_t *sf, vec3_t dir, double eta_rel, int *shading);

#endif
