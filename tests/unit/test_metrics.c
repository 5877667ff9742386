/* metrics: the master's figures in Prometheus' text exposition format (0.0.4), checked line by
 * line against the format's grammar rather than against the code's own strings: every sample
 * line is `name{label="value",...} number` with a metric name of [a-zA-Z_:][a-zA-Z0-9_:]*, its
 * family announced by # HELP and # TYPE (gauge or counter, counters named *_total) before its
 * first sample, no family twice, label values escaped, every number finite; and the figures of
 * a snapshot come out where they belong. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <ctype.h>
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "metrics.h"

static bool name_char(char c, bool first)
{
    return isalpha((unsigned char)c) || c == '_' || c == ':' || (!first && isdigit((unsigned char)c));
}

/* Reads a metric name at *p; returns its length (0: none). */
static size_t read_name(const char *p)
{
    size_t n = 0;
    while (p[n] && name_char(p[n], n == 0))
        n++;
    return n;
}

/* Reads {label="value",...} at *p (escapes \\ \" \n only); returns the characters read, or
 * -1 if malformed; the unescaped value of label "worker" goes to worker. */
static long read_labels(const char *p, char *worker, size_t size)
{
    const char *s = p;
    if (*p != '{')
        return 0;
    p++;
    while (*p != '}') {
        size_t n = read_name(p);
        if (n == 0)
            return -1;
        bool is_worker = n == 6 && !strncmp(p, "worker", 6);
        p += n;
        if (*p++ != '=' || *p++ != '"')
            return -1;
        size_t k = 0;
        while (*p != '"') {
            char c = *p++;
            if (c == '\n' || c == 0)
                return -1;
            if (c == '\\') {
                c = *p++;
                if (c == 'n')
                    c = '\n';
                else if (c != '\\' && c != '"')
                    return -1;
            }
            if (is_worker && k + 1 < size)
                worker[k++] = c;
        }
        if (is_worker)
            worker[k] = 0;
        p++;
        if (*p == ',')
            p++;
        else if (*p != '}')
            return -1;
    }
    return (long)(p + 1 - s);
}

typedef struct seen {
    char families[32][96];
    char types[32][16];
    int nfamilies;
    int samples;
} seen_t;

/* Checks the whole text; fills *seen. worker gets the last worker label read. */
static void check_format(const char *text, size_t len, seen_t *seen, char *worker, size_t size)
{
    assert_int_equal(strlen(text), len);
    assert_true(len > 0 && text[len - 1] == '\n');
    memset(seen, 0, sizeof *seen);
    const char *line = text;
    char help_for[96] = "";
    while (*line) {
        const char *end = strchr(line, '\n');
        assert_non_null(end);
        char buf[1024];
        size_t n = (size_t)(end - line);
        assert_true(n < sizeof buf);
        memcpy(buf, line, n);
        buf[n] = 0;
        if (!strncmp(buf, "# HELP ", 7)) {
            size_t k = read_name(buf + 7);
            assert_true(k > 0 && buf[7 + k] == ' ' && buf[8 + k]);
            snprintf(help_for, sizeof help_for, "%.*s", (int)k, buf + 7);
        } else if (!strncmp(buf, "# TYPE ", 7)) {
            size_t k = read_name(buf + 7);
            assert_true(k > 0 && buf[7 + k] == ' ');
            char name[96];
            snprintf(name, sizeof name, "%.*s", (int)k, buf + 7);
            assert_string_equal(name, help_for); /* HELP, then TYPE, of the same family */
            const char *type = buf + 8 + k;
            assert_true(!strcmp(type, "gauge") || !strcmp(type, "counter"));
            if (!strcmp(type, "counter"))
                assert_non_null(strstr(name, "_total"));
            for (int i = 0; i < seen->nfamilies; i++)
                assert_string_not_equal(seen->families[i], name);
            assert_true(seen->nfamilies < 32);
            snprintf(seen->families[seen->nfamilies], 96, "%s", name);
            snprintf(seen->types[seen->nfamilies], 16, "%.15s", type);
            seen->nfamilies++;
        } else {
            assert_true(buf[0] != '#');
            size_t k = read_name(buf);
            assert_true(k > 0);
            /* The family is the last one announced. */
            assert_true(seen->nfamilies > 0);
            assert_int_equal(strlen(seen->families[seen->nfamilies - 1]), k);
            assert_memory_equal(seen->families[seen->nfamilies - 1], buf, k);
            long l = read_labels(buf + k, worker, size);
            assert_true(l >= 0);
            const char *v = buf + k + l;
            assert_true(*v == ' ');
            char *vend;
            double d = strtod(v + 1, &vend);
            assert_true(vend != v + 1 && *vend == 0);
            assert_true(isfinite(d));
            seen->samples++;
        }
        line = end + 1;
    }
}

/* The value of the sample line that starts with prefix (name and labels), or NAN. */
static double sample(const char *text, const char *prefix)
{
    for (const char *p = text; p && *p; p = strchr(p, '\n') ? strchr(p, '\n') + 1 : NULL)
        if (!strncmp(p, prefix, strlen(prefix)) && p[strlen(prefix)] == ' ')
            return strtod(p + strlen(prefix) + 1, NULL);
    return NAN;
}

static void test_format_and_figures(void **state)
{
    (void)state;
    metrics_worker_t ws[] = {
        {.name = "node01", .id = 3, .state = PROTO_WORKER_BUSY, .samples_per_s = 1.25e6,
         .tasks_done = 40, .tasks_failed = 1},
        /* A hostile name: quote, backslash, newline. */
        {.name = "evil\"\\\nname", .id = 4, .state = PROTO_WORKER_BLOCKED, .samples_per_s = 0,
         .tasks_done = 0, .tasks_failed = 5},
        {.name = "gone", .id = 5, .state = PROTO_WORKER_LOST, .samples_per_s = 7},
    };
    metrics_snapshot_t s = {.tasks_in_flight = 12, .queue_depth = 3400, .workers = ws,
                            .nworkers = 3, .messages_workers = 99, .bytes_workers = 123456789012,
                            .bytes_clients = 42, .journal_writes = 17,
                            .journal_write_seconds = 0.03125};
    s.jobs[JOB_RUNNING] = 2;
    s.jobs[JOB_PAUSED] = 1;
    s.jobs[JOB_DONE] = 30;
    char *text;
    size_t len;
    err_t err;
    assert_int_equal(metrics_render(&s, &text, &len, &err), 0);
    seen_t seen;
    char worker[64] = "";
    check_format(text, len, &seen, worker, sizeof worker);
    assert_true(seen.nfamilies >= 11);
    assert_true(sample(text, "prismfarm_jobs{state=\"running\"}") == 2);
    assert_true(sample(text, "prismfarm_jobs{state=\"paused\"}") == 1);
    assert_true(sample(text, "prismfarm_jobs{state=\"done\"}") == 30);
    assert_true(sample(text, "prismfarm_jobs{state=\"failed\"}") == 0);
    assert_true(sample(text, "prismfarm_tasks_in_flight") == 12);
    assert_true(sample(text, "prismfarm_queue_depth") == 3400);
    assert_true(sample(text, "prismfarm_workers{state=\"blocked\"}") == 1);
    assert_true(sample(text, "prismfarm_workers{state=\"lost\"}") == 1);
    assert_true(sample(text, "prismfarm_worker_samples_per_second{worker=\"node01\",id=\"3\"}") ==
                1.25e6);
    /* The hostile name, escaped, and read back as it was. */
    assert_non_null(strstr(text, "{worker=\"evil\\\"\\\\\\nname\",id=\"4\"}"));
    assert_true(sample(text, "prismfarm_worker_tasks_failed_total{worker=\"evil\\\"\\\\\\nname\","
                             "id=\"4\"}") == 5);
    /* A lost worker has no rate. */
    assert_null(strstr(text, "prismfarm_worker_samples_per_second{worker=\"gone\""));
    assert_true(sample(text, "prismfarm_received_bytes_total{endpoint=\"workers\"}") ==
                123456789012.0);
    assert_true(sample(text, "prismfarm_received_messages_total{endpoint=\"workers\"}") == 99);
    assert_true(sample(text, "prismfarm_journal_writes_total") == 17);
    assert_true(sample(text, "prismfarm_journal_write_seconds_total") == 0.03125);
    free(text);
}

/* No workers, nothing done: still every family, and only finite numbers (a NaN rate becomes 0). */
static void test_empty_and_nonfinite(void **state)
{
    (void)state;
    metrics_worker_t w = {.name = "", .id = 1, .state = PROTO_WORKER_IDLE, .samples_per_s = NAN};
    metrics_snapshot_t s = {.workers = &w, .nworkers = 1, .journal_write_seconds = INFINITY};
    char *text;
    size_t len;
    err_t err;
    assert_int_equal(metrics_render(&s, &text, &len, &err), 0);
    seen_t seen;
    char worker[64] = "x";
    check_format(text, len, &seen, worker, sizeof worker);
    assert_string_equal(worker, "");
    assert_true(sample(text, "prismfarm_journal_write_seconds_total") == 0);
    free(text);
    s.nworkers = 0;
    assert_int_equal(metrics_render(&s, &text, &len, &err), 0);
    check_format(text, len, &seen, worker, sizeof worker);
    assert_true(seen.nfamilies >= 11);
    free(text);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_format_and_figures),
        cmocka_unit_test(test_empty_and_nonfinite),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
