#include "camera.h"

#include "equal_area.h"
#include "sample.h"

#include <math.h>

camera_frame_t camera_frame_make(const camera_t *cam, int xres, int yres)
{
    /* pbrt-v4 CameraBase: the screen window spans [-aspect, aspect] x [-1, 1] (or the
     * transpose for portrait images) unless the scene gives one; the perspective camera puts
     * it at tan(fov/2) on the z = 1 plane, the orthographic one on z = 0 as it is. A frame
     * aspect ratio takes the film's place in the default window. */
    double aspect = cam->frame_aspect > 0.0 ? cam->frame_aspect : (double)xres / (double)yres;
    camera_frame_t f = {.cam = cam,
                        .xres = xres,
                        .yres = yres,
                        .tan_half = cam->kind == CAMERA_PERSPECTIVE
                                        ? tan(0.5 * cam->fov_deg * PF_PI / 180.0)
                                        : 1.0,
                        .sx = aspect >= 1.0 ? aspect : 1.0,
                        .sy = aspect >= 1.0 ? 1.0 : 1.0 / aspect};
    const double *w = cam->screen;
    if (w[0] != w[1] && w[2] != w[3]) {
        f.sx = 0.5 * (w[1] - w[0]);
        f.sy = 0.5 * (w[3] - w[2]);
        f.cx = 0.5 * (w[0] + w[1]);
        f.cy = 0.5 * (w[2] + w[3]);
    }
    return f;
}

/* pbrt-v4 SphericalCamera: the raster position over the image to a direction, equal-area
 * (EqualAreaSquareToSphere) or equirectangular (theta from the top row, phi across), then
 * y and z swapped so that the image's centre row is the horizon around +y up. */
static vec3_t spherical_direction(const camera_frame_t *f, double fx, double fy)
{
    double u = fx / f->xres, v = fy / f->yres;
    vec3_t d;
    if (f->cam->equirect) {
        double theta = PF_PI * v, phi = 2.0 * PF_PI * u;
        d = vec3_make(sin(theta) * cos(phi), sin(theta) * sin(phi), cos(theta));
    } else {
        d = equal_area_square_to_sphere(u, v);
    }
    return vec3_make(d.x, d.z, d.y);
}

double camera_frame_ray_lambda(const camera_frame_t *f, double fx, double fy, double u1, double u2,
                               double lambda_nm, vec3_t *org, vec3_t *dir)
{
    const camera_t *cam = f->cam;
    if (cam->kind != CAMERA_REALISTIC) {
        camera_frame_ray(f, fx, fy, u1, u2, org, dir);
        return 1.0;
    }
    double o[3], d[3];
    double w = lens_system_ray(cam->lens, fx, fy, u1, u2, lambda_nm, o, d);
    if (!(w > 0.0)) {
        /* Vignetted: a valid ray that carries nothing. */
        *org = transform_point(&cam->camera_to_world, vec3_make(0, 0, 0));
        *dir = vec3_normalize(transform_vector(&cam->camera_to_world, vec3_make(0, 0, 1)));
        return 0.0;
    }
    *org = transform_point(&cam->camera_to_world, vec3_make(o[0], o[1], o[2]));
    *dir = vec3_normalize(transform_vector(&cam->camera_to_world, vec3_make(d[0], d[1], d[2])));
    return w;
}

void camera_frame_ray(const camera_frame_t *f, double fx, double fy, double u1, double u2,
                      vec3_t *org, vec3_t *dir)
{
    const camera_t *cam = f->cam;
    if (cam->kind == CAMERA_REALISTIC) {
        camera_frame_ray_lambda(f, fx, fy, u1, u2, LENS_LAMBDA_D, org, dir);
        return;
    }
    if (cam->kind == CAMERA_SPHERICAL) {
        *org = transform_point(&cam->camera_to_world, vec3_make(0, 0, 0));
        *dir = vec3_normalize(transform_vector(&cam->camera_to_world, spherical_direction(f, fx, fy)));
        return;
    }
    double x = (f->cx + (2.0 * fx / f->xres - 1.0) * f->sx) * f->tan_half;
    double y = (f->cy + (1.0 - 2.0 * fy / f->yres) * f->sy) * f->tan_half;
    vec3_t d, o;
    if (cam->kind == CAMERA_ORTHOGRAPHIC) {
        o = vec3_make(x, y, 0.0);
        d = vec3_make(0, 0, 1);
    } else {
        o = vec3_make(0, 0, 0);
        d = vec3_normalize(vec3_make(x, y, 1.0));
    }
    if (cam->lens_radius > 0.0) {
        vec3_t lens = vec3_scale(sample_concentric_disk(u1, u2), cam->lens_radius);
        double ft = cam->focal_distance / d.z;
        vec3_t focus = vec3_add(o, vec3_scale(d, ft));
        o = vec3_add(o, lens);
        d = vec3_normalize(vec3_sub(focus, o));
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
