#include "equal_area.h"

#include <math.h>

static double clamp01(double x)
{
    return x > 0.0 ? (x < 1.0 ? x : 1.0) : 0.0; /* NaN reads as 0 */
}

/* With (u, v) in [-1, 1]^2: r = 1 - |1 - |u| - |v|| is the distance of the point from the
 * square's outer diamond border measured toward the centre, |z| = 1 - r^2 (equal area: the
 * diamond of "radius" r has area 2 r^2, the cap it maps to 2 pi (1 - |z|) -- both a fraction
 * r^2 / 2 of their whole), z's sign says inside (north) or outside (south) the diamond
 * |u| + |v| = 1, and phi in the first quadrant is (|v| - |u|) / r + 1 times pi / 4. */
vec3_t equal_area_square_to_sphere(double su, double sv)
{
    double u = 2.0 * clamp01(su) - 1.0, v = 2.0 * clamp01(sv) - 1.0;
    double up = fabs(u), vp = fabs(v);
    double sd = 1.0 - (up + vp);
    double r = 1.0 - fabs(sd);
    double phi = (r == 0.0 ? 1.0 : (vp - up) / r + 1.0) * (PF_PI / 4.0);
    double z = copysign(1.0 - r * r, sd);
    double s = r * sqrt(fmax(0.0, 2.0 - r * r));
    return vec3_make(copysign(cos(phi), u) * s, copysign(sin(phi), v) * s, z);
}

void equal_area_sphere_to_square(vec3_t d, double *su, double *sv)
{
    double len = sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
    if (!(len > 0.0) || !isfinite(len)) {
        *su = *sv = 0.5;
        return;
    }
    double x = fabs(d.x / len), y = fabs(d.y / len), az = fabs(d.z / len);
    double r = sqrt(fmax(0.0, 1.0 - az));
    /* phi / (pi / 2) in [0, 1] within the first quadrant; v = phi r, u = r - v there. */
    double t = (x == 0.0 && y == 0.0) ? 0.0 : atan2(y, x) / (PF_PI / 2.0);
    double v = t * r, u = r - v;
    if (d.z < 0.0) {
        /* The southern hemisphere: mirrored across the quadrant's diagonal u + v = 1. */
        double w = u;
        u = 1.0 - v;
        v = 1.0 - w;
    }
    u = copysign(u, d.x);
    v = copysign(v, d.y);
    *su = clamp01(0.5 * (u + 1.0));
    *sv = clamp01(0.5 * (v + 1.0));
}
