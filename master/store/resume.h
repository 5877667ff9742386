/* resume: a master started on a spool with a journal takes up where the last one stopped
 * (docs/reliability.md). Every job of the journal is listed again; each unfinished one is put
 * back in the scheduler from its photon store, last checkpoint and pass records, and every
 * result journaled since is merged again in the scheduler's order, so that it goes on to the
 * pixels of an uninterrupted run. A job that cannot be resumed is listed as failed with the
 * reason, never dropped. */
#ifndef PRISMFARM_RESUME_H
#define PRISMFARM_RESUME_H

#include "master_state.h"

/* Every job of the journal: finished ones listed (their outputs stay fetchable, a photon job
 * refinable), unfinished ones resumed. Job ids continue after the highest. -1 with err when
 * the journal cannot be read or memory runs out. */
int resume_jobs(master_t *m, err_t *err);

#endif
