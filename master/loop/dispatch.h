/* dispatch: the scheduler's tasks to the workers. Every live worker's task slots are kept full
 * with TASK messages (a camera tile with the photon store's hash when its job has one, or a
 * photon batch), tagged with the job's round; a TASK that finds the worker's queue full is
 * kept and sent before any other, and the worker is skipped until it goes. A job's first TASK
 * sent marks it started. */
#ifndef PRISMFARM_DISPATCH_H
#define PRISMFARM_DISPATCH_H

#include "master_state.h"

/* Keeps every live worker's task slots full. */
void dispatch_tasks(master_t *m, double now);

#endif
