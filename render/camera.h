/* camera: pbrt-v4's perspective and orthographic cameras (thin lens when lens_radius > 0), its
 * spherical camera (equal-area or equirectangular) and its realistic camera (a lens system,
 * optics/lens.h, whose rays depend on wavelength): a raster position and a lens sample to a
 * world-space ray. fov is the angle of the image's shorter axis (perspective). */
#ifndef PRISMFARM_CAMERA_H
#define PRISMFARM_CAMERA_H

#include "scene.h"
#include "vec3.h"

/* (fx, fy) in raster space: x right in [0, xres), y down in [0, yres). (u1, u2) in [0,1)^2
 * pick the point on the lens. dir is unit length. */
void camera_ray(const camera_t *cam, int xres, int yres, double fx, double fy, double u1,
                double u2, vec3_t *org, vec3_t *dir);

/* camera_ray's per-image constants (tan(fov/2) and the screen window's extents), computed
 * once so that a renderer does not take a tangent per camera ray. camera_frame_ray(&f, ...)
 * with f = camera_frame_make(cam, xres, yres) gives camera_ray(cam, xres, yres, ...) bit for
 * bit. The frame points to cam, which must outlive it. */
typedef struct camera_frame {
    const camera_t *cam;
    int xres, yres;
    double tan_half; /* tan(fov / 2); 1 for the orthographic camera */
    double sx, sy;   /* the screen window's half-extents before tan_half */
    double cx, cy;   /* the screen window's centre (0, 0 for pbrt-v4's default) */
} camera_frame_t;

camera_frame_t camera_frame_make(const camera_t *cam, int xres, int yres);
void camera_frame_ray(const camera_frame_t *f, double fx, double fy, double u1, double u2,
                      vec3_t *org, vec3_t *dir);
/* The ray at wavelength lambda_nm and its weight (pbrt-v4's CameraRay weight): 1 for every
 * camera but the realistic one, whose weight is cos^4 theta times the exit pupil's area over
 * the rear element's distance squared, 0 when the lens vignettes the ray (the ray is then a
 * valid one from the camera's origin). camera_frame_ray gives the realistic camera's ray at
 * the d line (587.56 nm), without its weight. */
double camera_frame_ray_lambda(const camera_frame_t *f, double fx, double fy, double u1, double u2,
                               double lambda_nm, vec3_t *org, vec3_t *dir);

#endif
