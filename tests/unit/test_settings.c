/* settings: a job's settings reach the scene loader unchanged; the stopping rules stay the
 * master's. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h> /* after the four headers it needs */

#include "settings.h"

static const proto_settings_t g_settings = {256, 640, 480, 42, "path", "fanout", 0.01, 90.5, 0, 2};

static void test_settings_mirror_overrides(void **state)
{
    (void)state;
    scene_overrides_t ov = settings_to_overrides(&g_settings);
    assert_int_equal(ov.spp, 256);
    assert_int_equal(ov.xres, 640);
    assert_int_equal(ov.yres, 480);
    assert_int_equal(ov.seed, 42);
    assert_string_equal(ov.integrator, "path");
    assert_string_equal(ov.dispersion, "fanout");
    assert_int_equal(ov.polarized, SCENE_POLARIZED_ON);
    assert_ptr_equal(ov.integrator, g_settings.integrator); /* strings are not copied */
    assert_ptr_equal(ov.dispersion, g_settings.dispersion);
}

/* "Keep the file's value" passes as itself: 0, -1 and NULL. */
static void test_keep_values_pass_through(void **state)
{
    (void)state;
    const proto_settings_t keep = PROTO_SETTINGS_FILE;
    scene_overrides_t ov = settings_to_overrides(&keep);
    assert_int_equal(ov.spp, 0);
    assert_int_equal(ov.xres, 0);
    assert_int_equal(ov.yres, 0);
    assert_int_equal(ov.seed, -1);
    assert_null(ov.integrator);
    assert_null(ov.dispersion);
    assert_int_equal(ov.polarized, SCENE_POLARIZED_FILE);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_settings_mirror_overrides),
        cmocka_unit_test(test_keep_values_pass_through),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
