/* dispersion: the IOR models against hand-derived values, pole and n^2 <= 0 rejection with
 * the material named, the dispersive test and the NaN-free guards of ior_eval. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h> /* after the four headers above, which it needs */

#include <math.h>
#include <string.h>

#include "dispersion.h"
#include "numeric_testutil.h"

/* Models with closed-form values are exact up to a few roundings of numbers near 1. */
#define EXACT 1e-14

static void test_constant(void **state)
{
    (void)state;
    ior_model_t m = ior_constant(1.5);
    assert_true(ior_eval(&m, 380.0) == 1.5);
    assert_true(ior_eval(&m, 720.0) == 1.5);
    assert_false(ior_is_dispersive(&m, 380.0, 720.0));
    double vd;
    assert_false(ior_abbe_number(&m, &vd));
    assert_true(vd == 0.0);
    assert_int_equal(ior_validate(&m, "c", 380.0, 720.0, NULL), 0);
}

/* n = A + B / L^2 with L in um: A = 1.5, B = 0.005 um^2 gives 1.5 + 0.005 / 0.25 = 1.52 at
 * 500 nm and 1.5 + 0.005 / 1 = 1.505 at 1000 nm. */
static void test_cauchy(void **state)
{
    (void)state;
    ior_model_t m = ior_cauchy(1.5, 0.005);
    testutil_assert_near(ior_eval(&m, 500.0), 1.52, EXACT);
    testutil_assert_near(ior_eval(&m, 1000.0), 1.505, EXACT);
    assert_true(ior_is_dispersive(&m, 380.0, 720.0));
    /* Abbe number from the definition, worked by hand: n_F - n_C = B (1/L_F^2 - 1/L_C^2). */
    double lf = IOR_LAMBDA_F_NM * 1e-3, lc = IOR_LAMBDA_C_NM * 1e-3, ld = IOR_LAMBDA_D_NM * 1e-3;
    double expected = (0.5 + 0.005 / (ld * ld)) / (0.005 * (1.0 / (lf * lf) - 1.0 / (lc * lc)));
    double vd;
    assert_true(ior_abbe_number(&m, &vd));
    testutil_assert_near(vd, expected, 1e-9);
    /* B = 1e-9 um^2 moves n by 5e-9 over 380-720 nm: below IOR_DISPERSIVE_EPSILON. */
    ior_model_t flat = ior_cauchy(1.5, 1e-9);
    assert_false(ior_is_dispersive(&flat, 380.0, 720.0));
    ior_model_t none = ior_cauchy(1.33, 0.0);
    assert_false(ior_is_dispersive(&none, 380.0, 720.0));
}

/* Sellmeier forms with closed-form values: B = 1, C = 0 gives n^2 = 1 + 1 = 2 at every
 * wavelength; A0 = 1 with no term also n^2 = 2; A0 = 0.5 plus B = 0.5, C = 0 again 2.
 * B = 1, C = 0.25 um^2 at 1000 nm: n^2 = 1 + 1 / (1 - 0.25) = 7/3. */
static void test_sellmeier_closed_forms(void **state)
{
    (void)state;
    ior_model_t m;
    double b1[] = {1.0}, c0[] = {0.0};
    assert_int_equal(ior_sellmeier(&m, 0.0, b1, c0, 1, NULL), 0);
    testutil_assert_near(ior_eval(&m, 400.0), sqrt(2.0), EXACT);
    testutil_assert_near(ior_eval(&m, 700.0), sqrt(2.0), EXACT);
    /* A Sellmeier model can be non-dispersive: the renderer must not fan out for it. */
    assert_false(ior_is_dispersive(&m, 380.0, 720.0));

    assert_int_equal(ior_sellmeier(&m, 1.0, NULL, NULL, 0, NULL), 0);
    testutil_assert_near(ior_eval(&m, 550.0), sqrt(2.0), EXACT);

    double bh[] = {0.5};
    assert_int_equal(ior_sellmeier(&m, 0.5, bh, c0, 1, NULL), 0);
    testutil_assert_near(ior_eval(&m, 550.0), sqrt(2.0), EXACT);

    double cq[] = {0.25};
    assert_int_equal(ior_sellmeier(&m, 0.0, b1, cq, 1, NULL), 0);
    testutil_assert_near(ior_eval(&m, 1000.0), sqrt(7.0 / 3.0), EXACT);
}

/* Terms add: six terms B_i = 0.1, C_i = 0 give n^2 = 1.6 exactly; seven are refused. */
static void test_sellmeier_term_count(void **state)
{
    (void)state;
    double b[7] = {0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1}, c[7] = {0};
    ior_model_t m = ior_constant(9.0);
    assert_int_equal(ior_sellmeier(&m, 0.0, b, c, IOR_SELLMEIER_MAX_TERMS, NULL), 0);
    testutil_assert_near(ior_eval(&m, 500.0), sqrt(1.6), EXACT);
    err_t err;
    ior_model_t untouched = ior_constant(9.0);
    assert_int_equal(ior_sellmeier(&untouched, 0.0, b, c, 7, &err), -1);
    assert_non_null(strstr(err.msg, "7 terms"));
    assert_true(untouched.kind == IOR_CONSTANT && untouched.constant == 9.0);
    double bad[] = {NAN};
    assert_int_equal(ior_sellmeier(&untouched, 0.0, bad, c, 1, &err), -1);
    assert_int_equal(ior_sellmeier(&untouched, INFINITY, NULL, NULL, 0, &err), -1);
}

/* C = 0.4521^2 um^2 puts the pole at exactly 452.1 nm, inside 380-720 nm. */
static void test_pole_rejected_with_material(void **state)
{
    (void)state;
    double b[] = {1.0, 0.2}, c[] = {0.4521 * 0.4521, 0.01};
    ior_model_t m;
    assert_int_equal(ior_sellmeier(&m, 0.0, b, c, 2, NULL), 0);
    err_t err;
    assert_int_equal(ior_validate(&m, "foo", 380.0, 720.0, &err), -1);
    assert_string_equal(err.msg, "material 'foo': Sellmeier pole at 452.1 nm lies inside the "
                                 "sampled range 380-720 nm");
    /* The same model is fine where the pole is not sampled. */
    assert_int_equal(ior_validate(&m, "foo", 500.0, 720.0, &err), 0);
    /* A pole exactly on the range's end is inside. */
    double c_edge[] = {0.38 * 0.38, 0.01};
    assert_int_equal(ior_sellmeier(&m, 0.0, b, c_edge, 2, NULL), 0);
    assert_int_equal(ior_validate(&m, "edge", 380.0, 720.0, &err), -1);
    assert_non_null(strstr(err.msg, "pole at 380.0 nm"));
    /* A term with B = 0 has no pole. */
    double b0[] = {0.0, 0.2};
    double c_in[] = {0.25, 0.01};
    assert_int_equal(ior_sellmeier(&m, 0.0, b0, c_in, 2, NULL), 0);
    assert_int_equal(ior_validate(&m, "zero-b", 380.0, 720.0, &err), 0);
    /* At 500 nm the zero term is 0 * 0.25 / 0 (once a NaN): only the second term counts,
     * n^2 = 1 + 0.2 * 0.25 / 0.24. */
    testutil_assert_near(ior_eval(&m, 500.0), sqrt(1.0 + 0.05 / 0.24), EXACT);
}

/* B = -0.5, C = 0.09 um^2 (pole at 300 nm, outside the range): at 380 nm
 * n^2 = 1 - 0.5 * 0.1444 / 0.0544 = -0.327, at 720 nm 1 - 0.5 * 0.5184 / 0.4284 = +0.395.
 * Only part of the range has no real index; validation must find it. */
static void test_negative_n2_rejected(void **state)
{
    (void)state;
    double b[] = {-0.5}, c[] = {0.09};
    ior_model_t m;
    assert_int_equal(ior_sellmeier(&m, 0.0, b, c, 1, NULL), 0);
    err_t err;
    assert_int_equal(ior_validate(&m, "bar", 380.0, 720.0, &err), -1);
    assert_non_null(strstr(err.msg, "material 'bar'"));
    assert_non_null(strstr(err.msg, "n^2"));
    /* n^2 = 0 where 0.5 L^2 = L^2 - 0.09, L = 0.4243 um: above it the model is physical. */
    assert_int_equal(ior_validate(&m, "bar", 430.0, 720.0, &err), 0);
    /* ior_eval never returns a NaN where n^2 < 0. */
    assert_true(ior_eval(&m, 380.0) == 1.0);

    ior_model_t neg = ior_constant(-1.0);
    assert_int_equal(ior_validate(&neg, "neg", 380.0, 720.0, &err), -1);
    assert_non_null(strstr(err.msg, "material 'neg'"));
    ior_model_t cneg = ior_cauchy(-0.5, 0.1); /* n = -0.5 + 0.1/L^2 < 0 above 447 nm */
    assert_int_equal(ior_validate(&cneg, "cneg", 380.0, 720.0, &err), -1);
    ior_model_t cnan = ior_cauchy(NAN, 0.1);
    assert_int_equal(ior_validate(&cnan, "cnan", 380.0, 720.0, &err), -1);
    assert_non_null(strstr(err.msg, "not finite"));
}

static void test_bad_range_rejected(void **state)
{
    (void)state;
    ior_model_t m = ior_cauchy(1.5, 0.004);
    err_t err;
    assert_int_equal(ior_validate(&m, "r", 720.0, 380.0, &err), -1);
    assert_non_null(strstr(err.msg, "material 'r'"));
    assert_int_equal(ior_validate(&m, "r", 0.0, 380.0, &err), -1);
    assert_int_equal(ior_validate(&m, "r", 380.0, INFINITY, &err), -1);
    assert_int_equal(ior_validate(&m, NULL, NAN, 720.0, &err), -1);
    assert_non_null(strstr(err.msg, "(unnamed)"));
    /* A single wavelength is a valid range. */
    assert_int_equal(ior_validate(&m, "r", 550.0, 550.0, &err), 0);
}

/* At a pole, at lambda <= 0 and at NaN the model has no index: 1.0, never NaN or Inf. */
static void test_eval_guards(void **state)
{
    (void)state;
    double b[] = {1.0}, c[] = {0.25};
    ior_model_t m;
    assert_int_equal(ior_sellmeier(&m, 0.0, b, c, 1, NULL), 0);
    assert_true(ior_eval(&m, 500.0) == 1.0);
    assert_true(ior_eval(&m, 0.0) == 1.0);
    assert_true(ior_eval(&m, -500.0) == 1.0);
    assert_true(ior_eval(&m, NAN) == 1.0);
    assert_true(ior_eval(&m, INFINITY) == 1.0);
    for (double l = 499.0; l <= 501.0; l += 0.001)
        assert_true(isfinite(ior_eval(&m, l)));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_constant),
        cmocka_unit_test(test_cauchy),
        cmocka_unit_test(test_sellmeier_closed_forms),
        cmocka_unit_test(test_sellmeier_term_count),
        cmocka_unit_test(test_pole_rejected_with_material),
        cmocka_unit_test(test_negative_n2_rejected),
        cmocka_unit_test(test_bad_range_rejected),
        cmocka_unit_test(test_eval_guards),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
