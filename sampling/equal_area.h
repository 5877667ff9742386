/* equal_area: Clarberg's equal-area octahedral map between the unit square and the unit sphere
 * (P. Clarberg, "Fast Equal-Area Mapping of the (Hemi)Sphere using SIMD", JGT 13(3), 2008), in
 * the orientation pbrt-v4 uses for its environment maps (EqualAreaSquareToSphere): the square's
 * centre is +z, its four corners -z, u runs along +x and v along +y. Equal area: a uniform point
 * of the square is a uniform direction, so a density p(u, v) on the square is p / (4 pi) in
 * solid angle. */
#ifndef PRISMFARM_EQUAL_AREA_H
#define PRISMFARM_EQUAL_AREA_H

#include "vec3.h"

/* The unit direction of (u, v) in [0, 1]^2 (clamped). */
vec3_t equal_area_square_to_sphere(double u, double v);

/* The inverse: (u, v) in [0, 1]^2 of direction d (any length > 0; the zero vector gives the
 * centre). Exact (atan2), where pbrt-v4 uses a polynomial fit of it. */
void equal_area_sphere_to_square(vec3_t d, double *u, double *v);

#endif
