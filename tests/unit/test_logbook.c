/* logbook: the master's last lines for its dashboard -- numbered in order, read after a number,
 * by job (a line is about the job it opens with or names after "for"), and bounded: the oldest
 * give way once LOGBOOK_LINES are kept, and a line is cut at LOGBOOK_TEXT bytes. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "logbook.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void test_jobs_and_since(void **state)
{
    (void)state;
    logbook_t *b = logbook_new();
    assert_non_null(b);
    logbook_add(b, 1.0, "workers on ipc://w, clients on ipc://c, spool s, next job 1");
    logbook_add(b, 2.0, "job 1 'a' submitted by x");
    logbook_add(b, 3.0, "job 12 'b' started");
    logbook_add(b, 4.0, "refused a result from worker 2 'w' (key 'k') for job 1 task 0: no");
    logbook_add(b, 5.0, "a jobless line mentioning job 1 in passing");
    logbook_line_t out[10];
    int n = logbook_read(b, 0, 0, out, 10);
    assert_int_equal(n, 5);
    for (int i = 0; i < n; i++)
        assert_int_equal(out[i].seq, (uint64_t)i + 1);
    /* Job 1: the line it opens and the one "for job 1"; not "next job 1", not job 12. */
    n = logbook_read(b, 1, 0, out, 10);
    assert_int_equal(n, 2);
    assert_int_equal(out[0].seq, 2);
    assert_int_equal(out[1].seq, 4);
    assert_int_equal(out[1].job, 1);
    assert_int_equal(logbook_read(b, 12, 0, out, 10), 1);
    /* After a number, and at most max. */
    n = logbook_read(b, 0, 3, out, 10);
    assert_int_equal(n, 2);
    assert_int_equal(out[0].seq, 4);
    assert_int_equal(logbook_read(b, 0, 0, out, 2), 2);
    assert_int_equal(logbook_read(b, 0, 5, out, 10), 0);
    assert_int_equal(logbook_read(b, 0, UINT64_MAX, out, 10), 0);
    logbook_destroy(&b);
    assert_null(b);
}

static void test_bounded(void **state)
{
    (void)state;
    logbook_t *b = logbook_new();
    char line[64];
    for (int i = 1; i <= LOGBOOK_LINES + 10; i++) {
        snprintf(line, sizeof line, "job %d line", i % 3 + 1);
        logbook_add(b, i, line);
    }
    logbook_line_t *out = calloc(LOGBOOK_LINES + 10, sizeof *out);
    int n = logbook_read(b, 0, 0, out, LOGBOOK_LINES + 10);
    assert_int_equal(n, LOGBOOK_LINES);
    assert_int_equal(out[0].seq, 11); /* the ten oldest gave way */
    assert_int_equal(out[n - 1].seq, LOGBOOK_LINES + 10);
    char big[LOGBOOK_TEXT * 2];
    memset(big, 'x', sizeof big - 1);
    big[sizeof big - 1] = 0;
    logbook_add(b, 0, big);
    n = logbook_read(b, 0, LOGBOOK_LINES + 10, out, 1);
    assert_int_equal(n, 1);
    assert_int_equal(strlen(out[0].text), LOGBOOK_TEXT - 1);
    free(out);
    logbook_destroy(&b);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_jobs_and_since),
        cmocka_unit_test(test_bounded),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
