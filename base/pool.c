#define _GNU_SOURCE /* sched_getaffinity, CPU_COUNT */
#include "pool.h"

#include <pthread.h>
#include <sched.h>
#include <stdlib.h>
#include <unistd.h>
#if defined(__SSE__)
#include <pmmintrin.h>
#include <xmmintrin.h>
#endif

int pool_cores(void)
{
    cpu_set_t set;
    if (sched_getaffinity(0, sizeof set, &set) == 0 && CPU_COUNT(&set) > 0)
        return CPU_COUNT(&set);
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n > 0 ? (int)n : 1;
}

void pool_fp_mode_set(void)
{
#if defined(__SSE__)
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
#endif
}

/* ------------------------------------------------------------------ pool_for */

typedef struct pool_for_run {
    pool_index_fn fn;
    void *user;
    int n, next;
    int outcome; /* 0 so far; 1 a call asked to stop; -1 one failed (err holds it) */
    err_t err;
    pthread_mutex_t lock;
} pool_for_run_t;

static void pool_for_loop(pool_for_run_t *r)
{
    for (;;) {
        pthread_mutex_lock(&r->lock);
        int i = r->outcome != 0 ? r->n : r->next++;
        pthread_mutex_unlock(&r->lock);
        if (i >= r->n)
            return;
        err_t err = {{0}};
        int rc = r->fn(r->user, i, &err);
        if (rc != 0) {
            pthread_mutex_lock(&r->lock);
            if (rc < 0 && r->outcome >= 0) {
                r->outcome = -1;
                r->err = err;
            } else if (rc > 0 && r->outcome == 0) {
                r->outcome = 1;
            }
            pthread_mutex_unlock(&r->lock);
        }
    }
}

static void *pool_for_thread(void *arg)
{
    pool_fp_mode_set();
    pool_for_loop(arg);
    return NULL;
}

int pool_for(int threads, int n, pool_index_fn fn, void *user, err_t *err)
{
    if (n <= 0)
        return 0;
    int k = threads > 0 ? threads : pool_cores();
    if (k > n)
        k = n;
    pool_for_run_t r = {.fn = fn, .user = user, .n = n};
    if (pthread_mutex_init(&r.lock, NULL))
        return err_set(err, "cannot create a mutex");
    pthread_t *th = calloc((size_t)k, sizeof *th);
    int started = 0;
    while (th && started < k && pthread_create(&th[started], NULL, pool_for_thread, &r) == 0)
        started++;
    if (started == 0) {
#if defined(__SSE__)
        unsigned int csr = _mm_getcsr();
#endif
        pool_fp_mode_set();
        pool_for_loop(&r);
#if defined(__SSE__)
        _mm_setcsr(csr);
#endif
    }
    for (int i = 0; i < started; i++)
        pthread_join(th[i], NULL);
    free(th);
    pthread_mutex_destroy(&r.lock);
    if (r.outcome < 0 && err)
        *err = r.err;
    return r.outcome;
}

/* ------------------------------------------------------------ long-lived threads */

struct pool {
    void *(*main)(void *);
    void *arg;
    int n;
    pthread_t *threads;
};

static void *pool_thread(void *arg)
{
    const pool_t *p = arg;
    pool_fp_mode_set();
    return p->main(p->arg);
}

pool_t *pool_start(int threads, void *(*main)(void *), void *arg, err_t *err)
{
    pool_t *p = calloc(1, sizeof *p);
    if (p && threads > 0)
        p->threads = calloc((size_t)threads, sizeof *p->threads);
    if (!p || !p->threads) {
        free(p);
        err_set(err, "cannot start %d threads: out of memory", threads);
        return NULL;
    }
    p->main = main;
    p->arg = arg;
    while (p->n < threads && pthread_create(&p->threads[p->n], NULL, pool_thread, p) == 0)
        p->n++;
    if (p->n == 0) {
        free(p->threads);
        free(p);
        err_set(err, "cannot start a thread");
        return NULL;
    }
    return p;
}

int pool_size(const pool_t *self)
{
    return self ? self->n : 0;
}

void pool_join(pool_t **self_p)
{
    pool_t *p = self_p ? *self_p : NULL;
    if (!p)
        return;
    for (int i = 0; i < p->n; i++)
        pthread_join(p->threads[i], NULL);
    free(p->threads);
    free(p);
    *self_p = NULL;
}
