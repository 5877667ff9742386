#include "film.h"

#include "image_exr.h"
#include "image_png.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

int film_to_rgb(const tilebuf_t *image, spectral_grid_t grid, float *rgb, err_t *err)
{
    int w = tilebuf_width(image), h = tilebuf_height(image), nb = tilebuf_nbuckets(image);
    if (nb != grid.n)
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

int film_write(const tilebuf_t *image, spectral_grid_t grid, const film_output_t *out, err_t *err)
{
    int w = tilebuf_width(image), h = tilebuf_height(image), nb = tilebuf_nbuckets(image);
    size_t npix = (size_t)w * (size_t)h;
    float *rgb = malloc(npix * 3 * sizeof *rgb);
    if (!rgb)
        return err_set(err, "out of memory for a %dx%d image", w, h);
    int r = film_to_rgb(image, grid, rgb, err);
    if (!r && out->exr_path) {
        if (out->spectral) {
            float *spec = malloc(npix * (size_t)nb * sizeof *spec);
            double *centres = malloc((size_t)nb * sizeof *centres);
            double *mean = malloc((size_t)nb * sizeof *mean);
            if (!spec || !centres || !mean) {
                r = err_set(err, "out of memory for a %dx%d spectral image", w, h);
            } else {
                for (int b = 0; b < nb; b++)
                    centres[b] = spectral_grid_centre(grid, b);
                for (int y = 0; y < h; y++)
                    for (int x = 0; x < w; x++) {
                        tilebuf_mean(image, tilebuf_x0(image) + x, tilebuf_y0(image) + y, mean);
                        float *o = spec + ((size_t)y * (size_t)w + (size_t)x) * (size_t)nb;
                        for (int b = 0; b < nb; b++)
                            o[b] = (float)mean[b];
                    }
                r = image_exr_write_spectral(out->exr_path, w, h, rgb, spec, nb, centres, NULL,
                                             out->info, err);
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
    free(rgb);
    return r;
}
