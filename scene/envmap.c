#include "envmap.h"

#include "colour.h"
#include "distrib2d.h"
#include "equal_area.h"
#include "spectrum.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Table nodes per face side, minus one: the two non-maximal components of rgb / m, each in
 * [0, 1/2], on a (TABLE_RES + 1)^2 grid (pbrt-v4's RGBToSpectrumTable uses 64 per axis). */
#define TABLE_RES 64
#define NODES ((TABLE_RES + 1) * (TABLE_RES + 1))

struct envmap {
    int n;            /* width = height */
    double *coef;     /* per texel: c0, c1, c2 (lambda in nm) and m; m = 0 is black */
    distrib2d_t *dist;
    double mean_y, upper_e;
};

typedef struct table {
    double c[3][NODES][3];
    unsigned char done[3][NODES];
} table_t;

/* Face f (the maximal channel), node (i, j): the other two channels in order are i / (2 RES)
 * and j / (2 RES). Fitted on first use: a sky needs a few hundred of the 12675 nodes. */
static const double *table_node(table_t *t, int f, int i, int j, err_t *err)
{
    int k = i * (TABLE_RES + 1) + j;
    if (!t->done[f][k]) {
        double o[2] = {0.5 * i / TABLE_RES, 0.5 * j / TABLE_RES};
        double v[3];
        v[f] = 0.5;
        v[(f + 1) % 3 < (f + 2) % 3 ? (f + 1) % 3 : (f + 2) % 3] = o[0];
        v[(f + 1) % 3 < (f + 2) % 3 ? (f + 2) % 3 : (f + 1) % 3] = o[1];
        spectrum_sigmoid_t fit;
        if (spectrum_sigmoid_fit((rgb_t){v[0], v[1], v[2]}, &fit, err))
            return NULL;
        memcpy(t->c[f][k], fit.c, sizeof fit.c);
        t->done[f][k] = 1;
    }
    return t->c[f][k];
}

/* Coefficients of rgb (>= 0, not all 0) into out[0..3]. */
static int texel_coef(table_t *t, const float *rgb, double *out, err_t *err)
{
    double r = rgb[0], g = rgb[1], b = rgb[2];
    double mx = fmax(r, fmax(g, b));
    if (!(mx > 0.0)) {
        out[0] = out[1] = out[2] = out[3] = 0.0;
        return 0;
    }
    double m = 2.0 * mx;
    double u[3] = {r / m, g / m, b / m};
    int f = r >= g && r >= b ? 0 : (g >= b ? 1 : 2);
    int a = f == 0 ? 1 : 0, c = f == 2 ? 1 : 2; /* the other two channels, in order */
    if (u[a] == 0.5 && u[c] == 0.5) { /* grey: exactly flat */
        out[0] = out[1] = out[2] = 0.0;
        out[3] = m;
        return 0;
    }
    double x = u[a] * 2.0 * TABLE_RES, y = u[c] * 2.0 * TABLE_RES;
    int i = (int)x, j = (int)y;
    if (i >= TABLE_RES)
        i = TABLE_RES - 1;
    if (j >= TABLE_RES)
        j = TABLE_RES - 1;
    double dx = x - i, dy = y - j;
    const double *n00 = table_node(t, f, i, j, err), *n10 = n00 ? table_node(t, f, i + 1, j, err) : NULL;
    const double *n01 = n10 ? table_node(t, f, i, j + 1, err) : NULL;
    const double *n11 = n01 ? table_node(t, f, i + 1, j + 1, err) : NULL;
    if (!n11)
        return -1;
    for (int q = 0; q < 3; q++)
        out[q] = (1 - dx) * (1 - dy) * n00[q] + dx * (1 - dy) * n10[q] + (1 - dx) * dy * n01[q] +
                 dx * dy * n11[q];
    out[3] = m;
    return 0;
}

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
    table_t *t = calloc(1, sizeof *t);
    double *weights = malloc(n * sizeof *weights);
    if (!e || !t || !weights || !(e->coef = malloc(4 * n * sizeof *e->coef))) {
        err_set(err, "%s: out of memory for a %dx%d environment", name, w, h);
        goto fail;
    }
    e->n = w;
    double sum_y = 0.0, sum_e = 0.0;
    for (size_t i = 0; i < n; i++) {
        const float *p = rgb + 3 * i;
        if (texel_coef(t, p, e->coef + 4 * i, err))
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
    free(t);
    return e;
fail:
    free(weights);
    free(t);
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
    const double *c = self->coef + 4 * texel;
    if (c[0] == 0.0 && c[1] == 0.0 && c[2] == 0.0)
        return 0.5 * c[3];
    return c[3] * spectrum_sigmoid((c[0] * lambda + c[1]) * lambda + c[2]);
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
