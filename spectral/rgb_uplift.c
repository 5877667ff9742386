#include "rgb_uplift.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define NODES ((RGB_UPLIFT_RES + 1) * (RGB_UPLIFT_RES + 1))

struct rgb_uplift {
    double c[3][NODES][3];
    unsigned char need[3][NODES]; /* 2: fitted (every node but in the bake's own build) */
};

#ifndef RGB_UPLIFT_BAKE
/* Every node's fit, made when prismfarm is built (spectral/bake/rgb_uplift_bake.c writes
 * rgb_uplift_table.c by rgb_uplift_bake_write below). */
extern const double rgb_uplift_baked[3][NODES][3];
#endif

rgb_uplift_t *rgb_uplift_new(err_t *err)
{
    rgb_uplift_t *t = calloc(1, sizeof *t);
    if (!t) {
        err_set(err, "out of memory for the RGB uplift table");
        return NULL;
    }
#ifndef RGB_UPLIFT_BAKE
    memcpy(t->c, rgb_uplift_baked, sizeof t->c);
    memset(t->need, 2, sizeof t->need);
#endif
    return t;
}

void rgb_uplift_destroy(rgb_uplift_t **self_p)
{
    if (!self_p)
        return;
    free(*self_p);
    *self_p = NULL;
}

/* Where rgb falls: face *f and the lower node (*i, *j) with the weights (*dx, *dy); returns
 * 0 for a colour that needs no node (black, grey), filling out[3] with m. */
static int locate(const float rgb[3], int *f, int *i, int *j, double *dx, double *dy, double *m)
{
    double r = rgb[0] > 0.0f ? rgb[0] : 0.0, g = rgb[1] > 0.0f ? rgb[1] : 0.0,
           b = rgb[2] > 0.0f ? rgb[2] : 0.0;
    double mx = fmax(r, fmax(g, b));
    *m = 2.0 * mx;
    if (!(mx > 0.0) || !isfinite(mx) || (r == g && g == b))
        return 0;
    double u[3] = {r / *m, g / *m, b / *m};
    *f = r >= g && r >= b ? 0 : (g >= b ? 1 : 2);
    int a = *f == 0 ? 1 : 0, c = *f == 2 ? 1 : 2;
    double x = u[a] * 2.0 * RGB_UPLIFT_RES, y = u[c] * 2.0 * RGB_UPLIFT_RES;
    *i = (int)x;
    *j = (int)y;
    if (*i >= RGB_UPLIFT_RES)
        *i = RGB_UPLIFT_RES - 1;
    if (*j >= RGB_UPLIFT_RES)
        *j = RGB_UPLIFT_RES - 1;
    *dx = x - *i;
    *dy = y - *j;
    return 1;
}

int rgb_uplift_coef(const rgb_uplift_t *t, const float rgb[3], double out[4], err_t *err)
{
    int f, i, j;
    double dx, dy, m;
    out[0] = out[1] = out[2] = 0.0;
    out[3] = 0.0;
    if (!locate(rgb, &f, &i, &j, &dx, &dy, &m)) {
        out[3] = isfinite(m) ? m : 0.0;
        return 0;
    }
    int k = i * (RGB_UPLIFT_RES + 1) + j;
    int ks[4] = {k, k + RGB_UPLIFT_RES + 1, k + 1, k + RGB_UPLIFT_RES + 2};
    for (int q = 0; q < 4; q++)
        if (t->need[f][ks[q]] != 2)
            return err_set(err, "RGB uplift table node (%d, %d) was not fitted", f, ks[q]);
    /* ks: (i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1) */
    const double *n00 = t->c[f][ks[0]], *n10 = t->c[f][ks[1]], *n01 = t->c[f][ks[2]],
                 *n11 = t->c[f][ks[3]];
    for (int q = 0; q < 3; q++)
        out[q] = (1 - dx) * (1 - dy) * n00[q] + dx * (1 - dy) * n10[q] + (1 - dx) * dy * n01[q] +
                 dx * dy * n11[q];
    out[3] = m;
    return 0;
}

#ifdef RGB_UPLIFT_BAKE
#include "pool.h"

/* Face f (the maximal channel), node k = i (RES + 1) + j: the other two channels, in order,
 * are i / (2 RES) and j / (2 RES); the maximal one is 1/2. */
static int fit_node(rgb_uplift_t *t, int f, int k, err_t *err)
{
    int i = k / (RGB_UPLIFT_RES + 1), j = k % (RGB_UPLIFT_RES + 1);
    double v[3];
    int a = f == 0 ? 1 : 0, c = f == 2 ? 1 : 2;
    v[f] = 0.5;
    v[a] = 0.5 * i / RGB_UPLIFT_RES;
    v[c] = 0.5 * j / RGB_UPLIFT_RES;
    spectrum_sigmoid_t fit;
    if (spectrum_sigmoid_fit((rgb_t){v[0], v[1], v[2]}, &fit, err))
        return -1;
    memcpy(t->c[f][k], fit.c, sizeof fit.c);
    t->need[f][k] = 2;
    return 0;
}

static int fit_one(void *user, int index, err_t *err)
{
    return fit_node(user, index / NODES, index % NODES, err);
}

int rgb_uplift_bake_write(FILE *f, int threads, err_t *err)
{
    rgb_uplift_t *t = rgb_uplift_new(err);
    if (!t)
        return -1;
    if (pool_for(threads, 3 * NODES, fit_one, t, err) < 0) {
        rgb_uplift_destroy(&t);
        return -1;
    }
    fprintf(
        f,
        "/* The RGB uplift table (rgb_uplift.h): every node's sigmoid fit, written when prismfarm\n"
        " * is built by spectral/bake/rgb_uplift_bake.c. Generated: do not edit. */\n"
        "#include \"rgb_uplift.h\"\n\n"
        "const double rgb_uplift_baked[3][(RGB_UPLIFT_RES + 1) * (RGB_UPLIFT_RES + 1)][3];\n"
        "const double rgb_uplift_baked[3][(RGB_UPLIFT_RES + 1) * (RGB_UPLIFT_RES + 1)][3] = {\n");
    for (int fc = 0; fc < 3; fc++) {
        fprintf(f, "    {\n");
        for (int k = 0; k < NODES; k++)
            fprintf(f, "        {%a, %a, %a},\n", t->c[fc][k][0], t->c[fc][k][1], t->c[fc][k][2]);
        fprintf(f, "    },\n");
    }
    fprintf(f, "};\n");
    rgb_uplift_destroy(&t);
    return ferror(f) ? err_set(err, "cannot write the table") : 0;
}
#endif
