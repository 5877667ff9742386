/* photon_testutil: the photon map's own noise in a rendered image's mean, shared by the caustic
 * tests (test_photon_caustic, test_lightmap_caustic) that bound a photon render against a path
 * traced one. Header-only (each test is its own executable); include after cmocka.h. */
#ifndef PRISMFARM_PHOTON_TESTUTIL_H
#define PRISMFARM_PHOTON_TESTUTIL_H

#include <math.h>
#include <stdlib.h>

#include "colour.h"
#include "photon_map.h"
#include "photon_store.h"
#include "scene.h"

/* The relative standard error of the image mean that the photons of ps add. Photon i, of
 * luminance-weighted power a_i, adds to the mean over pixels in proportion to the pixel density
 * at its landing point x: pixels per unit floor area = (pixels per steradian, proportional to
 * 1 / cos^3 alpha off the axis) times (steradians per unit area, cos theta / d^2), so its share
 * is a_i w_i with w_i = cos theta / (d^2 cos^3 alpha), and the mean's relative standard error
 * is sqrt(sum (a_i w_i)^2) / sum a_i w_i over the photons in view (photons are independent).
 * Fails the test when no photon is in view. */
static inline double testutil_photon_relative_se(const scene_t *s, const photon_store_t *ps)
{
    const photon_map_t *m = photon_store_map(ps);
    xyz_t *wts = calloc((size_t)s->settings.grid.n, sizeof *wts);
    assert_non_null(wts);
    colour_grid_weights(s->settings.grid, wts);
    transform_t to_cam = transform_inverse(s->camera.camera_to_world);
    vec3_t eye = transform_point(&s->camera.camera_to_world, vec3_make(0, 0, 0));
    double tanh_ = tan(0.5 * s->camera.fov_deg * PF_PI / 180.0), sum = 0, sq = 0;
    for (size_t i = 0; i < photon_map_count(m); i++) {
        photon_info_t ph = photon_map_photon(m, i);
        vec3_t q = transform_point(&to_cam, ph.p);
        if (!(q.z > 0) || fabs(q.x / q.z) > tanh_ || fabs(q.y / q.z) > tanh_)
            continue;
        vec3_t to_eye = vec3_sub(eye, ph.p);
        double d = vec3_length(to_eye), cos_t = fabs(vec3_dot(ph.normal, to_eye)) / d,
               cos_a = q.z / d;
        /* A white photon (photon_map.h) counts in every bucket by its light's spectrum. */
        const double *white = photon_store_white_spectrum(ps, ph.bucket);
        double y = 0.0;
        if (white)
            for (int b = 0; b < s->settings.grid.n; b++)
                y += white[b] * wts[b].y;
        else
            y = wts[ph.bucket].y;
        double a = ph.power * y * cos_t / (d * d * cos_a * cos_a * cos_a);
        sum += a;
        sq += a * a;
    }
    free(wts);
    assert_true(sum > 0);
    return sqrt(sq) / sum;
}

#endif
