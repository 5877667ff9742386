/* render_threads: what each of the worker's render threads (started by base/pool.h, which sets
 * their floating-point mode) does over and over: take the first ready task, acquire its job's
 * scene from the scene cache, run the task without the lock (render_tile or photon_batch_run),
 * put it among the done tasks and wake the loop. A task of a cancelled job is not run. The
 * threads end once the worker's quit is set. */
#ifndef PRISMFARM_RENDER_THREADS_H
#define PRISMFARM_RENDER_THREADS_H

/* A render thread's main; worker is the worker_t (worker_state.h). */
void *render_thread_main(void *worker);

#endif
