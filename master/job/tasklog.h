/* tasklog: each job's log of what happened to its tasks (docs/farm.md, "Task logs"): which
 * attempt of which task went to which worker and when, its result or failure with the
 * worker's message, re-issues (deadline, lost worker, by hand), blocks, and every operator
 * action with the key that asked. Lines go to jobs/<id>/tasks.log in the spool, so a restarted
 * master keeps them; they are buffered in memory for at most one loop turn (tasklog_flush) and
 * at most TASKLOG_BUFFER bytes, so memory stays bounded whatever the job's size; a file past
 * its max_bytes is renamed tasks.log.1 (replacing the older one), so the disk a job's log takes
 * is bounded too: its most recent 2 x max_bytes. A master killed between flushes loses at
 * most that turn's lines. */
#ifndef PRISMFARM_TASKLOG_H
#define PRISMFARM_TASKLOG_H

#include "err.h"

#include <stddef.h>
#include <stdint.h>

#define TASKLOG_BUFFER (256 << 10)        /* lines held before they are written */
#define TASKLOG_MAX_BYTES ((size_t)1 << 20) /* default size of a log file before it rotates */

typedef struct tasklog tasklog_t;

/* Logs in dir/jobs/<id>/ (dir: the spool folder); files rotate past max_bytes. */
tasklog_t *tasklog_new(const char *dir, size_t max_bytes, err_t *err);
/* Flushes what is buffered, then frees. */
void tasklog_destroy(tasklog_t **self_p);

/* One line for the job, after a UTC time stamp: "2026-12-02T02:10:03.123Z " + the text. A
 * line about one task starts its text with "task N " (tasklog_read's filter). Newlines in the
 * text (a worker's message) become spaces, so a line is one event. */
__attribute__((format(printf, 3, 4))) void tasklog_add(tasklog_t *self, uint64_t job,
                                                       const char *fmt, ...);
/* Writes the buffered lines to their files. Returns -1 with err naming the file that could not
 * be written (its lines are dropped: a full disk must not grow the master); only the first of
 * a run of failed flushes says so, so that a full disk does not fill the master's log. NULL
 * self: tasklog_add does nothing. */
int tasklog_flush(tasklog_t *self, err_t *err);
/* The job's lines, oldest first (the rotated file, then the current one, then the buffer), all
 * or those of one task (task < 0: all), at most max bytes: the most recent whole lines that fit.
 * *text is malloc'ed and NUL-terminated ("" for a job without a log). */
int tasklog_read(tasklog_t *self, uint64_t job, long long task, size_t max, char **text,
                 size_t *len, err_t *err);

#endif
