/* thinfilm: a thin film's reflectance and transmittance against optics: the Airy sum of its
 * inter-reflections summed term by term with this test's own Fresnel coefficients, the Airy
 * intensity formula, energy conservation (R + T = 1 for a lossless film), the quarter-wave
 * anti-reflection coating, the half-wave film that is absent, and degenerate inputs. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h> /* after the four headers above, which it needs */

#include <complex.h>
#include <math.h>

#include "numeric_testutil.h"
#include "polar_fresnel.h"
#include "thinfilm.h"

#define PI 3.14159265358979323846
#define DEG (PI / 180.0)

/* The test's own Fresnel amplitudes (Hecht, Optics, eq. 4.42-4.43, 4.48-4.49) for complex
 * indices and cosines. */
typedef struct amp {
    double complex r[2], t[2]; /* [0] s, [1] p */
} amp_t;

static amp_t amp(double complex ni, double complex ci, double complex nt, double complex ct)
{
    amp_t a;
    a.r[0] = (ni * ci - nt * ct) / (ni * ci + nt * ct);
    a.t[0] = 2.0 * ni * ci / (ni * ci + nt * ct);
    a.r[1] = (nt * ci - ni * ct) / (nt * ci + ni * ct);
    a.t[1] = 2.0 * ni * ci / (nt * ci + ni * ct);
    return a;
}

static double complex snell_cos(double complex n0, double cos0, double complex n)
{
    double complex s = n0 * sqrt(1.0 - cos0 * cos0) / n;
    double complex c = csqrt(1.0 - s * s);
    if (cimag(n * c) < 0.0)
        c = -c;
    return c;
}

/* The Airy sum (Born & Wolf §1.6.4; Hecht §9.7.1): the wave reflected at the top, plus the
 * waves that enter, bounce m + 1 times off the bottom and m times off the top, and leave:
 *   r = r01 + t01 t10 r12 e^{2ib} sum_m (r10 r12 e^{2ib})^m, t = t01 t12 e^{ib} sum_m (...)^m. */
static void airy_series(double cos0, double complex n0, double complex n1, double d,
                        double complex n2, double lambda, int pol, double complex *r,
                        double complex *t)
{
    double complex c1 = snell_cos(n0, cos0, n1), c2 = snell_cos(n0, cos0, n2);
    amp_t a01 = amp(n0, cos0, n1, c1), a10 = amp(n1, c1, n0, cos0), a12 = amp(n1, c1, n2, c2);
    double complex beta = 2.0 * PI * n1 * c1 * d / lambda, e2 = cexp(2.0 * I * beta);
    double complex q = a10.r[pol] * a12.r[pol] * e2, term = 1.0, sum = 0.0;
    for (int m = 0; m < 200000 && cabs(term) > 1e-18; m++) {
        sum += term;
        term *= q;
    }
    *r = a01.r[pol] + a01.t[pol] * a10.t[pol] * a12.r[pol] * e2 * sum;
    *t = a01.t[pol] * a12.t[pol] * cexp(I * beta) * sum;
}

/* The film's amplitudes against the term-by-term sum, for soap, MgF2 and TiO2 films over glass,
 * water, air and a metal, thicknesses 0 to 1 um, across the visible and at 0-80 degrees. */
static void test_airy_series(void **state)
{
    (void)state;
    const double complex films[] = {1.33, 1.38, 2.4};
    const double complex subs[] = {1.0, 1.333, 1.52, 0.43 + 2.45 * I};
    const double ds[] = {0.0, 35.0, 99.6, 250.0, 1000.0};
    const double lambdas[] = {400.0, 550.0, 700.0};
    int n = 0;
    for (size_t fi = 0; fi < 3; fi++)
        for (size_t si = 0; si < 4; si++)
            for (size_t di = 0; di < 5; di++)
                for (size_t li = 0; li < 3; li++)
                    for (double deg = 0.0; deg <= 80.0; deg += 20.0) {
                        double c0 = cos(deg * DEG);
                        thinfilm_t f =
                            thinfilm_eval(c0, 1.0, films[fi], ds[di], subs[si], lambdas[li]);
                        for (int pol = 0; pol < 2; pol++) {
                            double complex r, t;
                            airy_series(c0, 1.0, films[fi], ds[di], subs[si], lambdas[li], pol, &r,
                                        &t);
                            double complex fr = pol ? f.rp : f.rs, ft = pol ? f.tp : f.ts;
                            testutil_assert_near(creal(fr), creal(r), 1e-9);
                            testutil_assert_near(cimag(fr), cimag(r), 1e-9);
                            testutil_assert_near(creal(ft), creal(t), 1e-9);
                            testutil_assert_near(cimag(ft), cimag(t), 1e-9);
                            n++;
                        }
                    }
    assert_int_equal(n, 3 * 4 * 5 * 3 * 5 * 2);
}

/* The Airy formula for a lossless film below every critical angle (Born & Wolf §1.6.4 eq. 59;
 * Hecht eq. 9.61 with real coefficients):
 *   R = (r01^2 + r12^2 + 2 r01 r12 cos 2b) / (1 + r01^2 r12^2 + 2 r01 r12 cos 2b),
 * and R + T = 1 per polarisation. */
static void test_airy_formula_energy(void **state)
{
    (void)state;
    const double films[] = {1.33, 1.38, 1.7, 2.4};
    const double subs[] = {1.0, 1.333, 1.52, 1.9};
    for (size_t fi = 0; fi < 4; fi++)
        for (size_t si = 0; si < 4; si++)
            for (double d = 0.0; d <= 2000.0; d += 97.0)
                for (double lambda = 380.0; lambda <= 780.0; lambda += 50.0)
                    for (double deg = 0.0; deg <= 85.0; deg += 5.0) {
                        double c0 = cos(deg * DEG), s0 = sin(deg * DEG);
                        double n1 = films[fi], n2 = subs[si];
                        double c1 = sqrt(1.0 - s0 * s0 / (n1 * n1));
                        double c2 = sqrt(1.0 - s0 * s0 / (n2 * n2));
                        amp_t a01 = amp(1.0, c0, n1, c1), a12 = amp(n1, c1, n2, c2);
                        double b2 = 4.0 * PI * n1 * c1 * d / lambda;
                        thinfilm_t f = thinfilm_eval(c0, 1.0, n1, d, n2, lambda);
                        for (int pol = 0; pol < 2; pol++) {
                            double r01 = creal(a01.r[pol]), r12 = creal(a12.r[pol]);
                            double num = r01 * r01 + r12 * r12 + 2.0 * r01 * r12 * cos(b2);
                            double den = 1.0 + r01 * r01 * r12 * r12 + 2.0 * r01 * r12 * cos(b2);
                            double R = pol ? f.Rp : f.Rs, T = pol ? f.Tp : f.Ts;
                            testutil_assert_near(R, num / den, 1e-12);
                            testutil_assert_near(R + T, 1.0, 1e-12);
                        }
                    }
    /* Beyond the substrate's critical angle (glass, film, air: light inside the glass at 60
     * degrees) nothing leaves: R = 1, T = 0, for every film thickness (the evanescent wave in
     * the film does not frustrate it here: the air is semi-infinite). */
    for (double d = 0.0; d <= 500.0; d += 50.0) {
        thinfilm_t f = thinfilm_eval(cos(60.0 * DEG), 1.5, 1.38, d, 1.0, 550.0);
        testutil_assert_near(f.Rs, 1.0, 1e-12);
        testutil_assert_near(f.Rp, 1.0, 1e-12);
        testutil_assert_near(f.Ts + f.Tp, 0.0, 1e-12);
    }
}

/* Optical coatings (Hecht §9.7.2): a quarter-wave film of index sqrt(n_glass) reflects nothing
 * at its design wavelength at normal incidence; a half-wave film is absent (the bare substrate's
 * reflectance); a soap film much thinner than the wavelength turns black (R -> 0, Newton's
 * black film), and its reflectance peaks where 2 n d = (m + 1/2) lambda. */
static void test_coatings(void **state)
{
    (void)state;
    const double ng = 1.52, n1 = sqrt(ng), lambda = 550.0;
    thinfilm_t q = thinfilm_eval(1.0, 1.0, n1, lambda / (4.0 * n1), ng, lambda);
    testutil_assert_near(thinfilm_reflectance(&q), 0.0, 1e-15);
    testutil_assert_near(thinfilm_transmittance(&q), 1.0, 1e-14);
    const double bare = (ng - 1.0) * (ng - 1.0) / ((ng + 1.0) * (ng + 1.0));
    thinfilm_t h = thinfilm_eval(1.0, 1.0, 1.38, lambda / (2.0 * 1.38), ng, lambda);
    testutil_assert_near(thinfilm_reflectance(&h), bare, 1e-14);
    /* A real MgF2 coating (1.38) on the glass leaves about 1.3 % at 550 nm. */
    thinfilm_t mg = thinfilm_eval(1.0, 1.0, 1.38, lambda / (4.0 * 1.38), ng, lambda);
    double r = (1.52 - 1.38 * 1.38) / (1.52 + 1.38 * 1.38);
    testutil_assert_near(thinfilm_reflectance(&mg), r * r, 1e-14);
    /* The soap film. */
    thinfilm_t black = thinfilm_eval(1.0, 1.0, 1.33, 1e-3, 1.0, lambda);
    testutil_assert_near(thinfilm_reflectance(&black), 0.0, 1e-9);
    const double r01 = (1.0 - 1.33) / (2.33);
    const double peak = 4.0 * r01 * r01 / ((1.0 + r01 * r01) * (1.0 + r01 * r01));
    thinfilm_t p = thinfilm_eval(1.0, 1.0, 1.33, 0.5 * lambda / (2.0 * 1.33), 1.0, lambda);
    testutil_assert_near(thinfilm_reflectance(&p), peak, 1e-14);
    /* Zero thickness: the bare interface, as polar_fresnel gives it, at every angle. */
    for (double deg = 0.0; deg < 90.0; deg += 7.0) {
        thinfilm_t z = thinfilm_eval(cos(deg * DEG), 1.0, 1.7, 0.0, ng, lambda);
        polar_fresnel_t b = polar_fresnel_eval(cos(deg * DEG), 1.0, ng);
        testutil_assert_near(z.Rs, b.Rs, 1e-14);
        testutil_assert_near(z.Rp, b.Rp, 1e-14);
        testutil_assert_near(z.Ts, b.Ts, 1e-14);
        mueller_t m = thinfilm_reflection(&z), mb = polar_fresnel_reflection(&b);
        for (int i = 0; i < 4; i++)
            for (int j = 0; j < 4; j++)
                testutil_assert_near(m.m[i][j], mb.m[i][j], 1e-14);
    }
}

/* Grazing incidence, thick absorbing films, total reflection inside a film, absurd inputs: every
 * value finite and in [0, 1]. */
static void test_degenerate(void **state)
{
    (void)state;
    const double coss[] = {0.0, 4.9e-324, 1e-6, 0.3, 1.0};
    const double complex films[] = {1.0, 1.33, 0.2 + 3.0 * I, 1e-300 + 0.0 * I, 1e300};
    const double ds[] = {0.0, 1e-300, 500.0, 1e9, INFINITY, NAN};
    for (size_t i = 0; i < 5; i++)
        for (size_t j = 0; j < 5; j++)
            for (size_t k = 0; k < 6; k++) {
                thinfilm_t f = thinfilm_eval(coss[i], 1.5, films[j], ds[k], 0.43 + 2.45 * I, 550.0);
                double v[] = {f.Rs, f.Rp, f.Ts, f.Tp};
                for (int m = 0; m < 4; m++)
                    assert_true(v[m] >= 0.0 && v[m] <= 1.0);
                mueller_t r = thinfilm_reflection(&f), t = thinfilm_transmission(&f);
                for (int a = 0; a < 4; a++)
                    for (int b = 0; b < 4; b++)
                        assert_true(isfinite(r.m[a][b]) && isfinite(t.m[a][b]));
            }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_airy_series),
        cmocka_unit_test(test_airy_formula_energy),
        cmocka_unit_test(test_coatings),
        cmocka_unit_test(test_degenerate),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
