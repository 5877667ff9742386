/* suggest: edit distances against hand-counted ones (textbook pairs), the bound that separates
 * a slip of the hand from another word, ties, case and the limits. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <string.h>

#include "suggest.h"

static void test_distance(void **state)
{
    (void)state;
    assert_int_equal(suggest_distance("kitten", "sitting"), 3); /* k->s, e->i, +g */
    assert_int_equal(suggest_distance("", "abc"), 3);
    assert_int_equal(suggest_distance("abc", ""), 3);
    assert_int_equal(suggest_distance("same", "same"), 0);
    assert_int_equal(suggest_distance("Integrator", "integrator"), 0); /* case is no edit */
    assert_int_equal(suggest_distance("bpdt", "bdpt"), 1);             /* one swap */
    assert_int_equal(suggest_distance("ca", "abc"), 3); /* OSA: no edit of a swapped pair */
    assert_int_equal(suggest_distance("roughnes", "roughness"), 1);
    char longer[SUGGEST_MAX_LEN + 2];
    memset(longer, 'a', sizeof longer - 1);
    longer[sizeof longer - 1] = 0;
    assert_int_equal(suggest_distance(longer, "a"), -1);
    longer[SUGGEST_MAX_LEN] = 0; /* exactly the maximum is measured */
    assert_int_equal(suggest_distance(longer, longer), 0);
}

static void test_nearest(void **state)
{
    (void)state;
    static const char *const dirs[] = {"Integrator", "Include", "Identity", "LookAt", NULL};
    assert_string_equal(suggest_nearest("Integrater", dirs, 5), "Integrator");
    assert_string_equal(suggest_nearest("lookat", dirs, 5), "LookAt"); /* case only */
    assert_null(suggest_nearest("Integrator", dirs, 5)); /* the word itself: nothing to say */
    assert_null(suggest_nearest("Camera", dirs, 5));     /* another word, not a slip */
    assert_null(suggest_nearest("x", NULL, 0));
    /* The bound: 1 edit up to 4 characters, 2 up to 8, 3 beyond. */
    static const char *const spp[] = {"spp"};
    assert_string_equal(suggest_nearest("sp", spp, 1), "spp");
    assert_null(suggest_nearest("s", spp, 1)); /* 2 edits for a word of 1 */
    static const char *const seed[] = {"seed"};
    assert_null(suggest_nearest("samples", seed, 1));
    static const char *const thr[] = {"threads"};
    assert_string_equal(suggest_nearest("thread", thr, 1), "threads");
    assert_string_equal(suggest_nearest("thraeds", thr, 1), "threads");
    /* Ties: the first candidate in the table's order. */
    static const char *const tie[] = {"abd", "abe"};
    assert_string_equal(suggest_nearest("abc", tie, 2), "abd");
    /* The running form gives the same as the array form, the nearest of several. */
    suggest_t s = suggest_begin("photn");
    suggest_consider(&s, "path");
    suggest_consider(&s, NULL);
    suggest_consider(&s, "photon");
    assert_string_equal(suggest_result(&s), "photon");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_distance),
        cmocka_unit_test(test_nearest),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
