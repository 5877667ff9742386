#include "colour.h"

#include <math.h>

/* IEC 61966-2-1:1999 matrices (data/srgb_matrices.txt). SRGB_TO_XYZ is the standard's
 * 4-decimal matrix and XYZ_TO_SRGB its inverse to 8 decimals (the 4-decimal inverse printed
 * beside it, 3.2406 ..., is this one rounded), so the pair round-trips: their product is the
 * identity to 4e-9. (Derived afresh from the primaries and the white point, the inverse would
 * be 3.24096994 ..., different in the fourth decimal: data/README.md.) */
static const double XYZ_TO_SRGB[3][3] = {
    {3.24062548, -1.53720797, -0.49862860},
    {-0.96893071, 1.87575606, 0.04151752},
    {0.05571012, -0.20402105, 1.05699594},
};
static const double SRGB_TO_XYZ[3][3] = {
    {0.4124, 0.3576, 0.1805},
    {0.2126, 0.7152, 0.0722},
    {0.0193, 0.1192, 0.9505},
};

void colour_grid_weights(spectral_grid_t grid, xyz_t *weights)
{
    for (int i = 0; i < grid.n; i++) {
        xyz_t w =
            cie_cmf_integrate(spectral_grid_bucket_min(grid, i), spectral_grid_bucket_max(grid, i));
        weights[i] = (xyz_t){w.x / CIE_Y_INTEGRAL, w.y / CIE_Y_INTEGRAL, w.z / CIE_Y_INTEGRAL};
    }
}

xyz_t colour_buckets_to_xyz_weighted(int n, const xyz_t *weights, const double *buckets)
{
    xyz_t sum = {0.0, 0.0, 0.0};
    for (int i = 0; i < n; i++) {
        sum.x += buckets[i] * weights[i].x;
        sum.y += buckets[i] * weights[i].y;
        sum.z += buckets[i] * weights[i].z;
    }
    return sum;
}

xyz_t colour_buckets_to_xyz(spectral_grid_t grid, const double *buckets)
{
    xyz_t sum = {0.0, 0.0, 0.0};
    for (int i = 0; i < grid.n; i++) {
        xyz_t w =
            cie_cmf_integrate(spectral_grid_bucket_min(grid, i), spectral_grid_bucket_max(grid, i));
        sum.x += buckets[i] * w.x;
        sum.y += buckets[i] * w.y;
        sum.z += buckets[i] * w.z;
    }
    return (xyz_t){sum.x / CIE_Y_INTEGRAL, sum.y / CIE_Y_INTEGRAL, sum.z / CIE_Y_INTEGRAL};
}

rgb_t colour_xyz_to_linear_srgb(xyz_t c)
{
    const double(*m)[3] = XYZ_TO_SRGB;
    return (rgb_t){m[0][0] * c.x + m[0][1] * c.y + m[0][2] * c.z,
                   m[1][0] * c.x + m[1][1] * c.y + m[1][2] * c.z,
                   m[2][0] * c.x + m[2][1] * c.y + m[2][2] * c.z};
}

xyz_t colour_linear_srgb_to_xyz(rgb_t c)
{
    const double(*m)[3] = SRGB_TO_XYZ;
    return (xyz_t){m[0][0] * c.r + m[0][1] * c.g + m[0][2] * c.b,
                   m[1][0] * c.r + m[1][1] * c.g + m[1][2] * c.b,
                   m[2][0] * c.r + m[2][1] * c.g + m[2][2] * c.b};
}

double colour_luminance(rgb_t c)
{
    return SRGB_TO_XYZ[1][0] * c.r + SRGB_TO_XYZ[1][1] * c.g + SRGB_TO_XYZ[1][2] * c.b;
}

int colour_xyz_to_xy(xyz_t c, double *x, double *y)
{
    double sum = c.x + c.y + c.z;
    if (!(sum > 0.0) || !isfinite(sum)) {
        *x = 0.3127;
        *y = 0.3290;
        return -1;
    }
    *x = c.x / sum;
    *y = c.y / sum;
    return 0;
}

static double clamp01(double v)
{
    if (!(v > 0.0)) /* also NaN */
        return 0.0;
    return v < 1.0 ? v : 1.0;
}

double colour_srgb_encode(double linear)
{
    double l = clamp01(linear);
    return l <= 0.0031308 ? 12.92 * l : 1.055 * pow(l, 1.0 / 2.4) - 0.055;
}

double colour_srgb_decode(double encoded)
{
    double v = clamp01(encoded);
    return v <= 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4);
}

static int rgb_finite(rgb_t c)
{
    return isfinite(c.r) && isfinite(c.g) && isfinite(c.b);
}

/* Largest t in [0, 1] keeping y + t (v - y) inside [0, 1], for 0 < y < 1. */
static double clip_factor(double v, double y, double t)
{
    if (v > 1.0) {
        double f = (1.0 - y) / (v - y);
        return f < t ? f : t;
    }
    if (v < 0.0) {
        double f = y / (y - v);
        return f < t ? f : t;
    }
    return t;
}

rgb_t colour_gamut_clip(rgb_t c)
{
    if (!rgb_finite(c))
        return (rgb_t){0.0, 0.0, 0.0};
    double y = colour_luminance(c);
    if (!(y > 0.0))
        return (rgb_t){0.0, 0.0, 0.0};
    if (y >= 1.0)
        return (rgb_t){1.0, 1.0, 1.0};
    double t = 1.0;
    t = clip_factor(c.r, y, t);
    t = clip_factor(c.g, y, t);
    t = clip_factor(c.b, y, t);
    /* The mix is exact in real arithmetic; clamp the last ulp of rounding. */
    return (rgb_t){clamp01(y + t * (c.r - y)), clamp01(y + t * (c.g - y)),
                   clamp01(y + t * (c.b - y))};
}

static double tone_curve(colour_curve_t curve, double y)
{
    switch (curve) {
    case COLOUR_CURVE_ACES: {
        double v = (y * (2.51 * y + 0.03)) / (y * (2.43 * y + 0.59) + 0.14);
        return v < 1.0 ? v : 1.0;
    }
    case COLOUR_CURVE_REINHARD:
        return y / (1.0 + y);
    case COLOUR_CURVE_CLIP:
        break;
    }
    return y;
}

rgb_t colour_tonemap_apply(colour_tonemap_t tm, rgb_t c)
{
    double k = exp2(tm.exposure_stops);
    if (!rgb_finite(c) || !isfinite(k))
        return (rgb_t){0.0, 0.0, 0.0};
    c = (rgb_t){c.r * k, c.g * k, c.b * k};
    if (!rgb_finite(c))
        return (rgb_t){0.0, 0.0, 0.0};
    double y = colour_luminance(c);
    if (!(y > 0.0))
        return (rgb_t){0.0, 0.0, 0.0};
    double ratio = tone_curve(tm.curve, y) / y;
    return colour_gamut_clip((rgb_t){c.r * ratio, c.g * ratio, c.b * ratio});
}

void colour_tonemap_to_srgb8(colour_tonemap_t tm, rgb_t c, unsigned char out[3])
{
    rgb_t d = colour_tonemap_apply(tm, c);
    double v[3] = {d.r, d.g, d.b};
    for (int i = 0; i < 3; i++) {
        double q = floor(colour_srgb_encode(v[i]) * 255.0 + 0.5);
        out[i] = (unsigned char)(q < 0.0 ? 0.0 : q > 255.0 ? 255.0 : q);
    }
}
