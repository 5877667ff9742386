/* Adaptive sampling (film/adaptive.h, docs/rendering.md "Adaptive sampling"): the per-tile rule
 * on images whose variances are known, its record in the EXR's text (written and read back), and
 * the scheduler running it (master/sched.c): flat tiles stop before noisy ones, a stopped tile's
 * tasks are done without rendering, progress counts them, and the image and the tiles' passes
 * are the same bytes whatever the order of the results and after a restore from a checkpoint
 * taken mid-job (the master's restart). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <stdlib.h>
#include <string.h>

#include "adaptive.h"
#include "jobinfo.h"
#include "sched.h"
#include "sched_testutil.h"

#define NB 2

/* Adds n samples of luminance lum(k) to pixel (x, y): buckets and Y all lum. */
static void add_samples(tilebuf_t *b, int x, int y, int n, double (*lum)(int x, int y, int k))
{
    for (int k = 0; k < n; k++) {
        double l = lum(x, y, k);
        double v[NB] = {l, l};
        assert_int_equal(tilebuf_add_sample(b, x, y, v, (const double[3]){0, l, 0}), 0);
    }
}

static double flat(int x, int y, int k)
{
    (void)x, (void)y, (void)k;
    return 1.0;
}

/* 0 and 2 in turn: mean 1, variance 1 per sample (16/15 as the unbiased estimate of 16). */
static double noisy(int x, int y, int k)
{
    return ((x + y + k) & 1) ? 2.0 : 0.0;
}

static double dark(int x, int y, int k)
{
    (void)x, (void)y, (void)k;
    return 0.0;
}

/* An 8x4 image in 4x4 tiles: tile 0 (left) of lum_left, tile 1 (right) of lum_right, n samples
 * a pixel. */
static tilebuf_t *two_tiles(int n, double (*left)(int, int, int), double (*right)(int, int, int))
{
    tilebuf_t *b = tilebuf_new(0, 0, 8, 4, NB, NULL);
    assert_non_null(b);
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 8; x++)
            add_samples(b, x, y, n, x < 4 ? left : right);
    return b;
}

static void test_rule(void **state)
{
    (void)state;
    tilegrid_t g = tilegrid_make(8, 4, 4);
    assert_int_equal(tilegrid_count(&g), 2);
    /* Flat left, noisy right at 16 spp: V = 1/15 per noisy pixel, 0 per flat one; the image's
     * mean is 1, its estimate sqrt((16 / 15) / 32) = 0.183. */
    tilebuf_t *img = two_tiles(16, flat, noisy);
    error_estimate_t e = error_estimate_image(img);
    assert_true(e.valid);
    assert_true(e.rel_rmse > 0.18 && e.rel_rmse < 0.19);
    bool active[2] = {true, true};
    /* Target 0.1: the flat tile (V = 0) stops, the noisy one (V per pixel 1/15 > 0.1^2) goes
     * on. */
    assert_int_equal(adaptive_decide(img, &g, 0.1, 16, &e, active), 1);
    assert_false(active[0]);
    assert_true(active[1]);
    /* Below the least spp nothing stops. */
    active[0] = active[1] = true;
    assert_int_equal(adaptive_decide(img, &g, 0.1, ADAPTIVE_MIN_SPP / 2, &e, active), 0);
    assert_true(active[0] && active[1]);
    /* At its target the image ends as a whole: no tile is singled out. */
    assert_int_equal(adaptive_decide(img, &g, 0.2, 16, &e, active), 0);
    /* No target, no rule. */
    assert_int_equal(adaptive_decide(img, &g, 0, 16, &e, active), 0);
    /* The flat tile stopped before and is left alone; the noisy one, at sqrt(1/15) = 0.258 of
     * the mean, is above 0.15 and goes on. */
    active[0] = false;
    assert_int_equal(adaptive_decide(img, &g, 0.15, 16, &e, active), 0);
    assert_true(active[1]);
    tilebuf_destroy(&img);

    /* The last running tiles never stop on their own while the image is above its target (its
     * mean moved since earlier tiles stopped): two noisy tiles, each at 0.258 of the mean, within
     * a target of 0.26, with the image's estimate above it. */
    img = two_tiles(16, noisy, noisy);
    e = error_estimate_image(img);
    active[0] = active[1] = true;
    error_estimate_t above = e;
    above.rel_rmse = 0.3;
    assert_int_equal(adaptive_decide(img, &g, 0.26, 16, &above, active), 0);
    assert_true(active[0] && active[1]);
    tilebuf_destroy(&img);

    /* A tile without light (every sample 0) stops at the first boundary allowed; a tile with a
     * pixel of one sample never does. */
    img = two_tiles(16, dark, noisy);
    e = error_estimate_image(img);
    active[0] = active[1] = true;
    assert_int_equal(adaptive_decide(img, &g, 0.1, 16, &e, active), 1);
    assert_false(active[0]);
    tilebuf_destroy(&img);
    tilebuf_t *lone = tilebuf_new(0, 0, 8, 4, NB, NULL);
    for (int y = 0; y < 4; y++)
        for (int x = 0; x < 8; x++)
            add_samples(lone, x, y, x == 1 && y == 1 ? 1 : 16, x < 4 ? flat : noisy);
    e = error_estimate_image(lone);
    active[0] = active[1] = true;
    assert_int_equal(adaptive_decide(lone, &g, 0.1, 16, &e, active), 0);
    tilebuf_destroy(&lone);
}

static void test_record(void **state)
{
    (void)state;
    tilegrid_t g = tilegrid_make(20, 9, 4); /* 5 x 3 tiles, the last column and row clipped */
    int spp[15] = {16, 16, 16, 64, 32, 32, 16, 16, 16, 16, 16, 16, 64, 64, 64};
    char text[256];
    adaptive_format_tile_spp(spp, 15, text, sizeof text);
    assert_string_equal(text, "16*3,64,32*2,16*6,64*3");
    /* A cut text stays NUL-terminated and the length says how long it would be. */
    char small[8];
    assert_int_equal(adaptive_format_tile_spp(spp, 15, small, sizeof small), strlen(text));
    assert_int_equal(strlen(small), 7);

    adaptive_summary_t s = adaptive_summarize(&g, spp);
    assert_int_equal(s.tiles, 15);
    assert_int_equal(s.max_spp, 64);
    assert_int_equal(s.min_spp, 16);
    assert_int_equal(s.stopped, 11);
    assert_int_equal(s.at_min, 9);
    /* Pixels weighted: the last column is 4 wide of 20... computed by hand: rows 0-1 are 4
     * pixels tall, row 2 one pixel; columns 0-3 are 4 wide, column 4 is 4 wide (20 = 5 x 4). */
    double want = (16 * 16 + 16 * 16 + 16 * 16 + 64 * 16 + 32 * 16 + 32 * 16 + 16 * 16 * 4 +
                   16 * 4 * 2 + 64 * 4 * 3) /
                  180.0;
    assert_true(s.mean_spp > want - 1e-9 && s.mean_spp < want + 1e-9);
    char line[160];
    adaptive_summary_line(&s, line, sizeof line);
    assert_non_null(strstr(line, "adaptive: 60 % of tiles stopped at 16 spp, 73 % before 64 spp"));

    /* The job's record carries it, and reads back. */
    pass_record_t h[1] = {{.pass = 7, .spp = 64, .valid = true, .rel_error = 0.05}};
    jobinfo_t ji = {.scene = "s.pbrt",
                    .spp = 64,
                    .xres = 20,
                    .yres = 9,
                    .spp_done = 64,
                    .rule = {.target_error = 0.05},
                    .history = h,
                    .nhistory = 1,
                    .tile_spp = spp,
                    .grid = g};
    char info[1024];
    jobinfo_format(&ji, info, sizeof info);
    assert_non_null(strstr(info, ";adaptive=on;tile=4;tiles=5x3;"));
    assert_non_null(strstr(info, ";tile_spp=16*3,64,32*2,16*6,64*3;history=7:64:"));
    tilegrid_t back;
    int *got = NULL;
    err_t err;
    assert_int_equal(jobinfo_tile_spp(info, &back, &got, &err), 1);
    assert_int_equal(back.tiles_x, 5);
    assert_int_equal(back.tiles_y, 3);
    assert_memory_equal(got, spp, sizeof spp);
    free(got);
    /* Without tile_spp: no adaptive keys at all (the text of a job before adaptive sampling). */
    ji.tile_spp = NULL;
    jobinfo_format(&ji, info, sizeof info);
    assert_null(strstr(info, "adaptive"));
    assert_int_equal(jobinfo_tile_spp(info, &back, &got, &err), 0);
    /* A list that does not fill the grid is refused. */
    assert_int_equal(jobinfo_tile_spp("xres=20;yres=9;adaptive=on;tile=4;tiles=5x3;tile_spp=16*14;",
                                      &back, &got, &err),
                     -1);
    assert_null(got);
}

/* ---------------------------------------------------------------- the scheduler */

/* 16 x 8 pixels in 4x4 tiles: 8 tiles; the left half flat, the right half noisy. */
#define XRES 16
#define YRES 8
#define SPP 256
#define TARGET 0.04

static double scene_lum(int x, int y, int s)
{
    if (x < XRES / 2)
        return 1.0 + 0.001 * ((x + y + s) % 3); /* nearly flat */
    /* Noisy: 0 or 4, a pattern over samples that is not periodic in the pass bounds. */
    unsigned h = (unsigned)(x * 73856093u) ^ (unsigned)(y * 19349663u) ^ (unsigned)(s * 83492791u);
    h ^= h >> 13;
    h *= 0x5bd1e995u;
    h ^= h >> 15;
    return (h & 3) == 0 ? 4.0 : 0.0;
}

static tilebuf_t *result_of(const sched_task_t *t)
{
    tilebuf_t *r = tilebuf_new(t->x0, t->y0, t->w, t->h, NB, NULL);
    assert_non_null(r);
    for (int y = t->y0; y < t->y0 + t->h; y++)
        for (int x = t->x0; x < t->x0 + t->w; x++)
            for (uint32_t s = t->sample_begin; s < t->sample_end; s++) {
                double l = scene_lum(x, y, (int)s);
                double v[NB] = {l, 0.5 * l};
                tilebuf_add_sample(r, x, y, v, (const double[3]){0.3 * l, l, 0.2 * l});
            }
    tilebuf_round_sums(r);
    return r;
}

static sched_t *new_job(void)
{
    sched_t *s = testutil_sched_new(&(sched_config_t){.task_deadline_s = 100,
                                                      .worker_timeout_s = 100,
                                                      .max_task_failures = 4,
                                                      .max_worker_job_failures = 2,
                                                      .tile_size = 4});
    err_t err;
    assert_int_equal(sched_add_job(s, 1, XRES, YRES, SPP, testutil_grid(NB), NB, &err), 0);
    assert_int_equal(sched_set_whole_passes(s, 1, &err), 0);
    assert_int_equal(sched_set_adaptive(s, 1, TARGET, &err), 0);
    assert_int_equal(sched_worker_join(s, 1, 4096, 0.0, &err), 0);
    return s;
}

/* A whole-buffer copy (merging into zeros changes no bit). */
static tilebuf_t *copy_of(const tilebuf_t *b)
{
    tilebuf_t *c =
        tilebuf_new(0, 0, tilebuf_width(b), tilebuf_height(b), tilebuf_nbuckets(b), NULL);
    assert_non_null(c);
    assert_int_equal(tilebuf_merge(c, b, NULL), 0);
    return c;
}

static void assert_same_image(const tilebuf_t *a, const tilebuf_t *b)
{
    size_t n = (size_t)XRES * YRES;
    assert_memory_equal(tilebuf_sums(a), tilebuf_sums(b), n * NB * sizeof(double));
    assert_memory_equal(tilebuf_xyz_sums(a), tilebuf_xyz_sums(b), n * 3 * sizeof(double));
    assert_memory_equal(tilebuf_counts(a), tilebuf_counts(b), n * sizeof(uint64_t));
    assert_memory_equal(tilebuf_luminance_sums(a), tilebuf_luminance_sums(b), n * sizeof(double));
    assert_memory_equal(tilebuf_luminance_sq_sums(a), tilebuf_luminance_sq_sums(b),
                        n * sizeof(double));
}

typedef struct outcome {
    tilebuf_t *image;
    int next[8];
    /* The checkpoint taken at the first boundary at or past pass stop_at (if asked). */
    tilebuf_t *ckpt;
    int ckpt_next[8];
} outcome_t;

/* Runs job 1 of s to its end: all tasks given at once in rounds, results in the seed's order,
 * every whole pass merged as it becomes ready. With ckpt_at > 0, copies the image and the tiles'
 * passes (what persist.c writes) at the first boundary of at least ckpt_at passes. */
static void run_job(sched_t *s, unsigned seed, int ckpt_at, outcome_t *o)
{
    err_t err;
    sched_task_t *t = calloc(4096, sizeof *t);
    assert_non_null(t);
    int rounds = 0;
    for (;;) {
        sched_job_info_t info;
        assert_int_equal(sched_job_info(s, 1, &info), 0);
        if (info.state != JOB_RUNNING && info.state != JOB_QUEUED)
            break;
        int n = testutil_take_all(s, t, 4096);
        assert_true(n > 0);
        testutil_shuffle(t, n, sizeof *t, seed + (unsigned)rounds++);
        /* Half the tasks come back this round: the others stay out while passes merge, so
         * that some of a tile's tasks are out when adaptive sampling stops it. */
        int back = n > 1 ? n / 2 : 1;
        for (int i = 0; i < back; i++) {
            tilebuf_t *r = result_of(&t[i]);
            int rc = sched_task_done(s, 1, 1, t[i].task, t[i].attempt, &r, 1.0, &err);
            assert_true(rc > 0);
            for (;;) {
                /* One boundary per call: a checkpoint may be taken at any of them. */
                assert_int_equal(sched_job_info(s, 1, &info), 0);
                if (ckpt_at > 0 && !o->ckpt && info.passes_done >= ckpt_at &&
                    info.state == JOB_RUNNING) {
                    o->ckpt = copy_of(sched_job_image(s, 1));
                    assert_int_equal(sched_job_next_pass(s, 1, o->ckpt_next, 8), 8);
                }
                if (!(rc & SCHED_PASS_READY))
                    break;
                rc = sched_merge_next_pass(s, 1, &err);
            }
        }
        /* The rest are lost with their worker: they go back to the queue. */
        sched_worker_leave(s, 1);
        assert_int_equal(sched_worker_join(s, 1, 4096, 1.0, &err), 0);
    }
    sched_job_info_t info;
    assert_int_equal(sched_job_info(s, 1, &info), 0);
    assert_int_equal(info.state, JOB_DONE);
    assert_int_equal(info.samples_done, info.samples_total);
    o->image = copy_of(sched_job_image(s, 1));
    assert_int_equal(sched_job_next_pass(s, 1, o->next, 8), 8);
    free(t);
}

static void test_sched_adaptive(void **state)
{
    (void)state;
    uint32_t bounds[PASSES_MAX_BOUNDS];
    int npasses = passes_bounds(SPP, bounds);
    outcome_t a = {0}, b = {0};
    sched_t *s = new_job();
    sched_job_info_t info;
    assert_int_equal(sched_job_info(s, 1, &info), 0);
    assert_true(info.adaptive);
    assert_int_equal(info.samples_total, (uint64_t)XRES * YRES * SPP);
    run_job(s, 1, 0, &a);
    assert_int_equal(sched_job_info(s, 1, &info), 0);
    /* The flat tiles stopped at the first boundary allowed (16 spp: 5 passes), the noisy ones
     * ran on: each got more; and progress counted a stopped tile as done. */
    for (int t = 0; t < 8; t++) {
        bool left = t % 4 < 2;
        print_message("tile %d: %u spp\n", t, bounds[a.next[t]]);
        if (left)
            assert_int_equal(bounds[a.next[t]], ADAPTIVE_MIN_SPP);
        else
            assert_true(bounds[a.next[t]] > ADAPTIVE_MIN_SPP);
    }
    assert_true(info.samples_total < (uint64_t)XRES * YRES * SPP);
    assert_true(info.tiles_active < 8);
    /* The scheduler alone has no stopping rule (the master's merge.c ends a job at its target):
     * the job ran its passes, the noisy tiles to the end unless they reached their share. */
    error_estimate_t e = error_estimate_image(a.image);
    print_message("estimate %.4f at %d of %d passes\n", e.rel_rmse, info.passes_done, npasses);
    assert_true(e.valid);
    sched_destroy(&s);

    /* Another order of results and of losses: the same bytes and the same tiles' passes. */
    s = new_job();
    run_job(s, 99, 0, &b);
    assert_same_image(a.image, b.image);
    assert_memory_equal(a.next, b.next, sizeof a.next);
    sched_destroy(&s);
    tilebuf_destroy(&b.image);

    /* A master restarted on a checkpoint ends with the same bytes: one taken at the boundary
     * where the flat tiles stop (5 passes: every tile is at pass 5 in it, and the restore must
     * make that boundary's decision again) and one after it (6: the stopped tiles are behind). */
    tilebuf_destroy(&a.ckpt);
    for (int at = 5; at <= 6; at++) {
        outcome_t r = {0};
        s = new_job();
        run_job(s, 3, at, &r);
        sched_destroy(&s);
        assert_same_image(a.image, r.image);
        assert_non_null(r.ckpt);
        int behind = 0;
        for (int t = 0; t < 8; t++)
            behind += r.ckpt_next[t] < at;
        assert_int_equal(behind, at == 5 ? 0 : 4);
        s = new_job();
        err_t err;
        int rc = sched_restore_job(s, 1, &r.ckpt, r.ckpt_next, 0, &err);
        if (rc < 0)
            fail_msg("%s", err.msg);
        assert_int_equal(sched_job_info(s, 1, &info), 0);
        assert_int_equal(info.tiles_active, 4); /* the flat tiles stopped, again or as before */
        outcome_t c = {0};
        run_job(s, 7, 0, &c);
        assert_same_image(a.image, c.image);
        assert_memory_equal(a.next, c.next, sizeof a.next);
        sched_destroy(&s);
        tilebuf_destroy(&c.image);
        tilebuf_destroy(&r.image);
    }
    tilebuf_destroy(&a.image);
}

/* Adaptive sampling needs whole passes and a target; a job that merged results cannot start
 * it. */
static void test_sched_adaptive_refused(void **state)
{
    (void)state;
    sched_t *s = testutil_sched_new(&(sched_config_t){.task_deadline_s = 100,
                                                      .worker_timeout_s = 100,
                                                      .max_task_failures = 4,
                                                      .max_worker_job_failures = 2,
                                                      .tile_size = 4});
    err_t err;
    assert_int_equal(sched_add_job(s, 1, 8, 8, 64, testutil_grid(NB), NB, &err), 0);
    assert_int_equal(sched_set_adaptive(s, 1, 0.1, &err), -1);
    assert_non_null(strstr(err.msg, "whole-pass"));
    assert_int_equal(sched_set_whole_passes(s, 1, &err), 0);
    assert_int_equal(sched_set_adaptive(s, 1, 0, &err), -1);
    assert_int_equal(sched_set_adaptive(s, 2, 0.1, &err), -1);
    sched_job_info_t info;
    assert_int_equal(sched_job_info(s, 1, &info), 0);
    assert_false(info.adaptive);
    assert_int_equal(info.tiles_active, info.ntiles);
    sched_destroy(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rule),
        cmocka_unit_test(test_record),
        cmocka_unit_test(test_sched_adaptive),
        cmocka_unit_test(test_sched_adaptive_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
