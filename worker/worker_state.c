#include "worker_state.h"

#include <stdarg.h>
#include <stdio.h>

void worker_log(const worker_t *w, const char *fmt, ...)
{
    if (!w->verbose)
        return;
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "worker: ");
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
}

int worker_send(worker_t *w, const proto_msg_t *m)
{
    err_t err;
    int r = net_send(w->conn.net, NULL, m, &err);
    if (r)
        worker_log(w, "sending %s failed: %s", proto_type_name(m->type), err.msg);
    return r;
}
