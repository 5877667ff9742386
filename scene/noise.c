#include "noise.h"

#include <math.h>

/* Ken Perlin's permutation of 0..255 ("Improving Noise", SIGGRAPH 2002, the reference
 * implementation's p[]), the table pbrt-v4's NoisePerm repeats; indexed modulo 256 here. */
static const unsigned char PERM[256] = {
    151, 160, 137, 91,  90,  15,  131, 13,  201, 95,  96,  53,  194, 233, 7,   225, 140, 36,  103,
    30,  69,  142, 8,   99,  37,  240, 21,  10,  23,  190, 6,   148, 247, 120, 234, 75,  0,   26,
    197, 62,  94,  252, 219, 203, 117, 35,  11,  32,  57,  177, 33,  88,  237, 149, 56,  87,  174,
    20,  125, 136, 171, 168, 68,  175, 74,  165, 71,  134, 139, 48,  27,  166, 77,  146, 158, 231,
    83,  111, 229, 122, 60,  211, 133, 230, 220, 105, 92,  41,  55,  46,  245, 40,  244, 102, 143,
    54,  65,  25,  63,  161, 1,   216, 80,  73,  209, 76,  132, 187, 208, 89,  18,  169, 200, 196,
    135, 130, 116, 188, 159, 86,  164, 100, 109, 198, 173, 186, 3,   64,  52,  217, 226, 250, 124,
    123, 5,   202, 38,  147, 118, 126, 255, 82,  85,  212, 207, 206, 59,  227, 47,  16,  58,  17,
    182, 189, 28,  42,  223, 183, 170, 213, 119, 248, 152, 2,   44,  154, 163, 70,  221, 153, 101,
    155, 167, 43,  172, 9,   129, 22,  39,  253, 19,  98,  108, 110, 79,  113, 224, 232, 178, 185,
    112, 104, 218, 246, 97,  228, 251, 34,  242, 193, 238, 210, 144, 12,  191, 179, 162, 241, 81,
    51,  145, 235, 249, 14,  239, 107, 49,  192, 214, 31,  181, 199, 106, 157, 184, 84,  204, 176,
    115, 121, 50,  45,  127, 4,   150, 254, 138, 236, 205, 93,  222, 114, 67,  29,  24,  72,  243,
    141, 128, 195, 78,  66,  215, 61,  156, 180};

/* The lattice point's hash picks one of Perlin's 12 edge gradients (16 entries, four of them
 * repeated); the weight is that gradient's dot product with the offset from the point. */
static double grad(int x, int y, int z, double dx, double dy, double dz)
{
    int h = PERM[(PERM[(PERM[x & 255] + y) & 255] + z) & 255] & 15;
    double u = h < 8 || h == 12 || h == 13 ? dx : dy;
    double v = h < 4 || h == 12 || h == 13 ? dy : dz;
    return ((h & 1) ? -u : u) + ((h & 2) ? -v : v);
}

/* Perlin's quintic fade 6t^5 - 15t^4 + 10t^3: zero first and second derivatives at 0 and 1. */
static double fade(double t)
{
    return t * t * t * (t * (6.0 * t - 15.0) + 10.0);
}

static double lerp(double t, double a, double b)
{
    return a + t * (b - a);
}

double noise_perlin(vec3_t p)
{
    const double wrap = 1073741824.0; /* 2^30: the cell index fits an int */
    double x = fmod(p.x, wrap), y = fmod(p.y, wrap), z = fmod(p.z, wrap);
    if (!isfinite(x) || !isfinite(y) || !isfinite(z))
        return 0.0;
    double fx = floor(x), fy = floor(y), fz = floor(z);
    int ix = (int)fx & 255, iy = (int)fy & 255, iz = (int)fz & 255;
    double dx = x - fx, dy = y - fy, dz = z - fz;
    double w000 = grad(ix, iy, iz, dx, dy, dz);
    double w100 = grad(ix + 1, iy, iz, dx - 1, dy, dz);
    double w010 = grad(ix, iy + 1, iz, dx, dy - 1, dz);
    double w110 = grad(ix + 1, iy + 1, iz, dx - 1, dy - 1, dz);
    double w001 = grad(ix, iy, iz + 1, dx, dy, dz - 1);
    double w101 = grad(ix + 1, iy, iz + 1, dx - 1, dy, dz - 1);
    double w011 = grad(ix, iy + 1, iz + 1, dx, dy - 1, dz - 1);
    double w111 = grad(ix + 1, iy + 1, iz + 1, dx - 1, dy - 1, dz - 1);
    double wx = fade(dx), wy = fade(dy), wz = fade(dz);
    double y0 = lerp(wy, lerp(wx, w000, w100), lerp(wx, w010, w110));
    double y1 = lerp(wy, lerp(wx, w001, w101), lerp(wx, w011, w111));
    return lerp(wz, y0, y1);
}

double noise_fbm(vec3_t p, double omega, int octaves)
{
    double sum = 0.0, freq = 1.0, o = 1.0;
    for (int i = 0; i < octaves; i++) {
        sum += o * noise_perlin(vec3_scale(p, freq));
        freq *= 1.99;
        o *= omega;
    }
    return sum;
}

double noise_turbulence(vec3_t p, double omega, int octaves)
{
    double sum = 0.0, freq = 1.0, o = 1.0;
    for (int i = 0; i < octaves; i++) {
        sum += o * fabs(noise_perlin(vec3_scale(p, freq)));
        freq *= 1.99;
        o *= omega;
    }
    return sum + 0.2 * o;
}
