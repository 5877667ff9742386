#include "loader.h"

#include "pool.h"

#include <pthread.h>
#include <stdlib.h>

typedef struct item {
    loader_fn fn;
    void *arg;
    struct item *next;
} item_t;

struct loader {
    pthread_mutex_t lock;
    pthread_cond_t wake;
    item_t *queue, *queue_tail; /* to run, oldest first */
    item_t *done, *done_tail;   /* run, oldest first */
    size_t pending;             /* queued + running + done */
    bool stop;
    pool_t *thread;
};

static void push(item_t **head, item_t **tail, item_t *it)
{
    it->next = NULL;
    if (*tail)
        (*tail)->next = it;
    else
        *head = it;
    *tail = it;
}

static item_t *pop(item_t **head, item_t **tail)
{
    item_t *it = *head;
    if (it) {
        *head = it->next;
        if (!*head)
            *tail = NULL;
    }
    return it;
}

static void *loader_main(void *arg)
{
    loader_t *self = arg;
    pthread_mutex_lock(&self->lock);
    for (;;) {
        while (!self->stop && !self->queue)
            pthread_cond_wait(&self->wake, &self->lock);
        if (self->stop)
            break;
        item_t *it = pop(&self->queue, &self->queue_tail);
        pthread_mutex_unlock(&self->lock);
        it->fn(it->arg);
        pthread_mutex_lock(&self->lock);
        push(&self->done, &self->done_tail, it);
    }
    pthread_mutex_unlock(&self->lock);
    return NULL;
}

loader_t *loader_new(err_t *err)
{
    loader_t *self = calloc(1, sizeof *self);
    if (!self) {
        err_set(err, "loader: out of memory");
        return NULL;
    }
    pthread_mutex_init(&self->lock, NULL);
    pthread_cond_init(&self->wake, NULL);
    if (!(self->thread = pool_start(1, loader_main, self, err))) {
        pthread_cond_destroy(&self->wake);
        pthread_mutex_destroy(&self->lock);
        free(self);
        return NULL;
    }
    return self;
}

int loader_run(loader_t *self, loader_fn fn, void *arg, err_t *err)
{
    item_t *it = malloc(sizeof *it);
    if (!it)
        return err_set(err, "loader: out of memory");
    it->fn = fn;
    it->arg = arg;
    pthread_mutex_lock(&self->lock);
    push(&self->queue, &self->queue_tail, it);
    self->pending++;
    pthread_cond_signal(&self->wake);
    pthread_mutex_unlock(&self->lock);
    return 0;
}

void *loader_done(loader_t *self)
{
    pthread_mutex_lock(&self->lock);
    item_t *it = pop(&self->done, &self->done_tail);
    if (it)
        self->pending--;
    pthread_mutex_unlock(&self->lock);
    void *arg = it ? it->arg : NULL;
    free(it);
    return arg;
}

size_t loader_pending(const loader_t *self)
{
    loader_t *s = (loader_t *)self; /* the lock only */
    pthread_mutex_lock(&s->lock);
    size_t n = s->pending;
    pthread_mutex_unlock(&s->lock);
    return n;
}

void loader_destroy(loader_t **self_p, void (*release)(void *arg))
{
    loader_t *self = self_p ? *self_p : NULL;
    if (!self)
        return;
    pthread_mutex_lock(&self->lock);
    self->stop = true;
    pthread_cond_broadcast(&self->wake);
    pthread_mutex_unlock(&self->lock);
    pool_join(&self->thread);
    item_t *lists[2] = {self->queue, self->done};
    for (int l = 0; l < 2; l++)
        for (item_t *it = lists[l], *next; it; it = next) {
            next = it->next;
            if (release)
                release(it->arg);
            free(it);
        }
    pthread_cond_destroy(&self->wake);
    pthread_mutex_destroy(&self->lock);
    free(self);
    *self_p = NULL;
}
