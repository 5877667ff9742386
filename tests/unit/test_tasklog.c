/* tasklog: per-job task logs in the spool: lines time-stamped and one per event (a worker's
 * newlines flattened), read back whole or by task, kept by a new instance (a restarted master),
 * bounded on disk by rotation and in an answer by the caller's maximum (the newest lines). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "files_testutil.h"
#include "tasklog.h"

static int count_lines(const char *s)
{
    int n = 0;
    for (; *s; s++)
        n += *s == '\n';
    return n;
}

static void test_lines_filter_and_restart(void **state)
{
    (void)state;
    char dir[64];
    assert_int_equal(testutil_mkdtemp(dir, sizeof dir, "tasklog"), 0);
    err_t err;
    tasklog_t *t = tasklog_new(dir, 0, &err);
    assert_non_null(t);
    tasklog_add(t, 3, "task 1 attempt 1 assigned to worker 2 'a'");
    tasklog_add(t, 3, "task 12 attempt 1 failed on worker 2 'a': line one\nline two");
    tasklog_add(t, 4, "task 1 attempt 1 assigned to worker 2 'a'");
    tasklog_add(t, 3, "job paused by alice");
    /* Read before any flush: the buffer is part of the answer. */
    char *text;
    size_t len;
    assert_int_equal(tasklog_read(t, 3, -1, 1 << 20, &text, &len, &err), 0);
    assert_int_equal(count_lines(text), 3);
    assert_int_equal(strlen(text), len);
    assert_non_null(strstr(text, "line one line two\n"));
    /* 2026-12-02T02:10:03.123Z: a UTC time stamp first. */
    assert_true(strlen(text) > 25 && text[4] == '-' && text[10] == 'T' && text[23] == 'Z' &&
                text[24] == ' ');
    free(text);
    /* By task: "task 1 " is not "task 12 ". */
    assert_int_equal(tasklog_read(t, 3, 1, 1 << 20, &text, &len, &err), 0);
    assert_int_equal(count_lines(text), 1);
    assert_non_null(strstr(text, "task 1 attempt 1 assigned"));
    free(text);
    tasklog_destroy(&t);
    assert_null(t);
    /* A new instance (a restarted master) reads what the old one wrote. */
    t = tasklog_new(dir, 0, &err);
    assert_int_equal(tasklog_read(t, 3, 12, 1 << 20, &text, &len, &err), 0);
    assert_int_equal(count_lines(text), 1);
    free(text);
    assert_int_equal(tasklog_read(t, 4, -1, 1 << 20, &text, &len, &err), 0);
    assert_int_equal(count_lines(text), 1);
    free(text);
    assert_int_equal(tasklog_read(t, 99, -1, 1 << 20, &text, &len, &err), 0);
    assert_int_equal(len, 0);
    assert_string_equal(text, "");
    free(text);
    tasklog_destroy(&t);
    assert_int_equal(testutil_rmtree(dir), 0);
}

static void test_bounded(void **state)
{
    (void)state;
    char dir[64], path[128];
    assert_int_equal(testutil_mkdtemp(dir, sizeof dir, "tasklog"), 0);
    err_t err;
    size_t max = 4096;
    tasklog_t *t = tasklog_new(dir, max, &err);
    assert_non_null(t);
    /* 2000 lines of ~70 bytes: 140 kB through a log kept to 2 x 4 kB on disk. */
    for (int i = 0; i < 2000; i++) {
        tasklog_add(t, 1, "task %d attempt 1 from worker 1 'w' (0.010 s, 64 samples): merged", i);
        if (i % 100 == 99)
            assert_int_equal(tasklog_flush(t, &err), 0);
    }
    assert_int_equal(tasklog_flush(t, &err), 0);
    struct stat st;
    snprintf(path, sizeof path, "%s/jobs/1/tasks.log", dir);
    assert_true(stat(path, &st) != 0 || (size_t)st.st_size <= max + 100 * 128);
    snprintf(path, sizeof path, "%s/jobs/1/tasks.log.1", dir);
    assert_int_equal(stat(path, &st), 0);
    assert_true((size_t)st.st_size <= max + 100 * 128);
    /* The newest lines survive; an answer holds at most max bytes, whole lines. */
    char *text;
    size_t len;
    assert_int_equal(tasklog_read(t, 1, -1, 1000, &text, &len, &err), 0);
    assert_true(len <= 1000 && len > 800);
    assert_non_null(strstr(text, "task 1999 attempt"));
    assert_true(text[0] == '2' && text[len - 1] == '\n'); /* starts with a time stamp */
    free(text);
    assert_int_equal(tasklog_read(t, 1, 5, 1 << 20, &text, &len, &err), 0);
    assert_int_equal(len, 0); /* rotated away */
    free(text);
    tasklog_destroy(&t);
    assert_int_equal(testutil_rmtree(dir), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_lines_filter_and_restart),
        cmocka_unit_test(test_bounded),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
