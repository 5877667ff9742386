/* bsdf: the surface models against their own defining properties and against optics.
 *
 * - Sampling: a chi-square goodness-of-fit test of bsdf_sample's directions against
 *   bsdf_pdf integrated over (theta, phi) bins of the whole sphere, with a bin for the
 *   samples that fail (their probability is 1 - the pdf's integral), as pbrt-v3's bsdftest
 *   and Mitsuba's chi2 test do. Bins under 5 expected are pooled. The bound is the chi-square
 *   quantile at a family-wise significance of 1e-4 after Sidak's correction over every test
 *   of the run, so a correct model fails with probability < 1e-4 (and the seeds are fixed).
 * - Monte-Carlo estimates (furnace albedos) are accepted within 5 standard errors.
 * - The layered models' pdf is itself a stochastic estimate (pbrt-v4), and not the exact
 *   density of their sampling: they get a weaker test (see test_layered_consistency). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bsdf.h"
#include "fresnel.h"
#include "numeric_testutil.h"

#define PI 3.14159265358979323846

static vec3_t sph(double theta, double phi)
{
    return vec3_make(sin(theta) * cos(phi), sin(theta) * sin(phi), cos(theta));
}

static bsdf_t make(bsdf_kind_t kind, int n)
{
    bsdf_t b;
    memset(&b, 0, sizeof b);
    b.kind = kind;
    b.mode = BSDF_RADIANCE;
    b.n = n;
    b.thickness = 0.01;
    b.g = 0.0;
    b.maxdepth = 10;
    b.nsamples = 1;
    for (int j = 0; j < BSDF_MAX_LANES; j++) {
        b.eta[j] = 1.5;
        b.cond_eta[j] = 0.2;
        b.cond_k[j] = 3.0;
        b.reflectance[j] = 0.7;
        b.transmittance[j] = 0.3;
    }
    return b;
}

static bsdf_t with_roughness(bsdf_t b, double ru, double rv)
{
    b.mf = microfacet_make(ru, rv, true);
    b.mf_base = b.mf;
    return b;
}

/* The upper standard-normal quantile z with P(Z > z) = p, by bisection on erfc. */
static double normal_upper_quantile(double p)
{
    double lo = 0.0, hi = 40.0;
    for (int i = 0; i < 200; i++) {
        double mid = 0.5 * (lo + hi);
        if (0.5 * erfc(mid / sqrt(2.0)) > p)
            lo = mid;
        else
            hi = mid;
    }
    return 0.5 * (lo + hi);
}

/* The number of chi-square tests in this run, for Sidak's correction. */
#define CHI2_TESTS 48
static double chi2_z(void)
{
    return normal_upper_quantile(1.0 - pow(1.0 - 1e-4, 1.0 / CHI2_TESTS));
}

enum { NT = 18, NP = 36, SUB = 4, NSAMPLES = 40000 };

typedef struct chi2_result {
    double chi2, bound, pdf_total, success;
    int df;
} chi2_result_t;

/* The integral of lane 0's pdf over bin (i, k) by a sub x sub midpoint rule. */
static double bin_integral(const bsdf_t *b, vec3_t wo, int i, int k, int sub, rng_stream_t *rng)
{
    double e = 0.0;
    for (int p = 0; p < sub; p++)
        for (int q = 0; q < sub; q++) {
            double th = PI * (i + (p + 0.5) / sub) / NT;
            double ph = -PI + 2 * PI * (k + (q + 0.5) / sub) / NP;
            double pdf[BSDF_MAX_LANES];
            bsdf_pdf(b, wo, sph(th, ph), rng, pdf);
            e += pdf[0] * sin(th);
        }
    return e * (PI / NT) * (2 * PI / NP) / (sub * sub);
}

/* Bins the sphere in theta (NT) x phi (NP), samples lane 0, integrates lane 0's pdf. */
static chi2_result_t chi2_run(const bsdf_t *b, vec3_t wo, uint64_t seed)
{
    static double obs[NT][NP];
    memset(obs, 0, sizeof obs);
    double fails = 0.0;
    rng_stream_t rng = rng_stream_make(seed, 1, 0);
    for (int s = 0; s < NSAMPLES; s++) {
        bsdf_sample_t bs;
        double uc = testutil_splitmix_u(&seed), u1 = testutil_splitmix_u(&seed),
               u2 = testutil_splitmix_u(&seed);
        if (!bsdf_sample(b, wo, 0, uc, u1, u2, &rng, &bs)) {
            fails += 1.0;
            continue;
        }
        double th = acos(fmax(-1.0, fmin(1.0, bs.wi.z)));
        double ph = atan2(bs.wi.y, bs.wi.x) + PI;
        int i = (int)(th / PI * NT), k = (int)(ph / (2 * PI) * NP);
        obs[i < NT ? i : NT - 1][k < NP ? k : NP - 1] += 1.0;
    }
    chi2_result_t r = {0};
    double pool_e = 0.0, pool_o = 0.0;
    r.df = -1;
    for (int i = 0; i < NT; i++)
        for (int k = 0; k < NP; k++) {
            /* The pdf has hard edges (the rough refraction's reachable set, the horizon):
             * a bin where two midpoint rules disagree is integrated again, finer. */
            double e = bin_integral(b, wo, i, k, SUB, &rng);
            double e2 = bin_integral(b, wo, i, k, 2 * SUB, &rng);
            if (fabs(e - e2) * NSAMPLES > 0.05 + 1e-3 * e2 * NSAMPLES)
                e = bin_integral(b, wo, i, k, 8 * SUB, &rng);
            else
                e = e2;
            r.pdf_total += e;
            e *= NSAMPLES;
            if (e < 5.0) {
                pool_e += e;
                pool_o += obs[i][k];
                continue;
            }
            r.chi2 += (obs[i][k] - e) * (obs[i][k] - e) / e;
            if (getenv("BSDF_TEST_BINS") && (obs[i][k] - e) * (obs[i][k] - e) / e > 9)
                printf("  bin theta %d phi %d: obs %g exp %g\n", i, k, obs[i][k], e);
            r.df++;
        }
    /* The failures' bin: their probability is what the pdf does not cover. */
    double ef = fmax(0.0, 1.0 - r.pdf_total) * NSAMPLES;
    if (ef >= 5.0) {
        r.chi2 += (fails - ef) * (fails - ef) / ef;
        r.df++;
    } else {
        pool_e += ef;
        pool_o += fails;
    }
    if (pool_e >= 5.0 || pool_o > 0.0) {
        r.chi2 += (pool_o - pool_e) * (pool_o - pool_e) / fmax(pool_e, 5.0);
        r.df++;
    }
    r.success = 1.0 - fails / NSAMPLES;
    r.bound = testutil_chi2_quantile(r.df > 1 ? r.df : 1, chi2_z());
    return r;
}

static void check_chi2(const char *what, const bsdf_t *b, vec3_t wo, uint64_t seed,
                       bool lossless)
{
    chi2_result_t r = chi2_run(b, wo, seed);
    if (getenv("BSDF_TEST_VERBOSE"))
        printf("%-40s wo.z %+.3f chi2 %8.1f / %8.1f (df %d) pdf %.5f success %.5f\n", what,
               wo.z, r.chi2, r.bound, r.df, r.pdf_total, r.success);
    if (!(r.chi2 <= r.bound))
        fail_msg("%s wo (%g %g %g): chi2 %g > %g (df %d)", what, wo.x, wo.y, wo.z, r.chi2,
                 r.bound, r.df);
    /* The pdf integrates to the probability that a sample succeeds, never above 1. The
     * quadrature's error (SUB^2 midpoints per 10 x 10 degree bin) is under 2e-3 for these
     * lobes; the binomial noise of the success rate adds 5 standard errors. */
    double se = sqrt(fmax(r.success * (1 - r.success), 1e-12) / NSAMPLES);
    if (!(r.pdf_total <= 1.0 + 3e-3))
        fail_msg("%s: pdf integrates to %g > 1", what, r.pdf_total);
    if (!(fabs(r.pdf_total - r.success) <= 3e-3 + 5 * se))
        fail_msg("%s: pdf integrates to %g, samples succeed %g", what, r.pdf_total, r.success);
    if (lossless && !(fabs(r.pdf_total - 1.0) <= 3e-3))
        fail_msg("%s: pdf integrates to %g, expected 1", what, r.pdf_total);
}

static const double ROUGH[] = {0.05, 0.3, 1.0};

static void test_chi2_conductor(void **state)
{
    (void)state;
    const double thetas[] = {0.1, 0.8, 1.35};
    uint64_t seed = 100;
    for (int r = 0; r < 3; r++)
        for (int t = 0; t < 3; t++) {
            bsdf_t b = with_roughness(make(BSDF_CONDUCTOR, 1), ROUGH[r], ROUGH[r]);
            check_chi2("conductor", &b, sph(thetas[t], 0.5), seed++, false);
        }
    bsdf_t b = with_roughness(make(BSDF_CONDUCTOR, 1), 0.05, 0.5);
    check_chi2("conductor anisotropic", &b, sph(0.9, 0.7), seed++, false);
    /* From below: conductors reflect on both sides. */
    b = with_roughness(make(BSDF_CONDUCTOR, 1), 0.3, 0.3);
    check_chi2("conductor from below", &b, sph(2.3, 0.7), seed++, false);
}

static void test_chi2_dielectric(void **state)
{
    (void)state;
    const double etas[] = {1.33, 1.5, 2.4};
    const double thetas[] = {0.15, 1.1, 2.4}; /* the last from inside */
    uint64_t seed = 200;
    for (int e = 0; e < 3; e++)
        for (int r = 0; r < 3; r++)
            for (int t = 0; t < 3; t++) {
                bsdf_t b = with_roughness(make(BSDF_DIELECTRIC, 1), ROUGH[r], ROUGH[r]);
                b.eta[0] = etas[e];
                char what[64];
                snprintf(what, sizeof what, "dielectric eta %.2f rough %.2f", etas[e], ROUGH[r]);
                check_chi2(what, &b, sph(thetas[t], 0.5), seed++, false);
            }
}

static void test_chi2_diffuse(void **state)
{
    (void)state;
    const double thetas[] = {0.0, 1.0, 2.9};
    uint64_t seed = 300;
    for (int t = 0; t < 3; t++) {
        bsdf_t b = make(BSDF_DIFFUSE, 1);
        check_chi2("diffuse", &b, sph(thetas[t], 0.5), seed++, true);
        b = make(BSDF_DIFFUSE_TRANSMISSION, 1);
        check_chi2("diffuse transmission", &b, sph(thetas[t], 0.5), seed++, true);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_chi2_conductor),
        cmocka_unit_test(test_chi2_dielectric),
        cmocka_unit_test(test_chi2_diffuse),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
