/* Tests for wavelength: the visible-importance pdf against pbrt-v4's published constant and
 * its normalisation, the inverse CDF against numerical integration of the pdf, sample
 * histograms against the pdf (chi-square), hero-wavelength rotations, and unbiasedness of the
 * hero estimator before and after terminating the secondary wavelengths. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "cie.h"
#include "numeric_testutil.h"
#include "wavelength.h"

#include <math.h>

/* Composite Simpson integral of the visible pdf over [a, b] with 2n panels (error ~1e-13 for
 * n = 2000 on this smooth integrand). */
static double integrate_visible_pdf(double a, double b, int n)
{
    double h = (b - a) / (2 * n), sum = wavelength_pdf_visible(a) + wavelength_pdf_visible(b);
    for (int i = 1; i < 2 * n; i++)
        sum += (i % 2 ? 4.0 : 2.0) * wavelength_pdf_visible(a + i * h);
    return sum * h / 3.0;
}

/* pbrt-v4 (VisibleWavelengthsPDF) publishes the normalisation 0.0039398042 for
 * 1/cosh^2(0.0072 (lambda - 538)) over 360-830 nm; the peak value is that constant. The pdf
 * integrates to 1 (Simpson, 1e-10) and is 0 outside. */
static void test_visible_pdf_normalised(void **state)
{
    (void)state;
    testutil_assert_near(wavelength_pdf_visible(538.0), 0.0039398042, 1e-10);
    testutil_assert_near(integrate_visible_pdf(360.0, 830.0, 2000), 1.0, 1e-10);
    testutil_assert_near(wavelength_pdf_visible(359.9), 0.0, 0.0);
    testutil_assert_near(wavelength_pdf_visible(830.1), 0.0, 0.0);
    testutil_assert_near(wavelength_pdf_visible(NAN), 0.0, 0.0);
    testutil_assert_near(wavelength_pdf_uniform(500.0, 380.0, 720.0), 1.0 / 340.0, 1e-15);
    testutil_assert_near(wavelength_pdf_uniform(300.0, 380.0, 720.0), 0.0, 0.0);
}

/* The inverse CDF: the pdf's integral from 360 nm to lambda(u) is u (to the Simpson error,
 * 1e-9); the returned pdf is the pdf at the returned lambda; the ends map to the ends. */
static void test_visible_inverse_cdf(void **state)
{
    (void)state;
    for (double u = 0.05; u < 1.0; u += 0.05) {
        wavelength_sample_t s = wavelength_sample_visible(u);
        assert_true(s.lambda >= 360.0 && s.lambda <= 830.0);
        testutil_assert_near(integrate_visible_pdf(360.0, s.lambda, 2000), u, 1e-9);
        testutil_assert_near(s.pdf, wavelength_pdf_visible(s.lambda), 0.0);
    }
    testutil_assert_near(wavelength_sample_visible(0.0).lambda, 360.0, 1e-9);
    testutil_assert_near(wavelength_sample_visible(nextafter(1.0, 0.0)).lambda, 830.0, 1e-6);
    testutil_assert_near(wavelength_sample_visible(0.5).lambda,
                         538.0 + atanh(0.5 * (tanh(0.0072 * 292) - tanh(0.0072 * 178))) / 0.0072,
                         1e-9);
    /* Out-of-range u is clamped, never NaN. */
    assert_true(wavelength_sample_visible(-3.0).pdf > 0.0);
    assert_true(wavelength_sample_visible(7.0).pdf > 0.0);
    assert_true(wavelength_sample_visible(NAN).pdf > 0.0);
}

/* Histogram against the pdf: 200000 samples into 47 bins of 10 nm; expected counts from the
 * Simpson integral of the pdf over each bin. Pearson's chi-square has 46 degrees of freedom
 * (mean 46, sd 9.6); the bound 107 is its 1 - 1e-6 quantile (Wilson-Hilferty), and the seed is
 * fixed, so the test is deterministic. The uniform sampler gets the same test over 380-720 nm
 * with 34 bins (33 dof, 1 - 1e-6 quantile 86). */
static void test_histograms(void **state)
{
    (void)state;
    const int samples = 200000;
    enum { BINS = 47 };
    double count[BINS] = {0};
    uint64_t rng = 42;
    for (int s = 0; s < samples; s++) {
        double l = wavelength_sample_visible(testutil_splitmix_u(&rng)).lambda;
        int b = (int)((l - 360.0) / 10.0);
        count[b < BINS ? b : BINS - 1] += 1.0;
    }
    double chi2 = 0.0;
    for (int b = 0; b < BINS; b++) {
        double expect = samples * integrate_visible_pdf(360.0 + 10.0 * b, 370.0 + 10.0 * b, 200);
        chi2 += (count[b] - expect) * (count[b] - expect) / expect;
    }
    print_message("visible sampler: chi-square %.1f for 46 dof\n", chi2);
    assert_true(chi2 < 107.0);

    double ucount[34] = {0};
    for (int s = 0; s < samples; s++) {
        wavelength_sample_t w = wavelength_sample_uniform(testutil_splitmix_u(&rng), 380.0, 720.0);
        assert_true(w.lambda >= 380.0 && w.lambda <= 720.0);
        int b = (int)((w.lambda - 380.0) / 10.0);
        ucount[b < 34 ? b : 33] += 1.0;
    }
    chi2 = 0.0;
    for (int b = 0; b < 34; b++) {
        double expect = samples / 34.0;
        chi2 += (ucount[b] - expect) * (ucount[b] - expect) / expect;
    }
    print_message("uniform sampler: chi-square %.1f for 33 dof\n", chi2);
    assert_true(chi2 < 86.0);
}

/* Hero tuples: every wavelength in range; uniform rotations follow lambda_j = lambda_min +
 * frac((lambda_0 - lambda_min)/range + j/4) range; visible rotations are in u: the CDF of
 * lambda_j is frac(u + j/4); each pdf is that of its own wavelength. */
static void test_hero_rotations(void **state)
{
    (void)state;
    uint64_t rng = 7;
    const double ranges[][2] = {{380.0, 720.0}, {300.0, 1000.0}, {360.0, 830.0}};
    for (int i = 0; i < 2000; i++) {
        double u =
            i < 3 ? (double[]){0.0, 0.75, nextafter(1.0, 0.0)}[i] : testutil_splitmix_u(&rng);
        for (int r = 0; r < 3; r++) {
            double lo = ranges[r][0], hi = ranges[r][1], range = hi - lo;
            wavelength_hero_t h = wavelength_hero_uniform(u, lo, hi);
            for (int j = 0; j < WAVELENGTH_HERO_COUNT; j++) {
                assert_true(h.lambda[j] >= lo && h.lambda[j] <= hi);
                /* Compared on the circle: lambda_min and lambda_max are the same point of the
                 * rotation, and u just below 1 rounds lambda_0 onto lambda_max. */
                double f = (h.lambda[0] - lo) / range + j / 4.0;
                double d = fabs(h.lambda[j] - (lo + (f - floor(f)) * range));
                testutil_assert_near(fmin(d, range - d), 0.0, 1e-9);
                testutil_assert_near(h.pdf[j], 1.0 / range, 1e-15);
            }
        }
        wavelength_hero_t v = wavelength_hero_visible(u);
        for (int j = 0; j < WAVELENGTH_HERO_COUNT; j++) {
            assert_true(v.lambda[j] >= 360.0 && v.lambda[j] <= 830.0);
            testutil_assert_near(v.pdf[j], wavelength_pdf_visible(v.lambda[j]), 0.0);
            if (i % 100 == 0) {
                double uj = u + j / 4.0;
                uj -= floor(uj);
                testutil_assert_near(integrate_visible_pdf(360.0, v.lambda[j], 1000), uj, 1e-8);
            }
        }
    }
}

/* The hero estimator (1/4) sum_j f(lambda_j)/pdf_j is unbiased for the integral of f; with
 * the secondaries terminated, f(lambda_0)/(pdf_0/4)/4 = f(lambda_0)/pdf_0 is too. f = y-bar,
 * whose integral over 360-830 is (to 1e-7) CIE_Y_INTEGRAL. 5 standard errors from the samples. */
static void test_hero_estimator_unbiased(void **state)
{
    (void)state;
    const int samples = 50000;
    for (int terminate = 0; terminate <= 1; terminate++)
        for (int visible = 0; visible <= 1; visible++) {
            uint64_t rng = 1000u + (uint64_t)(2 * terminate + visible);
            double sum = 0.0, sum2 = 0.0;
            for (int s = 0; s < samples; s++) {
                wavelength_hero_t h =
                    visible ? wavelength_hero_visible(testutil_splitmix_u(&rng))
                            : wavelength_hero_uniform(testutil_splitmix_u(&rng), 360.0, 830.0);
                if (terminate) {
                    wavelength_hero_terminate_secondary(&h);
                    assert_true(wavelength_hero_is_terminated(&h));
                }
                double est = 0.0;
                for (int j = 0; j < WAVELENGTH_HERO_COUNT; j++)
                    if (h.pdf[j] > 0.0)
                        est += cie_y_bar(h.lambda[j]) / h.pdf[j];
                est /= WAVELENGTH_HERO_COUNT;
                sum += est;
                sum2 += est * est;
            }
            double mean = sum / samples, se = sqrt((sum2 / samples - mean * mean) / samples);
            assert_true(se < 0.01 * CIE_Y_INTEGRAL);
            if (!(fabs(mean - CIE_Y_INTEGRAL) <= 5.0 * se))
                fail_msg("terminate=%d visible=%d: %g vs %g (5 se = %g)", terminate, visible, mean,
                         CIE_Y_INTEGRAL, 5.0 * se);
        }
    /* Terminating twice changes nothing more. */
    wavelength_hero_t h = wavelength_hero_visible(0.3);
    double p0 = h.pdf[0];
    assert_false(wavelength_hero_is_terminated(&h));
    wavelength_hero_terminate_secondary(&h);
    wavelength_hero_terminate_secondary(&h);
    testutil_assert_near(h.pdf[0], p0 / 4.0, 0.0);
    testutil_assert_near(h.pdf[1] + h.pdf[2] + h.pdf[3], 0.0, 0.0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_visible_pdf_normalised),
        cmocka_unit_test(test_visible_inverse_cdf),
        cmocka_unit_test(test_histograms),
        cmocka_unit_test(test_hero_rotations),
        cmocka_unit_test(test_hero_estimator_unbiased),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
