/* predict: a history whose error falls exactly as 1/sqrt(spp) and whose time is exactly a fixed
 * part plus a cost per spp is predicted exactly; what cannot be predicted says so; the job's
 * whole passes round the prediction up. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <math.h>

#include "predict.h"

/* Passes of 1, 1, 2, 4, ... spp: records at 1, 2, 4, 8, ... spp; error e1 / sqrt(spp) (none at
 * 1 spp, as error_estimate gives none), time fixed + per * spp. */
static int history(pass_record_t *h, int n, double e1, double fixed, double per)
{
    int spp = 1;
    for (int i = 0; i < n; i++, spp *= 2)
        h[i] = (pass_record_t){.pass = i + 1,
                               .spp = spp,
                               .elapsed = fixed + per * spp,
                               .valid = spp >= 2,
                               .rel_error = spp >= 2 ? e1 / sqrt(spp) : 0};
    return n;
}

static void test_exact(void **state)
{
    (void)state;
    pass_record_t h[8];
    int n = history(h, 5, 0.8, 1.5, 0.25); /* up to 16 spp: error 0.2 */
    predict_t p = predict_target(h, n, 0.05);
    assert_true(p.valid);
    assert_int_equal(p.from_spp, 16);
    assert_true(fabs(p.from_error - 0.2) < 1e-12);
    assert_true(fabs(p.spp - 256.0) < 1e-9); /* 16 (0.2 / 0.05)^2 */
    assert_true(fabs(p.per_spp - 0.25) < 1e-12);
    assert_true(fabs(p.fixed - 1.5) < 1e-12);
    assert_true(fabs(p.seconds - (1.5 + 0.25 * 256)) < 1e-9);
    /* The passes' cut: 256 is a boundary; 257 rounds up to 512; past the cap, the cap. */
    assert_int_equal(predict_pass_spp(&p, 1024), 256);
    assert_true(fabs(predict_pass_seconds(&p, 1024) - (1.5 + 0.25 * 256)) < 1e-9);
    p.spp = 257;
    assert_int_equal(predict_pass_spp(&p, 1024), 512);
    assert_int_equal(predict_pass_spp(&p, 300), 300);
}

static void test_unpredictable(void **state)
{
    (void)state;
    pass_record_t h[4];
    history(h, 1, 0.8, 0, 1); /* 1 spp: no estimate */
    assert_false(predict_target(h, 1, 0.1).valid);
    history(h, 3, 0.8, 0, 1);
    assert_false(predict_target(h, 3, 0.0).valid);
    assert_false(predict_target(h, 3, 1.0).valid);
    assert_false(predict_target(h, 3, NAN).valid);
    assert_false(predict_target(NULL, 0, 0.1).valid);
    h[1].rel_error = h[2].rel_error = INFINITY; /* an unbounded estimate is no estimate */
    assert_false(predict_target(h, 3, 0.1).valid);
    /* One record with an estimate: the rate alone, no fixed part. */
    history(h, 2, 0.8, 0, 0.5);
    h[0].elapsed = h[1].elapsed; /* no time between the records */
    predict_t p = predict_target(h, 2, 0.1);
    assert_true(p.valid);
    assert_true(fabs(p.per_spp - h[1].elapsed / 2) < 1e-12);
    assert_true(p.fixed == 0.0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_exact),
        cmocka_unit_test(test_unpredictable),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
