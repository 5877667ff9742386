#include "camera.h"

#include "sample.h"

#include <math.h>

camera_frame_t camera_frame_make(const camera_t *cam, int xres, int yres)
{
    /* pbrt-v4 PerspectiveCamera: the screen window spans [-aspect, aspect] x [-1, 1] (or the
     * transpose for portrait images) at tan(fov/2) on the z = 1 plane. */
    double aspect = (double)xres / (double)yres;
    return (camera_frame_t){.cam = cam,
                            .xres = xres,
                            .yres = yres,
                            .tan_half = tan(0.5 * cam->fov_deg * PF_PI / 180.0),
                            .sx = aspect >= 1.0 ? aspect : 1.0,
                            .sy = aspect >= 1.0 ? 1.0 : 1.0 / aspect};
}

void camera_frame_ray(const camera_frame_t *f, double fx, double fy, double u1, double u2,
                      vec3_t *org, vec3_t *dir)
{
    const camera_t *cam = f->cam;
    double x = (2.0 * fx / f->xres - 1.0) * f->sx * f->tan_half;
    double y = (1.0 - 2.0 * fy / f->yres) * f->sy * f->tan_half;
    vec3_t d = vec3_normalize(vec3_make(x, y, 1.0));
    vec3_t o = vec3_make(0, 0, 0);
    if (cam->lens_radius > 0.0) {
        vec3_t lens = vec3_scale(sample_concentric_disk(u1, u2), cam->lens_radius);
        double ft = cam->focal_distance / d.z;
        vec3_t focus = vec3_scale(d, ft);
        o = lens;
        d = vec3_normalize(vec3_sub(focus, lens));
    }
    *org = transform_point(&cam->camera_to_world, o);
    *dir = vec3_normalize(transform_vector(&cam->camera_to_world, d));
}

void camera_ray(const camera_t *cam, int xres, int yres, double fx, double fy, double u1,
                double u2, vec3_t *org, vec3_t *dir)
{
    camera_frame_t f = camera_frame_make(cam, xres, yres);
    camera_frame_ray(&f, fx, fy, u1, u2, org, dir);
}
