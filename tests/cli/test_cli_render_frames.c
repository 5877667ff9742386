/* prismfarm render of a frame sequence (docs/farm.md, "Frame sequences"), run as a process:
 * several frame files, or a pattern with --frames, each frame's EXR the pixels `render` writes
 * for that frame alone (through the farm and with --direct); -o as a pattern, outputs named
 * after the frame files without it; a missing frame or a bad pattern refused before anything
 * is rendered. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#define CLI_RUN_TIMEOUT_MS 120000
#include "cli_run.h"
#include "farm_testutil.h"
#include "image_exr.h"

#include <limits.h>
#include <sys/stat.h>

/* Three frames of data/render/tiny.pbrt in scratch/fr/walk000K.pbrt, the camera moved 0.1 to
 * the side from each to the next, so that a frame rendered in another's place shows. */
static int write_frames(void **state)
{
    (void)state;
    if (testutil_scratch_setup(state) < 0)
        return -1;
    size_t size;
    char *tiny = testutil_slurp("data/render/tiny.pbrt", &size);
    char *look = tiny ? strstr(tiny, "LookAt 0 1 -3") : NULL;
    if (!look || mkdir(testutil_scratch("fr"), 0755) != 0 ||
        mkdir(testutil_scratch("out"), 0755) != 0)
        return -1;
    for (int k = 1; k <= 3; k++) {
        char name[64];
        snprintf(name, sizeof name, "fr/walk%04d.pbrt", k);
        FILE *f = fopen(testutil_scratch(name), "w");
        if (!f)
            return -1;
        fprintf(f, "%.*sLookAt 0.%d 1 -3%s", (int)(look - tiny), tiny, k,
                look + strlen("LookAt 0 1 -3"));
        fclose(f);
    }
    free(tiny);
    return 0;
}

static const char *frame(int k)
{
    char name[64];
    snprintf(name, sizeof name, "fr/walk%04d.pbrt", k);
    return testutil_scratch(name);
}

static void expect_ok(const run_t *r)
{
    if (r->status != 0)
        fail_msg("exit %d: %s", r->status, r->err);
}

/* Whether the two EXRs hold the same pixels, spectral and RGB (a file that cannot be read fails
 * the test). Their bytes differ in the record of the render (its seconds, job id and name). */
static bool same_pixels(const char *a, const char *b)
{
    err_t err;
    image_exr_t *x = image_exr_read(a, &err), *y = x ? image_exr_read(b, &err) : NULL;
    if (!x || !y)
        fail_msg("%s", err.msg);
    bool same =
        image_exr_width(x) == 24 && image_exr_width(y) == 24 && image_exr_height(x) == 16 &&
        image_exr_height(y) == 16 && image_exr_n_spectral(x) == 8 && image_exr_n_spectral(y) == 8 &&
        !memcmp(image_exr_spectral(x), image_exr_spectral(y), 24 * 16 * 8 * sizeof(float)) &&
        !memcmp(image_exr_rgb(x), image_exr_rgb(y), 24 * 16 * 3 * sizeof(float));
    image_exr_destroy(&x);
    image_exr_destroy(&y);
    return same;
}

static bool exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

static void test_sequence_equals_frames_alone(void **state)
{
    (void)state;
    for (int direct = 0; direct < 2; direct++) {
        const char *pattern = testutil_scratch(direct ? "out/d%04d.exr" : "out/f%04d.exr");
        const run_t *r = run("render", frame(1), frame(2), frame(3), "-o", pattern, "--threads",
                             "2", "--quiet", direct ? "--direct" : NULL, NULL);
        expect_ok(r);
        expect_in(r->out, "3 frames written");
        /* The one result buffer: every line read before the next command runs. */
        for (int k = 1; k <= 3; k++) {
            char name[64];
            snprintf(name, sizeof name, direct ? "out/d%04d.exr" : "out/f%04d.exr", k);
            expect_in(r->out, name);
        }
        for (int k = 1; k <= 3; k++) {
            char name[64], alone[64], png[64];
            snprintf(name, sizeof name, direct ? "out/d%04d.exr" : "out/f%04d.exr", k);
            snprintf(png, sizeof png, direct ? "out/d%04d.png" : "out/f%04d.png", k);
            snprintf(alone, sizeof alone, "alone%d-%d.exr", direct, k);
            assert_true(exists(testutil_scratch(png)));
            expect_ok(run("render", frame(k), "-o", testutil_scratch(alone), "--threads", "1",
                          "--quiet", direct ? "--direct" : NULL, NULL));
            if (!same_pixels(testutil_scratch(name), testutil_scratch(alone)))
                fail_msg("%s differs from frame %d rendered alone", name, k);
        }
        /* The frames are different images: each file is its own frame's. */
        assert_false(same_pixels(testutil_scratch(direct ? "out/d0001.exr" : "out/f0001.exr"),
                                 testutil_scratch(direct ? "out/d0002.exr" : "out/f0002.exr")));
    }
}

/* The pattern form, without -o: each output is named after its frame file, in the current
 * folder (as `submit --wait` names them), and only the frames of the range are rendered. */
static void test_pattern_and_default_names(void **state)
{
    (void)state;
    char cwd[PATH_MAX];
    assert_non_null(getcwd(cwd, sizeof cwd));
    assert_int_equal(chdir(testutil_scratch_dir()), 0);
    const run_t *r = run("render", "fr/walk%04d.pbrt", "--frames", "2-3", "--quiet", NULL);
    assert_int_equal(chdir(cwd), 0);
    expect_ok(r);
    expect_in(r->out, "2 frames written");
    assert_false(exists(testutil_scratch("walk0001.exr")));
    assert_true(exists(testutil_scratch("walk0003.png")));
    assert_true(same_pixels(testutil_scratch("walk0002.exr"), testutil_scratch("out/f0002.exr")));
}

static void test_bad_sequences(void **state)
{
    (void)state;
    const char *pattern = testutil_path_in(testutil_scratch_dir(), "fr/walk%04d.pbrt");
    const char *out = testutil_scratch("out/e%04d.exr");
    /* A missing frame: refused before the first is rendered. */
    const run_t *r = run("render", pattern, "--frames", "1-4", "-o", out, "--quiet", NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "frame 4:");
    expect_in(r->err, "walk0004.pbrt does not exist");
    assert_false(exists(testutil_scratch("out/e0001.exr")));
    r = run("render", pattern, "--frames", "3-1", "--quiet", NULL);
    assert_int_equal(r->status, 2);
    r = run("render", pattern, "--quiet", NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "give --frames");
    /* A missing file in a list: refused before the frames before it are rendered. */
    r = run("render", frame(1), testutil_scratch("fr/walk0009.pbrt"), "-o", out, "--quiet", NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "walk0009.pbrt (scene file 2 of 2) does not exist");
    assert_false(exists(testutil_scratch("out/e0001.exr")));
    r = run("render", testutil_scratch("fr/*.exr"), "--quiet", NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "matched no file");
    /* -o of a sequence is a pattern: one file for three frames is refused. */
    r = run("render", frame(1), frame(2), "-o", testutil_scratch("out/one.exr"), "--quiet", NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "-o for a sequence of frames");
    assert_false(exists(testutil_scratch("out/one.exr")));
    /* A broken frame: named with its file and line before any frame is rendered. */
    const char *broken = testutil_scratch("fr/walk0005.pbrt");
    testutil_write_text(broken, "LookAt 0 1 -3  0 0.5 0  0 1 0\nCamera \"perspective\" \"float\n",
                        0644);
    r = run("render", frame(1), broken, "-o", out, "--quiet", NULL);
    assert_int_equal(unlink(broken), 0);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "frame 2 of 2: ");
    expect_in(r->err, "walk0005.pbrt:");
    assert_false(exists(testutil_scratch("out/e0001.exr")));
    /* With --direct every frame is loaded first, for the sequence's one polarisation decision
     * (polar_seq.h): a broken frame is refused before any is written. */
    r = run("render", frame(1), "data/render/broken.pbrt", "-o", out, "--quiet", "--direct", NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "frame 2 (data/render/broken.pbrt): data/render/broken.pbrt:4:");
    assert_false(exists(testutil_scratch("out/e0001.exr")));
    /* With the decision forced there is nothing to load first: the frames render one by one,
     * and the frames before a broken one are written. */
    r = run("render", frame(1), "data/render/broken.pbrt", "-o", out, "--quiet", "--direct",
            "--polarized", "off", NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "data/render/broken.pbrt:4:");
    expect_in(r->err, "1 of 2 frames written");
    assert_true(exists(testutil_scratch("out/e0001.exr")));
}

/* Frames of two folders cannot share a bundle: each renders in a farm of its own, with the same
 * pixels (numbered 1, 2: tiny.pbrt's name has no number). */
static void test_frames_of_two_folders(void **state)
{
    (void)state;
    const char *out = testutil_scratch("out/two%04d.exr");
    const run_t *r = run("render", frame(3), "data/render/tiny.pbrt", "-o", out, "--quiet", NULL);
    expect_ok(r);
    expect_in(r->out, "2 frames written");
    assert_true(same_pixels(testutil_scratch("out/two0001.exr"), testutil_scratch("out/f0003.exr")));
    expect_ok(run("render", "data/render/tiny.pbrt", "-o", testutil_scratch("tiny.exr"), "--quiet",
                  NULL));
    assert_true(same_pixels(testutil_scratch("out/two0002.exr"), testutil_scratch("tiny.exr")));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sequence_equals_frames_alone),
        cmocka_unit_test(test_pattern_and_default_names),
        cmocka_unit_test(test_bad_sequences),
        cmocka_unit_test(test_frames_of_two_folders),
    };
    return cmocka_run_group_tests(tests, write_frames, testutil_scratch_teardown);
}
