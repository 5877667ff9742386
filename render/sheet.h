/* sheet: a polariser or retarder sheet (MATERIAL_POLARISER, MATERIAL_RETARDER; docs/physics.md
 * §14) crossed straight by a ray: the axis its element acts along and the element's Mueller
 * matrix per lane, one rule for the camera pass (render.c) and the photon pass (photon_polar.h),
 * so that light crosses a sheet the same way in both directions. The sheet is thin and has no
 * index: no Fresnel reflection, no change of direction. Pure functions of their arguments. */
#ifndef PRISMFARM_SHEET_H
#define PRISMFARM_SHEET_H

#include "polar_frame.h"
#include "scene.h"

/* The unit axis of the sheet's element at sf: at the sheet's angle (material_sheet.h) from dp/du toward ng x dp/du
 * (a surface without dp/du: from vec3_basis's tangent of ng), in the sheet's plane. */
vec3_t sheet_axis(const surface_t *sf, const material_t *m);

/* The element for lanes [0, n) at wavelengths lambda for light crossing along k (the light's
 * direction, not the path's), in the frames of polar_event_sheet(k, axis): an ideal polariser
 * (M[0][0] = 1/2) or a lossless retarder -- a constant retardance, 2 pi Gamma / lambda, or a
 * crystal plate's (polar/waveplate.h: with its axis in the plate, even in k; cut across it,
 * the optical rotation and the oblique linear retardance in k's own frame) --, into mm[0] for
 * every lane (returns 0) or mm[j] per lane (returns 1). */
int sheet_mueller(const surface_t *sf, const material_t *m, vec3_t axis, vec3_t k, int n,
                  const double *lambda, mueller_t *mm);

#endif
