/* Tests for the subsurface material's tabulated BSSRDF (bsdf/bssrdf.h, pbrt-v4's
 * TabulatedBSSRDF with photon beam diffusion) and its exit lobe (bsdf.h BSDF_SSS_EXIT), against
 * numbers that do not come from their code:
 * - the slab's diffusion against the table: a normally incident beam refracted into a
 *   semi-infinite medium (sigma_t 1, albedo rho, HG g, index 1.33 behind a Fresnel boundary),
 *   simulated photon by photon (an analog random walk, 10000 walks per case), leaves through the
 * top with the probability that the table's effective albedo (the profile's integral) states, to
 * the accuracy photon beam diffusion has against transport (Habel et al. 2013 report a few per
 *   cent; here within 0.03 absolute or 12 % relative, whichever is larger; measured at most
 *   0.028 (4 %) at rho 0.99 and 0.015 at rho 0.7; the walk's own error is below 0.005);
 * - the Fresnel moments' polynomial fits against the moments integrated from the Fresnel
 *   equations (optics/fresnel.h);
 * - Catmull-Rom splines reproduce linear data (values, integral, inverse) exactly;
 * - the profile's sampling: a histogram of 200000 radii over 40 annuli matches the integral
 *   of bssrdf_pdf_sr over each (chi-square), and pdf_sr integrates to 1 over the plane;
 * - the probe estimator the renderer uses: on a plane, S_p / pdf_sp over probes from three
 *   axes averages to the effective albedo (only the normal axis finds the plane);
 * - the exit lobe: int S_w cos over the hemisphere is eta^2 in radiance mode (1 in importance
 *   mode), its sample reports its own density;
 * - finite everywhere: sigma_t from 1e-9 to 1e9, rho 0 and 1, r = 0, grazing normals. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <math.h>
#include <stdio.h>

#include "bsdf.h"
#include "bssrdf.h"
#include "catmull_rom.h"
#include "fresnel.h"
#include "numeric_testutil.h"
#include "phase_hg.h"

/* The fraction of a normally incident refracted beam that leaves a semi-infinite medium
 * (z < 0; sigma_t 1, albedo rho, HG g) through its top, of relative index eta: an analog walk,
 * absorbed at a collision with probability 1 - rho, Fresnel-reflected at the boundary (from
 * inside) with its probability, else counted. */
static double slab_walk(double rho, double g, double eta, int walks, uint64_t *seed)
{
    int out = 0;
    for (int w = 0; w < walks; w++) {
        vec3_t p = vec3_make(0, 0, 0), d = vec3_make(0, 0, -1);
        for (int step = 0; step < 100000; step++) {
            const double s = -log(1.0 - testutil_splitmix_u(seed));
            const vec3_t q = vec3_fma(p, d, s);
            if (q.z >= 0.0) {
                /* At the boundary: leave, or reflect and fly on from there (the exponential
                 * flight has no memory). */
                const double c = fabs(d.z);
                if (testutil_splitmix_u(seed) >= fresnel_dielectric(-c, 1.0, eta)) {
                    out++;
                    break;
                }
                p = vec3_fma(p, d, -p.z / d.z);
                p.z = 0.0;
                d.z = -d.z;
                continue;
            }
            p = q;
            if (testutil_splitmix_u(seed) >= rho)
                break;
            double pdf;
            const double u1 = testutil_splitmix_u(seed), u2 = testutil_splitmix_u(seed);
            d = phase_hg_sample(vec3_neg(d), g, u1, u2, &pdf);
        }
    }
    return (double)out / walks;
}

static void test_slab_diffusion(void **state)
{
    (void)state;
    uint64_t seed = 27;
    const double eta = 1.33;
    const double gs[2] = {0.0, 0.5};
    const double rhos[4] = {0.3, 0.7, 0.95, 0.99};
    for (int gi = 0; gi < 2; gi++) {
        bssrdf_table_t *t = bssrdf_table_new(gs[gi], eta);
        assert_non_null(t);
        for (int i = 0; i < 4; i++) {
            /* g acts through the reduced albedo in the diffusion part; the walk is exact. */
            const double mc = slab_walk(rhos[i], gs[gi], eta, 10000, &seed);
            const double table = bssrdf_rho_eff(t, rhos[i]);
            printf("g %.1f rho %.2f: walk %.4f table %.4f\n", gs[gi], rhos[i], mc, table);
            testutil_assert_near(table, mc, fmax(0.03, 0.12 * mc));
        }
        bssrdf_table_destroy(&t);
        assert_null(t);
    }
}

static void test_fresnel_moments(void **state)
{
    (void)state;
    const double etas[5] = {0.7, 0.9, 1.2, 1.33, 1.5};
    for (int e = 0; e < 5; e++) {
        double m1 = 0.0, m2 = 0.0;
        const int n = 200000;
        for (int i = 0; i < n; i++) {
            const double mu = (i + 0.5) / n;
            /* light inside a medium of relative index eta meeting the boundary */
            const double f = fresnel_dielectric(-mu, 1.0, etas[e]);
            m1 += f * mu / n;
            m2 += f * mu * mu / n;
        }
        testutil_assert_near(bssrdf_fresnel_moment1(etas[e]), m1, 0.004);
        testutil_assert_near(bssrdf_fresnel_moment2(etas[e]), m2, 0.004);
    }
}

static void test_catmull_rom_linear(void **state)
{
    (void)state;
    const double x[6] = {0.0, 0.1, 0.5, 0.6, 2.0, 3.0};
    double f[6], cdf[6];
    for (int i = 0; i < 6; i++)
        f[i] = 1.0 + 2.0 * x[i];
    for (double a = 0.0; a <= 3.0; a += 0.0625) {
        int off;
        double w[4], v = 0.0;
        assert_true(catmull_rom_weights(x, 6, a, &off, w));
        for (int k = 0; k < 4; k++)
            if (w[k] != 0.0)
                v += w[k] * f[off + k];
        testutil_assert_near(v, 1.0 + 2.0 * a, 1e-12);
        testutil_assert_near(catmull_rom_invert(x, f, 6, 1.0 + 2.0 * a), a, 1e-8);
    }
    int off;
    double w[4];
    assert_false(catmull_rom_weights(x, 6, 3.5, &off, w));
    testutil_assert_near(catmull_rom_integrate(x, f, 6, cdf), 3.0 + 9.0, 1e-12);
    testutil_assert_near(cdf[2], 0.5 + 0.25, 1e-12);
}

static void test_profile_sampling(void **state)
{
    (void)state;
    bssrdf_table_t *t = bssrdf_table_new(0.0, 1.33);
    const double sigma_t = 2.0, rho = 0.8;
    /* Annuli evenly spaced in log radius up to the 0.999 bound. */
    enum { BINS = 40 };
    const double rmax = bssrdf_sample_sr(t, sigma_t, rho, 0.999), rmin = rmax * 1e-4;
    double expect[BINS + 1] = {0}, count[BINS + 1] = {0};
    double total = 0.0;
    for (int b = 0; b <= BINS; b++) {
        const double lo = b == 0 ? 0.0 : rmin * pow(rmax / rmin, (b - 1.0) / BINS);
        const double hi = rmin * pow(rmax / rmin, (double)b / BINS);
        const int k = 2000;
        for (int i = 0; i < k; i++) {
            const double r = lo + (hi - lo) * (i + 0.5) / k;
            expect[b] += 2.0 * PF_PI * r * bssrdf_pdf_sr(t, sigma_t, rho, r) * (hi - lo) / k;
        }
        total += expect[b];
    }
    /* The density over the plane integrates to 1 (0.999 of it below the bound). */
    testutil_assert_near(total, 0.999, 0.004);
    uint64_t seed = 3;
    const int n = 200000;
    for (int i = 0; i < n; i++) {
        const double r = bssrdf_sample_sr(t, sigma_t, rho, testutil_splitmix_u(&seed));
        assert_true(r >= 0.0);
        if (r >= rmax)
            continue;
        const int b = r < rmin ? 0 : 1 + (int)(BINS * log(r / rmin) / log(rmax / rmin));
        count[b < BINS + 1 ? b : BINS] += 1.0;
    }
    double chi2 = 0.0;
    int df = 0;
    for (int b = 0; b <= BINS; b++) {
        const double e = expect[b] * n;
        if (e < 5.0)
            continue;
        chi2 += (count[b] - e) * (count[b] - e) / e;
        df++;
    }
    printf("chi2 %.1f over %d annuli\n", chi2, df);
    assert_true(chi2 < testutil_chi2_quantile(df - 1, 4.75));
    bssrdf_table_destroy(&t);
}

/* On the plane z = 0 through po: probes from bssrdf_probe, each intersected with the plane,
 * weighed S_r / pdf_sp, average to the integral of S_r over the plane, rho_eff. */
static void test_probe_estimator(void **state)
{
    (void)state;
    bssrdf_table_t *t = bssrdf_table_new(0.0, 1.4);
    const double sigma_t = 5.0, rho = 0.9;
    const vec3_t po = vec3_make(0.3, -0.2, 0.0), ns = vec3_make(0, 0, 1);
    uint64_t seed = 11;
    const int n = 100000;
    double sum = 0.0;
    for (int i = 0; i < n; i++) {
        vec3_t p0, p1;
        const double ua = testutil_splitmix_u(&seed), ur = testutil_splitmix_u(&seed),
                     up = testutil_splitmix_u(&seed);
        if (!bssrdf_probe(t, sigma_t, rho, po, ns, ua, ur, up, &p0, &p1))
            continue;
        if (!((p0.z < 0.0) != (p1.z < 0.0)))
            continue; /* a tangent probe runs beside the plane */
        const double s = p0.z / (p0.z - p1.z);
        const vec3_t pi = vec3_add(p0, vec3_scale(vec3_sub(p1, p0), s));
        const double pdf = bssrdf_pdf_sp(t, sigma_t, rho, po, ns, pi, ns);
        assert_true(pdf > 0.0);
        sum += bssrdf_sr(t, sigma_t, rho, vec3_length(vec3_sub(pi, po))) / pdf;
    }
    const double est = sum / n, want = bssrdf_rho_eff(t, rho);
    printf("probe estimate %.4f, rho_eff %.4f\n", est, want);
    testutil_assert_near(est, want, 0.02 * want);
    bssrdf_table_destroy(&t);
}

static void test_exit_lobe(void **state)
{
    (void)state;
    const double etas[3] = {1.0, 1.33, 1.8};
    for (int e = 0; e < 3; e++)
        for (int mode = 0; mode < 2; mode++) {
            bsdf_t b = {
                .kind = BSDF_SSS_EXIT, .mode = mode ? BSDF_IMPORTANCE : BSDF_RADIANCE, .n = 2};
            b.eta[0] = b.eta[1] = etas[e];
            const vec3_t wo = vec3_make(0, 0, 1);
            /* midpoint rule in mu = cos theta (the lobe is isotropic in azimuth) */
            double sum = 0.0;
            const int k = 20000;
            for (int i = 0; i < k; i++) {
                const double mu = (i + 0.5) / k, s = sqrt(1.0 - mu * mu);
                double f[2];
                bsdf_eval(&b, wo, vec3_make(s, 0, mu), NULL, f);
                sum += 2.0 * PF_PI * f[0] * mu / k;
            }
            const double want = mode ? 1.0 : etas[e] * etas[e];
            /* the moment's fit (test_fresnel_moments) bounds the normalisation */
            testutil_assert_near(sum, want, 0.01 * want);
            bsdf_sample_t s;
            assert_true(bsdf_sample(&b, wo, 0, 0.5, 0.3, 0.7, NULL, &s));
            double f[2], pdf[2];
            bsdf_eval(&b, wo, s.wi, NULL, f);
            bsdf_pdf(&b, wo, s.wi, NULL, pdf);
            testutil_assert_near(s.f[1], f[1], 1e-12);
            testutil_assert_near(s.pdf[1], pdf[1], 1e-12);
            bsdf_eval(&b, wo, vec3_make(0, 0, -1), NULL, f);
            assert_true(f[0] == 0.0);
        }
}

static void test_finite(void **state)
{
    (void)state;
    bssrdf_table_t *t = bssrdf_table_new(0.9, 1.01);
    const double sig[5] = {1e-9, 1e-3, 1.0, 1e4, 1e9};
    const double rhos[4] = {0.0, 1e-6, 0.5, 1.0};
    const double rs[5] = {0.0, 1e-12, 1e-3, 1.0, 1e6};
    const vec3_t po = vec3_make(0, 0, 0), ns = vec3_make(0, 0, 1);
    for (int a = 0; a < 5; a++)
        for (int b = 0; b < 4; b++) {
            for (int c = 0; c < 5; c++) {
                const double v[3] = {bssrdf_sr(t, sig[a], rhos[b], rs[c]),
                                     bssrdf_pdf_sr(t, sig[a], rhos[b], rs[c]),
                                     bssrdf_pdf_sp(t, sig[a], rhos[b], po, ns,
                                                   vec3_make(rs[c], 0, 0), vec3_make(1, 0, 0))};
                for (int k = 0; k < 3; k++)
                    assert_true(isfinite(v[k]) && v[k] >= 0.0);
            }
            vec3_t p0, p1;
            if (bssrdf_probe(t, sig[a], rhos[b], po, vec3_make(0, 1, 0), 0.9, 0.5, 0.5, &p0, &p1))
                assert_true(isfinite(p0.x + p0.y + p0.z + p1.x + p1.y + p1.z));
            const double e = bssrdf_rho_eff(t, rhos[b]);
            assert_true(isfinite(e) && e >= 0.0 && e <= 1.0);
        }
    assert_true(bssrdf_sample_sr(t, 0.0, 0.5, 0.5) < 0.0);
    /* the inversion pbrt-v4's "reflectance" uses */
    for (double re = 0.05; re < 0.9; re += 0.1)
        testutil_assert_near(bssrdf_rho_eff(t, bssrdf_rho_from_eff(t, re)), re, 1e-6);
    bssrdf_table_destroy(&t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_slab_diffusion),
        cmocka_unit_test(test_fresnel_moments),
        cmocka_unit_test(test_catmull_rom_linear),
        cmocka_unit_test(test_profile_sampling),
        cmocka_unit_test(test_probe_estimator),
        cmocka_unit_test(test_exit_lobe),
        cmocka_unit_test(test_finite),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
