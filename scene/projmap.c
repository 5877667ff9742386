#include "projmap.h"

#include "colour.h"
#include "distrib2d.h"
#include "envmap.h"
#include "rgb_uplift.h"

#include <math.h>
#include <stdlib.h>

/* pbrt-v4 ProjectionLight's hither: directions closer to the light's plane read nothing. */
#define PROJMAP_HITHER 1e-3

struct projmap {
    int w, h;
    double X, Y;  /* half-extents on the plane z = 1 */
    double *coef; /* per texel: rgb_uplift's c0, c1, c2 and m */
    distrib2d_t *dist;
    double power, omega;
};

void projmap_destroy(projmap_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    free((*self_p)->coef);
    distrib2d_destroy(&(*self_p)->dist);
    free(*self_p);
    *self_p = NULL;
}

static size_t texel_at(const projmap_t *self, double u, double v)
{
    int x = (int)(u * self->w), y = (int)(v * self->h);
    x = x >= self->w ? self->w - 1 : x < 0 ? 0 : x;
    y = y >= self->h ? self->h - 1 : y < 0 ? 0 : y;
    return (size_t)y * (size_t)self->w + (size_t)x;
}

/* The point of the plane z = 1 at image coordinates (u, v) in [0, 1]^2, and back. */
static void uv_to_plane(const projmap_t *self, double u, double v, double *px, double *py)
{
    *px = (2.0 * u - 1.0) * self->X;
    *py = (2.0 * v - 1.0) * self->Y;
}

/* 0 when w crosses no point of the image. */
static int dir_to_uv(const projmap_t *self, vec3_t w, double *u, double *v)
{
    double len = sqrt(vec3_dot(w, w));
    if (!(len > 0.0) || !(w.z >= PROJMAP_HITHER * len))
        return 0;
    double px = w.x / w.z, py = w.y / w.z;
    if (!(fabs(px) <= self->X && fabs(py) <= self->Y))
        return 0;
    *u = 0.5 * (px / self->X + 1.0);
    *v = 0.5 * (py / self->Y + 1.0);
    return 1;
}

projmap_t *projmap_new(const float *rgb, int w, int h, double fov_deg, const char *name, err_t *err)
{
    if (!rgb || w <= 0 || h <= 0) {
        err_set(err, "%s: empty projection image", name);
        return NULL;
    }
    if (!(fov_deg > 0.0 && fov_deg < 180.0)) {
        err_set(err, "%s: projection fov %g is not in (0, 180) degrees", name, fov_deg);
        return NULL;
    }
    size_t n = (size_t)w * (size_t)h;
    if (envmap_check_texels(rgb, w, h, name, err))
        return NULL;
    projmap_t *m = calloc(1, sizeof *m);
    rgb_uplift_t *t = rgb_uplift_new(err);
    double *weights = malloc(n * sizeof *weights);
    if (!m || !t || !weights || !(m->coef = malloc(4 * n * sizeof *m->coef))) {
        err_set(err, "%s: out of memory for a %dx%d projection image", name, w, h);
        goto fail;
    }
    m->w = w;
    m->h = h;
    double tn = tan(0.5 * fov_deg * PF_PI / 180.0), aspect = (double)w / (double)h;
    m->X = aspect > 1.0 ? aspect * tn : tn;
    m->Y = aspect > 1.0 ? tn : tn / aspect;
    double sum = 0.0;
    for (size_t i = 0; i < n; i++) {
        const float *p = rgb + 3 * i;
        if (rgb_uplift_coef(t, p, m->coef + 4 * i, err))
            goto fail;
        double px, py;
        uv_to_plane(m, ((double)(i % (size_t)w) + 0.5) / w, ((double)(i / (size_t)w) + 0.5) / h,
                    &px, &py);
        double c = 1.0 / sqrt(1.0 + px * px + py * py), c3 = c * c * c;
        weights[i] = ((double)p[0] + p[1] + p[2]) / 3.0 * c3;
        sum += colour_luminance((rgb_t){p[0], p[1], p[2]}) * c3;
    }
    m->power = 4.0 * m->X * m->Y * sum / (double)n;
    /* The solid angle of a rectangular pyramid of half-extents X, Y at unit height. */
    m->omega = 4.0 * asin(m->X * m->Y / sqrt((1.0 + m->X * m->X) * (1.0 + m->Y * m->Y)));
    if (!(m->dist = distrib2d_new(weights, w, h, err)))
        goto fail;
    free(weights);
    rgb_uplift_destroy(&t);
    return m;
fail:
    free(weights);
    rgb_uplift_destroy(&t);
    projmap_destroy(&m);
    return NULL;
}

void projmap_extent(const projmap_t *self, double *x, double *y)
{
    *x = self->X;
    *y = self->Y;
}

size_t projmap_texel(const projmap_t *self, vec3_t w)
{
    double u, v;
    return dir_to_uv(self, w, &u, &v) ? texel_at(self, u, v) : PROJMAP_OUTSIDE;
}

double projmap_texel_value(const projmap_t *self, size_t texel, double lambda)
{
    return texel == PROJMAP_OUTSIDE ? 0.0 : rgb_uplift_eval(self->coef + 4 * texel, lambda);
}

vec3_t projmap_sample(const projmap_t *self, double u0, double u1, size_t *texel, double *pdf)
{
    double u, v, p, px, py;
    distrib2d_sample(self->dist, u0, u1, &u, &v, &p);
    *texel = texel_at(self, u, v);
    uv_to_plane(self, u, v, &px, &py);
    double len = sqrt(1.0 + px * px + py * py), c = 1.0 / len;
    /* Density p / A on the plane, times dA / d omega = 1 / cos^3. */
    *pdf = p / (4.0 * self->X * self->Y * c * c * c);
    return vec3_make(px * c, py * c, c);
}

double projmap_pdf(const projmap_t *self, vec3_t w)
{
    double u, v;
    if (!dir_to_uv(self, w, &u, &v))
        return 0.0;
    double c = w.z / sqrt(vec3_dot(w, w));
    return distrib2d_pdf(self->dist, u, v) / (4.0 * self->X * self->Y * c * c * c);
}

double projmap_power(const projmap_t *self)
{
    return self->power;
}

double projmap_solid_angle(const projmap_t *self)
{
    return self->omega;
}
