/* peers: the master's worker tables looked up by id (peers.h). The listings (WORKERS, the
 * dashboard's /api/workers, /metrics) and each loop turn's peers_agree_with_sched look every
 * worker up in the scheduler's table, and the scheduler looks its worker up for every task,
 * result and sign of life: a linear search made them quadratic in the workers (issue 17). The
 * lookups are binary searches over tables kept in id order, so these tests check that order
 * whatever order the workers joined in, and that each lookup finds the entry of its own id: a
 * table left in join order, or an entry shifted by the sorted insertion, fails them. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <stdlib.h>
#include <string.h>

#include "peers.h"
#include "sched_testutil.h"
#include "tilebuf.h"

#define NW 300

/* 1..NW in a fixed pseudo-random order. */
static void shuffled_ids(uint64_t *ids, unsigned seed)
{
    for (int i = 0; i < NW; i++)
        ids[i] = (uint64_t)i + 1;
    testutil_shuffle(ids, NW, sizeof *ids, seed);
}

/* Worker id has id % 13 + 1 slots: an entry found for the wrong id shows in its slots. */
static int slots_of(uint64_t id)
{
    return (int)(id % 13) + 1;
}

static void test_sched_table_in_id_order(void **state)
{
    (void)state;
    err_t err;
    sched_t *s = testutil_sched_new(NULL);
    uint64_t ids[NW];
    shuffled_ids(ids, 17);
    for (int i = 0; i < NW; i++)
        assert_int_equal(sched_worker_join(s, ids[i], slots_of(ids[i]), 0.0, &err), 0);
    master_opts_t opts = master_opts_default();
    master_t m = {.opts = &opts, .sched = s};

    size_t n = peers_sched_table(&m);
    assert_int_equal(n, NW);
    for (size_t i = 1; i < n; i++)
        assert_true(m.winfo[i - 1].id < m.winfo[i].id);
    for (uint64_t id = 1; id <= NW; id++) {
        const sched_worker_info_t *si = peers_sched_info(&m, n, id);
        assert_non_null(si);
        assert_int_equal(si->id, id);
        assert_int_equal(si->slots, slots_of(id));
    }
    assert_null(peers_sched_info(&m, n, 0));
    assert_null(peers_sched_info(&m, n, NW + 1));
    free(m.winfo);
    sched_destroy(&s);
}

/* The scheduler's own lookup: each worker, joined in shuffled order, is given a task and returns
 * it, and the counts land on its own entry (a worker shifted by the insertion would take another's
 * task or count another's result). A worker joining again keeps its place. */
static void test_sched_workers_joined_out_of_order(void **state)
{
    (void)state;
    err_t err;
    sched_config_t cfg = testutil_sched_config(8);
    sched_t *s = testutil_sched_new(&cfg);
    /* One 8x8 tile per worker, 1 spp: NW tasks of one pass. */
    assert_int_equal(sched_add_job(s, 1, 8 * NW, 8, 1, testutil_grid(2), 2, &err), 0);
    uint64_t ids[NW];
    shuffled_ids(ids, 5);
    for (int i = 0; i < NW; i++)
        assert_int_equal(sched_worker_join(s, ids[i], 1, 0.0, &err), 0);
    assert_int_equal(sched_worker_join(s, ids[NW / 2], 1, 0.0, &err), 0); /* again */
    sched_task_t tasks[NW];
    for (int i = 0; i < NW; i++) {
        assert_int_equal(sched_next_task(s, ids[i], 1.0, &tasks[i]), 1);
        assert_int_equal(sched_next_task(s, ids[i], 1.0, &(sched_task_t){0}), 0); /* 1 slot */
    }
    sched_worker_info_t info[NW];
    assert_int_equal(sched_workers(s, info, NW), NW);
    for (int i = 0; i < NW; i++) {
        assert_int_equal(info[i].id, (uint64_t)i + 1);
        assert_int_equal(info[i].busy, 1);
    }
    int mask = 0;
    for (int i = 0; i < NW; i++) {
        const sched_task_t *t = &tasks[i];
        tilebuf_t *r = testutil_fake_result(t, 2);
        mask = sched_task_done(s, ids[i], 1, t->task, t->attempt, &r, 2.0, &err);
        assert_true(mask & SCHED_MERGED);
    }
    assert_true(mask & SCHED_JOB_DONE);
    assert_int_equal(sched_workers(s, info, NW), NW);
    for (int i = 0; i < NW; i++) {
        assert_int_equal(info[i].busy, 0);
        assert_int_equal(info[i].tasks_done, 1);
        assert_int_equal(info[i].samples_done, 64);
    }
    sched_destroy(&s);
}

/* The master's table: ids in order as peers_add hands them out, and still after
 * peers_prune_lost took workers out of the middle. */
static void test_master_table_by_id(void **state)
{
    (void)state;
    master_opts_t opts = master_opts_default();
    master_t m = {.opts = &opts};
    for (int i = 0; i < NW; i++) {
        proto_peer_t p = {.len = 4};
        memcpy(p.id, &i, 4);
        mworker_t *w = peers_add(&m, &p);
        assert_non_null(w);
        /* 270 lost (above the 256 kept), each seen longer ago the higher its id. */
        w->alive = i % 10 == 0;
        w->last_seen = 1000.0 - i;
    }
    while (true) {
        size_t n = m.nworkers;
        peers_prune_lost(&m);
        if (m.nworkers == n)
            break;
    }
    assert_int_equal(m.nworkers, NW - 14);
    for (size_t i = 1; i < m.nworkers; i++)
        assert_true(m.workers[i - 1]->id < m.workers[i]->id);
    size_t found = 0;
    for (uint64_t id = 1; id <= NW; id++) {
        mworker_t *w = peers_by_id(&m, id);
        if (w) {
            assert_int_equal(w->id, id);
            found++;
        }
    }
    assert_int_equal(found, m.nworkers);
    /* The pruned are the 14 lost seen longest ago: ids 286-300 but the live 291. */
    assert_null(peers_by_id(&m, NW));
    assert_null(peers_by_id(&m, NW - 14));    /* 286, the 14th */
    assert_non_null(peers_by_id(&m, NW - 9));  /* 291, alive */
    assert_non_null(peers_by_id(&m, NW - 15)); /* 285, the newest lost kept */
    assert_null(peers_by_id(&m, 0));
    for (size_t i = 0; i < m.nworkers; i++)
        peers_free(m.workers[i]);
    free(m.workers);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sched_table_in_id_order),
        cmocka_unit_test(test_sched_workers_joined_out_of_order),
        cmocka_unit_test(test_master_table_by_id),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
