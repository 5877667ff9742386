/* sched's operations (docs/farm.md, "Operating a farm"): priorities, fair share between owners,
 * pause and resume, requeue by hand, a worker blocked after failures in a row and unblocked,
 * and the events the master logs; and that none of them changes a job's pixels. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <string.h>

#include "sched.h"
#include "sched_testutil.h"

static sched_t *new_sched(int worker_failures_in_row)
{
    sched_config_t c = testutil_sched_config(8);
    c.claim_start = 0;
    c.max_worker_failures_in_row = worker_failures_in_row;
    return testutil_sched_new(&c);
}

/* A job of 16x16 pixels at 1 spp and 8-pixel tiles: 4 tasks. */
static void add_job(sched_t *s, uint64_t id, const char *owner, int priority)
{
    err_t err;
    assert_int_equal(sched_add_job(s, id, 16, 16, 1, testutil_grid(2), 2, &err), 0);
    assert_int_equal(sched_set_job_owner(s, id, owner, &err), 0);
    assert_int_equal(sched_set_job_priority(s, id, priority, &err), 0);
}

static void finish(sched_t *s, uint64_t worker, const sched_task_t *t)
{
    err_t err;
    tilebuf_t *r = testutil_fake_result(t, 2);
    assert_true(sched_task_done(s, worker, t->job, t->task, t->attempt, &r, 1.0, &err) &
                SCHED_MERGED);
}

static void test_priority_first(void **state)
{
    (void)state;
    sched_t *s = new_sched(5);
    err_t err;
    add_job(s, 1, "", 0);
    add_job(s, 2, "", 5);
    assert_int_equal(sched_worker_join(s, 1, 16, 0.0, &err), 0);
    sched_task_t t;
    /* The later job of higher priority takes every task first. */
    for (int i = 0; i < 4; i++) {
        assert_int_equal(sched_next_task(s, 1, 0.0, &t), 1);
        assert_int_equal(t.job, 2);
    }
    assert_int_equal(sched_next_task(s, 1, 0.0, &t), 1);
    assert_int_equal(t.job, 1);
    /* A priority changed later counts from the next task on. */
    add_job(s, 3, "", 0);
    assert_int_equal(sched_set_job_priority(s, 3, 9, &err), 0);
    assert_int_equal(sched_next_task(s, 1, 0.0, &t), 1);
    assert_int_equal(t.job, 3);
    assert_int_equal(sched_set_job_priority(s, 3, 1001, &err), -1);
    assert_non_null(strstr(err.msg, "outside"));
    sched_job_info_t info;
    assert_int_equal(sched_job_info(s, 3, &info), 0);
    assert_int_equal(info.priority, 9);
    sched_destroy(&s);
}

static void test_fair_share_between_owners(void **state)
{
    (void)state;
    sched_t *s = new_sched(5);
    err_t err;
    /* alice submitted three jobs before bob's one: bob still gets every other task. */
    add_job(s, 1, "alice", 0);
    add_job(s, 2, "alice", 0);
    add_job(s, 3, "alice", 0);
    add_job(s, 4, "bob", 0);
    assert_int_equal(sched_worker_join(s, 1, 64, 0.0, &err), 0);
    sched_task_t t;
    int bob = 0, alice = 0;
    for (int i = 0; i < 8; i++) {
        assert_int_equal(sched_next_task(s, 1, 0.0, &t), 1);
        /* Alternating: alice (oldest job first), bob, alice, ... */
        if (i % 2 == 0) {
            assert_int_not_equal(t.job, 4);
            alice++;
        } else {
            assert_int_equal(t.job, 4);
            bob++;
        }
    }
    assert_int_equal(alice, 4);
    assert_int_equal(bob, 4);
    /* bob's job has no task left: alice's take the rest, her oldest job first. */
    assert_int_equal(sched_next_task(s, 1, 0.0, &t), 1);
    assert_int_equal(t.job, 2);
    sched_destroy(&s);
}

static void test_pause_and_resume(void **state)
{
    (void)state;
    sched_t *s = new_sched(5);
    err_t err;
    add_job(s, 1, "", 0);
    add_job(s, 2, "", 0);
    assert_int_equal(sched_worker_join(s, 1, 64, 0.0, &err), 0);
    sched_task_t held;
    assert_int_equal(sched_next_task(s, 1, 0.0, &held), 1);
    assert_int_equal(held.job, 1);
    assert_int_equal(sched_pause_job(s, 1, true, 0.0, &err), 0);
    sched_job_info_t info;
    assert_int_equal(sched_job_info(s, 1, &info), 0);
    assert_true(info.paused);
    /* Paused: no more of its tasks, the other job's only. */
    sched_task_t t;
    for (int i = 0; i < 4; i++) {
        assert_int_equal(sched_next_task(s, 1, 0.0, &t), 1);
        assert_int_equal(t.job, 2);
    }
    assert_int_equal(sched_next_task(s, 1, 0.0, &t), 0);
    /* The task it held finishes and is merged. */
    finish(s, 1, &held);
    assert_int_equal(sched_job_info(s, 1, &info), 0);
    assert_int_equal(info.tasks_done, 1);
    assert_int_equal(sched_pause_job(s, 1, false, 0.0, &err), 0);
    for (int i = 0; i < 3; i++) {
        assert_int_equal(sched_next_task(s, 1, 0.0, &t), 1);
        assert_int_equal(t.job, 1);
        finish(s, 1, &t);
    }
    assert_int_equal(sched_job_info(s, 1, &info), 0);
    assert_int_equal(info.state, JOB_DONE);
    assert_int_equal(sched_pause_job(s, 1, true, 0.0, &err), -1);
    assert_non_null(strstr(err.msg, "only a queued or running job"));
    sched_destroy(&s);
}

/* Issue 17: a paused job's time limit kept counting. The scheduler counts the time a job is
 * paused while it runs, on the caller's clock (here a fake one): the master's elapsed time (and
 * so its time limit, its pass records and what the journal keeps) leaves it out. A pause while
 * the job is still queued is not its time (it starts after it); a pause the master makes when it
 * restores a job from its journal (queued, then running at once) counts from that pause. */
static void test_pause_time_not_counted(void **state)
{
    (void)state;
    sched_t *s = new_sched(5);
    err_t err;
    add_job(s, 1, "", 0);
    assert_int_equal(sched_worker_join(s, 1, 64, 0.0, &err), 0);
    sched_task_t t;
    assert_int_equal(sched_next_task(s, 1, 1.0, &t), 1); /* running from 1 s */
    assert_true(sched_job_paused_s(s, 1, 5.0) == 0.0);
    assert_int_equal(sched_pause_job(s, 1, true, 10.0, &err), 0);
    assert_true(sched_job_paused_s(s, 1, 10.0) == 0.0);
    assert_true(sched_job_paused_s(s, 1, 15.0) == 5.0); /* the pause under way */
    assert_int_equal(sched_pause_job(s, 1, false, 30.0, &err), 0);
    assert_true(sched_job_paused_s(s, 1, 40.0) == 20.0);  /* ended: no longer grows */
    assert_int_equal(sched_pause_job(s, 1, true, 50.0, &err), 0);
    assert_int_equal(sched_pause_job(s, 1, true, 55.0, &err), 0); /* again: still from 50 */
    assert_int_equal(sched_pause_job(s, 1, false, 70.0, &err), 0);
    assert_true(sched_job_paused_s(s, 1, 100.0) == 40.0);
    sched_job_info_t info;
    assert_int_equal(sched_job_info(s, 1, &info), 0);
    assert_false(info.paused);

    /* Paused while queued, resumed before it starts: none of it counts. */
    add_job(s, 2, "", 0);
    assert_int_equal(sched_pause_job(s, 2, true, 0.0, &err), 0);
    assert_true(sched_job_paused_s(s, 2, 50.0) == 0.0);
    assert_int_equal(sched_pause_job(s, 2, false, 100.0, &err), 0);
    assert_true(sched_job_paused_s(s, 2, 200.0) == 0.0);

    /* Paused as the journal restored it: from that pause on. */
    add_job(s, 3, "", 0);
    assert_int_equal(sched_pause_job(s, 3, true, 200.0, &err), 0);
    assert_int_equal(sched_restore_job(s, 3, NULL, NULL, 0, &err), 0);
    assert_true(sched_job_paused_s(s, 3, 250.0) == 50.0);
    assert_int_equal(sched_pause_job(s, 3, false, 260.0, &err), 0);
    assert_true(sched_job_paused_s(s, 3, 1000.0) == 60.0);
    assert_true(sched_job_paused_s(s, 99, 1000.0) == 0.0); /* no such job */
    sched_destroy(&s);
}

static void test_requeue_by_hand(void **state)
{
    (void)state;
    sched_t *s = new_sched(5);
    err_t err;
    add_job(s, 1, "", 0);
    assert_int_equal(sched_worker_join(s, 1, 1, 0.0, &err), 0);
    assert_int_equal(sched_worker_join(s, 2, 1, 0.0, &err), 0);
    sched_task_t stuck, t;
    assert_int_equal(sched_next_task(s, 1, 0.0, &stuck), 1);
    assert_int_equal(sched_requeue_task(s, 1, 1, &err), -1); /* task 1 is still queued */
    assert_non_null(strstr(err.msg, "waiting in the queue"));
    assert_int_equal(sched_requeue_task(s, 1, 99, &err), -1);
    assert_non_null(strstr(err.msg, "no task 99"));
    assert_int_equal(sched_requeue_task(s, 1, stuck.task, &err), 0);
    sched_event_t ev[8];
    assert_int_equal(sched_events_take(s, ev, 8, NULL), 1);
    assert_int_equal(ev[0].kind, SCHED_EV_REQUEUED_BY_HAND);
    assert_int_equal(ev[0].worker, 1);
    assert_int_equal(ev[0].task, stuck.task);
    /* Not back to the worker it was stuck on: worker 1 gets the next task... */
    sched_task_t other;
    assert_int_equal(sched_next_task(s, 1, 0.0, &other), 1);
    assert_int_not_equal(other.task, stuck.task);
    /* ...and worker 2 the requeued one, as a new attempt. */
    assert_int_equal(sched_next_task(s, 2, 0.0, &t), 1);
    assert_int_equal(t.task, stuck.task);
    assert_int_equal(t.attempt, stuck.attempt + 1);
    finish(s, 2, &t);
    assert_int_equal(sched_requeue_task(s, 1, stuck.task, &err), -1);
    assert_non_null(strstr(err.msg, "is done"));
    /* The stuck worker's late copy is the same bytes: accepted as a duplicate. */
    tilebuf_t *r = testutil_fake_result(&stuck, 2);
    assert_int_equal(sched_task_done(s, 1, 1, stuck.task, stuck.attempt, &r, 2.0, &err),
                     SCHED_DUPLICATE);
    sched_destroy(&s);
}

static void test_worker_blocked_in_a_row_and_unblocked(void **state)
{
    (void)state;
    sched_t *s = new_sched(3);
    err_t err;
    /* Jobs allow 2 failures each before blocking the worker from them (the default); three in
     * a row over different jobs block it from every job. */
    add_job(s, 1, "", 0);
    add_job(s, 2, "", 0);
    add_job(s, 3, "", 0);
    add_job(s, 4, "", 0);
    assert_int_equal(sched_worker_join(s, 7, 1, 0.0, &err), 0);
    sched_task_t t;
    assert_int_equal(sched_next_task(s, 7, 0.0, &t), 1);
    sched_task_failed(s, 7, t.job, t.task, t.attempt, "bad GPU driver");
    assert_int_equal(sched_next_task(s, 7, 0.0, &t), 1);
    finish(s, 7, &t); /* a success breaks the row */
    sched_worker_info_t wi;
    assert_int_equal(sched_workers(s, &wi, 1), 1);
    assert_int_equal(wi.fail_streak, 0);
    for (int i = 0; i < 3; i++) {
        assert_int_equal(sched_next_task(s, 7, 0.0, &t), 1);
        sched_task_failed(s, 7, t.job, t.task, t.attempt, "bad GPU driver");
    }
    assert_int_equal(sched_workers(s, &wi, 1), 1);
    assert_true(wi.blocked);
    assert_int_equal(sched_next_task(s, 7, 0.0, &t), 0);
    sched_event_t ev[16];
    size_t n = sched_events_take(s, ev, 16, NULL);
    bool blocked_ev = false, job_ev = false;
    for (size_t i = 0; i < n; i++) {
        blocked_ev |= ev[i].kind == SCHED_EV_WORKER_BLOCKED && ev[i].worker == 7;
        job_ev |= ev[i].kind == SCHED_EV_WORKER_BLOCKED_JOB && ev[i].job == 1;
    }
    assert_true(blocked_ev);
    assert_true(job_ev); /* its two failures of job 1 blocked it from job 1 first */
    assert_int_equal(sched_events_take(s, ev, 16, NULL), 0);
    /* Unblocked: it serves every job again, job 1 included. */
    assert_int_equal(sched_worker_block(s, 7, false, &err), 0);
    assert_int_equal(sched_workers(s, &wi, 1), 1);
    assert_false(wi.blocked);
    assert_int_equal(wi.blocked_jobs, 0);
    assert_int_equal(sched_next_task(s, 7, 0.0, &t), 1);
    assert_int_equal(t.job, 1);
    assert_int_equal(sched_worker_block(s, 99, false, &err), -1);
    sched_destroy(&s);
}

static void test_events_on_deadline_and_loss(void **state)
{
    (void)state;
    sched_t *s = new_sched(5);
    err_t err;
    add_job(s, 1, "", 0);
    assert_int_equal(sched_worker_join(s, 1, 1, 0.0, &err), 0);
    assert_int_equal(sched_worker_join(s, 2, 1, 0.0, &err), 0);
    sched_task_t a, b;
    assert_int_equal(sched_next_task(s, 1, 0.0, &a), 1);
    assert_int_equal(sched_next_task(s, 2, 0.0, &b), 1);
    sched_worker_leave(s, 2);
    sched_worker_seen(s, 1, 11.0);
    assert_int_equal(sched_tick(s, 11.0), 1);
    sched_event_t ev[8];
    assert_int_equal(sched_events_take(s, ev, 8, NULL), 2);
    assert_int_equal(ev[0].kind, SCHED_EV_REQUEUED_LOST);
    assert_int_equal(ev[0].worker, 2);
    assert_int_equal(ev[0].task, b.task);
    assert_int_equal(ev[1].kind, SCHED_EV_REQUEUED_DEADLINE);
    assert_int_equal(ev[1].worker, 1);
    assert_int_equal(ev[1].task, a.task);
    sched_destroy(&s);
}

static sched_worker_info_t worker_info(const sched_t *s, uint64_t id)
{
    sched_worker_info_t wi[16];
    size_t n = sched_workers(s, wi, 16);
    for (size_t i = 0; i < n; i++)
        if (wi[i].id == id)
            return wi[i];
    fail_msg("no worker %llu", (unsigned long long)id);
    return wi[0];
}

/* A worker killed mid-task (SIGKILL: its connection drops holding tasks) is struck as if its
 * tasks had expired, and the same key's next connection takes the strike
 * and the probation over: a key that keeps dying mid-task is blocked (issue 26). On the code
 * before, a dropped connection cost nothing and the key came back with a clean row each time. */
static void test_worker_dying_mid_task_is_struck(void **state)
{
    (void)state;
    sched_t *s = new_sched(3);
    err_t err;
    add_job(s, 1, "", 0);
    add_job(s, 2, "", 0);
    sched_task_t t, honest;
    assert_int_equal(sched_worker_join(s, 1, 1, 0.0, &err), 0);
    /* Leaving without a task held is no strike. */
    assert_int_equal(sched_worker_join(s, 10, 1, 0.0, &err), 0);
    sched_worker_dropped(s, 10);
    assert_int_equal(worker_info(s, 10).fail_streak, 0);
    /* The key's connections 10, 11, 12 each die holding a task. */
    assert_int_equal(sched_worker_join(s, 10, 1, 0.0, &err), 0);
    assert_int_equal(sched_next_task(s, 10, 0.0, &t), 1);
    sched_worker_dropped(s, 10);
    assert_int_equal(worker_info(s, 10).fail_streak, 1);
    sched_event_t ev[8];
    assert_int_equal(sched_events_take(s, ev, 8, NULL), 1);
    assert_int_equal(ev[0].kind, SCHED_EV_REQUEUED_LOST);
    assert_int_equal(ev[0].task, t.task);
    assert_int_equal(sched_worker_join(s, 11, 1, 0.0, &err), 0);
    assert_int_equal(sched_worker_take_over(s, 11, 10), 0); /* 10 held nothing any more */
    assert_int_equal(worker_info(s, 11).fail_streak, 1);
    /* On probation: nothing while the honest worker has room, one task once it has none. */
    assert_int_equal(sched_next_task(s, 11, 0.0, &t), 0);
    assert_int_equal(sched_next_task(s, 1, 0.0, &honest), 1);
    assert_int_equal(sched_next_task(s, 11, 0.0, &t), 1);
    sched_worker_dropped(s, 11);
    assert_int_equal(worker_info(s, 11).fail_streak, 2);
    assert_false(worker_info(s, 11).blocked);
    assert_int_equal(sched_worker_join(s, 12, 1, 0.0, &err), 0);
    assert_int_equal(sched_worker_take_over(s, 12, 11), 0);
    assert_int_equal(sched_next_task(s, 12, 0.0, &t), 1);
    sched_worker_dropped(s, 12); /* the third strike in a row */
    sched_worker_info_t wi = worker_info(s, 12);
    assert_int_equal(wi.fail_streak, 3);
    assert_true(wi.blocked);
    size_t n = sched_events_take(s, ev, 8, NULL);
    assert_int_equal(n, 3); /* two tasks lost, then the block */
    assert_int_equal(ev[2].kind, SCHED_EV_WORKER_BLOCKED);
    assert_int_equal(ev[2].worker, 12);
    /* The key's next connection is blocked from the start, even with no one else to run. */
    assert_int_equal(sched_worker_join(s, 13, 1, 0.0, &err), 0);
    assert_int_equal(sched_worker_take_over(s, 13, 12), 0);
    assert_true(worker_info(s, 13).blocked);
    assert_int_equal(sched_next_task(s, 13, 0.0, &t), 0);
    /* The honest worker returns its task and drops with nothing held: no strike; one that
     * only leaves (silent: sched_worker_leave) holding a task is not struck either. */
    finish(s, 1, &honest);
    sched_worker_dropped(s, 1);
    assert_int_equal(worker_info(s, 1).fail_streak, 0);
    assert_int_equal(sched_worker_join(s, 1, 1, 0.0, &err), 0);
    assert_int_equal(sched_next_task(s, 1, 0.0, &honest), 1);
    sched_worker_leave(s, 1);
    assert_int_equal(worker_info(s, 1).fail_streak, 0);
    sched_destroy(&s);
}

/* Two schedules of the same job -- one with pauses, priorities, a rival owner's job and a
 * requeue, one plain -- give the same image bytes. */
static void test_operations_leave_pixels_alone(void **state)
{
    (void)state;
    const tilebuf_t *img[2];
    sched_t *s[2];
    err_t err;
    for (int run = 0; run < 2; run++) {
        s[run] = new_sched(5);
        add_job(s[run], 1, "alice", 0);
        assert_int_equal(sched_worker_join(s[run], 1, 1, 0.0, &err), 0);
        assert_int_equal(sched_worker_join(s[run], 2, 1, 0.0, &err), 0);
        if (run == 1) {
            add_job(s[run], 2, "bob", 3);
            assert_int_equal(sched_pause_job(s[run], 2, true, 0.0, &err), 0);
        }
        sched_task_t t;
        int k = 0;
        for (;;) {
            uint64_t w = 1 + (uint64_t)(k++ % 2);
            if (!sched_next_task(s[run], w, 0.0, &t))
                break;
            if (run == 1 && k == 2) {
                assert_int_equal(sched_requeue_task(s[run], t.job, t.task, &err), 0);
                continue;
            }
            if (t.job == 1)
                finish(s[run], w, &t);
        }
        sched_job_info_t info;
        assert_int_equal(sched_job_info(s[run], 1, &info), 0);
        assert_int_equal(info.state, JOB_DONE);
        img[run] = sched_job_image(s[run], 1);
    }
    size_t n = (size_t)16 * 16 * 2;
    assert_memory_equal(tilebuf_sums(img[0]), tilebuf_sums(img[1]), n * sizeof(double));
    sched_destroy(&s[0]);
    sched_destroy(&s[1]);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_priority_first),
        cmocka_unit_test(test_fair_share_between_owners),
        cmocka_unit_test(test_pause_and_resume),
        cmocka_unit_test(test_pause_time_not_counted),
        cmocka_unit_test(test_requeue_by_hand),
        cmocka_unit_test(test_worker_blocked_in_a_row_and_unblocked),
        cmocka_unit_test(test_events_on_deadline_and_loss),
        cmocka_unit_test(test_worker_dying_mid_task_is_struck),
        cmocka_unit_test(test_operations_leave_pixels_alone),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
