#include "envmap.h"

#include "colour.h"
#include "distrib2d.h"
#include "equal_area.h"
#include "rgb_uplift.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

struct envmap {
    int w, h;          /* equal-area: w = h; lat-long: w = 2 h */
    bool latlong;
    double *coef;      /* per texel: rgb_uplift's c0, c1, c2 and m */
    distrib2d_t *dist;
    distrib2d_t *comp; /* the compensated distribution; NULL: dist serves (envmap.h) */
    double mean_y, upper_e;
};

void envmap_destroy(envmap_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    free((*self_p)->coef);
    distrib2d_destroy(&(*self_p)->dist);
    distrib2d_destroy(&(*self_p)->comp);
    free(*self_p);
    *self_p = NULL;
}

/* The direction of image point (u, v) in [0, 1]^2, light space. Lat-long: pbrt-v3's layout
 * (its InfiniteAreaLight), u = phi / 2 pi, v = theta / pi from +z at the top row. */
static vec3_t uv_to_dir(const envmap_t *self, double u, double v)
{
    if (!self->latlong)
        return equal_area_square_to_sphere(u, v);
    double phi = 2.0 * PF_PI * u, theta = PF_PI * v;
    double st = sin(theta);
    return vec3_make(st * cos(phi), st * sin(phi), cos(theta));
}

static void dir_to_uv(const envmap_t *self, vec3_t w, double *u, double *v)
{
    if (!self->latlong) {
        equal_area_sphere_to_square(w, u, v);
        return;
    }
    double len = sqrt(vec3_dot(w, w));
    double z = len > 0.0 ? w.z / len : 1.0;
    z = z > 1.0 ? 1.0 : z < -1.0 ? -1.0 : z;
    double phi = atan2(w.y, w.x);
    if (phi < 0.0)
        phi += 2.0 * PF_PI;
    *u = phi / (2.0 * PF_PI);
    *v = acos(z) / PF_PI;
}

/* Solid angle per unit of (u, v) area at v: 4 pi everywhere for the equal-area map,
 * 2 pi^2 sin(theta) for lat-long (so texels near the poles are small). */
static double jacobian(const envmap_t *self, double v)
{
    return self->latlong ? 2.0 * PF_PI * PF_PI * sin(PF_PI * v) : 4.0 * PF_PI;
}

static size_t texel_at(const envmap_t *self, double u, double v)
{
    int x = (int)(u * self->w), y = (int)(v * self->h);
    x = x >= self->w ? self->w - 1 : x < 0 ? 0 : x;
    y = y >= self->h ? self->h - 1 : y < 0 ? 0 : y;
    return (size_t)y * (size_t)self->w + (size_t)x;
}

/* The compensated distribution (pbrt-v4 ImageInfiniteLight; PBR 4th ed. sec. 12.5.3; Karlik et
 * al. 2019, "MIS Compensation"): texel weights max(c - c_avg, 0), c the channel average the plain
 * distribution uses and c_avg its mean over directions (lat-long: weighted by each texel's solid
 * angle, sin(theta), and the weight multiplied by it as in the plain one, so that the density
 * over directions stays proportional to max(c - c_avg, 0)). weights holds the plain weights and
 * is overwritten. An image with no texel above its average (a uniform one) keeps e->comp NULL:
 * the plain distribution serves, as pbrt-v4's all-ones fallback does for its square images. */
static int compensate(envmap_t *e, const float *rgb, double *weights, err_t *err)
{
    size_t n = (size_t)e->w * (size_t)e->h;
    double sum = 0.0, sum_sa = 0.0, lo = INFINITY;
    for (size_t i = 0; i < n; i++) {
        double sa = e->latlong ? sin(PF_PI * ((double)(i / (size_t)e->w) + 0.5) / e->h) : 1.0;
        const float *p = rgb + 3 * i;
        double c = ((double)p[0] + p[1] + p[2]) / 3.0;
        sum += c * sa;
        sum_sa += sa;
        lo = fmin(lo, c);
    }
    /* The mean is at least the least texel; rounding in the sum must not put a uniform
     * image's texels an ulp above their own average. */
    const double avg = fmax(sum / sum_sa, lo);
    int any = 0;
    for (size_t i = 0; i < n; i++) {
        double sa = e->latlong ? sin(PF_PI * ((double)(i / (size_t)e->w) + 0.5) / e->h) : 1.0;
        const float *p = rgb + 3 * i;
        double c = ((double)p[0] + p[1] + p[2]) / 3.0 - avg;
        weights[i] = c > 0.0 ? c * sa : 0.0;
        any |= weights[i] > 0.0;
    }
    if (!any)
        return 0;
    return (e->comp = distrib2d_new(weights, e->w, e->h, err)) ? 0 : -1;
}

int envmap_check_texels(const float *rgb, int w, int h, const char *name, err_t *err)
{
    size_t n = (size_t)w * (size_t)h;
    for (size_t i = 0; i < 3 * n; i++)
        if (!(rgb[i] >= 0.0f) || !isfinite(rgb[i]))
            return err_set(err, "%s: texel (%zu, %zu) has %s value %g: not suitable as a light",
                           name, (i / 3) % (size_t)w, (i / 3) / (size_t)w,
                           isnan(rgb[i])   ? "a NaN"
                           : rgb[i] < 0.0f ? "a negative"
                                           : "an infinite",
                           rgb[i]);
    return 0;
}

envmap_t *envmap_new(const float *rgb, int w, int h, const char *name, err_t *err)
{
    if (!rgb || w <= 0 || h <= 0) {
        err_set(err, "%s: empty environment image", name);
        return NULL;
    }
    if (w != h && w != 2 * h) {
        err_set(err,
                "%s: environment image is %dx%d, neither square (pbrt-v4's equal-area octahedral "
                "layout) nor twice as wide as high (lat-long)",
                name, w, h);
        return NULL;
    }
    size_t n = (size_t)w * (size_t)h;
    if (envmap_check_texels(rgb, w, h, name, err))
        return NULL;
    envmap_t *e = calloc(1, sizeof *e);
    rgb_uplift_t *t = rgb_uplift_new(err);
    double *weights = malloc(n * sizeof *weights);
    if (!e || !t || !weights || !(e->coef = malloc(4 * n * sizeof *e->coef))) {
        err_set(err, "%s: out of memory for a %dx%d environment", name, w, h);
        goto fail;
    }
    e->w = w;
    e->h = h;
    e->latlong = w != h;
    /* Sums over texels weighted by their solid angle (jacobian / n each): the mean over
     * directions and pbrt-v4's illuminance normaliser, which is half the upper illuminance. */
    double sum_y = 0.0, sum_e = 0.0;
    for (size_t i = 0; i < n; i++) {
        const float *p = rgb + 3 * i;
        if (rgb_uplift_coef(t, p, e->coef + 4 * i, err))
            goto fail;
        size_t x = i % (size_t)w, yy = i / (size_t)w;
        double u = (x + 0.5) / w, v = (yy + 0.5) / h, sa = jacobian(e, v) / (double)n;
        /* pbrt-v4 draws texels by their channel average; a lat-long texel also by its
         * solid angle, so that the density over directions stays proportional to radiance. */
        weights[i] = ((double)p[0] + p[1] + p[2]) / 3.0 * (e->latlong ? sin(PF_PI * v) : 1.0);
        double y = colour_luminance((rgb_t){p[0], p[1], p[2]});
        sum_y += y * sa;
        vec3_t d = uv_to_dir(e, u, v);
        if (d.z > 0.0)
            sum_e += y * d.z * sa;
    }
    e->mean_y = sum_y / (4.0 * PF_PI);
    e->upper_e = 0.5 * sum_e;
    if (!(e->dist = distrib2d_new(weights, w, h, err)) || compensate(e, rgb, weights, err))
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
    return self->w;
}

bool envmap_is_latlong(const envmap_t *self)
{
    return self->latlong;
}

size_t envmap_texel(const envmap_t *self, vec3_t w)
{
    double u, v;
    dir_to_uv(self, w, &u, &v);
    return texel_at(self, u, v);
}

double envmap_texel_value(const envmap_t *self, size_t texel, double lambda)
{
    return rgb_uplift_eval(self->coef + 4 * texel, lambda);
}

static const distrib2d_t *distribution(const envmap_t *self, bool compensated)
{
    return compensated && self->comp ? self->comp : self->dist;
}

bool envmap_has_compensated(const envmap_t *self)
{
    return self->comp != NULL;
}

vec3_t envmap_sample(const envmap_t *self, double u0, double u1, size_t *texel, double *pdf)
{
    return envmap_sample_as(self, false, u0, u1, texel, pdf);
}

double envmap_pdf(const envmap_t *self, vec3_t w)
{
    return envmap_pdf_as(self, false, w);
}

vec3_t envmap_sample_as(const envmap_t *self, bool compensated, double u0, double u1, size_t *texel,
                        double *pdf)
{
    double u, v, p;
    distrib2d_sample(distribution(self, compensated), u0, u1, &u, &v, &p);
    *texel = texel_at(self, u, v);
    double jac = jacobian(self, v);
    /* At a lat-long pole the density over directions is unbounded: no sample (pdf 0). */
    *pdf = jac > 0.0 ? p / jac : 0.0;
    return uv_to_dir(self, u, v);
}

double envmap_pdf_as(const envmap_t *self, bool compensated, vec3_t w)
{
    double u, v;
    dir_to_uv(self, w, &u, &v);
    double jac = jacobian(self, v);
    return jac > 0.0 ? distrib2d_pdf(distribution(self, compensated), u, v) / jac : 0.0;
}

double envmap_mean_luminance(const envmap_t *self)
{
    return self->mean_y;
}

double envmap_upper_illuminance(const envmap_t *self)
{
    return self->upper_e;
}
