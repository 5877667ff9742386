/* camera: pbrt-v4's perspective, orthographic and spherical cameras from scene text, checked
 * against their geometry (cameras.cpp): where a pixel's ray starts and where it goes. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "camera.h"
#include "scene_builders.h"

static scene_t *with_camera(const char *camera, int w, int h)
{
    char text[1024];
    snprintf(text, sizeof text,
             "%s\nFilm \"rgb\" \"integer xresolution\" [ %d ] \"integer yresolution\" [ %d ]\n"
             "WorldBegin\nLightSource \"point\"\nShape \"sphere\"\n",
             camera, w, h);
    return sb_load_text(text, NULL);
}

static void ray_at(const scene_t *s, double fx, double fy, vec3_t *o, vec3_t *d)
{
    camera_frame_t f = camera_frame_make(&s->camera, s->settings.xres, s->settings.yres);
    camera_frame_ray(&f, fx, fy, 0.5, 0.5, o, d);
}

static void near3(vec3_t a, vec3_t b, const char *what)
{
    if (!(fabs(a.x - b.x) < 1e-9 && fabs(a.y - b.y) < 1e-9 && fabs(a.z - b.z) < 1e-9))
        fail_msg("%s: (%.9g %.9g %.9g), expected (%.9g %.9g %.9g)", what, a.x, a.y, a.z, b.x, b.y, b.z);
}

/* Orthographic: parallel rays along the view from the screen window on the camera's plane:
 * pbrt-v4's default window [-aspect, aspect] x [-1, 1], or the scene's. pbrt's LookAt here
 * keeps the world's axes (right = up x dir = +x): the image's right is world +x. */
static void test_orthographic(void **state)
{
    (void)state;
    scene_t *s = with_camera("LookAt 0 0 -5  0 0 0  0 1 0\nCamera \"orthographic\"", 200, 100);
    assert_int_equal(s->camera.kind, CAMERA_ORTHOGRAPHIC);
    vec3_t o, d;
    ray_at(s, 100, 50, &o, &d);
    near3(o, vec3_make(0, 0, -5), "centre origin");
    near3(d, vec3_make(0, 0, 1), "centre direction");
    ray_at(s, 200, 0, &o, &d); /* the top right corner: x = aspect 2, y = 1 */
    near3(o, vec3_make(2, 1, -5), "corner origin");
    near3(d, vec3_make(0, 0, 1), "corner direction");
    scene_destroy(&s);
    s = with_camera("LookAt 0 0 -5  0 0 0  0 1 0\nCamera \"orthographic\" \"float screenwindow\" [ 0 4 -1 1 ]", 200, 100);
    ray_at(s, 0, 50, &o, &d);
    near3(o, vec3_make(0, 0, -5), "window's left edge");
    ray_at(s, 200, 100, &o, &d);
    near3(o, vec3_make(4, -1, -5), "window's bottom right");
    scene_destroy(&s);
    /* A sphere of radius 1 seen orthographically covers pi / (4 x 2) of a 4 x 2 window. */
    s = with_camera("LookAt 0 0 -5  0 0 0  0 1 0\nCamera \"orthographic\"", 200, 100);
    int hits = 0;
    for (int y = 0; y < 100; y++)
        for (int x = 0; x < 200; x++) {
            hit_t h;
            ray_at(s, x + 0.5, y + 0.5, &o, &d);
            hits += geometry_intersect(s->geometry, o, d, 0, INFINITY, &h);
        }
    double frac = hits / 20000.0, want = PF_PI / 8.0;
    if (!(fabs(frac - want) < 0.01))
        fail_msg("sphere covers %.4f of the image, expected %.4f", frac, want);
    scene_destroy(&s);
}

/* Perspective with a screen window or a frame aspect ratio (pbrt-v4 CameraBase): the window
 * at tan(fov / 2). */
static void test_perspective_window(void **state)
{
    (void)state;
    scene_t *s = with_camera("Camera \"perspective\" \"float fov\" [ 90 ] \"float frameaspectratio\" [ 1 ]", 200, 100);
    vec3_t o, d;
    ray_at(s, 200, 100, &o, &d); /* bottom right: (1, -1, 1) with the square frame */
    near3(d, vec3_normalize(vec3_make(1, -1, 1)), "frame aspect 1");
    scene_destroy(&s);
    s = with_camera("Camera \"perspective\" \"float fov\" [ 90 ] \"float screenwindow\" [ -0.5 0.5 -0.25 0.25 ]", 200, 100);
    ray_at(s, 0, 0, &o, &d);
    near3(d, vec3_normalize(vec3_make(-0.5, 0.25, 1)), "screen window");
    scene_destroy(&s);
}

/* Spherical: the whole sphere of directions over the image, pbrt-v4's y/z swap putting the
 * image's middle row on the horizon of camera space's +y. */
static void test_spherical(void **state)
{
    (void)state;
    scene_t *s = with_camera("Camera \"spherical\" \"string mapping\" \"equirectangular\"", 200, 100);
    assert_int_equal(s->camera.kind, CAMERA_SPHERICAL);
    vec3_t o, d;
    ray_at(s, 0, 0, &o, &d); /* theta 0: straight up (+z before the swap) */
    near3(d, vec3_make(0, 1, 0), "top row");
    ray_at(s, 0, 50, &o, &d); /* theta pi/2, phi 0: +x */
    near3(d, vec3_make(1, 0, 0), "left of the middle row");
    ray_at(s, 50, 50, &o, &d); /* phi pi/2: +y before the swap, +z after */
    near3(d, vec3_make(0, 0, 1), "a quarter across");
    scene_destroy(&s);
    s = with_camera("Camera \"spherical\"", 64, 64);
    ray_at(s, 32, 32, &o, &d); /* the equal-area square's centre is +z, swapped to +y */
    near3(d, vec3_make(0, 1, 0), "equal-area centre");
    /* Every direction equally likely: the mean direction over the pixels is ~0. */
    vec3_t sum = vec3_make(0, 0, 0);
    for (int y = 0; y < 64; y++)
        for (int x = 0; x < 64; x++) {
            ray_at(s, x + 0.5, y + 0.5, &o, &d);
            sum = vec3_add(sum, d);
        }
    assert_true(vec3_length(sum) / 4096.0 < 0.01);
    scene_destroy(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_orthographic),
        cmocka_unit_test(test_perspective_window),
        cmocka_unit_test(test_spherical),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
