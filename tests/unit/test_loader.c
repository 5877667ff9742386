#define _DEFAULT_SOURCE /* usleep */
/* loader (master/loader.h): work runs off the calling thread, one item at a time in the order
 * given, and comes back through loader_done without waiting; while an item runs, the caller
 * is free (loader_done returns NULL at once); destroying the loader waits for the running item
 * and hands every other back to release, run or not. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "loader.h"
#include "test_wait.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <unistd.h>

typedef struct work {
    int id;
    atomic_int *gate;    /* the item waits until *gate is non-zero */
    atomic_int *started; /* items started, in order */
    int order;           /* its place among the items run */
    int released;
} work_t;

static void run(void *arg)
{
    work_t *w = arg;
    w->order = atomic_fetch_add(w->started, 1);
    while (!atomic_load(w->gate))
        usleep(1000);
}

static void release(void *arg)
{
    ((work_t *)arg)->released++;
}

static void test_order_and_no_wait(void **state)
{
    (void)state;
    err_t err;
    loader_t *l = loader_new(&err);
    assert_non_null(l);
    atomic_int gate = 0, started = 0;
    work_t w[3];
    for (int i = 0; i < 3; i++) {
        w[i] = (work_t){.id = i, .gate = &gate, .started = &started, .order = -1};
        assert_int_equal(loader_run(l, run, &w[i], &err), 0);
    }
    assert_int_equal(loader_pending(l), 3);
    /* The first item holds the loader: nothing is done, and asking does not wait for it. */
    double deadline = test_wait_s();
    for (double t = 0; atomic_load(&started) == 0 && t < deadline; t += 0.001)
        usleep(1000);
    assert_int_equal(atomic_load(&started), 1);
    assert_null(loader_done(l));
    atomic_store(&gate, 1);
    int got = 0;
    for (double t = 0; got < 3 && t < deadline; t += 0.001) {
        work_t *d = loader_done(l);
        if (!d) {
            usleep(1000);
            continue;
        }
        assert_int_equal(d->id, got); /* handed back in the order given */
        assert_int_equal(d->order, got);
        got++;
    }
    assert_int_equal(got, 3);
    assert_int_equal(loader_pending(l), 0);
    assert_null(loader_done(l));
    loader_destroy(&l, release);
    assert_null(l);
    for (int i = 0; i < 3; i++)
        assert_int_equal(w[i].released, 0); /* all were taken back */
}

static void *open_gate_later(void *arg)
{
    usleep(50000);
    atomic_store((atomic_int *)arg, 1);
    return NULL;
}

static void test_destroy_releases(void **state)
{
    (void)state;
    err_t err;
    loader_t *l = loader_new(&err);
    assert_non_null(l);
    atomic_int gate = 0, started = 0;
    work_t w[3];
    for (int i = 0; i < 3; i++) {
        w[i] = (work_t){.id = i, .gate = &gate, .started = &started, .order = -1};
        assert_int_equal(loader_run(l, run, &w[i], &err), 0);
    }
    for (double t = 0; atomic_load(&started) == 0 && t < test_wait_s(); t += 0.001)
        usleep(1000);
    /* The running item finishes (the gate opens while destroy waits); the others never run. */
    pthread_t th;
    assert_int_equal(pthread_create(&th, NULL, open_gate_later, &gate), 0);
    loader_destroy(&l, release);
    pthread_join(th, NULL);
    assert_int_equal(w[0].order, 0);
    assert_int_equal(w[1].order, -1);
    assert_int_equal(w[2].order, -1);
    for (int i = 0; i < 3; i++)
        assert_int_equal(w[i].released, 1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_order_and_no_wait),
        cmocka_unit_test(test_destroy_releases),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
