/* camera: pbrt-v4's perspective camera (thin lens when lens_radius > 0): a raster position and
 * a lens sample to a world-space ray. fov is the angle of the image's shorter axis. */
#ifndef PRISMFARM_CAMERA_H
#define PRISMFARM_CAMERA_H

#include "scene.h"
#include "vec3.h"

/* (fx, fy) in raster space: x right in [0, xres), y down in [0, yres). (u1, u2) in [0,1)^2
 * pick the point on the lens. dir is unit length. */
void camera_ray(const camera_t *cam, int xres, int yres, double fx, double fy, double u1,
                double u2, vec3_t *org, vec3_t *dir);

#endif
