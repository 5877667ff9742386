#include "envmap.h"

#include "colour.h"
#include "distrib2d.h"
#include "equal_area.h"
#include "rgb_uplift.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

struct envmap {
    int n;            /* width = height */
    double *coef;     /* per texel: rgb_uplift's c0, c1, c2 and m */
    distrib2d_t *dist;
    double mean_y, upper_e;
};

void envmap_destroy(envmap_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    free((*self_p)->coef);
    distrib2d_destroy(&(*self_p)->dist);
    free(*self_p);
    *self_p = NULL;
}

envmap_t *envmap_new(const float *rgb, int w, int h, const char *name, err_t *err)
{
    if (!rgb || w <= 0 || h <= 0) {
        err_set(err, "%s: empty environment image", name);
        return NULL;
    }
    if (w != h) {
        err_set(err,
                "%s: environment image is %dx%d, not square: an \"infinite\" light's image must "
                "be in the equal-area octahedral layout, which is square (pbrt-v4 refuses it too)",
                name, w, h);
        return NULL;
    }
    size_t n = (size_t)w * (size_t)h;
    for (size_t i = 0; i < 3 * n; i++)
        if (!(rgb[i] >= 0.0f) || !isfinite(rgb[i])) {
            err_set(err, "%s: texel (%zu, %zu) has %s value %g: not suitable as a light", name,
                    (i / 3) % (size_t)w, (i / 3) / (size_t)w,
                    isnan(rgb[i]) ? "a NaN" : rgb[i] < 0 ? "a negative" : "an infinite", rgb[i]);
            return NULL;
        }
    envmap_t *e = calloc(1, sizeof *e);
    rgb_uplift_t *t = rgb_uplift_new(err);
    double *weights = malloc(n * sizeof *weights);
    if (!e || !t || !weights || !(e->coef = malloc(4 * n * sizeof *e->coef))) {
        err_set(err, "%s: out of memory for a %dx%d environment", name, w, h);
        goto fail;
    }
    e->n = w;
    for (size_t i = 0; i < n; i++)
        rgb_uplift_need(t, rgb + 3 * i);
    if (rgb_uplift_prepare(t, 0, err))
        goto fail;
    double sum_y = 0.0, sum_e = 0.0;
    for (size_t i = 0; i < n; i++) {
        const float *p = rgb + 3 * i;
        if (rgb_uplift_coef(t, p, e->coef + 4 * i, err))
            goto fail;
        weights[i] = ((double)p[0] + p[1] + p[2]) / 3.0;
        double y = colour_luminance((rgb_t){p[0], p[1], p[2]});
        sum_y += y;
        size_t x = i % (size_t)w, yy = i / (size_t)w;
        vec3_t d = equal_area_square_to_sphere((x + 0.5) / w, (yy + 0.5) / h);
        if (d.z > 0.0)
            sum_e += y * d.z;
    }
    e->mean_y = sum_y / (double)n;
    e->upper_e = 2.0 * PF_PI * sum_e / (double)n;
    if (!(e->dist = distrib2d_new(weights, w, h, err)))
        goto fail;
    free(weights);
    rgb_uplift_destroy(&t);
    return e;
fail:
    free(weights);
    rgb_uplift_destroy(&t);
    envmap_destroy(&e);
    return NULL;
}

int envmap_resolution(const envmap_t *self)
{
    return self->n;
}

size_t envmap_texel(const envmap_t *self, vec3_t w)
{
    double u, v;
    equal_area_sphere_to_square(w, &u, &v);
    int x = (int)(u * self->n), y = (int)(v * self->n);
    if (x >= self->n)
        x = self->n - 1;
    if (y >= self->n)
        y = self->n - 1;
    return (size_t)y * (size_t)self->n + (size_t)x;
}

double envmap_texel_value(const envmap_t *self, size_t texel, double lambda)
{
    return rgb_uplift_eval(self->coef + 4 * texel, lambda);
}

vec3_t envmap_sample(const envmap_t *self, double u0, double u1, size_t *texel, double *pdf)
{
    double u, v, p;
    distrib2d_sample(self->dist, u0, u1, &u, &v, &p);
    vec3_t w = equal_area_square_to_sphere(u, v);
    int x = (int)(u * self->n), y = (int)(v * self->n);
    if (x >= self->n)
        x = self->n - 1;
    if (y >= self->n)
        y = self->n - 1;
    *texel = (size_t)y * (size_t)self->n + (size_t)x;
    *pdf = p / (4.0 * PF_PI);
    return w;
}

double envmap_pdf(const envmap_t *self, vec3_t w)
{
    double u, v;
    equal_area_sphere_to_square(w, &u, &v);
    return distrib2d_pdf(self->dist, u, v) / (4.0 * PF_PI);
}

double envmap_mean_luminance(const envmap_t *self)
{
    return self->mean_y;
}

double envmap_upper_illuminance(const envmap_t *self)
{
    return self->upper_e;
}
