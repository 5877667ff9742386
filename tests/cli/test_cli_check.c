/* prismfarm check: every refusal and warning of a scene in one run, each naming file:line:col,
 * with the exit status saying whether the scene renders; --json carries the same lines. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h> /* after the four headers above, which it needs */

#include "cli_run.h"
#include "files_testutil.h"

#include <jansson.h>
#include <string.h>

static const char *BAD = "WorldBegin\n"
                         "PixelFilter \"box\"\n"
                         "Material \"skin\"\n"
                         "Shape \"hyperboloid\"\n"
                         "Material \"diffuse\" \"float bogus\" 1\n"
                         "LightSource \"point\"\n"
                         "Shape \"sphere\"\n"
                         "MakeNamedMedium \"m\" \"string type\" \"cloud\"\n";

static void test_every_refusal_at_once(void **state)
{
    (void)state;
    const char *path = testutil_scratch("bad.pbrt");
    testutil_write_text(path, BAD, 0644);
    const run_t *r = run("check", path, NULL);
    assert_int_equal(r->status, 1);
    char line[512];
    snprintf(line, sizeof line, "error: %s:2:1: PixelFilter must come before WorldBegin", path);
    expect_in(r->out, line);
    snprintf(line, sizeof line, "error: %s:3:10: unsupported material \"skin\"", path);
    expect_in(r->out, line);
    snprintf(line, sizeof line, "error: %s:4:7: unsupported shape \"hyperboloid\"", path);
    expect_in(r->out, line);
    snprintf(line, sizeof line, "error: %s:5:20: unsupported parameter \"float bogus\"", path);
    expect_in(r->out, line);
    snprintf(line, sizeof line, "warning: %s:8:1: \"cloud\" media are not simulated", path);
    expect_in(r->out, line);
    expect_in(r->out, "4 refused, 1 warnings; it does not render");

    r = run("check", path, "--json", NULL);
    assert_int_equal(r->status, 1);
    json_error_t je;
    json_t *o = json_loads(r->out, 0, &je);
    assert_non_null(o);
    assert_true(json_is_false(json_object_get(o, "renders")));
    assert_int_equal(json_array_size(json_object_get(o, "errors")), 4);
    assert_int_equal(json_array_size(json_object_get(o, "warnings")), 1);
    json_decref(o);
}

/* A scene that parses is loaded too: its loader warnings come with it, and it renders. */
static void test_clean_scene(void **state)
{
    (void)state;
    const char *path = testutil_scratch("dark.pbrt");
    testutil_write_text(path, "WorldBegin\nShape \"sphere\"\n", 0644);
    const run_t *r = run("check", path, NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "the scene has no light source");
    expect_in(r->out, "0 refused, 1 warnings; it renders");
    r = run("check", NULL);
    assert_int_equal(r->status, 2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_refusal_at_once),
        cmocka_unit_test(test_clean_scene),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_setup, testutil_scratch_teardown);
}
