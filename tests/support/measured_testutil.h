/* measured_testutil: RGL-layout measured BSDF files (bsdf/measured.h) made from an analytic
 * model, so that the tests need no measured file: a GGX conductor, isotropic or not, whose
 * complex index varies with wavelength, tabulated the way Dupuy & Jakob 2018 lay
 * their files out (the fields pbrt-v4's MeasuredBxDFData reads):
 *   ndf(u)      = D(wm(u)) over wm's (theta2u, phi2u), phi relative to wo's in an isotropic file;
 *   sigma(u)    = projected area (cos + sqrt(cos^2 + alpha(phi)^2 sin^2)) / 2 of wo(u);
 *   vndf        = D_wo(wm) 2 pi^2 u sin(theta_m), the visible normals' density over the square;
 *   luminance   = F G2 / G1(wo) at the wm the vndf warp gives each grid point (f cos over the
 *                 vndf's density of wi), 0 where wi falls below the surface;
 *   spectra     = R = f 4 sigma cos(theta_i) / D = F(lambda) G2 / G1(wo) at the same points.
 * Header-only (each test is its own executable); the caller frees the bytes. */
#ifndef PRISMFARM_MEASURED_TESTUTIL_H
#define PRISMFARM_MEASURED_TESTUTIL_H

#include "fresnel.h"
#include "le_bytes.h"
#include "microfacet.h"
#include "plinear2d.h"
#include "vec3.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* The conductor's index at lambda nm: a made-up smooth spectrum, reddish like copper. */
static inline void measured_testutil_index(double lambda, double *eta, double *k)
{
    const double t = (lambda - 380.0) / 400.0;
    *eta = 1.2 - 0.9 * t;
    *k = 2.2 + 1.6 * t;
}

typedef struct measured_testutil_field {
    const char *name;
    uint8_t type; /* 1 uint8, 10 float32 */
    int ndim;
    uint64_t shape[5];
    const void *data; /* floats (host order) or bytes */
} measured_testutil_field_t;

/* The tensor file of the fields, into a malloc'ed buffer. */
static inline uint8_t *measured_testutil_pack(const measured_testutil_field_t *f, int n,
                                              size_t *len)
{
    size_t header = 12 + 2 + 4, body = 0;
    for (int i = 0; i < n; i++) {
        uint64_t count = 1;
        for (int d = 0; d < f[i].ndim; d++)
            count *= f[i].shape[d];
        header += 2 + strlen(f[i].name) + 2 + 1 + 8 + 8 * (size_t)f[i].ndim;
        body += count * (f[i].type == 10 ? 4 : 1);
    }
    uint8_t *buf = calloc(1, header + body), *p = buf;
    if (!buf)
        return NULL;
    memcpy(p, "tensor_file", 12);
    p[12] = 1;
    p[13] = 0;
    le_put_u32(p + 14, (uint32_t)n);
    p += 18;
    size_t offset = header;
    for (int i = 0; i < n; i++) {
        uint64_t count = 1;
        for (int d = 0; d < f[i].ndim; d++)
            count *= f[i].shape[d];
        const size_t nl = strlen(f[i].name);
        le_put_u16(p, (uint16_t)nl);
        memcpy(p + 2, f[i].name, nl);
        p += 2 + nl;
        le_put_u16(p, (uint16_t)f[i].ndim);
        p[2] = f[i].type;
        le_put_u64(p + 3, offset);
        p += 11;
        for (int d = 0; d < f[i].ndim; d++, p += 8)
            le_put_u64(p, f[i].shape[d]);
        if (f[i].type == 10)
            for (uint64_t j = 0; j < count; j++)
                le_put_f32(buf + offset + 4 * j, ((const float *)f[i].data)[j]);
        else
            memcpy(buf + offset, f[i].data, count);
        offset += count * (f[i].type == 10 ? 4 : 1);
    }
    *len = header + body;
    return buf;
}

/* The GGX conductor of roughness alpha_x, alpha_y over np outgoing azimuths (1: an isotropic
 * file, whose wm azimuths are relative to wo's; more: phi_i spans -pi to pi and the azimuths
 * are absolute), nt incident angles, an n x n grid and nl wavelengths over 380-780 nm. */
static inline uint8_t *measured_testutil_ggx_aniso(double alpha_x, double alpha_y, int np, int nt,
                                                   int n, int nl, size_t *len)
{
    const double pi = PF_PI;
    const microfacet_t mf = {alpha_x, alpha_y};
    const size_t g = (size_t)n * n, slices = (size_t)np * nt;
    float *theta = malloc(nt * sizeof(float)), *phi = malloc(np * sizeof(float));
    float *wl = malloc(nl * sizeof(float));
    float *ndf = malloc(g * sizeof(float)), *sigma = malloc(g * sizeof(float));
    float *vndf = malloc(slices * g * sizeof(float)), *lum = malloc(slices * g * sizeof(float));
    float *spec = malloc(slices * nl * g * sizeof(float));
    for (int i = 0; i < nt; i++)
        theta[i] = (float)(1.45 * i / (nt - 1)); /* 0 to 83 degrees */
    for (int p = 0; p < np; p++)
        phi[p] = np == 1 ? 0.0f : (float)(-pi + 2.0 * pi * p / (np - 1));
    for (int l = 0; l < nl; l++)
        wl[l] = (float)(380.0 + 400.0 * l / (nl > 1 ? nl - 1 : 1));
    for (int y = 0; y < n; y++)
        for (int x = 0; x < n; x++) {
            const double ux = (double)x / (n - 1), uy = (double)y / (n - 1);
            const double th = ux * ux * 0.5 * pi, ph = (2.0 * uy - 1.0) * pi;
            const vec3_t w = vec3_make(sin(th) * cos(ph), sin(th) * sin(ph), cos(th));
            ndf[y * n + x] = (float)microfacet_d(&mf, w);
            /* (1 + Lambda) cos theta, finite at the horizon */
            const double c = cos(th), s2 = 1.0 - c * c;
            const double a2 =
                alpha_x * alpha_x * cos(ph) * cos(ph) + alpha_y * alpha_y * sin(ph) * sin(ph);
            sigma[y * n + x] = (float)(0.5 * (c + sqrt(c * c + a2 * s2)));
        }
    for (size_t sl = 0; sl < slices; sl++) {
        const double ph_o = phi[sl / nt], th_o = theta[sl % nt];
        const vec3_t wo = vec3_make(sin(th_o) * cos(ph_o), sin(th_o) * sin(ph_o), cos(th_o));
        /* An isotropic file's wm azimuths are relative to wo's (0 here). */
        float *v = vndf + sl * g;
        for (int y = 0; y < n; y++)
            for (int x = 0; x < n; x++) {
                const double ux = (double)x / (n - 1), uy = (double)y / (n - 1);
                const double th = ux * ux * 0.5 * pi, ph = (2.0 * uy - 1.0) * pi;
                const vec3_t wm = vec3_make(sin(th) * cos(ph), sin(th) * sin(ph), cos(th));
                v[y * n + x] = (float)(microfacet_pdf(&mf, wo, wm) * 2.0 * pi * pi * ux * sin(th));
            }
        plinear2d_t *warp = plinear2d_new(v, n, n, 0, NULL, NULL, true, "vndf", NULL);
        for (int y = 0; y < n; y++)
            for (int x = 0; x < n; x++) {
                double um[2], pdf;
                plinear2d_sample(warp, (double)x / (n - 1), (double)y / (n - 1), NULL, um, &pdf);
                const double th = um[0] * um[0] * 0.5 * pi, ph = (2.0 * um[1] - 1.0) * pi;
                const vec3_t wm = vec3_make(sin(th) * cos(ph), sin(th) * sin(ph), cos(th));
                const double d = vec3_dot(wo, wm);
                const vec3_t wi = vec3_sub(vec3_scale(wm, 2.0 * d), wo);
                const double ratio =
                    wi.z > 0.0 ? microfacet_g(&mf, wo, wi) / microfacet_g1(&mf, wo) : 0.0;
                double mean = 0.0;
                for (int l = 0; l < nl; l++) {
                    double eta, k;
                    measured_testutil_index(wl[l], &eta, &k);
                    const double r = fresnel_conductor(fabs(d), eta, k) * ratio;
                    spec[((sl * nl + l) * n + y) * n + x] = (float)r;
                    mean += r / nl;
                }
                lum[sl * g + y * n + x] = (float)mean;
            }
        plinear2d_destroy(&warp);
    }
    static const char text[] = "prismfarm test: GGX conductor";
    const uint8_t jac[1] = {1};
    const uint64_t P = (uint64_t)np, T = (uint64_t)nt, N = (uint64_t)n, L = (uint64_t)nl;
    const measured_testutil_field_t f[] = {
        {"description", 1, 1, {sizeof text - 1}, text},
        {"jacobian", 1, 1, {1}, jac},
        {"theta_i", 10, 1, {T}, theta},
        {"phi_i", 10, 1, {P}, phi},
        {"wavelengths", 10, 1, {L}, wl},
        {"ndf", 10, 2, {N, N}, ndf},
        {"sigma", 10, 2, {N, N}, sigma},
        {"vndf", 10, 4, {P, T, N, N}, vndf},
        {"luminance", 10, 4, {P, T, N, N}, lum},
        {"spectra", 10, 5, {P, T, L, N, N}, spec},
    };
    uint8_t *buf = measured_testutil_pack(f, (int)(sizeof f / sizeof *f), len);
    free(theta);
    free(phi);
    free(wl);
    free(ndf);
    free(sigma);
    free(vndf);
    free(lum);
    free(spec);
    return buf;
}

/* The isotropic GGX conductor of roughness alpha (an isotropic file: one phi_i). */
static inline uint8_t *measured_testutil_ggx(double alpha, int nt, int n, int nl, size_t *len)
{
    return measured_testutil_ggx_aniso(alpha, alpha, 1, nt, n, nl, len);
}

#endif
