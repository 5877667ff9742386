/* Material "measured" (bsdf/measured.h, sampling/plinear2d.h, bsdf/tensor_file.h): a
 * measured BSDF tabulated from an analytic GGX conductor in RGL's layout
 * (support/measured_testutil.h) reproduces the conductor it was built from (bsdf's own
 * BSDF_CONDUCTOR, the oracle) in value and albedo; its sampling has the density its pdf
 * says; it is reciprocal as its data are and never reflects more than comes in; each lane
 * reads its own wavelength; and damaged files are refused with messages naming the file. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "bsdf.h"
#include "le_bytes.h"
#include "measured.h"
#include "measured_testutil.h"
#include "numeric_testutil.h"
#include "plinear2d.h"
#include "tensor_file.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define ALPHA 0.3
#define NT 10 /* incident angles */
#define NG 48 /* grid points per axis */
#define NL 5  /* wavelengths */

static uint8_t *file_bytes;
static size_t file_len;
static measured_t *brdf;

static int setup(void **state)
{
    (void)state;
    err_t err;
    file_bytes = measured_testutil_ggx(ALPHA, NT, NG, NL, &file_len);
    if (!file_bytes)
        return -1;
    brdf = measured_new(file_bytes, file_len, "ggx.bsdf", &err);
    if (!brdf)
        fprintf(stderr, "%s\n", err.msg);
    return brdf ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    measured_destroy(&brdf);
    free(file_bytes);
    return 0;
}

static vec3_t dir(double theta, double phi)
{
    return vec3_make(sin(theta) * cos(phi), sin(theta) * sin(phi), cos(theta));
}

/* The analytic conductor a file was made from, at one wavelength. */
static bsdf_t conductor_of(microfacet_t mf, double lambda)
{
    bsdf_t b = {.kind = BSDF_CONDUCTOR, .n = 1, .mf = mf};
    measured_testutil_index(lambda, &b.cond_eta[0], &b.cond_k[0]);
    return b;
}

static bsdf_t conductor(double lambda)
{
    return conductor_of((microfacet_t){ALPHA, ALPHA}, lambda);
}

static bsdf_t measured_of(const measured_t *data, const double *lambda, int n)
{
    bsdf_t b = {.kind = BSDF_MEASURED, .n = n, .measured = data};
    for (int j = 0; j < n; j++)
        b.lambda[j] = lambda[j];
    return b;
}

static bsdf_t measured_bsdf(const double *lambda, int n)
{
    return measured_of(brdf, lambda, n);
}

/* The warp alone: sample and invert are inverses, sample's density is eval's, and the
 * density integrates to 1, for parameters between and outside the grid values. */
static void test_plinear2d_warp(void **state)
{
    (void)state;
    enum { NX = 7, NY = 5, NP = 3 };
    float data[NP * NX * NY];
    uint64_t s = 42;
    for (int i = 0; i < NP * NX * NY; i++)
        data[i] = (float)(0.05 + testutil_splitmix_u(&s));
    const float values[NP] = {0.0f, 0.5f, 2.0f};
    const float *vp[1] = {values};
    const int res[1] = {NP};
    err_t err;
    plinear2d_t *w = plinear2d_new(data, NX, NY, 1, res, vp, true, "test", &err);
    assert_non_null(w);
    const double params[] = {-1.0, 0.0, 0.3, 1.7, 5.0};
    for (size_t k = 0; k < sizeof params / sizeof *params; k++) {
        for (int i = 0; i < 200; i++) {
            double u0 = testutil_splitmix_u(&s), u1 = testutil_splitmix_u(&s), p[2], q[2], pdf,
                   pdf2;
            plinear2d_sample(w, u0, u1, &params[k], p, &pdf);
            plinear2d_invert(w, p[0], p[1], &params[k], q, &pdf2);
            testutil_assert_near(q[0], u0, 1e-5);
            testutil_assert_near(q[1], u1, 1e-5);
            testutil_assert_near(pdf, pdf2, 1e-6 * pdf);
            testutil_assert_near(plinear2d_eval(w, p[0], p[1], &params[k]), pdf, 1e-6 * pdf);
        }
        double sum = 0.0;
        const int m = 400;
        for (int y = 0; y < m; y++)
            for (int x = 0; x < m; x++)
                sum += plinear2d_eval(w, (x + 0.5) / m, (y + 0.5) / m, &params[k]);
        testutil_assert_near(sum / (m * m), 1.0, 1e-3);
    }
    plinear2d_destroy(&w);
    /* Bad grids and parameter values are refused by name. */
    const float down[2] = {1.0f, 0.5f};
    const float *dp[1] = {down};
    const int two[1] = {2};
    assert_null(plinear2d_new(data, NX, NY, 1, two, dp, true, "x.bsdf: field \"vndf\"", &err));
    assert_non_null(strstr(err.msg, "x.bsdf: field \"vndf\""));
    assert_non_null(strstr(err.msg, "increasing"));
    assert_null(plinear2d_new(data, 1, NY, 0, NULL, NULL, true, "w", &err));
    data[3] = -1.0f;
    assert_null(plinear2d_new(data, NX, NY, 0, NULL, NULL, true, "w", &err));
    assert_non_null(strstr(err.msg, "not negative"));
}

static int by_value(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* f of the measured data against the conductor mf over directions up to 70 degrees from the
 * normal, where the grids resolve the lobe: the median, 95th percentile and worst relative
 * error where the conductor's f is above 0.05 (the lobe's far tail, where a relative error
 * means little). */
static int f_errors(const measured_t *data, microfacet_t mf, double *median, double *p95,
                    double *worst)
{
    uint64_t s = 7;
    const double lambda[3] = {400.0, 550.0, 700.0};
    bsdf_t m = measured_of(data, lambda, 3);
    enum { N = 2000 };
    static double rel[3 * N];
    int count = 0;
    *worst = 0.0;
    for (int i = 0; i < N; i++) {
        vec3_t wo =
            dir(acos(1.0 - 0.66 * testutil_splitmix_u(&s)), 2 * PF_PI * testutil_splitmix_u(&s));
        vec3_t wi =
            dir(acos(1.0 - 0.66 * testutil_splitmix_u(&s)), 2 * PF_PI * testutil_splitmix_u(&s));
        double f[3];
        bsdf_eval(&m, wo, wi, NULL, f);
        for (int j = 0; j < 3; j++) {
            bsdf_t c = conductor_of(mf, lambda[j]);
            double g;
            bsdf_eval(&c, wo, wi, NULL, &g);
            if (g < 0.05)
                continue;
            rel[count++] = fabs(f[j] - g) / g;
            *worst = fmax(*worst, fabs(f[j] - g) / g);
        }
    }
    qsort(rel, (size_t)count, sizeof *rel, by_value);
    *median = rel[count / 2];
    *p95 = rel[count * 95 / 100];
    fprintf(stderr, "f: %d pairs, median rel err %.4f, 95%% %.4f, worst %.4f\n", count, *median,
            *p95, *worst);
    return count;
}

static void test_reproduces_the_conductor(void **state)
{
    (void)state;
    double median, p95, worst;
    assert_true(f_errors(brdf, (microfacet_t){ALPHA, ALPHA}, &median, &p95, &worst) > 1000);
    assert_true(median < 0.01);
    assert_true(p95 < 0.03);
}

/* The directional albedo (f cos over the hemisphere, by the measured BSDF's own sampling)
 * against the conductor's (by its sampling), and never above 1. */
static void test_albedo(void **state)
{
    (void)state;
    const double lambda[2] = {450.0, 650.0};
    bsdf_t m = measured_bsdf(lambda, 2);
    const double thetas[] = {0.0, 0.5, 1.0, 1.3};
    for (size_t t = 0; t < sizeof thetas / sizeof *thetas; t++) {
        vec3_t wo = dir(thetas[t], 0.7);
        uint64_t s = 99 + t;
        enum { N = 40000 };
        double a[2] = {0, 0}, ref[2] = {0, 0};
        for (int i = 0; i < N; i++) {
            double u1 = testutil_splitmix_u(&s), u2 = testutil_splitmix_u(&s);
            bsdf_sample_t out;
            if (bsdf_sample(&m, wo, 0, 0.5, u1, u2, NULL, &out))
                for (int j = 0; j < 2; j++)
                    a[j] += out.f[j] * fabs(out.wi.z) / out.pdf[j] / N;
            for (int j = 0; j < 2; j++) {
                bsdf_t c = conductor(lambda[j]);
                if (bsdf_sample(&c, wo, 0, 0.5, u1, u2, NULL, &out))
                    ref[j] += out.f[0] * fabs(out.wi.z) / out.pdf[0] / N;
            }
        }
        for (int j = 0; j < 2; j++) {
            fprintf(stderr, "albedo theta %.2f lambda %.0f: measured %.4f conductor %.4f\n",
                    thetas[t], lambda[j], a[j], ref[j]);
            assert_true(a[j] <= 1.0);
            testutil_assert_near(a[j], ref[j], 0.02 * ref[j]);
        }
    }
}

/* Sampling's density is the pdf: a histogram of sampled directions over (cos theta, phi) cells
 * against the pdf integrated over each cell (chi-square, tail 1e-6), and sample's f and pdf
 * are eval's and pdf's at its direction. */
static void check_sampling(const bsdf_t *m, vec3_t wo, uint64_t seed)
{
    enum { NC = 16, NP = 32, N = 200000 };
    static double hist[NC * NP], expect[NC * NP];
    memset(hist, 0, sizeof hist);
    memset(expect, 0, sizeof expect);
    uint64_t s = seed;
    for (int i = 0; i < N; i++) {
        bsdf_sample_t out;
        if (!bsdf_sample(m, wo, 0, 0.5, testutil_splitmix_u(&s), testutil_splitmix_u(&s), NULL,
                         &out))
            continue;
        if (i < 200) {
            double f, pdf;
            bsdf_eval(m, wo, out.wi, NULL, &f);
            bsdf_pdf(m, wo, out.wi, NULL, &pdf);
            assert_true(f == out.f[0] && pdf == out.pdf[0]);
        }
        int c = (int)(out.wi.z * NC),
            p = (int)((atan2(out.wi.y, out.wi.x) + PF_PI) / (2 * PF_PI) * NP);
        c = c < NC ? c : NC - 1;
        p = p < NP ? p : NP - 1;
        hist[c * NP + p] += 1.0;
    }
    /* The pdf over each cell by the midpoint rule on a finer grid (d omega = dz dphi). */
    const int sub = 8;
    double total = 0.0;
    for (int c = 0; c < NC; c++)
        for (int p = 0; p < NP; p++) {
            double sum = 0.0;
            for (int a = 0; a < sub; a++)
                for (int b = 0; b < sub; b++) {
                    double z = (c + (a + 0.5) / sub) / NC;
                    double ph = -PF_PI + 2 * PF_PI * (p + (b + 0.5) / sub) / NP;
                    double r = sqrt(fmax(0.0, 1 - z * z));
                    double pdf;
                    bsdf_pdf(m, wo, vec3_make(r * cos(ph), r * sin(ph), z), NULL, &pdf);
                    sum += pdf;
                }
            expect[c * NP + p] = sum / (sub * sub) * (1.0 / NC) * (2 * PF_PI / NP) * N;
            total += expect[c * NP + p];
        }
    /* Cells pooled until each expects at least 20 samples. */
    double chi2 = 0.0, eo = 0.0, ee = 0.0;
    int dof = 0;
    for (int i = 0; i < NC * NP; i++) {
        eo += hist[i];
        ee += expect[i];
        if (ee >= 20.0) {
            chi2 += (eo - ee) * (eo - ee) / ee;
            dof++;
            eo = ee = 0.0;
        }
    }
    fprintf(stderr, "wo (%.2f %.2f %.2f): pdf integrates to %.4f, chi2 %.1f over %d cells\n", wo.x,
            wo.y, wo.z, total / N, chi2, dof);
    assert_true(total / N <= 1.01);
    assert_true(dof > 50);
    assert_true(chi2 < testutil_chi2_quantile(dof - 1, 4.75));
}

static void test_sampling_matches_pdf(void **state)
{
    (void)state;
    const double lambda[1] = {550.0};
    bsdf_t m = measured_bsdf(lambda, 1);
    check_sampling(&m, dir(0.2, 1.1), 5);
    check_sampling(&m, dir(0.9, 1.1), 6);
}

/* An anisotropic file (phi_i over the full circle, wm's azimuths absolute): the conductor of
 * alphas 0.15 along u and 0.45 along v, its lobe's orientation in the shading frame included,
 * in value, albedo and sampling, at outgoing azimuths between the file's. */
static void test_anisotropic(void **state)
{
    (void)state;
    const microfacet_t mf = {0.15, 0.45};
    size_t len = 0;
    uint8_t *bytes = measured_testutil_ggx_aniso(mf.alpha_x, mf.alpha_y, 13, 8, 48, 3, &len);
    assert_non_null(bytes);
    err_t err;
    measured_t *an = measured_new(bytes, len, "aniso.bsdf", &err);
    if (!an)
        fail_msg("%s", err.msg);
    assert_false(measured_isotropic(an));
    double median, p95, worst;
    assert_true(f_errors(an, mf, &median, &p95, &worst) > 1000);
    assert_true(median < 0.02);
    assert_true(p95 < 0.06);
    /* Turned a quarter: the lobe is then the wrong way round, and far off. */
    double turned;
    assert_true(f_errors(an, (microfacet_t){mf.alpha_y, mf.alpha_x}, &turned, &p95, &worst) > 100);
    assert_true(turned > 10 * median);
    const double lambda[1] = {550.0};
    bsdf_t m = measured_of(an, lambda, 1);
    check_sampling(&m, dir(0.7, 0.4), 8);
    bsdf_t c = conductor_of(mf, 550.0);
    for (int t = 0; t < 2; t++) {
        vec3_t wo = dir(t ? 1.1 : 0.3, t ? 2.0 : 0.4);
        uint64_t s = 31 + t;
        double a = 0.0, ref = 0.0;
        enum { N = 40000 };
        for (int i = 0; i < N; i++) {
            double u1 = testutil_splitmix_u(&s), u2 = testutil_splitmix_u(&s);
            bsdf_sample_t out;
            if (bsdf_sample(&m, wo, 0, 0.5, u1, u2, NULL, &out))
                a += out.f[0] * fabs(out.wi.z) / out.pdf[0] / N;
            if (bsdf_sample(&c, wo, 0, 0.5, u1, u2, NULL, &out))
                ref += out.f[0] * fabs(out.wi.z) / out.pdf[0] / N;
        }
        fprintf(stderr, "anisotropic albedo: measured %.4f conductor %.4f\n", a, ref);
        testutil_assert_near(a, ref, 0.02 * ref);
    }
    measured_destroy(&an);
    free(bytes);
}

/* The conductor's data are reciprocal: f(wo, wi) = f(wi, wo) to the tabulation's accuracy;
 * and a wo below the surface sees the data mirrored. */
static void test_reciprocity(void **state)
{
    (void)state;
    uint64_t s = 11;
    const double lambda[1] = {600.0};
    bsdf_t m = measured_bsdf(lambda, 1);
    double worst = 0.0, sum = 0.0;
    int n = 0;
    for (int i = 0; i < 1000; i++) {
        vec3_t a =
            dir(acos(1.0 - 0.66 * testutil_splitmix_u(&s)), 2 * PF_PI * testutil_splitmix_u(&s));
        vec3_t b =
            dir(acos(1.0 - 0.66 * testutil_splitmix_u(&s)), 2 * PF_PI * testutil_splitmix_u(&s));
        double fab, fba, fneg;
        bsdf_eval(&m, a, b, NULL, &fab);
        bsdf_eval(&m, b, a, NULL, &fba);
        bsdf_eval(&m, vec3_neg(a), vec3_neg(b), NULL, &fneg);
        assert_true(fneg == fab);
        if (fab + fba < 0.1)
            continue;
        double r = fabs(fab - fba) / (0.5 * (fab + fba));
        worst = fmax(worst, r);
        sum += r;
        n++;
    }
    fprintf(stderr, "reciprocity: mean %.4f worst %.4f over %d pairs\n", sum / n, worst, n);
    assert_true(sum / n < 0.01);
    assert_true(worst < 0.05);
    /* Never transmits. */
    double f;
    bsdf_eval(&m, dir(0.3, 0), vec3_neg(dir(0.3, 0)), NULL, &f);
    assert_true(f == 0.0);
}

/* Each lane reads the spectra at its own wavelength: the ratio of two lanes' f is the ratio
 * of the conductor's Fresnel at the two wavelengths; outside the file's range the nearest
 * end's value. */
static void test_lanes_read_their_wavelength(void **state)
{
    (void)state;
    const double lambda[4] = {380.0, 780.0, 300.0, 900.0};
    bsdf_t m = measured_bsdf(lambda, 4);
    vec3_t wo = dir(0.4, 0.2), wi = dir(0.4, 0.2 + PF_PI);
    double f[4];
    bsdf_eval(&m, wo, wi, NULL, f);
    double eta, k;
    measured_testutil_index(380.0, &eta, &k);
    double f380 = fresnel_conductor(0.92106, eta, k);
    measured_testutil_index(780.0, &eta, &k);
    double f780 = fresnel_conductor(0.92106, eta, k); /* cos 0.4: normal incidence on wm = z */
    testutil_assert_near(f[0] / f[1], f380 / f780, 0.01 * f380 / f780);
    assert_true(f[2] == f[0]);
    assert_true(f[3] == f[1]);
    double lo, hi;
    measured_lambda_range(brdf, &lo, &hi);
    assert_true(lo == 380.0 && hi == 780.0);
    assert_true(measured_isotropic(brdf));
    assert_string_equal(measured_description(brdf), "prismfarm test: GGX conductor");
}

static void expect_refused(const uint8_t *buf, size_t len, const char *phrase)
{
    err_t err = {{0}};
    measured_t *m = measured_new(buf, len, "bad.bsdf", &err);
    if (m)
        fail_msg("a damaged file was read (expected \"%s\")", phrase);
    if (!strstr(err.msg, "bad.bsdf") || (phrase && !strstr(err.msg, phrase)))
        fail_msg("message \"%s\" lacks \"bad.bsdf\" or \"%s\"", err.msg, phrase ? phrase : "");
}

/* Offset of field name's header in the file (its name-length u16). */
static size_t field_header(const uint8_t *buf, const char *name)
{
    size_t at = 18;
    for (uint32_t i = 0; i < le_get_u32(buf + 14); i++) {
        uint16_t nl = le_get_u16(buf + at);
        if (nl == strlen(name) && !memcmp(buf + at + 2, name, nl))
            return at;
        at += 2 + nl;
        uint16_t nd = le_get_u16(buf + at);
        at += 2 + 1 + 8 + 8 * (size_t)nd;
    }
    fail_msg("no field %s", name);
    return 0;
}

/* Damaged files: every truncation of the header and a sample of the data's, bad magic and
 * version, counts and extents too large for the file, wrong types, missing and mismatched
 * fields, RGB-only data: each refused, naming the file and what was expected, without
 * reading past the bytes (the sanitizer build checks that) or allocating beyond them. */
static void test_damaged_files_refused(void **state)
{
    (void)state;
    size_t len = 0;
    uint8_t *good = measured_testutil_ggx(0.5, 3, 4, 2, &len);
    assert_non_null(good);
    uint8_t *b = malloc(len);
    assert_non_null(b);
    err_t err;
    measured_t *ok = measured_new(good, len, "bad.bsdf", &err);
    assert_non_null(ok);
    measured_destroy(&ok);
    for (size_t n = 0; n < len; n += n < 600 ? 1 : 97) {
        /* a buffer of exactly n bytes: the sanitizer build sees any read past it */
        uint8_t *exact = malloc(n ? n : 1);
        memcpy(exact, good, n);
        expect_refused(exact, n, NULL);
        free(exact);
    }
    memcpy(b, good, len);
    b[0] = 'T';
    expect_refused(b, len, "not a tensor file");
    memcpy(b, good, len);
    b[12] = 2;
    expect_refused(b, len, "version 2.0");
    memcpy(b, good, len);
    le_put_u32(b + 14, 0xffffffffu);
    expect_refused(b, len, "fields");
    /* An extent of 2^40 for vndf: more than the file holds, refused before any allocation. */
    memcpy(b, good, len);
    size_t at = field_header(b, "vndf");
    le_put_u64(b + at + 2 + 4 + 2 + 1 + 8, (uint64_t)1 << 40);
    expect_refused(b, len, "more elements than the file");
    /* A data offset past the end. */
    memcpy(b, good, len);
    at = field_header(b, "spectra");
    le_put_u64(b + at + 2 + 7 + 2 + 1, (uint64_t)len - 8);
    expect_refused(b, len, "past the file's end");
    /* A wrong type, a missing field (renamed), an RGB file, mismatched extents. */
    memcpy(b, good, len);
    at = field_header(b, "sigma");
    b[at + 2 + 5 + 2] = 11;
    expect_refused(b, len, "field \"sigma\" is float64");
    memcpy(b, good, len);
    at = field_header(b, "ndf");
    b[at + 2] = 'x';
    expect_refused(b, len, "no field \"ndf\"");
    const float one[1] = {1.0f};
    const measured_testutil_field_t rgb[] = {{"rgb", 10, 1, {1}, one}};
    size_t rlen = 0;
    uint8_t *rfile = measured_testutil_pack(rgb, 1, &rlen);
    expect_refused(rfile, rlen, "an RGB measured BSDF");
    free(rfile);
    memcpy(b, good, len);
    at = field_header(b, "luminance");
    le_put_u64(b + at + 2 + 9 + 2 + 1 + 8 + 8, 2); /* theta_i extent 3 -> 2 */
    expect_refused(b, len, "expected phi_i x theta_i");
    memcpy(b, good, len);
    at = field_header(b, "theta_i");
    uint64_t off = le_get_u64(b + at + 2 + 7 + 2 + 1);
    le_put_f32(b + off + 4, 5.0f); /* theta_i no longer increasing */
    expect_refused(b, len, "increasing");
    memcpy(b, good, len);
    at = field_header(b, "vndf");
    off = le_get_u64(b + at + 2 + 4 + 2 + 1);
    le_put_f32(b + off, NAN);
    expect_refused(b, len, "finite");
    free(b);
    free(good);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_plinear2d_warp),
        cmocka_unit_test(test_reproduces_the_conductor),
        cmocka_unit_test(test_albedo),
        cmocka_unit_test(test_sampling_matches_pdf),
        cmocka_unit_test(test_anisotropic),
        cmocka_unit_test(test_reciprocity),
        cmocka_unit_test(test_lanes_read_their_wavelength),
        cmocka_unit_test(test_damaged_files_refused),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
