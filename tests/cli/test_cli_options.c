/* The option parser every prismfarm command shares (cli/cli_args.h), run as the executable:
 * options before and after the operands (also under POSIXLY_CORRECT), --opt=value and -oVALUE,
 * "--" ending the options, no abbreviations, -h anywhere, and errors that name the flag and its
 * bad value; each command's --help lists the options it takes, the shared ones included. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#define CLI_RUN_TIMEOUT_MS 120000
#include "cli_run.h"
#include "farm_testutil.h"

#include <sys/stat.h>

#define SCENE "data/render/tiny.pbrt"

static int exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

static void expect_fails(const run_t *r, const char *message)
{
    if (r->status != 2)
        fail_msg("exit %d, expected 2 (stderr: %s)", r->status, r->err);
    expect_in(r->err, message);
    assert_string_equal(r->out, "");
}

/* The options are found wherever they stand, in each spelling; a 4x4 render at 1 spp is quick. */
static void test_spellings_and_order(void **state)
{
    (void)state;
    char out[512];
    snprintf(out, sizeof out, "-o%s", testutil_scratch("attached.exr"));
    const run_t *r = run("render", "--spp=1", "--res", "4x4", out, SCENE, "--quiet", NULL);
    if (r->status != 0)
        fail_msg("render: exit %d: %s", r->status, r->err);
    assert_true(exists(testutil_scratch("attached.exr")));
    expect_in(r->out, "1 of 1 spp");

    r = run("render", SCENE, "--res=4x4", "--spp", "1", "--output", testutil_scratch("after.exr"),
            "--quiet", "--direct", NULL);
    if (r->status != 0)
        fail_msg("render: exit %d: %s", r->status, r->err);
    assert_true(exists(testutil_scratch("after.exr")));

    /* POSIXLY_CORRECT stops a plain getopt at the first operand; the options after it still
     * count. */
    setenv("POSIXLY_CORRECT", "1", 1);
    r = run("render", SCENE, "--spp", "1", "--res", "4x4", "-o", testutil_scratch("posix.exr"),
            "--quiet", NULL);
    unsetenv("POSIXLY_CORRECT");
    if (r->status != 0)
        fail_msg("render under POSIXLY_CORRECT: exit %d: %s", r->status, r->err);
    assert_true(exists(testutil_scratch("posix.exr")));

    /* "--" ends the options: what follows is an operand even when it looks like an option. */
    expect_fails(run("render", "--", SCENE, "--spp", NULL), "--spp (scene file 2 of 2) does not exist");
    r = run("glass", "--", "N-BK7", NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "n_d = 1.51680");
    r = run("glass", "--cauchy=1.5,0.005", "500", NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "n(500 nm) = 1.52000");
}

/* Bad command lines exit 2 with a message naming the flag (and the bad value). */
static void test_errors(void **state)
{
    (void)state;
    expect_fails(run("render", SCENE, "--frobnicate", NULL),
                 "prismfarm render: unknown option '--frobnicate' (see prismfarm render --help)");
    expect_fails(run("render", SCENE, "-x", NULL), "prismfarm render: unknown option '-x'");
    /* getopt_long's abbreviations are refused: --sp is no --spp. */
    expect_fails(run("render", SCENE, "--sp", "4", "-o", testutil_scratch("abbrev.exr"), NULL),
                 "unknown option '--sp'");
    expect_fails(run("submit", SCENE, "--ma", "tcp://x:1", NULL), "unknown option '--ma'");
    expect_fails(run("render", SCENE, "--spp", NULL), "prismfarm render: --spp needs a value");
    expect_fails(run("fetch", "1", "-o", NULL), "prismfarm fetch: -o needs a value");
    expect_fails(run("jobs", "--master", NULL), "prismfarm jobs: --master needs a value");
    expect_fails(run("worker", "--connect", NULL), "prismfarm worker: --connect needs a value");
    expect_fails(run("submit", SCENE, "--key", NULL), "prismfarm submit: --key needs a value");
    expect_fails(run("render", SCENE, "--spp=0", NULL),
                 "prismfarm render: --spp expects an integer in 1..16777216, got '0'");
    expect_fails(run("render", SCENE, "--quiet=yes", NULL),
                 "prismfarm render: --quiet takes no value, got '--quiet=yes'");
    expect_fails(run("render", SCENE, "--exposure", "nan", NULL),
                 "--exposure expects stops in -30..30, got 'nan'");
    expect_fails(run("jobs", "--timeout", "0", NULL),
                 "prismfarm jobs: --timeout expects seconds in 0.1..3600, got '0'");
    expect_fails(run("refine", "3", "--photons", "-1", NULL),
                 "--photons expects an integer in 1..1099511627776, got '-1'");
    expect_fails(run("keygen", "k", "--dir", "", NULL), "prismfarm keygen: --dir needs a folder");
    expect_fails(run("master", "--spool", "", NULL),
                 "prismfarm master: --spool needs a folder name");
    expect_fails(run("master", "stray", NULL), "prismfarm master: unknown argument 'stray'");
    expect_fails(run("worker", "stray", NULL), "prismfarm worker: unexpected argument 'stray'");
    expect_fails(run("jobs", "7", NULL), "prismfarm jobs: unexpected argument '7'");
    expect_fails(run("status", "1", "2", NULL), "prismfarm status: unexpected argument '2'");
    /* plan takes a sequence's frames (docs/plan.md, "Polarisation"), each once. */
    expect_fails(run("plan", SCENE, SCENE, NULL),
                 "prismfarm plan: data/render/tiny.pbrt is given twice as a frame");
    /* plan words --target-error its own way, with the setting's bounds (proto/job_settings.h). */
    expect_fails(run("plan", SCENE, "--target-error", "1", NULL),
                 "prismfarm plan: --target-error expects a relative error in (0, 1), e.g. 0.05, "
                 "got '1'");
    expect_fails(run("submit", SCENE, "--time-limit", "2y", NULL),
                 "prismfarm submit: --time-limit expects seconds in (0, 31536000], optionally "
                 "with s, m or h, got '2y'");
    expect_fails(run("keygen", "a", "b", NULL), "one NAME only ('a' and 'b' given)");
    /* Errors come in the order of the arguments. */
    expect_fails(run("render", "--spp", "x", SCENE, "--res", "0x0", NULL), "--spp expects");
    expect_fails(run("render", "--res", "0x0", SCENE, "--spp", "x", NULL), "--res expects");
}

/* A slip of the hand gets the nearest valid name: commands, options, integrators, and in a
 * scene file directives and the parameters the entity reads. A name far from every valid one
 * gets no suggestion. */
static void test_suggestions(void **state)
{
    (void)state;
    expect_fails(run("rendr", SCENE, NULL), "unknown command 'rendr' (did you mean 'render'?");
    expect_fails(run("render", SCENE, "--sed", "3", NULL),
                 "unknown option '--sed' (did you mean '--seed'?");
    expect_fails(run("render", SCENE, "--thraeds=2", NULL),
                 "unknown option '--thraeds=2' (did you mean '--threads'?");
    /* A word another renderer uses, too far for an edit, names the option too. */
    expect_fails(run("render", SCENE, "--samples", "4", NULL),
                 "unknown option '--samples' (did you mean '--spp'?");
    expect_fails(run("render", SCENE, "--integrator", "bpdt", NULL), "got 'bpdt' (did you mean 'bdpt'?)");
    expect_fails(run("render", SCENE, "--integrator", "ambientocclusion", NULL),
                 "--integrator ambientocclusion is not supported: ambient occlusion renders");
    const char *bad = testutil_scratch("misspelt.pbrt");
    FILE *f = fopen(bad, "w");
    assert_non_null(f);
    fputs("LookAt 0 0 5 0 0 0 0 1 0\nCamera \"perspective\"\nIntegrater \"path\"\nWorldBegin\n"
          "Material \"conductor\" \"float roughnes\" 0.1\nShape \"sphere\"\n",
          f);
    fclose(f);
    const run_t *r = run("check", bad, NULL);
    assert_int_not_equal(r->status, 0);
    expect_in(r->out, "misspelt.pbrt:3:1: unknown directive Integrater (did you mean Integrator?)");
    expect_in(r->out,
              "misspelt.pbrt:5:22: unsupported parameter \"float roughnes\" for Material "
              "\"conductor\" (did you mean \"roughness\"?)");
}

/* --integrator takes every name a scene's Integrator may use, and the header names what runs
 * (and what was asked, where they differ). */
static void test_integrator_names(void **state)
{
    (void)state;
    const char *exr = testutil_scratch("named.exr");
    const run_t *r = run("render", SCENE, "--res", "4x4", "--spp", "1", "-o", exr, "--integrator",
                         "photon", "--direct", NULL);
    if (r->status != 0)
        fail_msg("--integrator photon: exit %d: %s", r->status, r->err);
    expect_in(r->err, "integrator photon+path,");
    expect_in(r->err, "render: why: --integrator photon asks for photons");
    r = run("render", SCENE, "--res", "4x4", "--spp", "1", "-o", exr, "--integrator", "volpath",
            "--direct", NULL);
    if (r->status != 0)
        fail_msg("--integrator volpath: exit %d: %s", r->status, r->err);
    expect_in(r->err, "integrator path (asked: volpath)"); /* no media: volpath is path */
    r = run("render", SCENE, "--res", "4x4", "--spp", "1", "-o", exr, "--integrator", "bdpt",
            "--direct", NULL);
    if (r->status != 0)
        fail_msg("--integrator bdpt: exit %d: %s", r->status, r->err);
    expect_in(r->err, "(asked: bdpt, the plan's choice)");
    expect_in(r->err, "render: why: no photon pass: path tracing finds every light's caustics");
    /* A collimated beam through glass: the plan's photon pass, and the light that decided it. */
    r = run("render", "data/photon/beam.pbrt", "--res", "8x8", "--spp", "1", "-o", exr,
            "--integrator", "auto", "--direct", NULL);
    if (r->status != 0)
        fail_msg("--integrator auto: exit %d: %s", r->status, r->err);
    expect_in(r->err, "integrator photon+path (asked: auto, the plan's choice)");
    expect_in(r->err, "render: why: a photon pass for light ");
    expect_in(r->err, "(collimated): light that path tracing cannot find");
}

/* plan --target-error renders a pilot and predicts the samples and time that reach the target;
 * --json carries the same figures. */
static void test_plan_prediction(void **state)
{
    (void)state;
    const run_t *r = run("plan", SCENE, "--target-error", "0.05", "--pilot", "0.5", NULL);
    if (r->status != 0)
        fail_msg("plan --target-error: exit %d: %s", r->status, r->err);
    expect_in(r->out, "PREDICTION (target error 0.05");
    expect_in(r->out, "pilot: ");
    expect_in(r->out, "a prediction, not a promise");
    r = run("plan", SCENE, "--target-error", "0.05", "--pilot", "0.5", "--json", NULL);
    if (r->status != 0)
        fail_msg("plan --json --target-error: exit %d: %s", r->status, r->err);
    expect_in(r->out, "\"prediction\": {");
    expect_in(r->out, "\"pilot_spp\": ");
    expect_fails(run("plan", SCENE, "--target-error", "1.5", NULL), "--target-error expects");
}

/* --polarized on|off|auto (proto/job_settings.h): the user forces polarised transport and the
 * plan says so; auto is the plan's own decision, so forcing what the plan decides renders the
 * same bytes (polar_off: the plan leaves it off; polar_on: its pilot turns it on), forcing the
 * other changes them; off with a Stokes output is refused. 16 x 12 pixels at 4 spp. */
static void test_polarized_switch(void **state)
{
    (void)state;
    expect_fails(run("render", SCENE, "--polarized", "maybe", NULL),
                 "prismfarm render: --polarized expects on, off or auto, got 'maybe'");
    const run_t *r = run("plan", "data/render/polar_on.pbrt", "--polarized", "off", NULL);
    if (r->status != 0)
        fail_msg("plan --polarized off: exit %d: %s", r->status, r->err);
    expect_in(r->out, "forced by the user (--polarized off");
    r = run("plan", "data/render/polar_off.pbrt", "--polarized", "on", NULL);
    if (r->status != 0)
        fail_msg("plan --polarized on: exit %d: %s", r->status, r->err);
    expect_in(r->out, "forced by the user (--polarized on");
    r = run("plan", "data/render/polar_off.pbrt", "--polarized", "auto", NULL);
    assert_int_equal(r->status, 0);
    assert_null(strstr(r->out, "forced by the user"));

    const char *scenes[2] = {"data/render/polar_off.pbrt", "data/render/polar_on.pbrt"};
    const char *forced[2][2] = {{"off", "on"}, {"on", "off"}}; /* the plan's, the other */
    for (int i = 0; i < 2; i++) {
        char a[512], b[512], c[512];
        snprintf(a, sizeof a, "%s", testutil_scratch(i ? "pon_auto.exr" : "poff_auto.exr"));
        snprintf(b, sizeof b, "%s", testutil_scratch(i ? "pon_same.exr" : "poff_same.exr"));
        snprintf(c, sizeof c, "%s", testutil_scratch(i ? "pon_other.exr" : "poff_other.exr"));
        const char *outs[3] = {a, b, c};
        const char *values[3] = {"auto", forced[i][0], forced[i][1]};
        for (int k = 0; k < 3; k++) {
            r = run("render", scenes[i], "--direct", "--quiet", "--polarized", values[k], "-o",
                    outs[k], NULL);
            if (r->status != 0)
                fail_msg("render %s --polarized %s: exit %d: %s", scenes[i], values[k], r->status,
                         r->err);
        }
        testutil_assert_same_pixels(a, b);
        if (i == 1) /* polar_on's plates change the image by 6 % (its file says why) */
            assert_true(testutil_pixels_differ(a, c));
    }
    r = run("render", "data/render/stokes.pbrt", "--direct", "--quiet", "--polarized", "off", "-o",
            testutil_scratch("stokes_off.exr"), NULL);
    assert_int_not_equal(r->status, 0);
    expect_in(r->err, "--polarized off: the film writes Stokes layers");
}

/* -h and --help anywhere print the usage with every option the command takes, exit 0. */
static void test_help(void **state)
{
    (void)state;
    static const struct {
        const char *cmd;
        const char *options[8];
    } want[] = {
        {"render",
         {"-o, --output OUT.exr", "--spp N", "--res WxH", "--dispersion NAME", "--target-error E",
          "--time-limit T", "--exposure STOPS", "--direct"}},
        {"submit",
         {"--master ENDPOINT", "--name NAME", "--seed N", "--wait", "-o, --output OUT", "--json",
          "--master-key FILE", "--insecure"}},
        {"status",
         {"--master ENDPOINT", "--timeout S", "--json", "--wait", "--quiet", "--key FILE"}},
        {"jobs", {"--master ENDPOINT", "--timeout S", "--json"}},
        {"workers", {"--master ENDPOINT", "--json"}},
        {"cancel", {"--master ENDPOINT", "--json"}},
        {"fetch", {"-o, --output OUT.exr", "--master ENDPOINT", "--timeout S"}},
        {"refine", {"--photons N", "--master ENDPOINT", "--wait", "-o, --output OUT.exr"}},
        {"plan", {"--json", "--spp N", "--integrator NAME"}},
        {"glass", {"--list", "--sellmeier LIST", "--cauchy A,B", "-h, --help"}},
        {"keygen", {"--dir DIR", "--force"}},
        {"upgrade", {"-o, --output NEW.pbrt", "--quiet"}},
        {"master",
         {"--workers ENDPOINT", "--heartbeat MS", "--no-journal", "--key FILE", "--authorized DIR",
          "--max-bundle-files N"}},
        {"worker", {"--connect ENDPOINT", "--threads N", "--cache DIR", "--master-key FILE"}},
    };
    for (size_t i = 0; i < sizeof want / sizeof want[0]; i++) {
        const run_t *r = run(want[i].cmd, "--help", NULL);
        if (r->status != 0)
            fail_msg("%s --help: exit %d", want[i].cmd, r->status);
        char usage[64];
        snprintf(usage, sizeof usage, "usage: prismfarm %s", want[i].cmd);
        expect_in(r->out, usage);
        for (int k = 0; k < 8 && want[i].options[k]; k++)
            expect_in(r->out, want[i].options[k]);
    }
    const run_t *r = run("render", SCENE, "--spp", "4", "-h", NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "usage: prismfarm render");
    r = run("status", "3", "--help", NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "usage: prismfarm status");
    /* glass reads NAME's wavelengths after it as they are. */
    r = run("glass", "N-BK7", "--help", NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "bad wavelength '--help'");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_spellings_and_order),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_suggestions),
        cmocka_unit_test(test_integrator_names),
        cmocka_unit_test(test_plan_prediction),
        cmocka_unit_test(test_help),
        cmocka_unit_test(test_polarized_switch),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_setup, testutil_scratch_teardown);
}
