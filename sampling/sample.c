#include "sample.h"

#include <math.h>

#define SAMPLE_PI 3.14159265358979323846

/* sqrt of a quantity that is non-negative in exact arithmetic but may round to -1e-17. */
static inline double sqrt_safe(double x)
{
    return sqrt(fmax(x, 0.0));
}

/* fmin(fmax(u, 0), 1) as libm gives it (NaN -> 0, -0 stays -0), without its two calls. */
static inline double clamp01(double u)
{
    if (u > 0.0)
        return u < 1.0 ? u : 1.0;
    return u == 0.0 ? u : 0.0;
}

vec3_t sample_concentric_disk(double u1, double u2)
{
    /* Shirley and Chiu 1997: map the square [-1, 1]^2 to the disk wedge by wedge, with
     * r = a, phi = (pi / 4)(b / a) in the wedges where |a| > |b| and
     * r = b, phi = pi / 2 - (pi / 4)(a / b) otherwise. Concentric squares go to concentric
     * circles, so the map preserves area fractions (pdf 1 / pi). The division is by the larger
     * of |a|, |b|, which is zero only at the centre, handled first. */
    double a = 2.0 * clamp01(u1) - 1.0;
    double b = 2.0 * clamp01(u2) - 1.0;
    if (a == 0.0 && b == 0.0)
        return vec3_make(0.0, 0.0, 0.0);
    double r, phi;
    if (fabs(a) > fabs(b)) {
        r = a;
        phi = (SAMPLE_PI / 4.0) * (b / a);
    } else {
        r = b;
        phi = SAMPLE_PI / 2.0 - (SAMPLE_PI / 4.0) * (a / b);
    }
    return vec3_make(r * cos(phi), r * sin(phi), 0.0);
}

vec3_t sample_cosine_hemisphere(double u1, double u2)
{
    /* Malley's method: a uniform disk point (pdf 1 / pi per area) projected up to the
     * hemisphere has solid-angle pdf (1 / pi) cos(theta), since dA = cos(theta) dw. */
    vec3_t d = sample_concentric_disk(u1, u2);
    d.z = sqrt_safe(1.0 - d.x * d.x - d.y * d.y);
    return d;
}

double sample_cosine_hemisphere_pdf(double cos_theta)
{
    return cos_theta > 0.0 ? cos_theta / SAMPLE_PI : 0.0;
}

vec3_t sample_uniform_hemisphere(double u1, double u2)
{
    /* Archimedes: z uniform in [0, 1] gives uniform area on the hemisphere. */
    double z = clamp01(u1);
    double r = sqrt_safe(1.0 - z * z);
    double phi = 2.0 * SAMPLE_PI * clamp01(u2);
    return vec3_make(r * cos(phi), r * sin(phi), z);
}

double sample_uniform_hemisphere_pdf(void)
{
    return 1.0 / (2.0 * SAMPLE_PI);
}

vec3_t sample_uniform_sphere(double u1, double u2)
{
    /* Archimedes: z uniform in [-1, 1]. */
    double z = 1.0 - 2.0 * clamp01(u1);
    double r = sqrt_safe(1.0 - z * z);
    double phi = 2.0 * SAMPLE_PI * clamp01(u2);
    return vec3_make(r * cos(phi), r * sin(phi), z);
}

double sample_uniform_sphere_pdf(void)
{
    return 1.0 / (4.0 * SAMPLE_PI);
}

vec3_t sample_uniform_cone(double u1, double u2, double cos_theta_max)
{
    /* The solid angle of a cap is 2 pi (1 - cos theta), linear in cos theta, so cos theta
     * uniform in [cos_theta_max, 1] is uniform over the cap. Written as a lerp that gives
     * exactly 1 at u1 = 0 and exactly cos_theta_max at u1 = 1. */
    double cmax = fmin(fmax(cos_theta_max, -1.0), 1.0);
    double u = clamp01(u1);
    double z = (1.0 - u) + u * cmax;
    double r = sqrt_safe(1.0 - z * z);
    double phi = 2.0 * SAMPLE_PI * clamp01(u2);
    return vec3_make(r * cos(phi), r * sin(phi), z);
}

double sample_uniform_cone_pdf(double cos_theta_max)
{
    double cmax = fmin(fmax(cos_theta_max, -1.0), 1.0);
    double solid_angle = 2.0 * SAMPLE_PI * (1.0 - cmax);
    return solid_angle > 0.0 ? 1.0 / solid_angle : 0.0;
}

sample_bary_t sample_uniform_triangle(double u1, double u2)
{
    /* Heitz 2019: fold the square along its diagonal onto the triangle by halving the smaller
     * coordinate and shifting the other; the map has constant Jacobian (area preserving) and
     * needs no square root. b0 + b1 = max(u1, u2) <= 1, so b2 >= 0. */
    double x = clamp01(u1), y = clamp01(u2);
    double b0, b1;
    if (x < y) {
        b0 = x / 2.0;
        b1 = y - b0;
    } else {
        b1 = y / 2.0;
        b0 = x - b1;
    }
    return (sample_bary_t){b0, b1, fmax(1.0 - b0 - b1, 0.0)};
}

vec3_t sample_triangle_point(vec3_t p0, vec3_t p1, vec3_t p2, double u1, double u2)
{
    sample_bary_t b = sample_uniform_triangle(u1, u2);
    return vec3_add(vec3_add(vec3_scale(p0, b.b0), vec3_scale(p1, b.b1)), vec3_scale(p2, b.b2));
}

double sample_triangle_pdf(vec3_t p0, vec3_t p1, vec3_t p2)
{
    double area = 0.5 * vec3_length(vec3_cross(vec3_sub(p1, p0), vec3_sub(p2, p0)));
    double pdf = area > 0.0 ? 1.0 / area : 0.0;
    return isfinite(pdf) ? pdf : 0.0; /* a subnormal area would give 1 / area = Inf */
}

vec3_t sample_local_to_world(vec3_t local, vec3_t n)
{
    vec3_t t, b;
    vec3_basis(n, &t, &b);
    return vec3_add(vec3_add(vec3_scale(t, local.x), vec3_scale(b, local.y)),
                    vec3_scale(n, local.z));
}
