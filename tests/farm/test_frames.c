/* Frame sequences (docs/farm.md, "Frame sequences") end to end, with master and worker processes
 * on ipc:// endpoints: three frame files sharing an included file and a PLY mesh make one job
 * whose frames each have the pixels of that frame file submitted alone with the sequence's one
 * polarisation decision (polar_seq.h: the frames decide differently alone -- the pilot turns
 * it on for frame 1 only -- and the sequence carries it for all three, a restart keeps it, and
 * `render` of the sequence, with or without its farm, and `plan` agree), whatever the number of
 * workers; the shared files reach the master's spool and each worker's cache once; status lists
 * the frames under their job; fetch writes each frame to an -o pattern or to its file's name; a
 * master killed mid-sequence resumes every frame from its journal; cancel ends every frame; and
 * bad command lines (a missing frame, an empty glob, frames of two folders, a broken frame, an
 * -o without a frame number) are refused with a message saying why. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#define CLI_RUN_TIMEOUT_MS 120000
#include "cli_run.h"
#include "farm_testutil.h"
#include "polar_seq.h"

#include <dirent.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define NFRAMES 3

/* What every frame includes: the film, the world and a PLY mesh; the frames differ only in
 * their camera. */
static const char COMMON[] =
    "Film \"spectral\" \"integer xresolution\" [ 24 ] \"integer yresolution\" [ 16 ]\n"
    "    \"integer nbuckets\" [ 8 ] \"float lambdamin\" [ 380 ] \"float lambdamax\" [ 720 ]\n"
    "Sampler \"independent\" \"integer pixelsamples\" [ 4 ]\n"
    "Integrator \"path\" \"integer maxdepth\" [ 4 ]\n"
    "WorldBegin\n"
    "LightSource \"infinite\" \"rgb L\" [ 0.5 0.5 0.5 ]\n"
    "Material \"diffuse\" \"rgb reflectance\" [ 0.6 0.5 0.4 ]\n"
    "Shape \"trianglemesh\" \"point3 P\" [ -3 0 -3  3 0 -3  3 0 3  -3 0 3 ]\n"
    "    \"integer indices\" [ 0 2 1  0 3 2 ]\n"
    "Material \"dielectric\" \"string glass\" \"diamond\"\n"
    "Translate 0 0.5 0\n"
    "Shape \"plymesh\" \"string filename\" \"mesh.ply\"\n";

static char g_dir[1024]; /* the frames' folder in the scratch folder */

static const char *frame_path(int k)
{
    static char buf[4][1100];
    char *p = buf[k & 3];
    snprintf(p, sizeof buf[0], "%s/walk%04d.pbrt", g_dir, k);
    return p;
}

/* walk0001..walk0003.pbrt, common.pbrt and mesh.ply (the test mesh of tests/data) in the
 * scratch folder's frames/. */
static void write_frames(void)
{
    snprintf(g_dir, sizeof g_dir, "%s", testutil_scratch("frames"));
    assert_int_equal(mkdir(g_dir, 0755), 0);
    char path[1200];
    snprintf(path, sizeof path, "%s/common.pbrt", g_dir);
    testutil_write_text(path, COMMON, 0644);
    size_t size;
    char *ply = testutil_slurp("data/scenes/meshes/tetra_binary.ply", &size);
    assert_non_null(ply);
    snprintf(path, sizeof path, "%s/mesh.ply", g_dir);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(ply, 1, size, f), size);
    assert_int_equal(fclose(f), 0);
    free(ply);
    for (int k = 1; k <= NFRAMES; k++) {
        char text[256];
        snprintf(text, sizeof text,
                 "LookAt %d 1 -3  0 0.5 0  0 1 0\nCamera \"perspective\" \"float fov\" [ 40 ]\n"
                 "Include \"common.pbrt\"\n",
                 k - 2);
        testutil_write_text(frame_path(k), text, 0644);
    }
}

static int setup(void **state)
{
    if (testutil_scratch_setup(state) < 0)
        return -1;
    write_frames();
    return 0;
}

typedef struct farm {
    char spool[512], mlog[1024], wep[1100], cep[1100];
    pid_t master;
} farm_t;

/* A master on ipc:// endpoints in the scratch folder (no keys: ipc:// needs none), with its
 * dashboard on a port the system chooses when http, its reads open (--dashboard-public: the
 * test reads the sequence's view, not who may). */
static void start_master_http(farm_t *f, const char *name, bool http)
{
    snprintf(f->spool, sizeof f->spool, "%s", testutil_scratch(name));
    char log[128];
    snprintf(log, sizeof log, "%s.log", name);
    snprintf(f->mlog, sizeof f->mlog, "%s", testutil_scratch(log));
    snprintf(f->wep, sizeof f->wep, "ipc://%s-w.sock", f->spool);
    snprintf(f->cep, sizeof f->cep, "ipc://%s-c.sock", f->spool);
    f->master = testutil_spawn(f->mlog, "master", "--workers", f->wep, "--clients", f->cep,
                               "--spool", f->spool, "--heartbeat", "200", "--tile", "8",
                               http ? "--http" : NULL, "0", "--dashboard-public", NULL);
    testutil_wait_file_has(f->mlog, "clients on");
}

static void start_master(farm_t *f, const char *name)
{
    start_master_http(f, name, false);
}

static pid_t start_worker(const farm_t *f, const char *name, const char *cache)
{
    char log[128];
    snprintf(log, sizeof log, "%s.log", name);
    return testutil_spawn(testutil_scratch(log), "worker", "--connect", f->wep, "--threads", "1",
                          "--name", name, "--cache", cache, NULL);
}

/* The bundles a worker's cache holds: its folders named by a 64-digit hash. */
static int cached_bundles(const char *cache)
{
    DIR *d = opendir(cache);
    if (!d)
        return -1;
    int n = 0;
    for (struct dirent *e; (e = readdir(d));)
        n += strlen(e->d_name) == 64 && strspn(e->d_name, "0123456789abcdef") == 64;
    closedir(d);
    return n;
}

static void wait_workers(const farm_t *f, int n)
{
    for (double until = testutil_now_s() + test_wait_s();; testutil_sleep_ms(50)) {
        const run_t *r = run("workers", "--master", f->cep, NULL);
        assert_int_equal(r->status, 0);
        if (testutil_count_in(r->out, " idle ") + testutil_count_in(r->out, " busy ") >= n)
            return;
        if (testutil_now_s() > until)
            fail_msg("%d workers not listed after %.0f s:\n%s", n, test_wait_s(), r->out);
    }
}

/* The sequence with 1 and with 2 workers, against each frame submitted alone. */
static void test_sequence_renders_each_frame(void **state)
{
    (void)state;
    farm_t f;
    start_master_http(&f, "spool", true);
    char c1[1100], c2[1100];
    snprintf(c1, sizeof c1, "%s", testutil_scratch("cache1"));
    snprintf(c2, sizeof c2, "%s", testutil_scratch("cache2"));
    pid_t w1 = start_worker(&f, "w1", c1);
    wait_workers(&f, 1);

    /* One worker: job 1 with frames 2..4, written to a pattern. */
    char pattern[1100];
    snprintf(pattern, sizeof pattern, "%s/one-%%02d.exr", testutil_scratch_dir());
    const run_t *r = run("submit", frame_path(1), frame_path(2), frame_path(3), "--master", f.cep,
                         "--wait", "--quiet", "-o", pattern, NULL);
    if (r->status != 0)
        testutil_fail_quoting(f.mlog, "submit of 3 frames: exit %d: %s\nmaster log:", r->status,
                              r->err);
    expect_in(r->out, "job 1 done");
    expect_in(r->out, "3 frames written");
    expect_in(r->out, "frame 3: wrote ");
    expect_in(r->out, "one-03.exr");
    /* The frames' shared files were stored and sent once: one bundle in the spool (its folder
     * and its encoded SCENE), one in the worker's cache, one SCENE sent. */
    char scenes[1200];
    snprintf(scenes, sizeof scenes, "%s/scenes", f.spool);
    assert_int_equal(testutil_count_entries(scenes), 2);
    assert_int_equal(cached_bundles(c1), 1);
    assert_int_equal(testutil_file_count(f.mlog, " sent to worker "), 1);
    assert_true(testutil_file_has(f.mlog, "job 1 'walk0001..walk0003' submitted"));
    /* One polarisation decision for the sequence (issue 28): frame 1's pilot bound is above
     * the 1 % target (its noise at 4 spp), frames 2 and 3 alone are below it, and the
     * sequence's worst frame decides for all three. */
    assert_true(testutil_file_has(f.mlog, "polarisation on for all 3 frames: the pilot measured "
                                          "3 of them, the most on frame 1"));

    /* status: the job, then its frames by number; jobs: the sequence alone. */
    r = run("status", "1", "--master", f.cep, NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "walk0001..walk0003");
    expect_in(r->out, "(3 frames)");
    expect_in(r->out, "#1 walk0001.pbrt");
    expect_in(r->out, "#3 walk0003.pbrt");
    assert_int_equal(testutil_count_in(r->out, " done "), NFRAMES + 1);
    r = run("status", "1", "--master", f.cep, "--json", NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "\"nframes\": 3");
    expect_in(r->out, "\"frames\": [");
    expect_in(r->out, "\"sequence\": 1,\n        \"frame\": 2");
    assert_int_equal(testutil_count_in(r->out, "\"state\": \"done\""), NFRAMES + 1);
    r = run("jobs", "--master", f.cep, NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "walk0001..walk0003");
    assert_null(strstr(r->out, "walk0002.pbrt"));
    /* The dashboard: the sequence in the list, its frames in its view. */
    static char page[65536];
    int port = testutil_http_port(f.spool);
    assert_int_equal(testutil_http(port, "GET", "/api/jobs", NULL, NULL, page, sizeof page), 200);
    expect_in(page, "\"name\":\"walk0001..walk0003\"");
    expect_in(page, "\"nframes\":3");
    assert_null(strstr(page, "walk0002.pbrt"));
    assert_int_equal(testutil_http(port, "GET", "/api/jobs/1", NULL, NULL, page, sizeof page), 200);
    expect_in(page, "\"frames\":[");
    expect_in(page, "\"name\":\"walk0003.pbrt\"");
    expect_in(page, "\"sequence\":1,\"frame\":3");
    expect_in(page, "\"samples_done\":4608"); /* 3 frames of 24x16 at 4 spp */

    /* Two workers: the same frames, to names taken from the frame files (in the current
     * folder: fetch is run in the scratch folder's out/). */
    pid_t w2 = start_worker(&f, "w2", c2);
    wait_workers(&f, 2);
    r = run("submit", frame_path(1), frame_path(2), frame_path(3), "--master", f.cep, NULL);
    assert_int_equal(r->status, 0);
    assert_string_equal(r->out, "5\n");
    r = run("status", "5", "--wait", "--quiet", "--master", f.cep, NULL);
    if (r->status != 0)
        testutil_fail_quoting(f.mlog, "status 5 --wait: exit %d: %s\nmaster log:", r->status,
                              r->err);
    char cwd[1100], out[1100];
    assert_non_null(getcwd(cwd, sizeof cwd));
    snprintf(out, sizeof out, "%s", testutil_scratch("out"));
    assert_int_equal(mkdir(out, 0755), 0);
    assert_int_equal(chdir(out), 0);
    r = run("fetch", "5", "--master", f.cep, NULL);
    assert_int_equal(chdir(cwd), 0);
    if (r->status != 0)
        fail_msg("fetch 5: exit %d: %s", r->status, r->err);
    expect_in(r->out, "frame 2: wrote walk0002.exr and walk0002.png");
    /* No new bundle: the master already held it, and a worker fetches it once. */
    assert_int_equal(testutil_count_entries(scenes), 2);
    assert_true(cached_bundles(c2) <= 1);

    /* `render` of the sequence decides as the master did, on its in-process farm and frame by
     * frame (--direct): the same pixels as the farm's frames. */
    char pat[1100], local[1100], direct[1100];
    snprintf(pat, sizeof pat, "%s/walk%%04d.pbrt", g_dir);
    snprintf(local, sizeof local, "%s/l%%d.exr", testutil_scratch_dir());
    snprintf(direct, sizeof direct, "%s/d%%d.exr", testutil_scratch_dir());
    r = run("render", pat, "--frames", "1-3", "--threads", "2", "-o", local, "--quiet", NULL);
    if (r->status != 0)
        fail_msg("render of the sequence: exit %d: %s", r->status, r->err);
    r = run("render", pat, "--frames", "1-3", "--threads", "2", "-o", direct, "--direct", NULL);
    if (r->status != 0)
        fail_msg("render --direct of the sequence: exit %d: %s", r->status, r->err);
    expect_in(r->err, "render: polarisation on for all 3 frames");
    for (int k = 1; k <= NFRAMES; k++) {
        char got[64], gotp[1100], l[64], lp[1100], d[64], dp[1100];
        snprintf(got, sizeof got, "one-%02d.exr", k);
        snprintf(gotp, sizeof gotp, "%s", testutil_scratch(got));
        snprintf(l, sizeof l, "l%d.exr", k);
        snprintf(lp, sizeof lp, "%s", testutil_scratch(l));
        snprintf(d, sizeof d, "d%d.exr", k);
        snprintf(dp, sizeof dp, "%s", testutil_scratch(d));
        testutil_assert_same_pixels(gotp, lp);
        testutil_assert_same_pixels(gotp, dp);
    }

    /* Frame 2 alone decides otherwise: its pilot leaves polarisation off (and so its pixels
     * are not the sequence's frame 2's: what one decision per sequence is for). */
    char alone2[1100], seq2[1100];
    snprintf(alone2, sizeof alone2, "%s", testutil_scratch("alone2-auto.exr"));
    r = run("submit", frame_path(2), "--master", f.cep, "--wait", "--quiet", "-o", alone2, NULL);
    if (r->status != 0)
        fail_msg("submit frame 2 alone: exit %d: %s", r->status, r->err);
    testutil_wait_file_has(f.mlog, "'walk0002' submitted by");
    assert_true(testutil_file_has(f.mlog, ", polarisation off (the pilot measured"));
    snprintf(seq2, sizeof seq2, "%s", testutil_scratch("one-02.exr"));
    assert_true(testutil_pixels_differ(alone2, seq2));

    /* Each frame alone, as a job of its own with the sequence's decision (--polarized on): the
     * same pixels, from either run. */
    for (int k = 1; k <= NFRAMES; k++) {
        char alone[64], one[64], two[64];
        snprintf(alone, sizeof alone, "alone%d.exr", k);
        snprintf(one, sizeof one, "one-%02d.exr", k);
        snprintf(two, sizeof two, "out/walk%04d.exr", k);
        char alone_path[1100];
        snprintf(alone_path, sizeof alone_path, "%s", testutil_scratch(alone));
        r = run("submit", frame_path(k), "--master", f.cep, "--wait", "--quiet", "-o", alone_path,
                "--polarized", "on", NULL);
        if (r->status != 0)
            fail_msg("submit frame %d alone: exit %d: %s", k, r->status, r->err);
        char a[1100], b[1100];
        snprintf(a, sizeof a, "%s", testutil_scratch(one));
        snprintf(b, sizeof b, "%s", testutil_scratch(two));
        testutil_assert_same_pixels(a, alone_path);
        testutil_assert_same_pixels(b, alone_path);
    }
    /* The frames differ (else the comparison above proves nothing). */
    char a[1100], b[1100];
    snprintf(a, sizeof a, "%s", testutil_scratch("one-01.exr"));
    snprintf(b, sizeof b, "%s", testutil_scratch("one-02.exr"));
    assert_true(testutil_pixels_differ(a, b));

    testutil_stop(w1, SIGTERM);
    testutil_stop(w2, SIGTERM);
    testutil_stop(f.master, SIGTERM);
}

/* A master killed once the first frame is done resumes the others from its journal: every
 * frame ends with the pixels of `prismfarm render` of its file. The frames' spp: the last frame
 * cannot end between the first's "done" and the kill (one worker of one thread renders the
 * oldest job first: frames 2 and 3, 2 x 512 spp of 24 x 16 pixels, a few tenths of a second
 * in a Release build, are still to render, while the test reacts within its 10 ms poll). */
#define RESTART_SPP "512"
static void test_restart_mid_sequence(void **state)
{
    (void)state;
    farm_t f;
    start_master(&f, "rspool");
    char cache[1100];
    snprintf(cache, sizeof cache, "%s", testutil_scratch("rcache"));
    pid_t w = start_worker(&f, "rw", cache);
    const run_t *r =
        run("submit", "--frames", "1-3", "--spp", RESTART_SPP, "--master", f.cep, NULL);
    assert_int_equal(r->status, 2); /* --frames without a pattern */
    char pattern[1100];
    snprintf(pattern, sizeof pattern, "%s/walk%%04d.pbrt", g_dir);
    r = run("submit", pattern, "--frames", "1-3", "--spp", RESTART_SPP, "--master", f.cep, NULL);
    if (r->status != 0)
        fail_msg("submit --frames 1-3: exit %d: %s", r->status, r->err);
    assert_string_equal(r->out, "1\n");
    testutil_wait_file_has(f.mlog, "job 2 'walk0001.pbrt' done");
    /* The sequence's one decision (frames 2 and 3 alone would decide off): the resumed frames
     * keep it from the journal, and the references below are rendered with it. */
    assert_true(testutil_file_has(f.mlog, "polarisation on for all 3 frames"));
    testutil_stop(f.master, SIGKILL);
    start_master(&f, "rspool");
    /* The last frame cannot have ended: one worker of one thread renders the oldest job first. */
    testutil_wait_file_has(f.mlog, "job 4 'walk0003.pbrt' resumed");
    r = run("status", "1", "--wait", "--quiet", "--master", f.cep, NULL);
    if (r->status != 0)
        testutil_fail_quoting(f.mlog,
                              "status 1 --wait after the restart: exit %d: %s\n%s\nmaster "
                              "log:",
                              r->status, r->err, r->out);
    assert_int_equal(testutil_count_in(r->out, " done "), NFRAMES + 1);
    char out[1100];
    snprintf(out, sizeof out, "%s/r%%d.exr", testutil_scratch_dir());
    r = run("fetch", "1", "-o", out, "--master", f.cep, NULL);
    if (r->status != 0)
        fail_msg("fetch 1: exit %d: %s", r->status, r->err);
    for (int k = 1; k <= NFRAMES; k++) {
        char ref[1100], got[64], gotp[1100];
        snprintf(ref, sizeof ref, "%s/ref%d.exr", testutil_scratch_dir(), k);
        r = run("render", frame_path(k), "--spp", RESTART_SPP, "--workers", "1", "--threads", "2",
                "-o", ref, "--quiet", "--polarized", "on", NULL);
        if (r->status != 0)
            fail_msg("render frame %d: exit %d: %s", k, r->status, r->err);
        snprintf(got, sizeof got, "r%d.exr", k);
        snprintf(gotp, sizeof gotp, "%s", testutil_scratch(got));
        testutil_assert_same_pixels(gotp, ref);
    }
    /* `plan` of the sequence says the decision and why. */
    r = run("plan", pattern, "--frames", "1-3", NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "sequence of 3 frames (the plan above is frame 1's alone): polarisation on "
                      "for all 3 frames: the pilot measured 3 of them, the most on frame 1");
    testutil_stop(w, SIGTERM);
    testutil_stop(f.master, SIGTERM);
}

/* Pause, priority and resume of the sequence act on every frame; cancelling it cancels every
 * frame, running or queued. */
static void test_ops_and_cancel_act_on_every_frame(void **state)
{
    (void)state;
    farm_t f;
    start_master(&f, "cspool");
    char cache[1100];
    snprintf(cache, sizeof cache, "%s", testutil_scratch("ccache"));
    pid_t w = start_worker(&f, "cw", cache);
    const run_t *r = run("submit", frame_path(1), frame_path(2), frame_path(3), "--spp", "65536",
                         "--master", f.cep, NULL);
    assert_int_equal(r->status, 0);
    testutil_wait_file_has(f.mlog, "job 2 'walk0001.pbrt' started");
    /* Pause, priority and resume act on every frame. */
    r = run("pause", "1", "--master", f.cep, "--json", NULL);
    if (r->status != 0)
        fail_msg("pause 1: exit %d: %s", r->status, r->err);
    assert_int_equal(testutil_count_in(r->out, "\"state\": \"paused\""), NFRAMES + 1);
    r = run("priority", "1", "7", "--master", f.cep, "--json", NULL);
    if (r->status != 0)
        fail_msg("priority 1 7: exit %d: %s", r->status, r->err);
    assert_int_equal(testutil_count_in(r->out, "\"priority\": 7"), NFRAMES + 1);
    r = run("resume", "1", "--master", f.cep, "--json", NULL);
    if (r->status != 0)
        fail_msg("resume 1: exit %d: %s", r->status, r->err);
    assert_int_equal(testutil_count_in(r->out, "\"state\": \"paused\""), 0);
    /* A second sequence, queued behind the first (job 5, frames 6..8), loses its middle frame
     * by that frame's own id: the others render, and the sequence ends cancelled, not done. */
    r = run("submit", frame_path(1), frame_path(2), frame_path(3), "--master", f.cep, NULL);
    assert_int_equal(r->status, 0);
    assert_string_equal(r->out, "5\n");
    r = run("cancel", "7", "--master", f.cep, NULL);
    assert_int_equal(r->status, 0);
    r = run("cancel", "1", "--master", f.cep, NULL);
    assert_int_equal(r->status, 0);
    r = run("status", "5", "--wait", "--quiet", "--master", f.cep, "--json", NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->out,
              "\"id\": 5,\n    \"name\": \"walk0001..walk0003\",\n    \"state\": \"cancelled\"");
    assert_int_equal(testutil_count_in(r->out, "\"state\": \"done\""), 2);
    expect_in(r->out,
              "\"id\": 7,\n        \"name\": \"walk0002.pbrt\",\n        \"state\": \"cancelled\"");
    r = run("status", "1", "--master", f.cep, "--json", NULL);
    assert_int_equal(r->status, 0);
    assert_int_equal(testutil_count_in(r->out, "\"state\": \"cancelled\""), NFRAMES + 1);
    testutil_wait_file_has(f.mlog, "job 1 'walk0001..walk0003' (3 frames) cancelled");
    /* The sequence's log is its frames' logs, each line named by its frame; a task of the
     * sequence is refused with the frames' ids to use. */
    r = run("logs", "1", "--master", f.cep, NULL);
    if (r->status != 0)
        fail_msg("logs 1: exit %d: %s", r->status, r->err);
    expect_in(r->out, "frame 1 (job 2) ");
    expect_in(r->out, "Z task 0 (pass 0, tile 8x8 at 0,0) attempt 1 assigned to worker ");
    for (int k = 1; k <= NFRAMES; k++) {
        char line[64];
        snprintf(line, sizeof line, "frame %d (job %d) ", k, k + 1);
        const char *at = strstr(r->out, line);
        if (!at)
            fail_msg("no line of frame %d in the sequence's log:\n%s", k, r->out);
        assert_non_null(strstr(at, "Z job cancelled: "));
    }
    for (const char *l = r->out; *l; l = strchr(l, '\n') + 1) {
        if (strncmp(l, "frame ", 6) != 0)
            fail_msg("a line of the sequence's log without its frame: %.80s", l);
        if (!strchr(l, '\n'))
            break;
    }
    r = run("logs", "1", "0", "--master", f.cep, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "job 1 is a sequence of 3 frames: its tasks are its frames', give a "
                      "frame's id (jobs 2..4) with the task");
    r = run("logs", "2", "0", "--master", f.cep, NULL);
    assert_int_equal(r->status, 0);
    expect_in(r->out, "task 0 (pass 0, tile 8x8 at 0,0) attempt 1 assigned to worker ");
    /* Nothing to fetch: the frames did not finish. */
    char out[1100];
    snprintf(out, sizeof out, "%s/c%%d.exr", testutil_scratch_dir());
    r = run("fetch", "1", "-o", out, "--master", f.cep, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "is cancelled: nothing fetched");
    r = run("fetch", "5", "-o", out, "--master", f.cep, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "frame 2 (job 7) is cancelled: nothing fetched");
    testutil_stop(w, SIGTERM);
    testutil_stop(f.master, SIGTERM);
}

/* Command lines refused before anything is sent, each with its reason. */
static void test_bad_input(void **state)
{
    (void)state;
    const char *m = "ipc:///nonexistent/master.sock";
    char pattern[1100];
    snprintf(pattern, sizeof pattern, "%s/walk%%04d.pbrt", g_dir);
    const run_t *r = run("submit", pattern, "--frames", "1-4", "--master", m, NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "frame 4: ");
    expect_in(r->err, "walk0004.pbrt does not exist");
    r = run("submit", pattern, "--master", m, NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "looks like a frame pattern: give --frames FIRST-LAST");
    r = run("submit", pattern, "--frames", "3-1", "--master", m, NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "FIRST must be <= LAST");
    r = run("submit", g_dir, "--frames", "1-3", "--master", m, NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "has 0 frame number conversions, expected one");
    char glob[1100];
    snprintf(glob, sizeof glob, "%s/nothing*.pbrt", g_dir);
    r = run("submit", glob, "--master", m, NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "matched no file (an empty glob?)");
    /* A listed frame that is missing: refused as a bad command line (cli/frame_list.c). */
    char missing[1100];
    snprintf(missing, sizeof missing, "%s/walk0077.pbrt", g_dir);
    r = run("submit", frame_path(1), missing, "--master", m, NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "walk0077.pbrt (scene file 2 of 2) does not exist");
    /* Frames in two folders, and a broken frame, named. */
    char other[1100], broken[1100];
    snprintf(other, sizeof other, "%s", testutil_scratch("elsewhere.pbrt"));
    testutil_write_text(other,
                        "LookAt 0 1 -3  0 0.5 0  0 1 0\nCamera \"perspective\"\n"
                        "WorldBegin\n",
                        0644);
    r = run("submit", frame_path(1), other, "--master", m, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "the frames of a sequence must be in one folder");
    snprintf(broken, sizeof broken, "%s/walk0009.pbrt", g_dir);
    testutil_write_text(broken, "LookAt 0 1 -3  0 0.5 0  0 1 0\nCamera \"perspective\" \"float\n",
                        0644);
    r = run("submit", frame_path(1), broken, "--master", m, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "frame 2 of 2: ");
    expect_in(r->err, "walk0009.pbrt:");
    assert_int_equal(unlink(broken), 0);
    r = run("submit", frame_path(1), frame_path(1), "--master", m, NULL);
    assert_int_equal(r->status, 1);
    expect_in(r->err, "is given twice as a frame");
    /* -o of a sequence needs a frame number. */
    r = run("submit", frame_path(1), frame_path(2), "--wait", "-o", "same.exr", "--master", m,
            NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "-o for a sequence of frames: 'same.exr' has 0 frame number conversions");
    r = run("submit", frame_path(1), frame_path(2), "--wait", "-o", "f%s.exr", "--master", m, NULL);
    assert_int_equal(r->status, 2);
    expect_in(r->err, "is not a frame number's conversion");
}

/* A master loads a sequence's frames several at once (--load-threads): the frame reported when
 * frames fail is the first failing one in frame order, every time, as when they load one after
 * another. Frames 2..8 exceed the master's shape budget, frame 1 does not. */
static void test_first_failing_frame_reported(void **state)
{
    (void)state;
    char dir[1024], path[1200];
    snprintf(dir, sizeof dir, "%s", testutil_scratch("budget"));
    assert_int_equal(mkdir(dir, 0755), 0);
    const char *head = "LookAt 0 1 -3  0 0.5 0  0 1 0\nCamera \"perspective\"\n"
                       "Film \"spectral\" \"integer xresolution\" [ 8 ]\n"
                       "    \"integer yresolution\" [ 8 ]\n"
                       "WorldBegin\nLightSource \"infinite\"\n";
    char *argv_frames[8];
    for (int k = 1; k <= 8; k++) {
        char text[1024];
        int n = snprintf(text, sizeof text, "%s", head);
        for (int i = 0; i < (k == 1 ? 1 : 2 + k); i++)
            n += snprintf(text + n, sizeof text - (size_t)n,
                          "Shape \"sphere\" \"float radius\" [ 0.%d ]\n", i + 1);
        snprintf(path, sizeof path, "%s/b%02d.pbrt", dir, k);
        testutil_write_text(path, text, 0644);
        argv_frames[k - 1] = strdup(path);
    }
    farm_t f;
    snprintf(f.spool, sizeof f.spool, "%s", testutil_scratch("bspool"));
    snprintf(f.mlog, sizeof f.mlog, "%s", testutil_scratch("bspool.log"));
    snprintf(f.cep, sizeof f.cep, "ipc://%s-c.sock", f.spool);
    snprintf(f.wep, sizeof f.wep, "ipc://%s-w.sock", f.spool);
    f.master = testutil_spawn(f.mlog, "master", "--workers", f.wep, "--clients", f.cep, "--spool",
                              f.spool, "--max-shapes", "3", "--load-threads", "4", NULL);
    testutil_wait_file_has(f.mlog, "clients on");
    for (int rep = 0; rep < 4; rep++) {
        const run_t *r = run("submit", argv_frames[0], argv_frames[1], argv_frames[2],
                             argv_frames[3], argv_frames[4], argv_frames[5], argv_frames[6],
                             argv_frames[7], "--master", f.cep, NULL);
        assert_int_equal(r->status, 1);
        expect_in(r->err, "frame 2 (b02.pbrt): ");
        expect_in(r->err, "prismfarm master --max-shapes");
    }
    const run_t *r = run("jobs", "--master", f.cep, NULL);
    assert_int_equal(r->status, 0);
    assert_int_equal(testutil_count_in(r->out, "b01"), 0);
    for (int k = 0; k < 8; k++)
        free(argv_frames[k]);
    testutil_stop(f.master, SIGTERM);
}

/* The sequence's rule itself (polar_seq.h): which frames the pilot measures, and the decision
 * from the frames' parts -- a frame's scene asking for polarisation decides for all, else the
 * worst bound against the target -- the same in any order of the parts. */
static void test_polar_seq_rule(void **state)
{
    (void)state;
    for (size_t n = 1; n <= 5; n++)
        for (size_t k = 0; k < n; k++)
            assert_true(polar_seq_pilots(k, n));
    const bool twelve[12] = {1, 0, 0, 1, 0, 0, 1, 0, 1, 0, 0, 1};
    for (size_t k = 0; k < 12; k++)
        assert_int_equal(polar_seq_pilots(k, 12), twelve[k]);
    size_t measured = 0;
    for (size_t k = 0; k < 1000; k++)
        measured += polar_seq_pilots(k, 1000);
    assert_int_equal(measured, POLAR_SEQ_PILOTS);
    assert_true(polar_seq_pilots(0, 1000) && polar_seq_pilots(999, 1000));
    assert_false(polar_seq_pilots(5, 5));

    const polar_decision_t none = {0}, file = {.cause_file = 1},
                           low = {.measured = 1, .pilot = {.change = 0.002, .change_hi = 0.004}},
                           high = {.measured = 1, .pilot = {.change = 0.01, .change_hi = 0.02}};
    char why[512];
    /* Nothing asks, the pilot's bounds within 1 %: off, the worst frame named. */
    polar_seq_t s = polar_seq_make(0);
    polar_seq_add(&s, 0, &low);
    polar_seq_add(&s, 1, &none);
    assert_int_equal(s.setting, SCENE_POLARIZED_OFF);
    polar_seq_why(&s, NULL, why, sizeof why);
    expect_in(why, "polarisation off for all 2 frames: the pilot measured 1 of them, the most on "
                   "frame 1: ignoring it changes the image by 0.20 % (up to 0.40 %), within");
    /* One frame's bound above the target turns it on for all; a stricter target too. */
    polar_seq_add(&s, 2, &high);
    assert_int_equal(s.setting, SCENE_POLARIZED_ON);
    assert_int_equal(s.worst_frame, 2);
    polar_seq_t strict = polar_seq_make(0.003);
    polar_seq_add(&strict, 0, &low);
    assert_int_equal(strict.setting, SCENE_POLARIZED_ON);
    /* A frame's scene asking for it decides, whatever the pilot read elsewhere; the lowest
     * such frame is named, by its number. */
    const uint32_t numbers[4] = {10, 20, 30, 40};
    polar_seq_t a = polar_seq_make(0), b = polar_seq_make(0);
    const polar_decision_t *parts[4] = {&low, &file, &none, &file};
    for (size_t k = 0; k < 4; k++) {
        polar_seq_add(&a, k, parts[k]);
        polar_seq_add(&b, 3 - k, parts[3 - k]);
    }
    assert_int_equal(a.setting, SCENE_POLARIZED_ON);
    assert_int_equal(a.setting, b.setting);
    assert_int_equal(a.cause_frame, 1);
    assert_int_equal(b.cause_frame, 1);
    assert_int_equal(a.worst_frame, b.worst_frame);
    assert_int_equal(a.measured, b.measured);
    polar_seq_why(&a, numbers, why, sizeof why);
    expect_in(why, "polarisation on for all 4 frames: frame 20's scene asks for it");
    /* Nothing to measure and nothing asked: off. */
    polar_seq_t e = polar_seq_make(0);
    polar_seq_add(&e, 0, &none);
    assert_int_equal(e.setting, SCENE_POLARIZED_OFF);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_sequence_renders_each_frame, testutil_kill_children),
        cmocka_unit_test_teardown(test_restart_mid_sequence, testutil_kill_children),
        cmocka_unit_test_teardown(test_ops_and_cancel_act_on_every_frame, testutil_kill_children),
        cmocka_unit_test(test_bad_input),
        cmocka_unit_test(test_polar_seq_rule),
        cmocka_unit_test_teardown(test_first_failing_frame_reported, testutil_kill_children),
    };
    return cmocka_run_group_tests(tests, setup, testutil_scratch_teardown);
}
