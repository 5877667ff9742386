#define _POSIX_C_SOURCE 200809L /* gmtime_r, clock_gettime */
#include "tasklog.h"

#include "proto.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#define LINE_MAX_BYTES 1024 /* one event; a longer worker message is cut */

typedef struct entry {
    uint64_t job;
    size_t at, len; /* in buf, the newline included */
} entry_t;

struct tasklog {
    char dir[PATH_MAX - 64];
    size_t max_bytes;
    char *buf;
    size_t used;
    entry_t *entries;
    size_t nentries, cap_entries;
    bool failing; /* the last flush failed: the next failures are not reported again */
};

tasklog_t *tasklog_new(const char *dir, size_t max_bytes, err_t *err)
{
    tasklog_t *self = calloc(1, sizeof *self);
    if (!self || !(self->buf = malloc(TASKLOG_BUFFER))) {
        free(self);
        err_set(err, "task log: out of memory");
        return NULL;
    }
    if (strlen(dir) >= sizeof self->dir) {
        free(self->buf);
        free(self);
        err_set(err, "task log: folder name too long: '%s'", dir);
        return NULL;
    }
    snprintf(self->dir, sizeof self->dir, "%s", dir);
    self->max_bytes = max_bytes > 0 ? max_bytes : TASKLOG_MAX_BYTES;
    return self;
}

void tasklog_destroy(tasklog_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    tasklog_t *self = *self_p;
    err_t ignore;
    (void)tasklog_flush(self, &ignore);
    free(self->buf);
    free(self->entries);
    free(self);
    *self_p = NULL;
}

static void log_path(const tasklog_t *self, uint64_t job, bool rotated, char *buf, size_t size)
{
    snprintf(buf, size, "%s/jobs/%llu/tasks.log%s", self->dir, (unsigned long long)job,
             rotated ? ".1" : "");
}

/* Appends one job's run of lines [a, b) of the entries to its file, rotating it when it has
 * grown past max_bytes. */
static int write_run(tasklog_t *self, size_t a, size_t b, err_t *err)
{
    uint64_t job = self->entries[a].job;
    char path[PATH_MAX], old[PATH_MAX], folder[PATH_MAX];
    log_path(self, job, false, path, sizeof path);
    snprintf(folder, sizeof folder, "%s/jobs", self->dir);
    if (mkdir(folder, 0755) < 0 && errno != EEXIST)
        return err_set(err, "task log: cannot create '%s': %s", folder, strerror(errno));
    snprintf(folder, sizeof folder, "%s/jobs/%llu", self->dir, (unsigned long long)job);
    if (mkdir(folder, 0755) < 0 && errno != EEXIST)
        return err_set(err, "task log: cannot create '%s': %s", folder, strerror(errno));
    int fd = open(path, O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (fd < 0)
        return err_set(err, "task log: cannot open '%s': %s", path, strerror(errno));
    int rc = 0;
    for (size_t i = a; i < b && rc == 0; i++) {
        const char *p = self->buf + self->entries[i].at;
        size_t n = self->entries[i].len;
        while (n > 0) {
            ssize_t w = write(fd, p, n);
            if (w < 0 && errno == EINTR)
                continue;
            if (w <= 0) {
                rc = err_set(err, "task log: cannot write '%s': %s", path,
                             w < 0 ? strerror(errno) : "no progress");
                break;
            }
            p += w;
            n -= (size_t)w;
        }
    }
    struct stat st;
    bool rotate = rc == 0 && fstat(fd, &st) == 0 && (size_t)st.st_size > self->max_bytes;
    if (close(fd) != 0 && rc == 0)
        rc = err_set(err, "task log: closing '%s': %s", path, strerror(errno));
    if (rotate) {
        log_path(self, job, true, old, sizeof old);
        if (rename(path, old) != 0 && rc == 0)
            rc = err_set(err, "task log: cannot rotate '%s': %s", path, strerror(errno));
    }
    return rc;
}

int tasklog_flush(tasklog_t *self, err_t *err)
{
    int rc = 0;
    for (size_t a = 0; a < self->nentries;) {
        size_t b = a + 1;
        while (b < self->nentries && self->entries[b].job == self->entries[a].job)
            b++;
        err_t e;
        if (write_run(self, a, b, &e) < 0 && rc == 0) {
            *err = e;
            rc = -1;
        }
        a = b;
    }
    self->nentries = 0;
    self->used = 0;
    bool quiet = rc < 0 && self->failing;
    self->failing = rc < 0;
    return quiet ? 0 : rc;
}

void tasklog_add(tasklog_t *self, uint64_t job, const char *fmt, ...)
{
    if (!self)
        return;
    if (self->used + LINE_MAX_BYTES > TASKLOG_BUFFER) {
        err_t ignore;
        (void)tasklog_flush(self, &ignore); /* a full disk drops lines, never grows memory */
    }
    if (self->nentries == self->cap_entries) {
        size_t cap = self->cap_entries ? 2 * self->cap_entries : 256;
        entry_t *p = realloc(self->entries, cap * sizeof *p);
        if (!p)
            return;
        self->entries = p;
        self->cap_entries = cap;
    }
    char *line = self->buf + self->used;
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    struct tm tm;
    gmtime_r(&ts.tv_sec, &tm);
    size_t n = strftime(line, LINE_MAX_BYTES, "%Y-%m-%dT%H:%M:%S", &tm);
    n += (size_t)snprintf(line + n, LINE_MAX_BYTES - n, ".%03ldZ ", ts.tv_nsec / 1000000);
    va_list ap;
    va_start(ap, fmt);
    int w = vsnprintf(line + n, LINE_MAX_BYTES - n - 1, fmt, ap);
    va_end(ap);
    if (w < 0)
        return;
    size_t end = n + (size_t)w < LINE_MAX_BYTES - 2 ? n + (size_t)w : LINE_MAX_BYTES - 2;
    for (size_t i = n; i < end; i++)
        if (line[i] == '\n' || line[i] == '\r')
            line[i] = ' ';
    line[end] = '\n';
    line[end + 1] = 0;
    self->entries[self->nentries++] = (entry_t){.job = job, .at = self->used, .len = end + 1};
    self->used += end + 1;
}

/* Appends the file's lines of the task (or all) to *out. A missing file adds nothing. */
static int read_file(const char *path, const char *prefix, char **out, size_t *len, size_t *cap,
                     err_t *err)
{
    FILE *f = fopen(path, "r");
    if (!f)
        return errno == ENOENT ? 0 : err_set(err, "task log: cannot read '%s': %s", path,
                                             strerror(errno));
    char line[LINE_MAX_BYTES + 2];
    int rc = 0;
    while (fgets(line, sizeof line, f)) {
        const char *text = strchr(line, ' ');
        if (prefix && (!text || strncmp(text + 1, prefix, strlen(prefix)) != 0))
            continue;
        size_t n = strlen(line);
        if (*len + n + 1 > *cap) {
            size_t c = (*cap ? 2 * *cap : 4096) + n;
            char *p = realloc(*out, c);
            if (!p) {
                rc = err_set(err, "task log: out of memory");
                break;
            }
            *out = p;
            *cap = c;
        }
        memcpy(*out + *len, line, n);
        *len += n;
        (*out)[*len] = 0;
    }
    if (ferror(f) && rc == 0)
        rc = err_set(err, "task log: reading '%s': %s", path, strerror(errno));
    fclose(f);
    return rc;
}

int tasklog_read(tasklog_t *self, uint64_t job, long long task, size_t max, char **text,
                 size_t *len, err_t *err)
{
    *text = NULL;
    *len = 0;
    err_t ignore;
    (void)tasklog_flush(self, &ignore); /* so that the answer holds the latest lines */
    char prefix[40], path[PATH_MAX];
    char label[PROTO_TASK_LABEL_MAX];
    if (task >= 0) /* the lines name tasks as people type them: 12, p3 */
        snprintf(prefix, sizeof prefix, "task %s ", proto_task_label((uint32_t)task, label));
    size_t cap = 0;
    char *all = NULL;
    size_t n = 0;
    for (int rotated = 1; rotated >= 0; rotated--) {
        log_path(self, job, rotated, path, sizeof path);
        if (read_file(path, task >= 0 ? prefix : NULL, &all, &n, &cap, err) < 0) {
            free(all);
            return -1;
        }
    }
    /* The most recent whole lines that fit in max. */
    size_t from = 0;
    if (n > max) {
        from = n - max;
        while (from < n && all[from - 1] != '\n')
            from++;
    }
    char *out = malloc(n - from + 1);
    if (!out) {
        free(all);
        return err_set(err, "task log: out of memory");
    }
    if (n > from)
        memcpy(out, all + from, n - from);
    out[n - from] = 0;
    free(all);
    *text = out;
    *len = n - from;
    return 0;
}
