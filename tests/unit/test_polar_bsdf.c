/* polar_bsdf: the conductor and dielectric lobes of bsdf/ under polarisation (bsdf_mueller) and
 * thin films (bsdf_t.film_nm) against optics written out here, not the code's polar/ modules:
 * at the mirror and Snell directions -- where the microfacet is the macro normal at any
 * roughness -- the normalised Mueller matrix is Fresnel's (diattenuation (R_s - R_p)/(R_s + R_p),
 * the phase between r_s and r_p in the lower block) for a metal, glass from outside, glass from
 * inside beyond the critical angle (a pure retarder) and refraction; a microfacet tilted out of
 * the plane of incidence gives the same matrix in its own frame; a filmed lobe at alpha 0.002
 * reflects the Airy reflectance of the film (Born & Wolf §1.6.4) and polarises as it does. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h> /* after the four headers above, which it needs */

#include <complex.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "bsdf.h"

#define PI 3.14159265358979323846

/* Fresnel amplitudes from index ni into nt (complex), incidence cosine ci: r_s, r_p, t_s, t_p in
 * one convention (Hecht, Optics, eq. 4.42-4.43, 4.48-4.49), ct on the decaying branch. */
typedef struct amps {
    double complex rs, rp, ts, tp, ct;
} amps_t;

static amps_t fresnel(double complex ni, double complex ci, double complex nt)
{
    amps_t a;
    a.ct = csqrt(1.0 - (ni / nt) * (ni / nt) * (1.0 - ci * ci));
    if (cimag(nt * a.ct) < 0.0)
        a.ct = -a.ct;
    a.rs = (ni * ci - nt * a.ct) / (ni * ci + nt * a.ct);
    a.rp = (nt * ci - ni * a.ct) / (nt * ci + ni * a.ct);
    a.ts = 2.0 * ni * ci / (ni * ci + nt * a.ct);
    a.tp = 2.0 * ni * ci / (nt * ci + ni * a.ct);
    return a;
}

/* The normalised Mueller matrix of diag(a, b) (Jones, s then p) written out. */
static void jones_mueller(double complex a, double complex b, double m[4][4])
{
    const double A = creal(a * conj(a)), B = creal(b * conj(b)), s = A + B;
    const double complex c = a * conj(b);
    memset(m, 0, 16 * sizeof(double));
    m[0][0] = m[1][1] = 1.0;
    m[0][1] = m[1][0] = (A - B) / s;
    m[2][2] = m[3][3] = 2.0 * creal(c) / s;
    m[2][3] = -2.0 * cimag(c) / s;
    m[3][2] = 2.0 * cimag(c) / s;
}

static void expect_mueller(const mueller_t *got, double want[4][4], double tol, const char *what)
{
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++)
            if (!(fabs(got->m[r][c] - want[r][c]) <= tol))
                fail_msg("%s: M[%d][%d] = %.9f, want %.9f", what, r, c, got->m[r][c], want[r][c]);
}

static bsdf_t make(bsdf_kind_t kind, double alpha)
{
    bsdf_t b;
    memset(&b, 0, sizeof b);
    b.kind = kind;
    b.mode = BSDF_RADIANCE;
    b.n = 1;
    b.mf = (microfacet_t){alpha, alpha};
    return b;
}

static vec3_t dir(double theta, double phi)
{
    return vec3_make(sin(theta) * cos(phi), sin(theta) * sin(phi), cos(theta));
}

/* Mirror and Snell directions: the half vector is the normal whatever the roughness. */
static void test_fresnel_matrices(void **state)
{
    (void)state;
    const double alphas[] = {0.0, 0.05, 0.5};
    for (size_t ai = 0; ai < 3; ai++) {
        for (int deg = 5; deg <= 85; deg += 10) {
            const double th = deg * PI / 180.0, ci = cos(th);
            const vec3_t wo = dir(th, 0.7), wi = vec3_make(-wo.x, -wo.y, wo.z);
            double want[4][4];
            mueller_t m;
            vec3_t wm;
            char what[96];
            /* A metal: light from wi (outside) reflected toward wo. */
            bsdf_t b = make(BSDF_CONDUCTOR, alphas[ai]);
            b.cond_eta[0] = 0.2;
            b.cond_k[0] = 3.0;
            assert_true(bsdf_mueller(&b, 0, wo, wi, &m, &wm));
            assert_true(fabs(wm.z - 1.0) <= 1e-12);
            amps_t a = fresnel(1.0, ci, 0.2 + 3.0 * I);
            jones_mueller(a.rs, a.rp, want);
            snprintf(what, sizeof what, "metal at %d deg, alpha %g", deg, alphas[ai]);
            expect_mueller(&m, want, 1e-9, what);
            /* Glass from outside. */
            b = make(BSDF_DIELECTRIC, alphas[ai]);
            b.eta[0] = 1.5;
            assert_true(bsdf_mueller(&b, 0, wo, wi, &m, &wm));
            a = fresnel(1.0, ci, 1.5);
            jones_mueller(a.rs, a.rp, want);
            snprintf(what, sizeof what, "glass at %d deg, alpha %g", deg, alphas[ai]);
            expect_mueller(&m, want, 1e-9, what);
            /* Glass from inside: beyond 41.8 degrees totally reflected, a pure retarder. */
            const vec3_t wo_in = vec3_make(wo.x, wo.y, -wo.z), wi_in = vec3_make(wi.x, wi.y, -wi.z);
            assert_true(bsdf_mueller(&b, 0, wo_in, wi_in, &m, &wm));
            a = fresnel(1.5, ci, 1.0);
            jones_mueller(a.rs, a.rp, want);
            snprintf(what, sizeof what, "glass inside at %d deg, alpha %g", deg, alphas[ai]);
            expect_mueller(&m, want, 1e-9, what);
            if (deg > 42)
                assert_true(fabs(m.m[0][1]) <= 1e-9 && fabs(m.m[2][3]) > 1e-3);
            /* Refraction: light arrives from inside along Snell's direction and leaves toward wo
             * outside; the transmitted field's matrix diag(t_s, t_p) (from inside). */
            const double st = sin(th) / 1.5, ct = sqrt(1.0 - st * st);
            const vec3_t wt = vec3_scale(dir(PI - asin(st), 0.7 + PI), 1.0);
            assert_true(fabs(wt.z + ct) <= 1e-12);
            assert_true(bsdf_mueller(&b, 0, wo, wt, &m, &wm));
            assert_true(fabs(fabs(wm.z) - 1.0) <= 1e-9);
            a = fresnel(1.5, ct, 1.0);
            jones_mueller(a.ts, a.tp, want);
            snprintf(what, sizeof what, "refraction at %d deg, alpha %g", deg, alphas[ai]);
            expect_mueller(&m, want, 1e-9, what);
        }
    }
}

/* A microfacet tilted out of the plane of incidence: the matrix is Fresnel's at its own
 * incidence angle, and wm is the half vector. */
static void test_tilted_microfacet(void **state)
{
    (void)state;
    bsdf_t b = make(BSDF_CONDUCTOR, 0.3);
    b.cond_eta[0] = 1.2;
    b.cond_k[0] = 2.0;
    const vec3_t wo = dir(0.6, 0.0), wi = dir(0.9, 2.0);
    mueller_t m;
    vec3_t wm;
    assert_true(bsdf_mueller(&b, 0, wo, wi, &m, &wm));
    const vec3_t h = vec3_normalize(vec3_add(wo, wi));
    assert_true(vec3_length(vec3_sub(h, wm)) <= 1e-12);
    double want[4][4];
    const amps_t a = fresnel(1.0, vec3_dot(wi, h), 1.2 + 2.0 * I);
    jones_mueller(a.rs, a.rp, want);
    expect_mueller(&m, want, 1e-9, "tilted microfacet");
    /* No microfacet joins a reflection to the other side: the conductor has none. */
    assert_false(bsdf_mueller(&b, 0, wo, vec3_make(0.1, 0.2, -0.97), &m, &wm));
    /* Diffuse and layered models have no matrix (they depolarise). */
    b.kind = BSDF_DIFFUSE;
    assert_false(bsdf_mueller(&b, 0, wo, wi, &m, &wm));
}

/* The Airy sum of a film n1 of thickness d between 1 and n2 (Born & Wolf §1.6.4 eq. 57):
 * r = (r01 + r12 e^{2i beta}) / (1 + r01 r12 e^{2i beta}), beta = 2 pi n1 d cos theta1 / lambda,
 * per polarisation. */
static void airy(double cos0, double n1, double d, double complex n2, double lambda,
                 double complex *rs, double complex *rp)
{
    const amps_t a01 = fresnel(1.0, cos0, n1);
    const amps_t a12 = fresnel(n1, a01.ct, n2);
    const double complex e = cexp(2.0 * I * 2.0 * PI * n1 * d * a01.ct / lambda);
    *rs = (a01.rs + a12.rs * e) / (1.0 + a01.rs * a12.rs * e);
    *rp = (a01.rp + a12.rp * e) / (1.0 + a01.rp * a12.rp * e);
}

/* A filmed metal and filmed glass at alpha 0.002 and 55 degrees: the sampled reflection's mean
 * weight is the film's Airy reflectance (R_s + R_p)/2, and the matrix at the mirror direction
 * polarises by the Airy amplitudes, at three wavelengths (interference makes each differ). */
static void test_film(void **state)
{
    (void)state;
    const double th = 55.0 * PI / 180.0;
    const vec3_t wo = dir(th, 0.3), wi = vec3_make(-wo.x, -wo.y, wo.z);
    const double lambdas[] = {450.0, 550.0, 650.0};
    for (int kind = 0; kind < 2; kind++) {
        for (int li = 0; li < 3; li++) {
            bsdf_t b = make(kind ? BSDF_DIELECTRIC : BSDF_CONDUCTOR, 0.002);
            const double complex n2 = kind ? 1.5 : 0.2 + 3.0 * I;
            b.eta[0] = 1.5;
            b.cond_eta[0] = 0.2;
            b.cond_k[0] = 3.0;
            b.film_nm = kind ? 380.0 : 250.0;
            b.film_n[0] = kind ? 1.33 : 1.45;
            b.lambda[0] = lambdas[li];
            double complex rs, rp;
            airy(cos(th), b.film_n[0], b.film_nm, n2, lambdas[li], &rs, &rp);
            const double Rs = creal(rs * conj(rs)), Rp = creal(rp * conj(rp));
            const double R = 0.5 * (Rs + Rp);
            /* The mean reflected weight f |cos| / pdf over stratified lobe choices. */
            const int N = 20000;
            double sum = 0.0;
            for (int k = 0; k < N; k++) {
                bsdf_sample_t s;
                const double u1 = fmod(k * 0.7548776662466927, 1.0),
                             u2 = fmod(k * 0.5698402909980532, 1.0);
                if (bsdf_sample(&b, wo, 0, (k + 0.5) / N, u1, u2, NULL, &s) &&
                    (s.flags & BSDF_REFLECTION) && s.pdf[0] > 0.0)
                    sum += s.f[0] * fabs(s.wi.z) / s.pdf[0];
            }
            if (!(fabs(sum / N - R) <= 2e-3 * R + 1e-4))
                fail_msg("%s film at %g nm: reflected %.6f, Airy %.6f", kind ? "glass" : "metal",
                         lambdas[li], sum / N, R);
            mueller_t m;
            vec3_t wm;
            assert_true(bsdf_mueller(&b, 0, wo, wi, &m, &wm));
            double want[4][4];
            jones_mueller(rs, rp, want);
            expect_mueller(&m, want, 1e-9, kind ? "glass film" : "metal film");
        }
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fresnel_matrices),
        cmocka_unit_test(test_tilted_microfacet),
        cmocka_unit_test(test_film),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
