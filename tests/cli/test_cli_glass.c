/* prismfarm glass, run as a process ($PRISMFARM_BIN): its output against SCHOTT datasheet
 * values and its exit codes (0 ok, 1 unknown glass or unphysical model, 2 bad command line). */

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h> /* after the four headers above, which it needs */

#include "cli_run.h"

/* `prismfarm glass N-BK7` prints the catalogue's Fraunhofer-line indices and Abbe number,
 * which must be the SCHOTT N-BK7 datasheet's: n_F 1.52238, n_d 1.51680, n_C 1.51432,
 * v_d 64.17. */
static void test_nbk7_default(void **state)
{
    (void)state;
    const run_t *r = run("glass", "N-BK7", NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "n_d = 1.51680");
    expect_in(r->out, "n_F = 1.52238");
    expect_in(r->out, "n_C = 1.51432");
    expect_in(r->out, "v_d = 64.17");
    assert_string_equal(r->err, "");
}

/* Names are case-insensitive and aliases work: pbrt-v4's glass-BK7, the thesis's "LaSF 35"
 * (SCHOTT LASF35: n_d 2.02204, v_d 29.06), glass-F11 = SF11 (n_d 1.78472, v_d 25.76). */
static void test_names_and_aliases(void **state)
{
    (void)state;
    const run_t *r = run("glass", "n-bk7", NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "n_d = 1.51680");
    r = run("glass", "glass-BK7", NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "n_d = 1.51680");
    r = run("glass", "LaSF 35", NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "n_d = 2.02204");
    expect_in(r->out, "v_d = 29.06");
    r = run("glass", "glass-F11", NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "n_d = 1.78472");
    expect_in(r->out, "v_d = 25.76");
}

/* Explicit wavelengths: N-BK7 datasheet n_e (546.074 nm) = 1.51872; "nm" suffix accepted. */
static void test_wavelengths(void **state)
{
    (void)state;
    const run_t *r = run("glass", "N-BK7", "546.074", "587.5618nm", NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "n(546.074 nm) = 1.51872");
    expect_in(r->out, "n(587.562 nm) = 1.51680");
    assert_null(strstr(r->out, "v_d"));
}

static void test_list(void **state)
{
    (void)state;
    const run_t *r = run("glass", "--list", NULL);
    assert_int_equal(r->status, 0);
    const char *names[] = {"N-BK7",   "N-SF11",   "N-LASF9", "F2",           "N-SF6",    "N-BAF10",
                           "N-FK51A", "LASF35",   "SF5",     "SF10",         "SF11",     "water",
                           "diamond", "sapphire", "CaF2",    "fused-silica", "glass-F10"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        expect_in(r->out, names[i]);
    /* The N-BK7 row carries the datasheet n_d and v_d. */
    const char *row = strstr(r->out, "\nN-BK7 ");
    assert_non_null(row);
    const char *end = strchr(row + 1, '\n');
    assert_non_null(end);
    char line[256];
    size_t len = (size_t)(end - row) < sizeof line - 1 ? (size_t)(end - row) : sizeof line - 1;
    memcpy(line, row, len);
    line[len] = '\0';
    expect_in(line, "1.51680");
    expect_in(line, "64.17");
    expect_in(line, "SCHOTT");

    r = run("glass", "--list", "extra", NULL);
    assert_int_equal(r->status, 2);
}

static void test_help(void **state)
{
    (void)state;
    const run_t *r = run("glass", "--help", NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "usage: prismfarm glass");
    r = run("glass", NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "usage");
    r = run("glass", "--bogus", NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "'--bogus'");
}

static void test_unknown_glass(void **state)
{
    (void)state;
    const run_t *r = run("glass", "unobtainium", NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "unknown glass 'unobtainium' (see prismfarm glass --list)");
    assert_string_equal(r->out, "");
}

/* Bad wavelengths exit 2 and name the argument. */
static void test_bad_wavelengths(void **state)
{
    (void)state;
    const char *bad[] = {"abc", "-5", "nan", "inf", "1e9", "550x", "", "50"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        const run_t *r = run("glass", "N-BK7", "550", bad[i], NULL);
        if (r->status != 2)
            fail_msg("wavelength '%s': exit %d, expected 2", bad[i], r->status);
        char quoted[64];
        snprintf(quoted, sizeof quoted, "bad wavelength '%s'", bad[i]);
        expect_in(r->err, quoted);
        assert_string_equal(r->out, "");
    }
}

/* Custom models: Sellmeier B = 1, C = 0 is sqrt(2) = 1.41421 everywhere (not dispersive);
 * Cauchy A = 1.5, B = 0.005 um^2 is 1.52 at 500 nm; a pole at sqrt(0.25) um = 500 nm inside
 * the requested 400-600 nm is refused (exit 1, naming it); malformed lists exit 2. */
static void test_custom_models(void **state)
{
    (void)state;
    const run_t *r = run("glass", "--sellmeier", "1,0", NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "n_d = 1.41421");
    expect_in(r->out, "v_d = inf");
    r = run("glass", "--sellmeier", "1,1,0", "700", NULL); /* A0 = 1, B = 1, C = 0: sqrt 3 */
    assert_int_equal(r->status, 0);
    expect_in(r->out, "n(700 nm) = 1.73205");
    r = run("glass", "--cauchy", "1.5,0.005", "500", NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "n(500 nm) = 1.52000");
    r = run("glass", "--sellmeier", "1,0.25", "400", "600", NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "Sellmeier pole at 500.0 nm");
    r = run("glass", "--sellmeier", "1,x", NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "'1,x'");
    r = run("glass", "--cauchy", "1.5", NULL);
    assert_int_equal(r->status, 2);
    r = run("glass", "--sellmeier", NULL);
    assert_int_equal(r->status, 2);
    r = run("glass", "--sellmeier", "1,0,1,0,1,0,1,0,1,0,1,0,1,0", NULL);
    assert_int_equal(r->status, 2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_nbk7_default),
        cmocka_unit_test(test_names_and_aliases),
        cmocka_unit_test(test_wavelengths),
        cmocka_unit_test(test_list),
        cmocka_unit_test(test_help),
        cmocka_unit_test(test_unknown_glass),
        cmocka_unit_test(test_bad_wavelengths),
        cmocka_unit_test(test_custom_models),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
