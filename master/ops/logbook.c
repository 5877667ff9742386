#include "logbook.h"

#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct entry {
    uint64_t seq, job;
    double t;
    char text[LOGBOOK_TEXT];
} entry_t;

struct logbook {
    entry_t *ring; /* LOGBOOK_LINES entries; line seq is at (seq - 1) % LOGBOOK_LINES */
    uint64_t last; /* the last line's seq; 0: none yet */
};

logbook_t *logbook_new(void)
{
    logbook_t *self = calloc(1, sizeof *self);
    if (self && !(self->ring = calloc(LOGBOOK_LINES, sizeof *self->ring))) {
        free(self);
        return NULL;
    }
    return self;
}

void logbook_destroy(logbook_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    free((*self_p)->ring);
    free(*self_p);
    *self_p = NULL;
}

/* The job a line is about: "job N" opening the line or after "for " ("a result for job N");
 * 0 when none ("next job 3" at start-up names no job of its own). */
static uint64_t job_named(const char *text)
{
    for (const char *p = strstr(text, "job "); p; p = strstr(p + 4, "job ")) {
        const char *d = p + 4;
        bool about = p == text || (p - text >= 4 && !strncmp(p - 4, "for ", 4));
        if (!about || *d < '0' || *d > '9')
            continue;
        uint64_t v = 0;
        for (; *d >= '0' && *d <= '9' && v < UINT64_MAX / 10 - 10; d++)
            v = v * 10 + (uint64_t)(*d - '0');
        return v;
    }
    return 0;
}

void logbook_add(logbook_t *self, double t, const char *text)
{
    entry_t *e = &self->ring[self->last % LOGBOOK_LINES];
    e->seq = ++self->last;
    e->t = t;
    e->job = job_named(text);
    snprintf(e->text, sizeof e->text, "%s", text);
}

int logbook_read(const logbook_t *self, uint64_t job, uint64_t since, logbook_line_t *out, int max)
{
    if (since >= self->last)
        return 0; /* also keeps since + 1 from wrapping at 2^64 - 1 */
    uint64_t first = self->last > LOGBOOK_LINES ? self->last - LOGBOOK_LINES + 1 : 1;
    if (since + 1 > first)
        first = since + 1;
    int n = 0;
    for (uint64_t s = first; s <= self->last && n < max; s++) {
        const entry_t *e = &self->ring[(s - 1) % LOGBOOK_LINES];
        if (job && e->job != job)
            continue;
        out[n++] = (logbook_line_t){.seq = e->seq, .t = e->t, .job = e->job, .text = e->text};
    }
    return n;
}
