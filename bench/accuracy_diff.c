/* bench_accuracy_diff: how far a rendered EXR is from a reference, for bench/accuracy.sh
 * (docs/accuracy.md). Compares the linear sRGB channels, so that images of any bucket count compare
 * with one reference, and prints one line of key=value figures:
 *   lum      relative RMSE of luminance, sqrt(mean_p (Y - Yr)^2) / mean_p Yr, over every pixel
 *            (the measured counterpart of the job's own estimate, docs/farm.md "Accuracy");
 *   col      relative colour error: the RMS over pixels of E = C - (Y / Yr) Cr (C the pixel's
 *            R, G, B; the part of its error that a change of brightness alone cannot explain,
 *            i.e. Y times the error of its chromaticity C / Y), per channel, over mean_p Yr;
 *            pixels with Yr below --min-lum times the mean are left out (C / Yr is unstable);
 *   y_ratio  mean Y / mean Yr and r_ratio, g_ratio, b_ratio likewise per channel: energy
 *            lost or gained, or a colour cast;
 *   est      the job's own relative error estimate (the EXR's "prismfarm" attribute rel_rmse),
 *            "-" when the file has none; spp its spp_done and stop why it stopped (none, target,
 *            time);
 *   nonfinite  pixels of the test image with a NaN or an infinity (left out of every sum);
 *   lum4     relative RMSE of luminance after a 4x4 box downsample (the mean of each whole block
 *            of 4x4 pixels; a partial block at the right or bottom edge is left out), over the
 *            mean block luminance of the reference: the figure of the corpus references' own
 *            noise in ../shared/pbrt-scenes/reference/REFERENCE.md ("seed-2 rel. RMSE 4x4"),
 *            which averages away the pixel filter's and the sampler's pixel-scale differences
 *            and keeps the errors a viewer sees; a block with a non-finite pixel is left out;
 *   lum4_se  lum4's standard error from the spread of the blocks' squared differences (large
 *            when a few blocks carry lum4), "-" when it cannot be computed (one block, no difference);
 * With a second reference (an independent render, another seed) the reference is the mean of
 * the two and the reference's own noise is printed as well: floor_lum and floor_col are the
 * same figures for the first half against the mean. A - (A + B) / 2 = (A - B) / 2 has the
 * variance 2 s^2 / 4 = s^2 / 2 of the mean itself when A and B are independent with variance
 * s^2; E is linear in A - ref for a fixed reference, so this holds for col as well.
 * With --worst N it then prints the N 4x4 blocks that add most to lum4, one a line (block's
 * pixel x, y, its mean luminance in TEST and in the reference), to find where two images differ.
 * usage: bench_accuracy_diff [--min-lum F] [--worst N] TEST.exr REF.exr [REF2.exr] */
#include "image_exr.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Rec. 709 / sRGB luminance of linear R, G, B (IEC 61966-2-1: the Y row of the sRGB to XYZ
 * matrix), the Y that colour.c's XYZ to linear sRGB conversion inverts. */
static double luminance(const float *c)
{
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
}

static bool finite3(const float *c)
{
    return isfinite(c[0]) && isfinite(c[1]) && isfinite(c[2]);
}

static image_exr_t *load(const char *path)
{
    err_t err;
    image_exr_t *img = image_exr_read(path, &err);
    if (!img)
        fprintf(stderr, "bench_accuracy_diff: %s\n", err.msg);
    return img;
}

/* The value of key in the "prismfarm" attribute's key=value;... text, into buf ("-" if none). */
static void info_value(const image_exr_t *img, const char *key, char *buf, size_t size)
{
    snprintf(buf, size, "-");
    const char *info = image_exr_attribute(img, "prismfarm");
    size_t klen = strlen(key);
    for (const char *p = info; p && *p;) {
        if (!strncmp(p, key, klen) && p[klen] == '=') {
            const char *v = p + klen + 1;
            size_t n = strcspn(v, ";");
            snprintf(buf, size, "%.*s", (int)n, v);
            return;
        }
        p = strchr(p, ';');
        if (p)
            p++;
    }
}

/* Keeps buf only if it is a finite number ("rel_rmse=none" when a job has no estimate yet). */
static void keep_number(char *buf, size_t size)
{
    char *end = NULL;
    double v = strtod(buf, &end);
    if (end == buf || *end || !isfinite(v))
        snprintf(buf, size, "-");
}

/* Sums of one image against the reference ref (3 floats a pixel). */
typedef struct sums {
    double sq_lum, sq_col, y, r, g, b;
    long n, n_col, nonfinite;
} sums_t;

static sums_t compare(const float *test, const float *ref, size_t npix, double min_y)
{
    sums_t s = {0};
    for (size_t i = 0; i < npix; i++) {
        const float *c = test + 3 * i, *cr = ref + 3 * i;
        if (!finite3(c)) {
            s.nonfinite++;
            continue;
        }
        if (!finite3(cr))
            continue;
        double y = luminance(c), yr = luminance(cr);
        s.sq_lum += (y - yr) * (y - yr);
        s.y += y;
        s.r += c[0];
        s.g += c[1];
        s.b += c[2];
        s.n++;
        if (yr > min_y) {
            double k = y / yr, e2 = 0.0;
            for (int j = 0; j < 3; j++)
                e2 += (c[j] - k * cr[j]) * (c[j] - k * cr[j]);
            s.sq_col += e2 / 3.0;
            s.n_col++;
        }
    }
    return s;
}

/* The luminance sums of the 4x4 block at pixel (bx, by) in test and ref (w pixels a row of 3
 * floats), over its finite pixels; false when one pixel of either is not finite. */
static bool block_sums(const float *test, const float *ref, int w, int bx, int by, double *yt,
                       double *yr)
{
    bool finite = true;
    *yt = *yr = 0.0;
    for (int y = by; y < by + 4; y++)
        for (int x = bx; x < bx + 4; x++) {
            size_t i = 3 * ((size_t)y * (size_t)w + (size_t)x);
            bool ft = finite3(test + i), fr = finite3(ref + i);
            finite = finite && ft && fr;
            *yt += ft ? luminance(test + i) : 0.0;
            *yr += fr ? luminance(ref + i) : 0.0;
        }
    return finite;
}

/* lum4 (above): blocks of 4x4 pixels of test against ref, w x h pixels of 3 floats; and in
 * *se its standard error, from the spread of the blocks' squared differences e_b: lum4^2 is
 * their mean over mean_Yr^2, whose standard error is sd(e_b) / sqrt(n) / mean_Yr^2, and
 * d lum4 = d(lum4^2) / (2 lum4). Where a few blocks (a glint, a small light's edge) carry
 * most of lum4 it is large: lum4 itself is then uncertain by tens of per cent. */
static double block_rmse(const float *test, const float *ref, int w, int h, double *se)
{
    double sq = 0.0, sq2 = 0.0, sum_r = 0.0;
    long n = 0;
    *se = NAN;
    for (int by = 0; by + 4 <= h; by += 4)
        for (int bx = 0; bx + 4 <= w; bx += 4) {
            double yt, yr;
            if (!block_sums(test, ref, w, bx, by, &yt, &yr))
                continue;
            double e = (yt - yr) * (yt - yr) / 256.0;
            sq += e;
            sq2 += e * e;
            sum_r += yr / 16.0;
            n++;
        }
    if (n == 0 || !(sum_r > 0.0))
        return NAN;
    double mean_r = sum_r / (double)n, q = sq / (double)n;
    double lum4 = sqrt(q) / mean_r;
    if (n > 1 && q > 0.0) {
        double var_e = fmax(0.0, (sq2 / (double)n - q * q) * (double)n / (double)(n - 1));
        *se = sqrt(var_e / (double)n) / (mean_r * mean_r) / (2.0 * lum4);
    }
    return lum4;
}

/* --worst: the n blocks of 4x4 pixels with the largest squared luminance difference. */
typedef struct block {
    double err, test, ref;
    int x, y;
} block_t;

static int block_by_err_desc(const void *pa, const void *pb)
{
    const block_t *a = pa, *b = pb;
    return a->err < b->err ? 1 : a->err > b->err ? -1 : 0;
}

static int print_worst_blocks(const float *test, const float *ref, int w, int h, int n)
{
    size_t nb = (size_t)(w / 4) * (size_t)(h / 4), k = 0;
    block_t *blocks = malloc((nb ? nb : 1) * sizeof *blocks);
    if (!blocks) {
        fprintf(stderr, "bench_accuracy_diff: out of memory\n");
        return -1;
    }
    for (int by = 0; by + 4 <= h; by += 4)
        for (int bx = 0; bx + 4 <= w; bx += 4) {
            double yt, yr;
            (void)block_sums(test, ref, w, bx, by, &yt, &yr); /* non-finite pixels count 0 */
            blocks[k++] = (block_t){(yt - yr) * (yt - yr), yt / 16.0, yr / 16.0, bx, by};
        }
    qsort(blocks, k, sizeof *blocks, block_by_err_desc);
    for (size_t i = 0; i < k && i < (size_t)n; i++)
        printf("block x=%d y=%d test=%.6g ref=%.6g\n", blocks[i].x, blocks[i].y, blocks[i].test,
               blocks[i].ref);
    free(blocks);
    return 0;
}

static double safe_div(double a, double b)
{
    return b != 0.0 && isfinite(a / b) ? a / b : NAN;
}

static void print_value(const char *key, double v)
{
    if (isfinite(v))
        printf(" %s=%.6g", key, v);
    else
        printf(" %s=-", key);
}

int main(int argc, char **argv)
{
    double min_lum = 0.01;
    long worst = 0;
    int a = 1;
    for (;;) {
        if (a + 1 < argc && !strcmp(argv[a], "--min-lum")) {
            min_lum = strtod(argv[a + 1], NULL);
            a += 2;
        } else if (a + 1 < argc && !strcmp(argv[a], "--worst")) {
            worst = strtol(argv[a + 1], NULL, 10);
            a += 2;
        } else {
            break;
        }
    }
    if (argc - a < 2 || argc - a > 3 || !(min_lum >= 0.0) || worst < 0 || worst > 1000000) {
        fprintf(stderr, "usage: bench_accuracy_diff [--min-lum F] [--worst N] TEST.exr REF.exr "
                        "[REF2.exr]\n");
        return 2;
    }
    int n_img = argc - a, rc = 1;
    image_exr_t *img[3] = {NULL, NULL, NULL};
    float *ref = NULL;
    for (int i = 0; i < n_img; i++)
        if (!(img[i] = load(argv[a + i])))
            goto done;
    int w = image_exr_width(img[0]), h = image_exr_height(img[0]);
    for (int i = 1; i < n_img; i++)
        if (image_exr_width(img[i]) != w || image_exr_height(img[i]) != h) {
            fprintf(stderr, "bench_accuracy_diff: %s is %dx%d, %s is %dx%d\n", argv[a], w, h,
                    argv[a + i], image_exr_width(img[i]), image_exr_height(img[i]));
            goto done;
        }
    size_t npix = (size_t)w * (size_t)h;
    ref = malloc(npix * 3 * sizeof *ref);
    if (!ref) {
        fprintf(stderr, "bench_accuracy_diff: out of memory\n");
        goto done;
    }
    const float *ra = image_exr_rgb(img[1]), *rb = n_img == 3 ? image_exr_rgb(img[2]) : ra;
    for (size_t i = 0; i < 3 * npix; i++)
        ref[i] = 0.5f * (ra[i] + rb[i]);

    double mean_yr = 0.0, mr[3] = {0.0, 0.0, 0.0};
    long n_ref = 0;
    for (size_t i = 0; i < npix; i++)
        if (finite3(ref + 3 * i)) {
            mean_yr += luminance(ref + 3 * i);
            for (int j = 0; j < 3; j++)
                mr[j] += ref[3 * i + j];
            n_ref++;
        }
    if (n_ref == 0 || !(mean_yr > 0.0)) {
        fprintf(stderr, "bench_accuracy_diff: the reference has no light (mean luminance <= 0)\n");
        goto done;
    }
    mean_yr /= (double)n_ref;
    for (int j = 0; j < 3; j++)
        mr[j] /= (double)n_ref;

    sums_t s = compare(image_exr_rgb(img[0]), ref, npix, min_lum * mean_yr);
    char est[64], spp[64], stop[64];
    info_value(img[0], "rel_rmse", est, sizeof est);
    keep_number(est, sizeof est);
    info_value(img[0], "spp_done", spp, sizeof spp);
    info_value(img[0], "stop", stop, sizeof stop);
    printf("lum=%.6g", safe_div(sqrt(safe_div(s.sq_lum, (double)s.n)), mean_yr));
    print_value("col", safe_div(sqrt(safe_div(s.sq_col, (double)s.n_col)), mean_yr));
    print_value("y_ratio", safe_div(s.y / (double)s.n, mean_yr));
    print_value("r_ratio", safe_div(s.r / (double)s.n, mr[0]));
    print_value("g_ratio", safe_div(s.g / (double)s.n, mr[1]));
    print_value("b_ratio", safe_div(s.b / (double)s.n, mr[2]));
    double lum4_se;
    print_value("lum4", block_rmse(image_exr_rgb(img[0]), ref, w, h, &lum4_se));
    print_value("lum4_se", lum4_se);
    printf(" est=%s spp=%s stop=%s nonfinite=%ld col_pixels=%ld", est, spp, stop, s.nonfinite,
           s.n_col);

    if (n_img == 3) {
        sums_t f = compare(ra, ref, npix, min_lum * mean_yr);
        print_value("floor_lum", safe_div(sqrt(safe_div(f.sq_lum, (double)f.n)), mean_yr));
        print_value("floor_col", safe_div(sqrt(safe_div(f.sq_col, (double)f.n_col)), mean_yr));
        info_value(img[1], "rel_rmse", est, sizeof est);
        keep_number(est, sizeof est);
        info_value(img[2], "rel_rmse", spp, sizeof spp);
        keep_number(spp, sizeof spp);
        printf(" ref_est=%s,%s", est, spp);
    }
    printf("\n");
    if (worst > 0 && print_worst_blocks(image_exr_rgb(img[0]), ref, w, h, (int)worst) != 0)
        goto done;
    rc = 0;
done:
    for (int i = 0; i < 3; i++)
        image_exr_destroy(&img[i]);
    free(ref);
    return rc;
}
