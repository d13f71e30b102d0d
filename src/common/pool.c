#include "common/pool.h"

#include <pthread.h>

#include "common/alloc.h"
#include "common/thread.h"
#include "epsnet/epsnet.h"

typedef enum { SLOT_FREE, SLOT_QUEUED, SLOT_RUNNING, SLOT_DONE } slot_state;

typedef struct slot {
    en_job_fn fn;
    void *job;
    int result;
    slot_state state;
} slot;

/*
 * Lock: one mutex guards every field below except `threads`/`mask`/`ring`
 * pointers, which are written once before any worker starts.
 *   submitted  written by the caller (submit), read by workers
 *   started    written by workers (next job to take), read by workers
 *   retired    written by the caller (retire), read by the caller (submit)
 *   ring[i]    state/result written by the worker running it, fn/job by submit
 *   stopping   written by free, read by workers
 * Condition variables: `work` (a job was queued or stopping set: workers
 * wait) and `done` (a job finished: retire waits). No "space" condition is
 * needed: only the caller frees slots, by retiring.
 */
struct en_pool {
    pthread_mutex_t lock;
    pthread_cond_t work;
    pthread_cond_t done;
    slot *ring;
    size_t mask;
    uint64_t submitted, started, retired;
    int stopping;
    int nthreads;
    pthread_t *threads;
};

static void *worker(void *arg)
{
    en_pool *p = arg;
    pthread_mutex_lock(&p->lock);
    for (;;) {
        while (p->started == p->submitted && !p->stopping)
            pthread_cond_wait(&p->work, &p->lock);
        if (p->started == p->submitted && p->stopping)
            break;
        slot *s = &p->ring[p->started++ & p->mask];
        s->state = SLOT_RUNNING;
        pthread_mutex_unlock(&p->lock);
        int result = s->fn(s->job);
        pthread_mutex_lock(&p->lock);
        s->result = result;
        s->state = SLOT_DONE;
        pthread_cond_broadcast(&p->done);
    }
    pthread_mutex_unlock(&p->lock);
    return NULL;
}

int en_pool_new(en_pool **out, int threads, size_t capacity)
{
    *out = NULL;
    size_t cap = 1;
    while (cap < capacity)
        cap *= 2;
    en_pool *p = en_calloc(1, sizeof *p);
    if (!p)
        return EPSNET_ENOMEM;
    p->ring = en_calloc(cap, sizeof *p->ring);
    p->threads = threads > 0 ? en_calloc((size_t)threads, sizeof *p->threads) : NULL;
    if (!p->ring || (threads > 0 && !p->threads)) {
        en_free(p->ring);
        en_free(p->threads);
        en_free(p);
        return EPSNET_ENOMEM;
    }
    p->mask = cap - 1;
    pthread_mutex_init(&p->lock, NULL);
    pthread_cond_init(&p->work, NULL);
    pthread_cond_init(&p->done, NULL);
    for (int i = 0; i < threads; i++) {
        if (en_thread_create(&p->threads[i], worker, p) != 0) {
            p->nthreads = i;
            en_pool_free(&p);
            return EPSNET_EIO;
        }
        p->nthreads = i + 1;
    }
    *out = p;
    return 0;
}

/* Caller holds the lock. */
static int wait_oldest(en_pool *p)
{
    slot *s = &p->ring[p->retired & p->mask];
    while (s->state != SLOT_DONE)
        pthread_cond_wait(&p->done, &p->lock);
    return s->result;
}

int en_pool_submit(en_pool *p, en_job_fn fn, void *job)
{
    if (p->nthreads == 0) {
        /* Inline: run now, keep the result for retire, same order rules. */
        if (en_pool_full(p))
            return EPSNET_EINTERNAL; /* the caller must retire first */
        slot *s = &p->ring[p->submitted & p->mask];
        s->fn = fn;
        s->job = job;
        s->result = fn(job);
        s->state = SLOT_DONE;
        p->submitted++;
        p->started = p->submitted;
        return 0;
    }
    if (en_pool_full(p))
        return EPSNET_EINTERNAL; /* the caller must retire first */
    pthread_mutex_lock(&p->lock);
    slot *s = &p->ring[p->submitted & p->mask];
    s->fn = fn;
    s->job = job;
    s->state = SLOT_QUEUED;
    p->submitted++;
    pthread_cond_signal(&p->work);
    pthread_mutex_unlock(&p->lock);
    return 0;
}

int en_pool_retire(en_pool *p, void **job, int *result)
{
    if (p->nthreads == 0) {
        if (p->retired == p->submitted)
            return 0;
        slot *s = &p->ring[p->retired++ & p->mask];
        *job = s->job;
        *result = s->result;
        s->state = SLOT_FREE;
        return 1;
    }
    pthread_mutex_lock(&p->lock);
    if (p->retired == p->submitted) {
        pthread_mutex_unlock(&p->lock);
        return 0;
    }
    *result = wait_oldest(p);
    slot *s = &p->ring[p->retired++ & p->mask];
    *job = s->job;
    s->state = SLOT_FREE;
    pthread_mutex_unlock(&p->lock);
    return 1;
}

/* note: submitted and retired are written only by the caller's thread
 * (under the lock, since workers read them), so the caller reads them here
 * without it. */
size_t en_pool_in_flight(const en_pool *p)
{
    return (size_t)(p->submitted - p->retired);
}

int en_pool_full(const en_pool *p)
{
    return p->submitted - p->retired > p->mask;
}

void en_pool_free(en_pool **pp)
{
    en_pool *p = pp ? *pp : NULL;
    if (!p)
        return;
    pthread_mutex_lock(&p->lock);
    p->stopping = 1;
    pthread_cond_broadcast(&p->work);
    pthread_mutex_unlock(&p->lock);
    for (int i = 0; i < p->nthreads; i++)
        pthread_join(p->threads[i], NULL);
    pthread_cond_destroy(&p->work);
    pthread_cond_destroy(&p->done);
    pthread_mutex_destroy(&p->lock);
    en_free(p->threads);
    en_free(p->ring);
    en_free(p);
    *pp = NULL;
}
