/* dash_view: the master's side of its web dashboard (docs/dashboard.md). It implements the
 * dashboard's provider (dashboard/dash_provider.h) over the master's state -- jobs, their passes,
 * tiles, running tasks, previews and log lines, the workers -- and its actions (cancel; the
 * others as the master gains them), and owns the HTTP server, which loop.c polls beside the
 * sockets: every request is answered on the loop's thread between two turns. */
#ifndef PRISMFARM_DASH_VIEW_H
#define PRISMFARM_DASH_VIEW_H

#include "master_state.h"

typedef struct dash_view dash_view_t;

/* Checks opts' http settings without opening anything (master_run's option check): the
 * address, and a non-loopback one only with http_public. */
int dash_view_check(const master_opts_t *opts, err_t *err);

/* The server on opts->http with the tokens of the master's authorised folders and
 * opts->http_token_file; bound[size] gets "http://ADDR:PORT/" as bound. NULL with err. */
dash_view_t *dash_view_open(master_t *m, char *bound, size_t size, err_t *err);
void dash_view_close(dash_view_t **self_p);

/* The descriptor for the loop's poll, and how long it may wait (at most cap_ms). */
int dash_view_fd(const dash_view_t *self);
int dash_view_timeout_ms(dash_view_t *self, int cap_ms);
/* Answers whatever requests are ready, without blocking. */
int dash_view_run(dash_view_t *self, err_t *err);

#endif
