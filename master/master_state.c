#include "master_state.h"

#include "clock.h"
#include "logbook.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void master_log(const master_t *m, const char *fmt, ...)
{
    if (!m->opts->verbose && !m->logbook)
        return;
    char line[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    if (m->logbook) /* the dashboard's job logs */
        logbook_add(m->logbook, clock_now_s(), line);
    if (m->opts->verbose)
        fprintf(stderr, "master: %s\n", line);
}

double job_elapsed(const master_t *m, const job_t *j, double now)
{
    if (j->started <= 0)
        return 0;
    double end = j->finished > 0 ? j->finished : now;
    double paused = j->sched.known ? sched_job_paused_s(m->sched, j->id, end) : j->ops.paused_s;
    double s = end - j->started - paused;
    return s > 0 ? s : 0;
}

char *master_strdup(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = malloc(n);
    if (d)
        memcpy(d, s, n);
    return d;
}

void master_refuse(master_t *m, net_t *net, const proto_peer_t *to, const char *reason)
{
    proto_msg_t r = {.type = PROTO_REFUSE, .refuse = {.reason = reason}};
    err_t err;
    if (to->len > 0 && net_send(net, to, &r, &err) < 0)
        master_log(m, "cannot send REFUSE: %s", err.msg);
}

void master_reply(master_t *m, const proto_peer_t *to, const proto_msg_t *msg)
{
    err_t err;
    if (net_send(m->cnet, to, msg, &err) < 0)
        master_log(m, "cannot answer a client: %s", err.msg);
}

void master_reply_error(master_t *m, const proto_peer_t *to, const char *fmt, ...)
{
    char text[PROTO_MAX_STRING];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    proto_msg_t e = {.type = PROTO_ERROR, .error = {.message = text}};
    master_reply(m, to, &e);
}
