#include "microfacet.h"

#include <float.h>
#include <math.h>

double microfacet_roughness_to_alpha(double roughness)
{
    return roughness > 0.0 && isfinite(roughness) ? sqrt(roughness) : 0.0;
}

static double clean_roughness(double r)
{
    return r > 0.0 && isfinite(r) ? r : 0.0;
}

microfacet_t microfacet_make(double uroughness, double vroughness, bool remap)
{
    double u = clean_roughness(uroughness), v = clean_roughness(vroughness);
    if (remap) {
        u = microfacet_roughness_to_alpha(u);
        v = microfacet_roughness_to_alpha(v);
    }
    return (microfacet_t){u, v};
}

bool microfacet_smooth(const microfacet_t *m)
{
    return fmax(m->alpha_x, m->alpha_y) < MICROFACET_SMOOTH_ALPHA;
}

/* cos^2 phi and sin^2 phi of w's azimuth; the pole (x = y = 0) reads as phi = 0. */
static void azimuth2(vec3_t w, double *cos2, double *sin2)
{
    double r2 = w.x * w.x + w.y * w.y;
    if (r2 > 0.0) {
        *cos2 = w.x * w.x / r2;
        *sin2 = w.y * w.y / r2;
    } else {
        *cos2 = 1.0;
        *sin2 = 0.0;
    }
}

/* Trowbridge & Reitz 1975, anisotropic form (Heitz 2014, "Understanding the Masking-Shadowing
 * Function", eq. 85; pbrt-v4 eq. 9.16):
 *   D(wm) = 1 / (pi ax ay cos^4 (1 + tan^2 (cos^2 phi / ax^2 + sin^2 phi / ay^2))^2).
 * Written with the squared tangential components over alpha^2 instead of tan and phi, it
 * is the same expression without the 0/0 at the pole:
 *   D = 1 / (pi ax ay (x^2/ax^2 + y^2/ay^2 + z^2)^2) for unit wm. */
double microfacet_d(const microfacet_t *m, vec3_t wm)
{
    double ax = m->alpha_x, ay = m->alpha_y;
    if (!(ax > 0.0) || !(ay > 0.0))
        return 0.0;
    double z2 = wm.z * wm.z;
    /* pbrt-v4 returns 0 for normals within ~1e-4 rad of the plane (cos^4 < 1e-16), where the
     * density is negligible and the cos^4 in pbrt's form would underflow. */
    if (z2 * z2 < 1e-16)
        return 0.0;
    double s = (wm.x / ax) * (wm.x / ax) + (wm.y / ay) * (wm.y / ay) + z2;
    double d = 1.0 / (PF_PI * ax * ay * s * s);
    return isfinite(d) ? d : 0.0;
}

/* Smith's Lambda for GGX (Heitz 2014 eq. 86): (-1 + sqrt(1 + alpha(phi)^2 tan^2 theta)) / 2
 * with alpha(phi)^2 = cos^2 phi ax^2 + sin^2 phi ay^2. In the plane (tan = Inf) pbrt-v4
 * returns 0; every caller rejects such directions first (their cosine is 0). */
double microfacet_lambda(const microfacet_t *m, vec3_t w)
{
    double z2 = w.z * w.z;
    double sin2 = fmax(0.0, w.x * w.x + w.y * w.y);
    if (z2 == 0.0)
        return 0.0;
    double tan2 = sin2 / z2;
    if (!isfinite(tan2))
        return 0.0;
    double c2, s2;
    azimuth2(w, &c2, &s2);
    double alpha2 = c2 * m->alpha_x * m->alpha_x + s2 * m->alpha_y * m->alpha_y;
    double l = 0.5 * (-1.0 + sqrt(1.0 + alpha2 * tan2));
    return isfinite(l) ? l : DBL_MAX;
}

double microfacet_g1(const microfacet_t *m, vec3_t w)
{
    return 1.0 / (1.0 + microfacet_lambda(m, w));
}

/* Height-correlated Smith masking-shadowing (Heitz 2014 eq. 99). */
double microfacet_g(const microfacet_t *m, vec3_t wo, vec3_t wi)
{
    double l = microfacet_lambda(m, wo) + microfacet_lambda(m, wi);
    return 1.0 / (1.0 + fmin(l, DBL_MAX));
}

/* Visible normals (Heitz 2014 eq. 38): D_w(wm) = G1(w) max(0, w.wm) D(wm) / cos(w), with w
 * taken on the +z side (a direction below the surface sees the flipped distribution). */
double microfacet_pdf(const microfacet_t *m, vec3_t w, vec3_t wm)
{
    if (w.z < 0.0)
        w = vec3_neg(w);
    if (!(w.z > 0.0))
        return 0.0;
    double p = microfacet_d(m, wm) * microfacet_g1(m, w) * fmax(0.0, vec3_dot(w, wm)) / w.z;
    return isfinite(p) ? p : 0.0;
}

/* Heitz 2018, "Sampling the GGX Distribution of Visible Normals" (JCGT 7(4)), listing 1:
 * stretch w to the alpha = 1 configuration, sample the projected hemisphere of normals there
 * as a disk warped towards the visible half, lift it to the hemisphere and unstretch. */
vec3_t microfacet_sample_wm(const microfacet_t *m, vec3_t w, double u1, double u2)
{
    u1 = fmin(fmax(u1, 0.0), 1.0);
    u2 = fmin(fmax(u2, 0.0), 1.0);
    vec3_t wh = vec3_normalize(vec3_make(m->alpha_x * w.x, m->alpha_y * w.y, w.z));
    if (wh.z < 0.0)
        wh = vec3_neg(wh);
    if (vec3_dot(wh, wh) == 0.0)
        wh = vec3_make(0.0, 0.0, 1.0);
    /* The orthonormal frame (t1, t2, wh); at the pole any tangent will do. */
    double lensq = wh.x * wh.x + wh.y * wh.y;
    vec3_t t1 = lensq > 1e-20 ? vec3_scale(vec3_make(-wh.y, wh.x, 0.0), 1.0 / sqrt(lensq))
                              : vec3_make(1.0, 0.0, 0.0);
    vec3_t t2 = vec3_cross(wh, t1);
    /* Uniform polar disk point (eq. in listing 1), its t2 coordinate compressed onto the part
     * of the disk where the normals face wh: p2 = lerp(s, sqrt(1 - p1^2), p2), s = (1 + wh.z)/2. */
    double r = sqrt(u1), phi = 2.0 * PF_PI * u2;
    double p1 = r * cos(phi), p2 = r * sin(phi);
    double s = 0.5 * (1.0 + wh.z);
    double h = sqrt(fmax(0.0, 1.0 - p1 * p1));
    p2 = (1.0 - s) * h + s * p2;
    double p3 = sqrt(fmax(0.0, 1.0 - p1 * p1 - p2 * p2));
    vec3_t nh = vec3_add(vec3_add(vec3_scale(t1, p1), vec3_scale(t2, p2)), vec3_scale(wh, p3));
    /* Back to the ellipsoid (eq. 10 of the listing), kept strictly above the plane. */
    vec3_t wm = vec3_make(m->alpha_x * nh.x, m->alpha_y * nh.y, fmax(1e-6, nh.z));
    return vec3_normalize(wm);
}
