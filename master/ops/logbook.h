/* logbook: the master's recent log lines kept in memory for its dashboard (docs/dashboard.md):
 * the last LOGBOOK_LINES lines, each with an increasing number, the time it was logged and the
 * job it names ("job 12 ..." anywhere in the line; 0 for none), so that a page asks for the
 * lines after the last it has, of one job or of all. Bounded: an old line gives way to a new
 * one, and a line is cut at LOGBOOK_TEXT bytes. */
#ifndef PRISMFARM_LOGBOOK_H
#define PRISMFARM_LOGBOOK_H

#include <stddef.h>
#include <stdint.h>

#define LOGBOOK_LINES 4000
#define LOGBOOK_TEXT 400

typedef struct logbook logbook_t;

typedef struct logbook_line {
    uint64_t seq; /* 1, 2, ...: the line's number since the master started */
    double t;     /* monotonic seconds */
    uint64_t job; /* the job it names; 0: none */
    const char *text;
} logbook_line_t;

logbook_t *logbook_new(void);
void logbook_destroy(logbook_t **self_p);

void logbook_add(logbook_t *self, double t, const char *text);

/* Up to max lines numbered above since, oldest first, of job (0: every line); the texts stay
 * valid until the next logbook_add. Returns how many. */
int logbook_read(const logbook_t *self, uint64_t job, uint64_t since, logbook_line_t *out, int max);

#endif
