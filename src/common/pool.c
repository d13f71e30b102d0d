#include "common/pool.h"

#include <errno.h>
#include <pthread.h>
#include <time.h>

#include "common/alloc.h"
#include "common/thread.h"
#include "common/util.h"
#include "epsnet/epsnet.h"

/* SLOT_PENDING: submitted to a serial ring while a job of it is queued or
 * running; queued when that one is done. */
typedef enum { SLOT_FREE, SLOT_PENDING, SLOT_QUEUED, SLOT_RUNNING, SLOT_DONE } slot_state;

typedef struct slot slot;
struct slot {
    en_job_fn fn;          /* written by submit (owner), read by the worker that takes it */
    void *job;             /* likewise */
    en_jobring *ring;      /* written once by en_jobring_new; read by workers */
    int result;            /* written by the worker, read by retire (owner) after DONE */
    slot_state state;      /* written by submit, the worker and retire; under the lock */
    slot *next;            /* the pool's queue of QUEUED slots; under the lock */
};

/*
 * Lock: one mutex (pool->lock) guards every field marked "lock" below, in
 * the pool and in every ring of it; it is the only lock, so there is no
 * lock order. `threads`, `nthreads` and a ring's `slots`/`mask` are written
 * once before any job is queued.
 * Condition variables: `work` (a job was queued or stopping was set:
 * workers wait) and `done` (a job finished: retire and ring free wait). No
 * "space" condition is needed: only a ring's owner frees its slots, by
 * retiring.
 */
struct en_pool {
    pthread_mutex_t lock;
    pthread_cond_t work;
    pthread_cond_t done;
    slot *head, *tail;     /* lock: queued jobs of every ring, urgent rings' first, else oldest first */
    slot *urgent_tail;     /* lock: the last queued job of an urgent ring, NULL when none */
    int stopping;          /* lock: written by free, read by workers */
    double job_cpu;        /* lock: CPU seconds inside jobs, written by whoever ran one */
    int nthreads;
    pthread_t *threads;
};

struct en_jobring {
    en_pool *pool;
    slot *slots;
    size_t mask;
    /* Written only by the owner, under the lock (workers never read them), so
     * the owner may read them without it. */
    uint64_t submitted, retired;
    /* Written by the owner before its first submit; read by the owner and
     * the workers (en_jobring_set_order). */
    int serial, urgent;
    int active;            /* lock: serial ring: one of its jobs is queued or running */
};

/* Put s in the pool's queue: an urgent ring's job behind the urgent ones,
 * any other at the end. Lock held. */
static void enqueue(en_pool *p, slot *s)
{
    s->state = SLOT_QUEUED;
    if (s->ring->urgent) {
        slot **at = p->urgent_tail ? &p->urgent_tail->next : &p->head;
        s->next = *at;
        *at = s;
        if (!s->next)
            p->tail = s;
        p->urgent_tail = s;
        return;
    }
    s->next = NULL;
    if (p->tail)
        p->tail->next = s;
    else
        p->head = s;
    p->tail = s;
}

/* Run one job and account its CPU time; returns its result. Caller does
 * not hold the lock. */
static int run_job(en_pool *p, slot *s)
{
    double t0 = en_thread_cpu_seconds();
    int result = s->fn(s->job);
    double dt = en_thread_cpu_seconds() - t0;
    if (p->nthreads == 0) {
        p->job_cpu += dt; /* inline: the owner's thread is the only one */
    } else {
        pthread_mutex_lock(&p->lock);
        p->job_cpu += dt;
        pthread_mutex_unlock(&p->lock);
    }
    return result;
}

static void *worker(void *arg)
{
    en_pool *p = arg;
    pthread_mutex_lock(&p->lock);
    for (;;) {
        while (!p->head && !p->stopping)
            pthread_cond_wait(&p->work, &p->lock);
        if (!p->head)
            break; /* stopping, and nothing left to run */
        slot *s = p->head;
        p->head = s->next;
        if (!p->head)
            p->tail = NULL;
        if (p->urgent_tail == s)
            p->urgent_tail = NULL;
        s->state = SLOT_RUNNING;
        pthread_mutex_unlock(&p->lock);
        int result = run_job(p, s);
        pthread_mutex_lock(&p->lock);
        s->result = result;
        s->state = SLOT_DONE;
        en_jobring *r = s->ring;
        if (r->serial) {
            /* its next job, if submitted, may run now */
            slot *n = &r->slots[(size_t)(s - r->slots + 1) & r->mask];
            if (n->state == SLOT_PENDING) {
                enqueue(p, n);
                pthread_cond_signal(&p->work);
            } else {
                r->active = 0;
            }
        }
        pthread_cond_broadcast(&p->done);
    }
    pthread_mutex_unlock(&p->lock);
    return NULL;
}

int en_pool_new(en_pool **out, int threads)
{
    *out = NULL;
    en_pool *p = en_calloc(1, sizeof *p);
    if (!p)
        return EPSNET_ENOMEM;
    p->threads = threads > 0 ? en_calloc((size_t)threads, sizeof *p->threads) : NULL;
    if (threads > 0 && !p->threads) {
        en_free(p);
        return EPSNET_ENOMEM;
    }
    pthread_mutex_init(&p->lock, NULL);
    pthread_cond_init(&p->work, NULL);
    pthread_cond_init(&p->done, NULL);
    for (int i = 0; i < threads; i++) {
        if (en_thread_create(&p->threads[i], worker, p) != 0) {
            en_pool_free(&p);
            return EPSNET_EIO;
        }
        p->nthreads = i + 1;
    }
    *out = p;
    return 0;
}

int en_pool_threads(const en_pool *p)
{
    return p->nthreads;
}

double en_pool_job_cpu_seconds(const en_pool *p)
{
    en_pool *m = (en_pool *)p; /* the lock is not part of the value */
    pthread_mutex_lock(&m->lock);
    double t = p->job_cpu;
    pthread_mutex_unlock(&m->lock);
    return t;
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
    en_free(p);
    *pp = NULL;
}

int en_jobring_new(en_jobring **out, en_pool *pool, size_t capacity)
{
    *out = NULL;
    size_t cap = 1;
    while (cap < capacity)
        cap *= 2;
    en_jobring *r = en_calloc(1, sizeof *r);
    if (!r)
        return EPSNET_ENOMEM;
    r->slots = en_calloc(cap, sizeof *r->slots);
    if (!r->slots) {
        en_free(r);
        return EPSNET_ENOMEM;
    }
    r->pool = pool;
    r->mask = cap - 1;
    for (size_t i = 0; i < cap; i++)
        r->slots[i].ring = r;
    *out = r;
    return 0;
}

void en_jobring_set_order(en_jobring *r, int serial, int urgent)
{
    r->serial = serial;
    r->urgent = urgent;
}

/* Is the oldest job in flight done? With `until`, waits for it up to that
 * time (CLOCK_REALTIME, a default condition variable's clock). */
static int oldest_done(const en_jobring *r, const struct timespec *until)
{
    if (r->retired == r->submitted)
        return 0;
    en_pool *p = r->pool;
    const slot *s = &r->slots[r->retired & r->mask];
    if (p->nthreads == 0)
        return 1;
    pthread_mutex_lock(&p->lock);
    while (until && s->state != SLOT_DONE && pthread_cond_timedwait(&p->done, &p->lock, until) != ETIMEDOUT)
        ;
    int done = s->state == SLOT_DONE;
    pthread_mutex_unlock(&p->lock);
    return done;
}

int en_jobring_ready(const en_jobring *r)
{
    return oldest_done(r, NULL);
}

int en_jobring_wait(en_jobring *r, double seconds)
{
    struct timespec until;
    clock_gettime(CLOCK_REALTIME, &until);
    long ns = until.tv_nsec + (long)(seconds * 1e9);
    until.tv_sec += ns / 1000000000L;
    until.tv_nsec = ns % 1000000000L;
    return oldest_done(r, &until);
}

int en_jobring_full(const en_jobring *r)
{
    return r->submitted - r->retired > r->mask;
}

size_t en_jobring_in_flight(const en_jobring *r)
{
    return (size_t)(r->submitted - r->retired);
}

int en_jobring_submit(en_jobring *r, en_job_fn fn, void *job)
{
    if (en_jobring_full(r))
        return EPSNET_EINTERNAL; /* the owner must retire first */
    en_pool *p = r->pool;
    slot *s = &r->slots[r->submitted & r->mask];
    s->fn = fn;
    s->job = job;
    s->next = NULL;
    if (p->nthreads == 0) {
        /* Inline: run now, keep the result for retire, same order rules. */
        s->result = run_job(p, s);
        s->state = SLOT_DONE;
        r->submitted++;
        return 0;
    }
    pthread_mutex_lock(&p->lock);
    r->submitted++;
    if (r->serial && r->active) {
        s->state = SLOT_PENDING; /* the worker finishing the one before queues it */
    } else {
        r->active = r->serial;
        enqueue(p, s);
        pthread_cond_signal(&p->work);
    }
    pthread_mutex_unlock(&p->lock);
    return 0;
}

int en_jobring_retire(en_jobring *r, void **job, int *result)
{
    if (r->retired == r->submitted)
        return 0;
    en_pool *p = r->pool;
    slot *s = &r->slots[r->retired & r->mask];
    if (p->nthreads) {
        pthread_mutex_lock(&p->lock);
        while (s->state != SLOT_DONE)
            pthread_cond_wait(&p->done, &p->lock);
    }
    *job = s->job;
    *result = s->result;
    s->state = SLOT_FREE;
    r->retired++;
    if (p->nthreads)
        pthread_mutex_unlock(&p->lock);
    return 1;
}

void en_jobring_free(en_jobring **pr, void (*drop)(void *job))
{
    en_jobring *r = pr ? *pr : NULL;
    if (!r)
        return;
    void *job;
    int result;
    while (en_jobring_retire(r, &job, &result))
        if (drop)
            drop(job);
    en_free(r->slots);
    en_free(r);
    *pr = NULL;
}
