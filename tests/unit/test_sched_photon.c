/* sched: the photon phase of a job. Batches go out first and camera tasks wait for all of
 * them; lost workers, deadlines and failures requeue batches like tiles; a batch failing too
 * often fails the job; the master can fail a job outright. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <string.h>

#include "sched.h"
#include "sched_testutil.h"

static sched_t *new_sched(void)
{
    sched_config_t c = testutil_sched_config(4);
    c.max_task_failures = 2;
    c.max_worker_job_failures = 5;
    return testutil_sched_new(&c);
}

/* Runs every camera task the worker is given until there is none; returns the tasks run for
 * the job, which must then be done. */
static int finish_camera(sched_t *s, uint64_t worker, uint64_t job, double now)
{
    sched_task_t t;
    err_t err;
    int n = 0;
    while (sched_next_task(s, worker, now, &t)) {
        assert_int_equal(t.kind, SCHED_CAMERA);
        tilebuf_t *r = testutil_fake_result(&t, 4);
        assert_true(sched_task_done(s, worker, t.job, t.task, t.attempt, &r, now, &err) > 0);
        n += t.job == job;
    }
    sched_job_info_t info;
    assert_int_equal(sched_job_info(s, job, &info), 0);
    assert_int_equal(info.state, JOB_DONE);
    return n;
}

static void test_batches_before_tiles(void **state)
{
    (void)state;
    sched_t *s = new_sched();
    err_t err;
    /* 8x4 pixels in 4x4 tiles, 2 spp: 2 tiles x 2 passes; 3 photon batches. */
    assert_int_equal(sched_add_job(s, 1, 8, 4, 2, testutil_grid(4), 4, &err), 0);
    assert_int_equal(sched_add_photon_batches(s, 1, 3, &err), 0);
    assert_int_equal(sched_worker_join(s, 10, 100, 0.0, &err), 0);
    assert_int_equal(sched_worker_join(s, 11, 100, 0.0, &err), 0);
    sched_task_t t[3], x;
    for (int i = 0; i < 3; i++) {
        assert_int_equal(sched_next_task(s, i == 2 ? 11 : 10, 0.0, &t[i]), 1);
        assert_int_equal(t[i].kind, SCHED_PHOTON);
        assert_int_equal(t[i].batch, i);
        assert_int_equal(t[i].task, SCHED_PHOTON_TASK | (uint32_t)i);
    }
    /* Every batch is out: no camera task before they are all done. */
    assert_int_equal(sched_next_task(s, 10, 0.0, &x), 0);
    sched_job_info_t info;
    assert_int_equal(sched_job_info(s, 1, &info), 0);
    assert_int_equal(info.photon_batches, 3);
    assert_int_equal(info.tasks_total, 4 + 3);
    assert_int_equal(info.tasks_running, 3);
    /* Worker 11 dies: its batch goes back and is handed out again. */
    sched_worker_leave(s, 11);
    assert_int_equal(sched_next_task(s, 10, 1.0, &x), 1);
    assert_int_equal(x.kind, SCHED_PHOTON);
    assert_int_equal(x.batch, 2);
    assert_int_equal(x.attempt, 2);
    assert_int_equal(sched_photon_done(s, 10, 1, t[1].task, t[1].attempt, 1.0, &err), SCHED_MERGED);
    assert_int_equal(sched_photon_done(s, 10, 1, t[0].task, t[0].attempt, 1.0, &err), SCHED_MERGED);
    /* The dead worker's late copy of batch 2 counts; the re-issued one is then a duplicate. */
    assert_int_equal(sched_photon_done(s, 11, 1, t[2].task, t[2].attempt, 1.5, &err),
                     SCHED_MERGED | SCHED_PHASE_DONE);
    assert_int_equal(sched_photon_done(s, 10, 1, x.task, x.attempt, 1.6, &err), SCHED_DUPLICATE);
    /* Photon ids are refused as camera results and the other way round. */
    tilebuf_t *bogus = tilebuf_new(0, 0, 4, 4, 4, NULL);
    assert_int_equal(sched_task_done(s, 10, 1, t[0].task, 1, &bogus, 2.0, &err), -1);
    assert_null(bogus);
    assert_int_equal(sched_photon_done(s, 10, 1, 0, 1, 2.0, &err), -1);
    assert_int_equal(sched_photon_done(s, 10, 1, SCHED_PHOTON_TASK | 3, 1, 2.0, &err), -1);
    assert_int_equal(finish_camera(s, 10, 1, 2.0), 4);
    assert_int_equal(sched_job_info(s, 1, &info), 0);
    assert_int_equal(info.state, JOB_DONE);
    assert_int_equal(info.tasks_done, 7);
    assert_int_equal(info.photon_batches_done, 3);
    /* Batches only before the job starts. */
    assert_int_equal(sched_add_photon_batches(s, 1, 1, &err), -1);
    sched_destroy(&s);
}

static void test_deadline_and_failure(void **state)
{
    (void)state;
    sched_t *s = new_sched();
    err_t err;
    assert_int_equal(sched_add_job(s, 2, 4, 4, 1, testutil_grid(4), 4, &err), 0);
    assert_int_equal(sched_add_photon_batches(s, 2, 2, &err), 0);
    assert_int_equal(sched_worker_join(s, 10, 1, 0.0, &err), 0);
    sched_task_t a, b;
    assert_int_equal(sched_next_task(s, 10, 0.0, &a), 1);
    /* One slot: nothing more until a is back or overdue. */
    assert_int_equal(sched_next_task(s, 10, 0.0, &b), 0);
    sched_worker_seen(s, 10, 11.0);
    assert_int_equal(sched_tick(s, 11.0), 1);
    assert_int_equal(sched_next_task(s, 10, 11.0, &b), 1);
    assert_int_equal(b.batch, 0);
    assert_int_equal(b.attempt, 2);
    /* A batch the master refuses (a result that does not decode) fails like a tile; twice
     * fails the job with the batch named. */
    sched_task_failed(s, 10, 2, b.task, b.attempt, "photon batch 0: bad data");
    assert_int_equal(sched_next_task(s, 10, 12.0, &b), 1);
    assert_int_equal(b.batch, 0);
    sched_task_failed(s, 10, 2, b.task, b.attempt, "photon batch 0: bad data again");
    sched_job_info_t info;
    assert_int_equal(sched_job_info(s, 2, &info), 0);
    assert_int_equal(info.state, JOB_FAILED);
    assert_non_null(strstr(info.error, "photon batch 0 failed 2 times; last error: photon batch 0: bad data again"));
    assert_int_equal(info.tasks_running, 0);
    sched_destroy(&s);
}

/* The master fails a job whose merged store it cannot make: running tasks are released. */
static void test_fail_job(void **state)
{
    (void)state;
    sched_t *s = new_sched();
    err_t err;
    assert_int_equal(sched_add_job(s, 3, 8, 4, 2, testutil_grid(4), 4, &err), 0);
    assert_int_equal(sched_add_photon_batches(s, 3, 2, &err), 0);
    assert_int_equal(sched_worker_join(s, 10, 100, 0.0, &err), 0);
    sched_task_t t;
    assert_int_equal(sched_next_task(s, 10, 0.0, &t), 1);
    sched_fail_job(s, 3, "the merged photon store: out of memory");
    sched_job_info_t info;
    assert_int_equal(sched_job_info(s, 3, &info), 0);
    assert_int_equal(info.state, JOB_FAILED);
    assert_int_equal(info.tasks_running, 0);
    assert_string_equal(info.error, "the merged photon store: out of memory");
    assert_int_equal(sched_next_task(s, 10, 0.0, &t), 0);
    /* Once over, a job stays as it ended. */
    sched_fail_job(s, 3, "again");
    assert_int_equal(sched_job_info(s, 3, &info), 0);
    assert_string_equal(info.error, "the merged photon store: out of memory");
    sched_destroy(&s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_batches_before_tiles),
        cmocka_unit_test(test_deadline_and_failure),
        cmocka_unit_test(test_fail_job),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
