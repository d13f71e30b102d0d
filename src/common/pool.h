/*
 * One pool of worker threads for a whole run, and job rings on it
 * (docs/architecture.md §10).
 *
 * The pool is only threads and one queue. Work reaches it through *job
 * rings*: each producer (the sort, each ε-net pass) owns a ring of
 * `capacity` reusable slots with monotonically increasing submit and retire
 * counters. Workers take queued jobs from every ring in submission order
 * across rings and run them in any order; the owner retires its ring's jobs
 * strictly in submission order, so results (and errors, which ride inside
 * each job) come out in order whatever the thread count. Submission never
 * blocks: when a ring is full the owner retires its oldest job first, which
 * waits for it. That is the back-pressure that bounds the jobs, and the
 * memory they hold, in flight. With 0 threads every job runs inside
 * en_jobring_submit(), so the single-threaded path is the same code.
 *
 * Threads: a ring is driven by one thread at a time (its owner); different
 * rings of one pool may have different owners. Jobs run on the workers.
 */
#ifndef EN_COMMON_POOL_H
#define EN_COMMON_POOL_H

#include <stddef.h>
#include <stdint.h>

typedef struct en_pool en_pool;
typedef struct en_jobring en_jobring;

/* A job: returns 0 or a negative EPSNET_E* code, which retire hands back. */
typedef int (*en_job_fn)(void *job);

/*
 * Start `threads` workers (0: jobs run inline on the submitting thread).
 * @return 0, EPSNET_ENOMEM, or EPSNET_EIO when a thread cannot be created
 * (then nothing is left running and *pool is NULL).
 */
int en_pool_new(en_pool **pool, int threads);

/* Worker threads (0: inline). */
int en_pool_threads(const en_pool *pool);

/* CPU seconds spent inside jobs so far, on whichever thread ran them. */
double en_pool_job_cpu_seconds(const en_pool *pool);

/* Stop the workers and free; every ring must have been freed first. Sets
 * *pool to NULL. Accepts NULL. */
void en_pool_free(en_pool **pool);

/* A ring of `capacity` jobs in flight at most (rounded up to a power of
 * two, at least 1). @return 0 or EPSNET_ENOMEM. */
int en_jobring_new(en_jobring **ring, en_pool *pool, size_t capacity);

/* Queue fn(job). @return 0, or EPSNET_EINTERNAL when the ring is full
 * (a caller bug: retire first). Never blocks. */
int en_jobring_submit(en_jobring *ring, en_job_fn fn, void *job);

/*
 * How the pool runs ring's jobs (before its first submit; default 0, 0).
 * serial: one at a time, in submission order (a job may then build on the
 * state the one before it left: the jobs of the ring share it, in turn).
 * urgent: a free worker takes them before the jobs of rings that are not
 * urgent, for jobs that gate what the owner produces next.
 */
void en_jobring_set_order(en_jobring *ring, int serial, int urgent);

/* 1 when the oldest job in flight is done (retire will not wait). */
int en_jobring_ready(const en_jobring *ring);

/* Wait at most `seconds` for the oldest job in flight to be done: 1 when
 * it is (retire will not wait), 0 when the time ran out or nothing is in
 * flight. For an owner that reports progress while it waits. */
int en_jobring_wait(en_jobring *ring, double seconds);

/* 1 when capacity jobs are in flight: retire before submitting. */
int en_jobring_full(const en_jobring *ring);

/* Jobs submitted and not yet retired. */
size_t en_jobring_in_flight(const en_jobring *ring);

/*
 * Wait for the oldest job not yet retired and hand it back.
 * @return 1 with *job and *result set, or 0 when nothing is in flight.
 */
int en_jobring_retire(en_jobring *ring, void **job, int *result);

/* Wait for every job of the ring (results are dropped; the jobs are the
 * caller's to free, as retire would have handed them back: `drop` is
 * called on each, may be NULL), then free it. Sets *ring to NULL. Accepts
 * NULL. */
void en_jobring_free(en_jobring **ring, void (*drop)(void *job));

#endif
