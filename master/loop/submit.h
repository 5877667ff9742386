/* submit: the master's submission pipeline (docs/farm.md, "A job's life", step 2). A SUBMIT is
 * checked against the job limit and the bundle's paths and sizes, staged into the spool and its
 * scene loaded on the loader's thread (loader.h), so that a large scene never blocks the loop;
 * its client hears PROGRESS at once and every PROGRESS_S while it loads. A loaded scene becomes a
 * job (or a frame sequence and its frames), scheduled and journaled before the client is told
 * SUBMITTED; a refused one is answered with the reason, naming the bundle's paths, never the
 * master's spool folder. */
#ifndef PRISMFARM_SUBMIT_H
#define PRISMFARM_SUBMIT_H

#include "master_state.h"

/* How often a client whose scene is loading hears PROGRESS (well inside any client's wait),
 * after the first, sent as soon as the submission is queued to load. */
#define PROGRESS_S 2.0

/* A SUBMIT from a client: refused when the master holds opts->max_jobs unfinished jobs or the
 * bundle is refused; otherwise queued to load. Every outcome is answered. */
void submit_start(master_t *m, const proto_peer_t *from, const proto_msg_t *msg, double now);

/* Finishes the submissions whose scene the loader has loaded (or refused): each is scheduled,
 * journaled and answered SUBMITTED, or answered with the load's error; and sends a PROGRESS
 * to each client whose scene is still loading, every PROGRESS_S. Call it every turn. */
void submit_loads(master_t *m, double now);

/* Frees a submission the loader hands back without it being finished (loader_destroy's
 * release): its staged folder is removed. */
void submit_drop(void *arg);

#endif
