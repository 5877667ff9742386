/* sched, jobs that may end early (target error, time limit): whole-pass merging, one pass
 * boundary per call whatever the arrival order, sched_finish_job_at_pass, and the strong check
 * that a job ended after k passes holds the very bytes of a job asked for that many spp. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <string.h>

#include "sched.h"
#include "sched_testutil.h"

#define NB 3

static sched_t *new_sched(void)
{
    sched_config_t c = sched_config_default();
    c.tile_size = 4;
    return testutil_sched_new(&c);
}

static void test_pass_bounds(void **state)
{
    (void)state;
    uint32_t b[PASSES_MAX_BOUNDS];
    assert_int_equal(passes_bounds(5, b), 4);
    uint32_t want5[] = {0, 1, 2, 4, 5};
    assert_memory_equal(b, want5, sizeof want5);
    assert_int_equal(passes_bounds(1, b), 1);
    assert_int_equal(b[1], 1);
    assert_int_equal(passes_bounds(8, b), 4); /* 0 1 2 4 8 */
    assert_int_equal(b[4], 8);
    /* 2^24 spp: passes 1, 2, 4, ..., 2^24: 25 of them. */
    assert_int_equal(passes_bounds(1 << 24, b), 25);
    assert_int_equal(b[25], 1u << 24);
    assert_int_equal(passes_bounds(0, NULL), 0);
    assert_int_equal(passes_bounds(-3, NULL), 0);
    /* INT_MAX = 2^31 - 1: passes up to 2^30, then the rest: 32 passes, 33 bounds. */
    assert_int_equal(passes_bounds(0x7fffffff, b), 32);
    assert_int_equal(b[31], 1u << 30);
    assert_int_equal(b[32], 0x7fffffffu);
}

/* Results in reverse order: the last pass completes first, but is merged only after every
 * earlier one, one boundary per call, with SCHED_PASS_READY saying another is waiting. */
static void test_whole_passes_one_boundary_at_a_time(void **state)
{
    (void)state;
    sched_t *s = new_sched();
    err_t err;
    /* 8x8 pixels in 4x4 tiles: 4 tiles; spp 8: passes [0,1) [1,2) [2,4) [4,8). */
    assert_int_equal(sched_add_job(s, 1, 8, 8, 8, testutil_grid(NB), NB, &err), 0);
    assert_int_equal(sched_set_whole_passes(s, 1, &err), 0);
    assert_int_equal(sched_worker_join(s, 1, 100, 0.0, &err), 0);
    sched_task_t t[16];
    assert_int_equal(testutil_take_all(s, t, 16), 16);
    sched_job_info_t info;
    for (int i = 15; i >= 1; i--) {
        tilebuf_t *r = testutil_fake_result(&t[i], NB);
        int m = sched_task_done(s, 1, 1, t[i].task, t[i].attempt, &r, 0.0, &err);
        assert_int_equal(m, SCHED_MERGED); /* pass 0 still lacks tile 0: nothing merges */
        /* The image holds no sample yet: whole passes only. */
        assert_int_equal(tilebuf_count(sched_job_image(s, 1), t[i].x0, t[i].y0), 0);
    }
    tilebuf_t *r = testutil_fake_result(&t[0], NB);
    int m = sched_task_done(s, 1, 1, t[0].task, t[0].attempt, &r, 0.0, &err);
    assert_int_equal(m, SCHED_MERGED | SCHED_PASS_DONE | SCHED_PASS_READY);
    sched_job_info(s, 1, &info);
    assert_int_equal(info.passes_done, 1);
    assert_int_equal(info.spp_done, 1);
    assert_int_equal(info.samples_done, 64);
    int spp_after[] = {2, 4, 8};
    for (int k = 0; k < 3; k++) {
        m = sched_merge_next_pass(s, 1, &err);
        assert_true(m & SCHED_PASS_DONE);
        sched_job_info(s, 1, &info);
        assert_int_equal(info.spp_done, spp_after[k]);
        /* Every pixel has exactly spp_done samples at every boundary. */
        for (int y = 0; y < 8; y++)
            for (int x = 0; x < 8; x++)
                assert_int_equal(tilebuf_count(sched_job_image(s, 1), x, y), spp_after[k]);
        assert_int_equal(!!(m & SCHED_PASS_READY), k < 2);
        assert_int_equal(!!(m & SCHED_JOB_DONE), k == 2);
    }
    assert_int_equal(info.state, JOB_DONE);
    assert_int_equal(sched_merge_next_pass(s, 1, &err), 0);
    sched_destroy(&s);
}

/* Runs a job of spp samples to its end, or, with stop_after > 0, ends it with
 * sched_finish_job_at_pass once stop_after passes are merged; results arrive in a shuffled
 * order. Returns a copy of the image. */
static tilebuf_t *run_job(int spp, int stop_after, unsigned order_seed, bool whole)
{
    sched_t *s = new_sched();
    err_t err;
    assert_int_equal(sched_add_job(s, 9, 10, 6, spp, testutil_grid(NB), NB, &err), 0);
    if (whole)
        assert_int_equal(sched_set_whole_passes(s, 9, &err), 0);
    assert_int_equal(sched_worker_join(s, 1, 1000, 0.0, &err), 0);
    sched_task_t tasks[256];
    int n = testutil_take_all(s, tasks, 256);
    testutil_shuffle_tasks(tasks, n, order_seed);
    sched_job_info_t info;
    for (int i = 0; i < n; i++) {
        tilebuf_t *r = testutil_fake_result(&tasks[i], NB);
        int m = sched_task_done(s, 1, 9, tasks[i].task, tasks[i].attempt, &r, 0.0, &err);
        assert_true(m > 0);
        if (stop_after > 0 && (m & SCHED_DUPLICATE))
            break; /* the job ended: the rest are late copies */
        while (m & SCHED_PASS_DONE) {
            sched_job_info(s, 9, &info);
            if (stop_after > 0 && info.passes_done == stop_after) {
                assert_int_equal(sched_finish_job_at_pass(s, 9, &err), 0);
                break;
            }
            if (!(m & SCHED_PASS_READY))
                break;
            m = sched_merge_next_pass(s, 9, &err);
        }
    }
    sched_job_info(s, 9, &info);
    assert_int_equal(info.state, JOB_DONE);
    tilebuf_t *copy = tilebuf_new(0, 0, 10, 6, NB, NULL);
    assert_int_equal(tilebuf_merge(copy, sched_job_image(s, 9), &err), 0);
    sched_destroy(&s);
    return copy;
}

static void assert_same_image(const tilebuf_t *a, const tilebuf_t *b)
{
    assert_memory_equal(tilebuf_sums(a), tilebuf_sums(b), 10 * 6 * NB * sizeof(double));
    assert_memory_equal(tilebuf_counts(a), tilebuf_counts(b), 10 * 6 * sizeof(uint64_t));
    assert_memory_equal(tilebuf_luminance_sums(a), tilebuf_luminance_sums(b),
                        10 * 6 * sizeof(double));
    assert_memory_equal(tilebuf_luminance_sq_sums(a), tilebuf_luminance_sq_sums(b),
                        10 * 6 * sizeof(double));
}

/* The strong check, as far as the scheduler goes: a 64 spp job ended after 4 passes (8 spp)
 * holds the bytes of an 8 spp job run to its end, whole-pass or not, whatever the arrival
 * orders; and a whole-pass job run to its end equals the same job merged tile by tile. (The
 * fake worker's samples do not depend on the job's total; render_tile's stratified ones do for
 * square and power-of-two totals: docs/farm.md, "Accuracy".) */
static void test_stopped_job_equals_job_of_that_spp(void **state)
{
    (void)state;
    tilebuf_t *stopped = run_job(64, 4, 7, true);
    tilebuf_t *stopped2 = run_job(64, 4, 1234, true);
    tilebuf_t *asked = run_job(8, 0, 99, false);
    tilebuf_t *asked_whole = run_job(8, 0, 5, true);
    assert_int_equal(tilebuf_count(stopped, 9, 5), 8);
    assert_same_image(stopped, asked);
    assert_same_image(stopped2, asked);
    assert_same_image(asked_whole, asked);
    tilebuf_destroy(&stopped);
    tilebuf_destroy(&stopped2);
    tilebuf_destroy(&asked);
    tilebuf_destroy(&asked_whole);
}

/* Ending a job: running tasks come back (the worker's slots free), late results are ignored,
 * nothing more of the job is handed out, and the next job runs. */
static void test_finish_releases_tasks(void **state)
{
    (void)state;
    sched_t *s = new_sched();
    err_t err;
    assert_int_equal(sched_add_job(s, 1, 4, 4, 16, testutil_grid(NB), NB, &err),
                     0); /* one tile, 5 passes */
    assert_int_equal(sched_add_job(s, 2, 4, 4, 1, testutil_grid(NB), NB, &err), 0);
    assert_int_equal(sched_set_whole_passes(s, 1, &err), 0);
    assert_int_equal(sched_worker_join(s, 1, 3, 0.0, &err), 0);
    sched_task_t t[3];
    for (int i = 0; i < 3; i++)
        assert_int_equal(sched_next_task(s, 1, 0.0, &t[i]), 1);
    assert_int_equal(t[2].job, 1);
    /* Not before a whole pass is in. */
    assert_int_equal(sched_finish_job_at_pass(s, 1, &err), -1);
    assert_non_null(strstr(err.msg, "no whole pass"));
    tilebuf_t *r = testutil_fake_result(&t[0], NB);
    assert_true(sched_task_done(s, 1, 1, t[0].task, t[0].attempt, &r, 0.0, &err) & SCHED_PASS_DONE);
    assert_int_equal(sched_finish_job_at_pass(s, 1, &err), 0);
    sched_worker_info_t w;
    sched_workers(s, &w, 1);
    assert_int_equal(w.busy, 0);
    sched_job_info_t info;
    sched_job_info(s, 1, &info);
    assert_int_equal(info.state, JOB_DONE);
    assert_int_equal(info.passes_done, 1);
    assert_int_equal(info.npasses, 5);
    assert_int_equal(info.spp_done, 1);
    assert_int_equal(info.tasks_running, 0);
    assert_int_equal(info.samples_done, 16);
    r = testutil_fake_result(&t[1], NB);
    assert_int_equal(sched_task_done(s, 1, 1, t[1].task, t[1].attempt, &r, 0.0, &err),
                     SCHED_DUPLICATE);
    assert_null(r);
    sched_task_t u;
    assert_int_equal(sched_next_task(s, 1, 0.0, &u), 1);
    assert_int_equal(u.job, 2);
    /* Ended once: not again, and the image stays readable until removed. */
    assert_int_equal(sched_finish_job_at_pass(s, 1, &err), -1);
    assert_int_equal(tilebuf_count(sched_job_image(s, 1), 3, 3), 1);
    assert_int_equal(sched_remove_job(s, 1, &err), 0);
    sched_destroy(&s);
}

static void test_refusals(void **state)
{
    (void)state;
    sched_t *s = new_sched();
    err_t err;
    assert_int_equal(sched_set_whole_passes(s, 5, &err), -1);
    assert_non_null(strstr(err.msg, "no job 5"));
    assert_int_equal(sched_finish_job_at_pass(s, 5, &err), -1);
    assert_int_equal(sched_merge_next_pass(s, 5, &err), -1);
    assert_int_equal(sched_add_job(s, 5, 8, 4, 4, testutil_grid(NB), NB, &err), 0); /* two tiles */
    assert_int_equal(sched_worker_join(s, 1, 10, 0.0, &err), 0);
    sched_task_t t;
    assert_int_equal(sched_next_task(s, 1, 0.0, &t), 1);
    tilebuf_t *r = testutil_fake_result(&t, NB);
    assert_int_equal(sched_task_done(s, 1, 5, t.task, t.attempt, &r, 0.0, &err), SCHED_MERGED);
    /* A camera result is in: too late to choose whole passes. */
    assert_int_equal(sched_set_whole_passes(s, 5, &err), -1);
    assert_non_null(strstr(err.msg, "before"));
    assert_int_equal(sched_next_task(s, 1, 0.0, &t), 1);
    r = testutil_fake_result(&t, NB);
    assert_true(sched_task_done(s, 1, 5, t.task, t.attempt, &r, 0.0, &err) & SCHED_PASS_DONE);
    /* Merged tile by tile, its image may hold parts of later passes: it cannot end early. */
    assert_int_equal(sched_finish_job_at_pass(s, 5, &err), -1);
    assert_non_null(strstr(err.msg, "whole-pass"));
    assert_int_equal(sched_merge_next_pass(s, 5, &err), 0);
    /* A cancelled job cannot be ended as done. */
    assert_int_equal(sched_cancel_job(s, 5, &err), 0);
    assert_int_equal(sched_finish_job_at_pass(s, 5, &err), -1);
    assert_non_null(strstr(err.msg, "cancelled"));
    sched_destroy(&s);
}

/* Whole passes with a lost worker: its tasks go back to the queue, are done by another, and the
 * passes still merge one at a time into the same bytes. */
static void test_whole_passes_with_lost_worker(void **state)
{
    (void)state;
    sched_t *s = new_sched();
    err_t err;
    assert_int_equal(sched_add_job(s, 9, 10, 6, 8, testutil_grid(NB), NB, &err), 0);
    assert_int_equal(sched_set_whole_passes(s, 9, &err), 0);
    assert_int_equal(sched_worker_join(s, 1, 2, 0.0, &err), 0);
    assert_int_equal(sched_worker_join(s, 2, 1000, 0.0, &err), 0);
    sched_task_t lost[2];
    assert_int_equal(sched_next_task(s, 1, 0.0, &lost[0]), 1);
    assert_int_equal(sched_next_task(s, 1, 0.0, &lost[1]), 1);
    sched_task_t t[64];
    int n = 0;
    while (sched_next_task(s, 2, 0.0, &t[n]))
        n++;
    sched_worker_leave(s, 1);
    while (sched_next_task(s, 2, 0.0, &t[n]))
        n++;
    assert_int_equal(n, 24); /* 6 tiles x 4 passes */
    int boundaries = 0;
    for (int i = 0; i < n; i++) {
        tilebuf_t *r = testutil_fake_result(&t[i], NB);
        int m = sched_task_done(s, 2, 9, t[i].task, t[i].attempt, &r, 0.0, &err);
        while (m & SCHED_PASS_DONE) {
            boundaries++;
            m = (m & SCHED_PASS_READY) ? sched_merge_next_pass(s, 9, &err) : 0;
        }
    }
    assert_int_equal(boundaries, 4);
    tilebuf_t *asked = run_job(8, 0, 3, false);
    assert_same_image(sched_job_image(s, 9), asked);
    tilebuf_destroy(&asked);
    sched_destroy(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pass_bounds),
        cmocka_unit_test(test_whole_passes_one_boundary_at_a_time),
        cmocka_unit_test(test_stopped_job_equals_job_of_that_spp),
        cmocka_unit_test(test_finish_releases_tasks),
        cmocka_unit_test(test_refusals),
        cmocka_unit_test(test_whole_passes_with_lost_worker),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
