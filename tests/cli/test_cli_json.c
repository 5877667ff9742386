/* The --json output of the client commands is JSON whatever the text in it holds: job and
 * worker names with quotes and backslashes (the protocol refuses control characters in names,
 * so a name with a newline is refused before any output), output paths and a scene path with a
 * quote, a backslash, a newline, a tab and a control character, and a name that is not UTF-8
 * all come back through jansson's parser (each byte that is not UTF-8 as U+FFFD). A master and
 * a worker run as processes over ipc://, which needs no keys (docs/security.md). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#define CLI_RUN_TIMEOUT_MS 120000
#include "cli_run.h"
#include "farm_testutil.h"

#include <jansson.h>
#include <signal.h>
#include <sys/stat.h>

#define SCENE "data/render/tiny.pbrt"
#define AWKWARD_NAME "a \"quoted\" back\\slash {name}, caf\xc3\xa9"
#define AWKWARD_PATH "a \"q\" back\\slash\nnew line\ttab\x01 end"

/* stdout of a command that succeeded, parsed; the caller releases it. */
static json_t *parse_out(const run_t *r, const char *what)
{
    if (r->status != 0)
        fail_msg("%s: exit %d: %s", what, r->status, r->err);
    json_error_t e;
    json_t *v = json_loads(r->out, 0, &e);
    if (!v)
        fail_msg("%s: not JSON (line %d: %s):\n%s", what, e.line, e.text, r->out);
    return v;
}

static void expect_json_string(json_t *o, const char *key, const char *want)
{
    const char *got = json_string_value(json_object_get(o, key));
    if (!got)
        fail_msg("no string \"%s\" in the JSON", key);
    assert_string_equal(got, want);
}

/* The job with id in a JSON array of jobs. */
static json_t *job_in(json_t *jobs, json_int_t id)
{
    assert_true(json_is_array(jobs));
    size_t i;
    json_t *j;
    json_array_foreach(jobs, i, j)
    {
        if (json_integer_value(json_object_get(j, "id")) == id)
            return j;
    }
    fail_msg("no job %lld in the JSON", (long long)id);
    return NULL;
}

static void test_names_round_trip(void **state)
{
    (void)state;
    const char *spool = testutil_scratch("spool");
    char wipc[600], cipc[600];
    snprintf(wipc, sizeof wipc, "ipc://%s", testutil_scratch("w.ipc"));
    snprintf(cipc, sizeof cipc, "ipc://%s", testutil_scratch("c.ipc"));
    pid_t master = testutil_spawn(testutil_scratch("master.log"), "master", "--workers", wipc,
                                  "--clients", cipc, "--spool", spool, "--heartbeat", "200", NULL);
    char wep[256], cep[256];
    testutil_read_endpoints(spool, wep, cep, testutil_scratch("master.log"));

    /* A name with a newline never gets to the master, nor to the output. */
    const run_t *r = run("submit", SCENE, "--master", cep, "--name", "two\nlines", "--json", NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "control character");
    assert_string_equal(r->out, "");

    /* Submitted without a worker, the job waits in the queue: its name as given. */
    r = run("submit", SCENE, "--master", cep, "--spp", "2", "--name", AWKWARD_NAME, "--json", NULL);
    json_t *v = parse_out(r, "submit --json");
    expect_in(r->out, "\"a \\\"quoted\\\" back\\\\slash {name}, caf"); /* escaped */
    expect_json_string(v, "name", AWKWARD_NAME);
    json_int_t id = json_integer_value(json_object_get(v, "job"));
    assert_true(id > 0);
    json_decref(v);
    char idtext[32];
    snprintf(idtext, sizeof idtext, "%lld", (long long)id);

    v = parse_out(run("jobs", "--master", cep, "--json", NULL), "jobs --json");
    expect_json_string(job_in(v, id), "name", AWKWARD_NAME);
    json_decref(v);
    v = parse_out(run("status", idtext, "--master", cep, "--json", NULL), "status --json");
    expect_json_string(job_in(v, id), "name", AWKWARD_NAME);
    json_decref(v);
    v = parse_out(run("cancel", idtext, "--master", cep, "--json", NULL), "cancel --json");
    expect_json_string(job_in(v, id), "name", AWKWARD_NAME);
    json_decref(v);

    /* Not UTF-8: each stray byte becomes U+FFFD; the rest stays. */
    v = parse_out(run("submit", SCENE, "--master", cep, "--spp", "2", "--name", "caf\xe9 \xff\"x",
                      "--json", NULL),
                  "submit --json, a name not UTF-8");
    expect_json_string(v, "name", "caf\xEF\xBF\xBD \xEF\xBF\xBD\"x");
    json_decref(v);

    /* A worker with an awkward name, then the jobs done, with awkward output paths. */
    pid_t worker =
        testutil_spawn(testutil_scratch("worker.log"), "worker", "--connect", wep, "--threads", "2",
                       "--name", AWKWARD_NAME, "--cache", testutil_scratch("cache"), NULL);
    char exr[600], png[600];
    snprintf(exr, sizeof exr, "%s", testutil_scratch(AWKWARD_PATH ".exr"));
    snprintf(png, sizeof png, "%s", testutil_scratch(AWKWARD_PATH ".png"));
    v = parse_out(run("submit", SCENE, "--master", cep, "--spp", "2", "--name", AWKWARD_NAME,
                      "--wait", "--json", "-o", exr, "--quiet", NULL),
                  "submit --wait --json");
    expect_json_string(v, "state", "done");
    expect_json_string(v, "exr", exr);
    expect_json_string(v, "png", png);
    json_decref(v);
    struct stat st;
    assert_int_equal(stat(exr, &st), 0);

    v = parse_out(run("workers", "--master", cep, "--json", NULL), "workers --json");
    assert_true(json_is_array(v) && json_array_size(v) == 1);
    expect_json_string(json_array_get(v, 0), "name", AWKWARD_NAME);
    json_decref(v);

    testutil_stop(worker, SIGTERM);
    testutil_stop(master, SIGTERM);
}

/* `plan --json` names the scene by the path given. */
static void test_plan_scene_path(void **state)
{
    (void)state;
    char dir[600], scene[700];
    snprintf(dir, sizeof dir, "%s", testutil_scratch(AWKWARD_PATH));
    assert_int_equal(mkdir(dir, 0777), 0);
    snprintf(scene, sizeof scene, "%s/tiny.pbrt", dir);
    FILE *in = fopen(SCENE, "rb"), *out = fopen(scene, "wb");
    assert_non_null(in);
    assert_non_null(out);
    char buf[4096];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, in)) > 0)
        assert_int_equal(fwrite(buf, 1, n, out), n);
    fclose(in);
    assert_int_equal(fclose(out), 0);

    json_t *v = parse_out(run("plan", scene, "--json", NULL), "plan --json");
    expect_json_string(v, "scene", scene);
    json_decref(v);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_names_round_trip),
        cmocka_unit_test(test_plan_scene_path),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_setup, testutil_scratch_teardown);
}
