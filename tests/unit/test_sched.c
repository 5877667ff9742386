/* sched: the master's job bookkeeping, driven with a fake clock: task order, progressive
 * passes, merge order independence, lost workers, deadlines, failures and blocking. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <string.h>

#include "sched.h"
#include "sched_testutil.h"

static sched_t *new_sched(int tile)
{
    sched_config_t c = testutil_sched_config(tile);
    return testutil_sched_new(&c);
}

static void test_passes_and_tiles(void **state)
{
    (void)state;
    sched_t *s = new_sched(4);
    err_t err;
    /* 10x6 pixels in 4x4 tiles: 3 x 2 tiles; spp 5: passes [0,1) [1,2) [2,4) [4,5). */
    assert_int_equal(sched_add_job(s, 7, 10, 6, 5, testutil_grid(4), 4, &err), 0);
    sched_job_info_t info;
    assert_int_equal(sched_job_info(s, 7, &info), 0);
    assert_int_equal(info.ntiles, 6);
    assert_int_equal(info.npasses, 4);
    assert_int_equal(info.state, JOB_QUEUED);
    assert_int_equal(sched_worker_join(s, 1, 100, 0.0, &err), 0);
    sched_task_t t;
    uint32_t bounds[][2] = {{0, 1}, {1, 2}, {2, 4}, {4, 5}};
    for (int pass = 0; pass < 4; pass++)
        for (int tile = 0; tile < 6; tile++) {
            assert_int_equal(sched_next_task(s, 1, 0.0, &t), 1);
            assert_int_equal(t.pass, pass);
            assert_int_equal(t.sample_begin, bounds[pass][0]);
            assert_int_equal(t.sample_end, bounds[pass][1]);
            assert_int_equal(t.x0, (tile % 3) * 4);
            assert_int_equal(t.w, tile % 3 == 2 ? 2 : 4);
            assert_int_equal(t.h, tile >= 3 ? 2 : 4);
        }
    assert_int_equal(sched_next_task(s, 1, 0.0, &t), 0);
    sched_destroy(&s);
}

/* Results merged in any arrival order give identical image bytes. */
static void run_job(unsigned order_seed, tilebuf_t **image_out)
{
    sched_t *s = new_sched(4);
    err_t err;
    sched_add_job(s, 1, 10, 6, 9, testutil_grid(4), 4, &err);
    sched_worker_join(s, 1, 1000, 0.0, &err);
    sched_task_t tasks[256];
    int n = testutil_take_all(s, tasks, 256);
    /* A fixed pseudo-random permutation of the completion order. */
    testutil_shuffle_tasks(tasks, n, order_seed);
    int passes_done = 0, job_done = 0;
    for (int i = 0; i < n; i++) {
        tilebuf_t *r = testutil_fake_result(&tasks[i], 4);
        int m = sched_task_done(s, 1, 1, tasks[i].task, tasks[i].attempt, &r, 0.0, &err);
        assert_true(m > 0 && (m & SCHED_MERGED));
        assert_null(r);
        passes_done += !!(m & SCHED_PASS_DONE);
        job_done += !!(m & SCHED_JOB_DONE);
    }
    sched_job_info_t info;
    sched_job_info(s, 1, &info);
    assert_int_equal(info.state, JOB_DONE);
    /* One result can complete several passes at once (it unblocks a tile's later passes). */
    assert_int_equal(info.passes_done, info.npasses);
    assert_true(passes_done >= 1 && passes_done <= info.npasses);
    assert_int_equal(job_done, 1);
    assert_int_equal(info.samples_done, info.samples_total);
    const tilebuf_t *img = sched_job_image(s, 1);
    *image_out = tilebuf_new(0, 0, 10, 6, 4, NULL);
    tilebuf_merge(*image_out, img, NULL);
    assert_int_equal(tilebuf_count(img, 9, 5), 9);
    sched_destroy(&s);
}

static void test_merge_order_independent(void **state)
{
    (void)state;
    tilebuf_t *a, *b, *c;
    run_job(1, &a);
    run_job(2, &b);
    run_job(99, &c);
    assert_memory_equal(tilebuf_sums(a), tilebuf_sums(b), 10 * 6 * 4 * sizeof(double));
    assert_memory_equal(tilebuf_sums(a), tilebuf_sums(c), 10 * 6 * 4 * sizeof(double));
    tilebuf_destroy(&a);
    tilebuf_destroy(&b);
    tilebuf_destroy(&c);
}

static void test_dead_worker_and_deadline(void **state)
{
    (void)state;
    sched_t *s = new_sched(8);
    err_t err;
    sched_add_job(s, 3, 8, 8, 1, testutil_grid(4), 4, &err); /* one task */
    sched_worker_join(s, 10, 1, 0.0, &err);
    sched_worker_join(s, 11, 1, 0.0, &err);
    sched_task_t t, u;
    assert_int_equal(sched_next_task(s, 10, 0.0, &t), 1);
    assert_int_equal(sched_next_task(s, 11, 0.0, &u), 0); /* nothing left */
    /* Worker 10 goes silent: after the timeout its task returns to the queue. */
    sched_worker_seen(s, 11, 2.9);
    assert_int_equal(sched_tick(s, 3.5), 1);
    assert_int_equal(sched_next_task(s, 11, 3.5, &u), 1);
    assert_int_equal(u.task, t.task);
    assert_int_equal(u.attempt, 2);
    /* Worker 11 misses the deadline: re-issued (to 11 again, the only live worker). */
    sched_worker_seen(s, 11, 13.0);
    assert_int_equal(sched_tick(s, 14.0), 1);
    sched_task_t v;
    assert_int_equal(sched_next_task(s, 11, 14.0, &v), 1);
    assert_int_equal(v.attempt, 3);
    /* The late first result is accepted (all attempts give the same bytes); the next is a
     * duplicate. */
    tilebuf_t *r = testutil_fake_result(&u, 4);
    assert_true(sched_task_done(s, 11, 3, u.task, u.attempt, &r, 14.5, &err) & SCHED_JOB_DONE);
    r = testutil_fake_result(&v, 4);
    assert_int_equal(sched_task_done(s, 11, 3, v.task, v.attempt, &r, 14.6, &err), SCHED_DUPLICATE);
    sched_worker_info_t w[4];
    assert_int_equal(sched_workers(s, w, 4), 2);
    assert_false(w[0].alive);
    assert_true(w[1].alive);
    assert_int_equal(w[1].busy, 0);
    sched_destroy(&s);
}

static void test_failures_block_and_fail(void **state)
{
    (void)state;
    sched_config_t c = sched_config_default();
    c.tile_size = 8;
    c.max_task_failures = 3;
    c.max_worker_job_failures = 2;
    sched_t *s = testutil_sched_new(&c);
    err_t err;
    sched_add_job(s, 5, 8, 8, 1, testutil_grid(4), 4, &err);
    sched_worker_join(s, 1, 1, 0.0, &err);
    sched_worker_join(s, 2, 1, 0.0, &err);
    sched_task_t t;
    assert_int_equal(sched_next_task(s, 1, 0.0, &t), 1);
    sched_task_failed(s, 1, 5, t.task, t.attempt, "out of memory");
    assert_int_equal(sched_next_task(s, 1, 0.0, &t), 1);
    sched_task_failed(s, 1, 5, t.task, t.attempt, "out of memory");
    /* Worker 1 failed twice: blocked for job 5. */
    assert_int_equal(sched_next_task(s, 1, 0.0, &t), 0);
    assert_int_equal(sched_next_task(s, 2, 0.0, &t), 1);
    sched_task_failed(s, 2, 5, t.task, t.attempt, "scene.pbrt:3:1: bad");
    sched_job_info_t info;
    sched_job_info(s, 5, &info);
    assert_int_equal(info.state, JOB_FAILED);
    assert_non_null(strstr(info.error, "failed 3 times"));
    assert_non_null(strstr(info.error, "scene.pbrt:3:1: bad"));
    assert_int_equal(sched_next_task(s, 2, 0.0, &t), 0);
    assert_int_equal(sched_remove_job(s, 5, &err), 0);
    assert_int_equal(sched_job_info(s, 5, &info), -1);
    sched_destroy(&s);
}

static void test_bad_results_and_jobs(void **state)
{
    (void)state;
    sched_t *s = new_sched(4);
    err_t err;
    assert_int_equal(sched_add_job(s, 1, 0, 6, 4, testutil_grid(4), 4, &err), -1);
    assert_int_equal(sched_add_job(s, 1, 8, 8, 4, testutil_grid(4), 4, &err), 0);
    assert_int_equal(sched_add_job(s, 1, 8, 8, 4, testutil_grid(4), 4, &err), -1);
    assert_non_null(strstr(err.msg, "exists"));
    sched_worker_join(s, 1, 4, 0, &err);
    sched_task_t t;
    sched_next_task(s, 1, 0, &t);
    tilebuf_t *wrong = tilebuf_new(t.x0 + 1, t.y0, t.w - 1, t.h, 4, NULL);
    assert_int_equal(sched_task_done(s, 1, 1, t.task, t.attempt, &wrong, 0, &err), -1);
    assert_null(wrong);
    assert_non_null(strstr(err.msg, "does not cover"));
    tilebuf_t *r = testutil_fake_result(&t, 4);
    assert_int_equal(sched_task_done(s, 1, 99, 0, 1, &r, 0, &err), -1);
    assert_null(r);
    /* Cancelling frees the worker's slots and ignores late results. */
    assert_int_equal(sched_cancel_job(s, 1, &err), 0);
    sched_worker_info_t w;
    sched_workers(s, &w, 1);
    assert_int_equal(w.busy, 0);
    r = testutil_fake_result(&t, 4);
    assert_int_equal(sched_task_done(s, 1, 1, t.task, t.attempt, &r, 0, &err), SCHED_DUPLICATE);
    sched_destroy(&s);
}

/* Prefetch shrinks at the end of the work: two workers of 1 thread and 2 slots each. While
 * more tasks wait than the other worker has idle threads, the first may queue a second task;
 * once they do not, the last task goes to the idle worker instead. */
static void test_prefetch_shrinks_at_the_end(void **state)
{
    (void)state;
    sched_t *s = new_sched(4);
    err_t err;
    /* One 4x4 tile, spp 4: passes [0,1) [1,2) [2,4), three tasks. */
    assert_int_equal(sched_add_job(s, 1, 4, 4, 4, testutil_grid(4), 4, &err), 0);
    for (uint64_t w = 1; w <= 2; w++) {
        assert_int_equal(sched_worker_join(s, w, 2, 0, &err), 0);
        assert_int_equal(sched_worker_set_threads(s, w, 1, &err), 0);
    }
    assert_int_equal(sched_worker_set_threads(s, 9, 1, &err), -1);
    assert_int_equal(sched_worker_set_threads(s, 1, 3, &err), -1);
    sched_task_t a, b, c, d;
    assert_int_equal(sched_next_task(s, 1, 0, &a), 1);
    /* 2 tasks left, worker 2 has 1 idle thread: 2 > 1, so worker 1 may prefetch one. */
    assert_int_equal(sched_next_task(s, 1, 0, &b), 1);
    assert_int_equal(sched_next_task(s, 2, 0, &c), 1);
    assert_int_equal(sched_next_task(s, 2, 0, &d), 0); /* nothing left */
    sched_destroy(&s);

    /* The same with two tasks: worker 1 takes one; the other is left for worker 2's idle
     * thread rather than queued behind worker 1's. */
    s = new_sched(4);
    assert_int_equal(sched_add_job(s, 1, 4, 4, 2, testutil_grid(4), 4, &err), 0);
    for (uint64_t w = 1; w <= 2; w++) {
        assert_int_equal(sched_worker_join(s, w, 2, 0, &err), 0);
        assert_int_equal(sched_worker_set_threads(s, w, 1, &err), 0);
    }
    assert_int_equal(sched_next_task(s, 1, 0, &a), 1);
    assert_int_equal(sched_next_task(s, 1, 0, &b), 0);
    assert_int_equal(sched_next_task(s, 2, 0, &c), 1);
    assert_int_not_equal(a.task, c.task);
    /* A worker alone prefetches whatever is left: no thread elsewhere could take it. */
    sched_worker_leave(s, 2);
    assert_int_equal(sched_next_task(s, 1, 0, &b), 1);
    assert_int_equal(b.task, c.task);
    sched_destroy(&s);
}

/* A job restored from a checkpoint (the master's journal): the passes it holds count as
 * merged, the rest is handed out and merged after them, and the image equals a run that
 * merged everything itself. */
static void test_restore_from_checkpoint(void **state)
{
    (void)state;
    err_t err;
    /* The uninterrupted run: 8x4 pixels, tiles of 4 (2 tiles), spp 4 (3 passes). */
    sched_t *s = new_sched(4);
    assert_int_equal(sched_add_job(s, 1, 8, 4, 4, testutil_grid(4), 4, &err), 0);
    sched_worker_join(s, 1, 64, 0, &err);
    sched_task_t t;
    while (sched_next_task(s, 1, 0, &t) == 1) {
        tilebuf_t *r = testutil_fake_result(&t, 4);
        assert_true(sched_task_done(s, 1, 1, t.task, t.attempt, &r, 0, &err) >= 0);
    }
    const tilebuf_t *full = sched_job_image(s, 1);

    /* The interrupted one: tile 0 merged passes 0-1, tile 1 pass 0 (a checkpoint). */
    sched_t *s2 = new_sched(4);
    assert_int_equal(sched_add_job(s2, 1, 8, 4, 4, testutil_grid(4), 4, &err), 0);
    sched_worker_join(s2, 1, 64, 0, &err);
    int next[2] = {2, 1};
    tilebuf_t *img = tilebuf_new(0, 0, 8, 4, 4, &err);
    sched_task_t q;
    for (int tile = 0; tile < 2; tile++)
        for (int pass = 0; pass < next[tile]; pass++) {
            q = (sched_task_t){.x0 = 4 * tile, .y0 = 0, .w = 4, .h = 4};
            uint32_t bounds[4];
            passes_bounds(4, bounds);
            q.sample_begin = bounds[pass];
            q.sample_end = bounds[pass + 1];
            tilebuf_t *r = testutil_fake_result(&q, 4);
            assert_int_equal(tilebuf_merge(img, r, &err), 0);
            tilebuf_destroy(&r);
        }
    /* A pass table out of range, or an image of another size, is refused. */
    int bad[2] = {4, 0};
    tilebuf_t *small = tilebuf_new(0, 0, 4, 4, 4, &err);
    assert_int_equal(sched_restore_job(s2, 1, &small, next, 0, &err), -1);
    assert_null(small);
    tilebuf_t *copy = tilebuf_new(0, 0, 8, 4, 4, &err);
    assert_int_equal(sched_restore_job(s2, 1, &copy, bad, 0, &err), -1);
    assert_int_equal(sched_restore_job(s2, 1, &img, next, 0, &err), 0);
    assert_null(img);
    int got[2];
    assert_int_equal(sched_job_next_pass(s2, 1, got, 2), 2);
    assert_memory_equal(got, next, sizeof next);
    sched_job_info_t info;
    assert_int_equal(sched_job_info(s2, 1, &info), 0);
    assert_int_equal(info.state, JOB_RUNNING);
    assert_int_equal(info.passes_done, 1);
    assert_int_equal(info.samples_done, 16 * 2 + 16 * 1); /* passes 0-1 of tile 0, 0 of tile 1 */
    /* Only the three missing tasks are handed out. */
    int n = 0;
    while (sched_next_task(s2, 1, 0, &t) == 1) {
        assert_true((t.task % 2 == 0 && t.pass == 2) || (t.task % 2 == 1 && t.pass >= 1));
        tilebuf_t *r = testutil_fake_result(&t, 4);
        assert_true(sched_task_done(s2, 1, 1, t.task, t.attempt, &r, 0, &err) >= 0);
        n++;
    }
    assert_int_equal(n, 3);
    assert_int_equal(sched_job_info(s2, 1, &info), 0);
    assert_int_equal(info.state, JOB_DONE);
    const tilebuf_t *resumed = sched_job_image(s2, 1);
    assert_memory_equal(tilebuf_sums(resumed), tilebuf_sums(full), 8 * 4 * 4 * sizeof(double));
    assert_memory_equal(tilebuf_counts(resumed), tilebuf_counts(full), 8 * 4 * sizeof(uint64_t));
    /* A started job cannot be restored again. */
    assert_int_equal(sched_restore_job(s2, 1, NULL, NULL, 0, &err), -1);
    sched_destroy(&s);
    sched_destroy(&s2);
}

/* A peer that claims 4096 threads and never answers (issue 16, item 8) holds at most
 * claim_start tasks, for one deadline, and then one task at a time: the job is finished by the
 * worker that answers, in about (tasks / its threads) rounds, not stalled deadline after
 * deadline; once the silent peer answers again it is off probation and its claim grows by two
 * per task it returns. */
static void test_silent_greedy_worker(void **state)
{
    (void)state;
    sched_t *s = new_sched(4); /* deadline 10 s, worker timeout 3 s */
    err_t err;
    /* 32 x 16 pixels in 4 x 4 tiles: 32 tiles; spp 2: passes [0,1) [1,2): 64 tasks. */
    assert_int_equal(sched_add_job(s, 1, 32, 16, 2, testutil_grid(4), 4, &err), 0);
    assert_int_equal(sched_worker_join(s, 1, 4096, 0.0, &err), 0); /* the silent claimant */
    assert_int_equal(sched_worker_join(s, 2, 2, 0.0, &err), 0);    /* an honest worker */
    sched_task_t t;
    int greedy = 0;
    while (sched_next_task(s, 1, 0.0, &t))
        greedy++;
    assert_int_equal(greedy, sched_config_default().claim_start);
    double now = 0.0;
    int done = 0, rounds = 0, issued_later = 0;
    sched_job_info_t info;
    for (; rounds < 1000; rounds++) {
        now += 1.0;
        sched_worker_seen(s, 1, now); /* it sends heartbeats, but no results */
        sched_worker_seen(s, 2, now);
        sched_tick(s, now);
        while (sched_next_task(s, 1, now, &t))
            issued_later++;
        sched_task_t mine[2];
        int n = 0;
        while (n < 2 && sched_next_task(s, 2, now, &mine[n]))
            n++;
        for (int i = 0; i < n; i++) {
            tilebuf_t *r = testutil_fake_result(&mine[i], 4);
            int m = sched_task_done(s, 2, 1, mine[i].task, mine[i].attempt, &r, now, &err);
            assert_true(m > 0);
            done += !!(m & SCHED_MERGED);
        }
        sched_job_info(s, 1, &info);
        if (info.state == JOB_DONE)
            break;
    }
    assert_int_equal(info.state, JOB_DONE);
    print_message("job of 64 tasks done in %d rounds by the honest worker (%d tasks); the silent "
                  "one was given %d more after its first %d\n",
                  rounds, done, issued_later, greedy);
    /* The honest worker does two tasks a round; the greedy one's claim cost one deadline. */
    assert_true(rounds <= 64 / 2 + 10 + 2);
    /* On probation: one task at a time, re-issued only after each deadline (every 10 s). */
    assert_true(issued_later <= rounds / 10 + 2);
    sched_destroy(&s);
}

/* The running count of sched_job_info follows every way a task starts and stops running:
 * issued, done, failed, its worker gone, its deadline missed, its job cancelled (it is kept as
 * tasks change state, not counted by a scan: bench/farm_scale.sh found the scan in the
 * master's per-result path). The expected counts are the test's own arithmetic. */
static int running(sched_t *s, uint64_t job)
{
    sched_job_info_t info;
    assert_int_equal(sched_job_info(s, job, &info), 0);
    return (int)info.tasks_running;
}

static void test_running_count(void **state)
{
    (void)state;
    sched_t *s = new_sched(4);
    err_t err;
    /* 8x8 pixels in 4x4 tiles, spp 2: 4 tiles x passes [0,1) [1,2) = 8 tasks. */
    assert_int_equal(sched_add_job(s, 3, 8, 8, 2, testutil_grid(2), 2, &err), 0);
    assert_int_equal(sched_worker_join(s, 1, 4, 0.0, &err), 0);
    assert_int_equal(sched_worker_join(s, 2, 4, 0.0, &err), 0);
    sched_task_t a[4], b[4];
    for (int i = 0; i < 4; i++)
        assert_int_equal(sched_next_task(s, 1, 0.0, &a[i]), 1);
    assert_int_equal(running(s, 3), 4);
    for (int i = 0; i < 4; i++)
        assert_int_equal(sched_next_task(s, 2, 0.0, &b[i]), 1);
    assert_int_equal(running(s, 3), 8);
    tilebuf_t *r = testutil_fake_result(&a[0], 2);
    assert_true(sched_task_done(s, 1, 3, a[0].task, a[0].attempt, &r, 1.0, &err) > 0);
    assert_int_equal(running(s, 3), 7);
    sched_task_failed(s, 1, 3, a[1].task, a[1].attempt, "test failure");
    assert_int_equal(running(s, 3), 6);
    sched_worker_leave(s, 2);
    assert_int_equal(running(s, 3), 2);
    /* Worker 1 answers, but its two tasks are past their 10 s deadline. */
    sched_worker_seen(s, 1, 11.0);
    assert_int_equal(sched_tick(s, 11.0), 2);
    assert_int_equal(running(s, 3), 0);
    sched_task_t t;
    assert_int_equal(sched_next_task(s, 1, 11.0, &t), 1);
    assert_int_equal(running(s, 3), 1);
    assert_int_equal(sched_cancel_job(s, 3, &err), 0);
    assert_int_equal(running(s, 3), 0);
    sched_destroy(&s);
}

/* The prefetch rule (sched_worker_set_threads) with the scheduler's running counts of idle
 * threads and pending tasks (issue 17: it summed them over every worker and task at each
 * dispatch): a worker past its threads is given a task only while more tasks wait than the
 * other live workers have idle threads, through a worker lost, one joining again and one
 * changing its threads. */
static void test_prefetch_counts(void **state)
{
    (void)state;
    sched_t *s = new_sched(8);
    err_t err;
    /* 24x16 pixels in 8-pixel tiles, 1 spp: 6 tasks. */
    assert_int_equal(sched_add_job(s, 1, 24, 16, 1, testutil_grid(2), 2, &err), 0);
    for (uint64_t w = 1; w <= 3; w++) {
        assert_int_equal(sched_worker_join(s, w, 4, 0.0, &err), 0);
        assert_int_equal(sched_worker_set_threads(s, w, 2, &err), 0);
    }
    sched_task_t t[6];
    assert_int_equal(sched_next_task(s, 1, 0.0, &t[0]), 1);
    assert_int_equal(sched_next_task(s, 1, 0.0, &t[1]), 1);
    /* 4 waiting, 4 idle threads on workers 2 and 3: no prefetch. */
    assert_int_equal(sched_next_task(s, 1, 0.0, &t[2]), 0);
    /* Worker 2 lost: 4 waiting, 2 idle threads: two prefetches, then its 4 slots are full. */
    sched_worker_leave(s, 2);
    assert_int_equal(sched_next_task(s, 1, 0.0, &t[2]), 1);
    assert_int_equal(sched_next_task(s, 1, 0.0, &t[3]), 1);
    assert_int_equal(sched_next_task(s, 1, 0.0, &t[4]), 0);
    /* Worker 3 down to 1 thread; worker 2 back with 4 slots, all threads: 2 waiting, 5 idle. */
    assert_int_equal(sched_worker_set_threads(s, 3, 1, &err), 0);
    assert_int_equal(sched_worker_join(s, 2, 4, 1.0, &err), 0);
    /* Worker 3 past its thread: 2 waiting, 4 idle on worker 2: no prefetch. */
    assert_int_equal(sched_next_task(s, 3, 1.0, &t[4]), 1);
    assert_int_equal(sched_next_task(s, 3, 1.0, &t[5]), 0);
    /* A result frees a thread of worker 1 (past its threads still: 3 busy of 2): 1 waiting, 4
     * idle. Worker 2 takes the last one. */
    tilebuf_t *r = testutil_fake_result(&t[0], 2);
    assert_true(sched_task_done(s, 1, 1, t[0].task, t[0].attempt, &r, 2.0, &err) & SCHED_MERGED);
    assert_int_equal(sched_next_task(s, 1, 2.0, &t[5]), 0);
    assert_int_equal(sched_next_task(s, 2, 2.0, &t[5]), 1);
    sched_worker_info_t info[3];
    assert_int_equal(sched_workers(s, info, 3), 3);
    assert_int_equal(info[0].busy, 3);
    assert_int_equal(info[1].busy, 1);
    assert_int_equal(info[2].busy, 1);
    sched_destroy(&s);
}

/* Deadlines with the scheduler's earliest-deadline bound (issue 17: every tick scanned every
 * task of every running job): a tick before the first deadline requeues nothing, each task goes
 * back at its own deadline, and a task issued with an earlier deadline than those running (a
 * caller's clock that stepped back) is still seen. */
static void test_deadlines_bound(void **state)
{
    (void)state;
    sched_t *s = new_sched(8); /* deadline 10 s, timeout 3 s */
    err_t err;
    assert_int_equal(sched_add_job(s, 1, 24, 16, 1, testutil_grid(2), 2, &err), 0);
    assert_int_equal(sched_worker_join(s, 1, 8, 0.0, &err), 0);
    sched_task_t a, b, c;
    assert_int_equal(sched_next_task(s, 1, 100.0, &a), 1); /* due at 110 */
    assert_int_equal(sched_next_task(s, 1, 105.0, &b), 1); /* due at 115 */
    double now = 100.0;
    for (; now < 105.0; now += 1.0) {
        sched_worker_seen(s, 1, now);
        assert_int_equal(sched_tick(s, now), 0);
    }
    /* Due at 100, before a's 110 that the ticks since 100 went by: the clock stepped back. */
    assert_int_equal(sched_next_task(s, 1, 90.0, &c), 1);
    sched_worker_seen(s, 1, 105.0);
    assert_int_equal(sched_tick(s, 105.0), 1); /* c */
    for (now = 106.0; now < 110.0; now += 1.0) {
        sched_worker_seen(s, 1, now);
        assert_int_equal(sched_tick(s, now), 0);
    }
    sched_worker_seen(s, 1, 110.5);
    assert_int_equal(sched_tick(s, 110.5), 1); /* a */
    for (now = 111.0; now < 115.0; now += 1.0) {
        sched_worker_seen(s, 1, now);
        assert_int_equal(sched_tick(s, now), 0);
    }
    sched_worker_seen(s, 1, 115.5);
    assert_int_equal(sched_tick(s, 115.5), 1); /* b */
    sched_event_t ev[4];
    assert_int_equal(sched_events_take(s, ev, 4, NULL), 3);
    assert_int_equal(ev[0].task, c.task);
    assert_int_equal(ev[1].task, a.task);
    assert_int_equal(ev[2].task, b.task);
    assert_int_equal(ev[2].kind, SCHED_EV_REQUEUED_DEADLINE);
    sched_destroy(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_passes_and_tiles),
        cmocka_unit_test(test_merge_order_independent),
        cmocka_unit_test(test_dead_worker_and_deadline),
        cmocka_unit_test(test_failures_block_and_fail),
        cmocka_unit_test(test_bad_results_and_jobs),
        cmocka_unit_test(test_prefetch_shrinks_at_the_end),
        cmocka_unit_test(test_restore_from_checkpoint),
        cmocka_unit_test(test_silent_greedy_worker),
        cmocka_unit_test(test_running_count),
        cmocka_unit_test(test_prefetch_counts),
        cmocka_unit_test(test_deadlines_bound),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
