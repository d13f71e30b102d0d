/*
 * Worker pool (SPEC §2 "Worker pool"; STYLE.md: zstdmt's job ring).
 *
 * Jobs go into a ring of `capacity` slots with monotonically increasing
 * submit and retire counters. Workers run them in any order; the caller
 * retires them strictly in submission order, so results (and errors, which
 * ride inside each job) come out in order whatever the thread count.
 * Submission never blocks: when the ring is full (en_pool_full()) the caller
 * retires the oldest job first, which waits for it. That is the
 * back-pressure that bounds the jobs, and the memory they hold, in flight.
 * With 0 threads every job runs inside en_pool_submit(), so the
 * single-threaded path is the same code.
 *
 * Threads: en_pool_submit/en_pool_retire/en_pool_free are called from one
 * thread (the pipeline's); jobs run on the workers.
 */
#ifndef EN_COMMON_POOL_H
#define EN_COMMON_POOL_H

#include <stddef.h>
#include <stdint.h>

typedef struct en_pool en_pool;

/* A job: returns 0 or a negative EPSNET_E* code, which retire hands back. */
typedef int (*en_job_fn)(void *job);

/*
 * threads: workers to start (0 = run jobs inline); capacity: jobs in flight
 * at most (rounded up to a power of two, at least 1).
 * @return 0, EPSNET_ENOMEM, or EPSNET_EIO when a thread cannot be created
 * (then nothing is left running and *pool is NULL).
 */
int en_pool_new(en_pool **pool, int threads, size_t capacity);

/* Queue fn(job). @return 0, or EPSNET_EINTERNAL when the ring is full
 * (a caller bug: retire first). Never blocks. */
int en_pool_submit(en_pool *pool, en_job_fn fn, void *job);

/* 1 when capacity jobs are in flight: retire before submitting. */
int en_pool_full(const en_pool *pool);

/*
 * Wait for the oldest job not yet retired and hand it back.
 * @return 1 with *job and *result set, or 0 when nothing is in flight.
 */
int en_pool_retire(en_pool *pool, void **job, int *result);

/* Jobs submitted and not yet retired. */
size_t en_pool_in_flight(const en_pool *pool);

/* Finish every queued job (results are dropped), stop the workers, free;
 * sets *pool to NULL. Accepts NULL. */
void en_pool_free(en_pool **pool);

#endif
