#include "film.h"

#include "image_exr.h"
#include "image_png.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

int film_to_rgb(const tilebuf_t *image, spectral_grid_t grid, float *rgb, err_t *err)
{
    int w = tilebuf_width(image), h = tilebuf_height(image), nb = tilebuf_nbuckets(image);
    if (nb != grid.n && nb != 4 * grid.n)
        return err_set(err, "image has %d buckets, the grid %d", nb, grid.n);
    int x0 = tilebuf_x0(image), y0 = tilebuf_y0(image);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double m[3];
            tilebuf_xyz_mean(image, x0 + x, y0 + y, m);
            rgb_t c = colour_xyz_to_linear_srgb((xyz_t){m[0], m[1], m[2]});
            float *o = rgb + 3 * ((size_t)y * (size_t)w + (size_t)x);
            o[0] = (float)c.r;
            o[1] = (float)c.g;
            o[2] = (float)c.b;
        }
    return 0;
}

void film_png_path(const char *exr_path, char *buf, size_t size)
{
    size_t n = strlen(exr_path);
    if (n >= 4 && !strcmp(exr_path + n - 4, ".exr"))
        snprintf(buf, size, "%.*s.png", (int)(n - 4), exr_path);
    else
        snprintf(buf, size, "%s.png", exr_path);
}

static int has_ext(const char *name, size_t n, const char *ext)
{
    size_t e = strlen(ext);
    return n > e && !strcasecmp(name + n - e, ext);
}

void film_output_paths(const char *name, char *exr, size_t exr_size, char *png, size_t png_size,
                       int *other_format)
{
    static const char *OTHER[] = {".pfm", ".tga", ".jpg", ".jpeg", ".hdr", ".qoi"};
    size_t n = strlen(name);
    *other_format = 0;
    if (has_ext(name, n, ".png")) {
        snprintf(png, png_size, "%s", name);
        snprintf(exr, exr_size, "%.*s.exr", (int)(n - 4), name);
        return;
    }
    for (size_t i = 0; i < sizeof OTHER / sizeof OTHER[0]; i++)
        if (has_ext(name, n, OTHER[i])) {
            size_t stem = n - strlen(OTHER[i]);
            snprintf(exr, exr_size, "%.*s.exr", (int)stem, name);
            snprintf(png, png_size, "%.*s.png", (int)stem, name);
            *other_format = 1;
            return;
        }
    if (has_ext(name, n, ".exr")) {
        snprintf(exr, exr_size, "%s", name);
        snprintf(png, png_size, "%.*s.png", (int)(n - 4), name);
        return;
    }
    snprintf(exr, exr_size, "%s", name);
    film_png_path(name, png, png_size);
}

static int write_png(const char *path, int w, int h, const float *rgb, colour_tonemap_t tm,
                     err_t *err)
{
    size_t npix = (size_t)w * (size_t)h;
    unsigned char *px = malloc(npix * 3);
    if (!px)
        return err_set(err, "out of memory");
    for (size_t i = 0; i < npix; i++)
        colour_tonemap_to_srgb8(tm, (rgb_t){rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]}, px + 3 * i);
    int r = image_png_write_rgb(path, w, h, px, err);
    free(px);
    return r;
}

int film_png_from_exr(const char *exr_path, const char *png_path, colour_tonemap_t tonemap,
                      err_t *err)
{
    image_exr_t *img = image_exr_read(exr_path, err);
    if (!img)
        return -1;
    int r = write_png(png_path, image_exr_width(img), image_exr_height(img), image_exr_rgb(img),
                      tonemap, err);
    image_exr_destroy(&img);
    return r;
}

void film_stokes_preview_paths(const char *png_path, char *dop, size_t dop_size, char *aop,
                               size_t aop_size)
{
    size_t n = strlen(png_path);
    int stem = (int)(n >= 4 && !strcasecmp(png_path + n - 4, ".png") ? n - 4 : n);
    snprintf(dop, dop_size, "%.*s_dop.png", stem, png_path);
    snprintf(aop, aop_size, "%.*s_aop.png", stem, png_path);
}

/* HSV to RGB, hue h in [0, 6) sextants, s and v in [0, 1]. */
static void hsv_to_rgb(double h, double s, double v, double rgb[3])
{
    const int i = (int)h % 6;
    const double f = h - floor(h), p = v * (1.0 - s), q = v * (1.0 - s * f),
                 t = v * (1.0 - s * (1.0 - f));
    const double tab[6][3] = {{v, t, p}, {q, v, p}, {p, v, t}, {p, q, v}, {t, p, v}, {v, p, q}};
    for (int c = 0; c < 3; c++)
        rgb[c] = tab[i][c];
}

/* The previews of film_stokes_preview_paths from each pixel's Stokes planes summed over the
 * buckets (sum: w*h*4, S0-S3; the light of the film's whole range; the S0-S3 layers keep every
 * bucket). */
static int write_stokes_previews(int w, int h, const double *sum, const char *png_path, err_t *err)
{
    const size_t npix = (size_t)w * (size_t)h;
    unsigned char *dop = malloc(npix * 3), *aop = malloc(npix * 3);
    int r = 0;
    if (!dop || !aop)
        r = err_set(err, "out of memory for the polarisation previews");
    for (int y = 0; y < h && !r; y++)
        for (int x = 0; x < w; x++) {
            const double *s = sum + 4 * ((size_t)y * (size_t)w + (size_t)x);
            const double lin = s[0] > 0.0 ? fmin(1.0, sqrt(s[1] * s[1] + s[2] * s[2]) / s[0]) : 0.0;
            const double all =
                s[0] > 0.0 ? fmin(1.0, sqrt(s[1] * s[1] + s[2] * s[2] + s[3] * s[3]) / s[0]) : 0.0;
            const size_t i = 3 * ((size_t)y * (size_t)w + (size_t)x);
            dop[i] = dop[i + 1] = dop[i + 2] = (unsigned char)lrint(255.0 * all);
            /* Hue 2 * AoP (a full turn over 180 degrees of polarisation angle). */
            double hue = atan2(s[2], s[1]) / (2.0 * 3.14159265358979323846);
            hue = 6.0 * (hue - floor(hue));
            double rgb[3];
            hsv_to_rgb(hue, lin, lin, rgb);
            for (int c = 0; c < 3; c++)
                aop[i + (size_t)c] = (unsigned char)lrint(255.0 * rgb[c]);
        }
    char dop_path[1100], aop_path[1100];
    film_stokes_preview_paths(png_path, dop_path, sizeof dop_path, aop_path, sizeof aop_path);
    if (!r)
        r = image_png_write_rgb(dop_path, w, h, dop, err);
    if (!r)
        r = image_png_write_rgb(aop_path, w, h, aop, err);
    free(dop);
    free(aop);
    return r;
}

/* write_stokes_previews from the image's mean buckets (4 planes of nb), each rounded to the
 * float the EXR layer stores: the previews film_stokes_previews_from_exr makes from the EXR
 * (the farm's output path) are then these, byte for byte. */
static int image_stokes_previews(const tilebuf_t *image, int nb, const char *png_path, err_t *err)
{
    const int w = tilebuf_width(image), h = tilebuf_height(image);
    double *mean = malloc((size_t)nb * 4 * sizeof *mean);
    double *sum = calloc((size_t)w * (size_t)h * 4, sizeof *sum);
    if (!mean || !sum) {
        free(mean);
        free(sum);
        return err_set(err, "out of memory for the polarisation previews");
    }
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            tilebuf_mean(image, tilebuf_x0(image) + x, tilebuf_y0(image) + y, mean);
            double *s = sum + 4 * ((size_t)y * (size_t)w + (size_t)x);
            for (int k = 0; k < 4; k++)
                for (int b = 0; b < nb; b++)
                    s[k] += (double)(float)mean[k * nb + b]; /* as the EXR keeps it */
        }
    int r = write_stokes_previews(w, h, sum, png_path, err);
    free(mean);
    free(sum);
    return r;
}

int film_stokes_previews_from_exr(const char *exr_path, const char *png_path, err_t *err)
{
    image_exr_t *img = image_exr_read(exr_path, err);
    if (!img)
        return -1;
    const int w = image_exr_width(img), h = image_exr_height(img), nb = image_exr_n_spectral(img);
    const float *plane[4] = {image_exr_spectral(img), image_exr_stokes(img, 1),
                             image_exr_stokes(img, 2), image_exr_stokes(img, 3)};
    int r = 0;
    if (plane[1] && plane[2] && plane[3]) {
        const size_t npix = (size_t)w * (size_t)h;
        double *sum = calloc(npix * 4, sizeof *sum);
        if (!sum)
            r = err_set(err, "out of memory for the polarisation previews");
        for (size_t i = 0; i < npix && sum; i++)
            for (int k = 0; k < 4; k++)
                for (int b = 0; b < nb; b++)
                    sum[4 * i + (size_t)k] += (double)plane[k][i * (size_t)nb + (size_t)b];
        if (sum)
            r = write_stokes_previews(w, h, sum, png_path, err);
        free(sum);
    }
    image_exr_destroy(&img);
    return r;
}

int film_write(const tilebuf_t *image, spectral_grid_t grid, const film_output_t *out, err_t *err)
{
    int w = tilebuf_width(image), h = tilebuf_height(image), nb = tilebuf_nbuckets(image);
    const int planes = nb == 4 * grid.n && grid.n > 0 ? 4 : 1;
    size_t npix = (size_t)w * (size_t)h;
    float *rgb = malloc(npix * 3 * sizeof *rgb);
    if (!rgb)
        return err_set(err, "out of memory for a %dx%d image", w, h);
    int r = film_to_rgb(image, grid, rgb, err);
    if (!r && out->exr_path) {
        if (out->spectral || planes > 1) {
            float *spec = malloc(npix * (size_t)nb * sizeof *spec);
            double *centres = malloc((size_t)nb * sizeof *centres);
            double *mean = malloc((size_t)nb * sizeof *mean);
            if (!spec || !centres || !mean) {
                r = err_set(err, "out of memory for a %dx%d spectral image", w, h);
            } else {
                for (int b = 0; b < grid.n; b++)
                    centres[b] = spectral_grid_centre(grid, b);
                for (int y = 0; y < h; y++)
                    for (int x = 0; x < w; x++) {
                        tilebuf_mean(image, tilebuf_x0(image) + x, tilebuf_y0(image) + y, mean);
                        float *o = spec + ((size_t)y * (size_t)w + (size_t)x) * (size_t)nb;
                        for (int b = 0; b < nb; b++)
                            o[b] = (float)mean[b];
                    }
                r = image_exr_write_stokes(out->exr_path, w, h, rgb, spec, grid.n, planes, centres,
                                           NULL, out->info, err);
            }
            free(spec);
            free(centres);
            free(mean);
        } else {
            r = image_exr_write_rgb(out->exr_path, w, h, rgb, 3, out->info, err);
        }
    }
    if (!r && out->png_path)
        r = write_png(out->png_path, w, h, rgb, out->tonemap, err);
    if (!r && out->png_path && planes > 1)
        r = image_stokes_previews(image, grid.n, out->png_path, err);
    free(rgb);
    return r;
}
